"""What the MAVLink endpoint needs from the vehicle, and nothing more.

The endpoint never reaches into the autopilot or the simulator. A composition root (the
vehicle process, the headless runner, a test) implements :class:`VehiclePort` by wiring the
navigator, the estimators and the controllers, and may plug in a :class:`FailureInjector`
(the narrow fault-injection port of docs/design.md, implemented by the simulator's fault
engine) and extra :class:`ParamProvider` objects (e.g. ArduPilot-style ``SIM_*`` parameters).
The records that cross the port (snapshot, command results, set-points, mission items,
parameter specs, events) are :mod:`fcu.mavlink.port_records`'s.

Everything crossing this port is in SI units and in the NED/FRD frames of docs/design.md;
MAVLink units (degE7, mm, cdeg, PWM microseconds) exist only inside ``fcu/mavlink``.

Threading: the endpoint calls the port from the thread that calls
:meth:`fcu.mavlink.endpoint.MavlinkEndpoint.tick`; the port need not be thread-safe if the
composition root ticks the endpoint from its autopilot loop.

Failure injection (MAV_CMD_INJECT_FAILURE, 420) as the simulator's injector maps it
------------------------------------------------------------------------------------
The endpoint validates the numbers (known unit, known type, integer instance >= 0) and passes
them through unchanged; the injector decides what it supports and answers
``CommandResult.not_supported`` for the rest. The vehicle process (``sim/vehicle_port.py``,
where the full table and the magnitudes live) maps them onto the simulator's fault kinds
(instance 0 = every instance, 1..4 = that one; motors in the thesis numbering of
docs/design.md; ``OK`` clears whatever the unit had, except faults its ``SIM_*`` parameters
hold). param4, unused by the MAVLink spec, may carry the simulated time (s since boot) at
which the injection takes effect, so that a ground station can place a fault on the
simulation's clock exactly whatever the link's delay; 0 (what MAVSDK sends) means now:

=====================  ====================================================================
unit                   types
=====================  ====================================================================
GYRO 0, ACCEL 1,       OFF, STUCK: reading frozen at its last value; GARBAGE: uniform
BARO 3                 readings over the sensor's full scale; WRONG: constant bias; DRIFT:
                       bias ramp (SLOW, DELAYED, INTERMITTENT: unsupported)
MAG 2                  acts on the heading of the mocap attitude stream, same types
GPS 4                  acts on the mocap position stream, same types
MOTOR 101              OFF: total loss of effectiveness; WRONG: partial loss (SIM_FI_LOE,
                       cf. SIM_ENGINE_MUL); STUCK: command frozen at its current value;
                       GARBAGE: hard-over (full output); DRIFT: slowly varying loss;
                       INTERMITTENT: periodic cut-outs (SLOW, DELAYED: unsupported)
BATTERY 100, others    unsupported (nothing simulated)
=====================  ====================================================================
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from fcu.mavlink.port_records import (
    CommandResult,
    MissionItem,
    ParamSpec,
    VehicleEvent,
    VehicleSnapshot,
)
from fcu.navigation.fence import FenceAreas
from fcu.navigation.sticks import Sticks

if TYPE_CHECKING:
    from fcu.mavlink.protocols.follow_target import LeadReport

__all__ = ["FailureInjector", "ParamProvider", "VehiclePort"]


@runtime_checkable
class ParamProvider(Protocol):
    """A source of parameters: defines them and applies accepted changes."""

    def param_specs(self) -> Sequence[ParamSpec]:
        """Parameters with their current values; read once, at endpoint construction."""
        ...

    def set_param(self, name: str, value: float) -> CommandResult:
        """Apply ``value`` (already range-checked); refuse with a reason to keep the old one."""
        ...


class FailureInjector(Protocol):
    """Narrow fault-injection port (MAV_CMD_INJECT_FAILURE); see the module docstring."""

    def inject_failure(self, unit: int, failure_type: int, instance: int,
                       at_s: float | None = None) -> CommandResult:
        """Inject (``failure_type`` != 0) or clear (0) a failure of ``unit`` ``instance``;
        ``at_s``: simulated time (s since boot) at which an injection takes effect, None =
        now (an ``at_s`` already past also means now)."""
        ...


class VehiclePort(ParamProvider, Protocol):
    """Everything the endpoint reads from and asks of the vehicle."""

    def snapshot(self) -> VehicleSnapshot:
        """The current state (called when telemetry is due, at most once per tick).

        A port may compute some fields when they are first read (the autopilot's does:
        :mod:`fcu.mavlink.autopilot_port`); the endpoint reads a snapshot before it calls
        the port again or the vehicle ticks.
        """
        ...

    def drain_events(self) -> list[VehicleEvent]:
        """Events since the last call (STATUSTEXT, MISSION_ITEM_REACHED), oldest first."""
        ...

    def arm(self, *, force: bool) -> CommandResult:
        """Arm; ``force`` skips the pre-arm checks (COMPONENT_ARM_DISARM p2 = 21196)."""
        ...

    def disarm(self, *, force: bool) -> CommandResult:
        """Disarm; ``force`` disarms even in flight."""
        ...

    def set_mode(self, custom_mode: int) -> CommandResult:
        """Switch to ArduCopter mode ``custom_mode``."""
        ...

    def takeoff(self, alt_m: float) -> CommandResult:
        """Climb to ``alt_m`` above home (GUIDED)."""
        ...

    def land(self) -> CommandResult:
        """Land here."""
        ...

    def return_to_launch(self) -> CommandResult:
        """Return to home and land."""
        ...

    def goto(self, pos_ned: np.ndarray, yaw_rad: float | None) -> CommandResult:
        """Fly to ``pos_ned`` (m, NED about the origin), facing ``yaw_rad`` if given."""
        ...

    def set_velocity(self, vel_ned: np.ndarray, yaw_rad: float | None,
                     yaw_rate_rad_s: float | None, heading_frame: bool) -> CommandResult:
        """Fly at ``vel_ned`` (m/s, NED; ``heading_frame``: forward, right, down of the
        heading) in GUIDED, facing ``yaw_rad`` or turning at ``yaw_rate_rad_s`` if given."""
        ...

    def set_attitude(self, roll_rad: float, pitch_rad: float, yaw_rad: float | None,
                     thrust: float) -> CommandResult:
        """Lean to (``roll_rad``, ``pitch_rad``), face ``yaw_rad`` (None: as now) at
        ``thrust`` (0..1, 0.5 holds the altitude) in GUIDED (SET_ATTITUDE_TARGET)."""
        ...

    def orbit(self, centre_ned: np.ndarray | None, radius_m: float | None,
              speed_m_s: float | None) -> CommandResult:
        """DO_ORBIT: circle ``centre_ned`` (m, NED; None = here) at ``radius_m`` (None: the
        default) and ``speed_m_s`` along the circle (> 0 clockwise; None: the default)."""
        ...

    def change_speed(self, speed_m_s: float, speed_type: str) -> CommandResult:
        """Set the ``"ground"`` (horizontal), ``"climb"`` or ``"descent"`` speed, m/s."""
        ...

    def set_home(self, pos_ned: np.ndarray | None) -> CommandResult:
        """Move home to ``pos_ned`` (m, NED about the origin), or here when None."""
        ...

    def fence_set(self, areas: FenceAreas) -> CommandResult:
        """The uploaded fence (polygons and circles, local NED), to enforce."""
        ...

    def mission_set(self, items: Sequence[MissionItem]) -> CommandResult:
        """Replace the mission (items seq 1..n-1; empty clears it)."""
        ...

    def mission_start(self) -> CommandResult:
        """Start (or restart) the mission from the current item (in AUTO)."""
        ...

    def mission_set_current(self, seq: int) -> CommandResult:
        """Make ``seq`` (1..n-1) the current item."""
        ...

    def reboot(self) -> CommandResult:
        """Restart the autopilot (refuse when armed)."""
        ...

    def prearm_check(self) -> CommandResult:
        """Whether arming (not forced) would be accepted now: ok, or denied with the reason
        arming would give (RUN_PREARM_CHECKS)."""
        ...

    def set_sticks(self, sticks: Sticks | None) -> CommandResult:
        """The pilot's latest stick input (MANUAL_CONTROL, RC_CHANNELS_OVERRIDE), normalised;
        None releases the sticks (:mod:`fcu.mavlink.protocols.manual_input`)."""
        ...

    def trigger_failsafe(self, source: str, action: str) -> CommandResult:
        """Enter failsafe ``source`` (``"gcs"``, ``"radio"``) with ``action`` ``"land"`` or
        ``"rtl"``.

        The vehicle decides what that means in its state (ArduCopter: LAND or RTL in flight,
        disarm on the ground, arming refused while active).
        """
        ...

    def clear_failsafe(self, source: str) -> CommandResult:
        """Failsafe ``source`` is over (the mode is not changed back)."""
        ...

    def follow_target(self, report: LeadReport) -> None:
        """Another system's position (FOLLOW_TARGET, GLOBAL_POSITION_INT) for FOLLOW."""
        ...
