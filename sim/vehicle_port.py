"""The MAVLink endpoint's view of one simulated vehicle: a World and an Autopilot behind a port.

:class:`SimVehicle` implements :class:`fcu.mavlink.port.VehiclePort` (telemetry snapshots,
events, commands, the autopilot configuration as parameters) and
:class:`fcu.mavlink.port.FailureInjector` (MAV_CMD_INJECT_FAILURE) over one
:class:`sim.world.World` and one :class:`fcu.autopilot.Autopilot`;
:attr:`SimVehicle.sim_params` is the ``SIM_*`` parameter source. It also owns the tick the
headless runner (:mod:`sim.runner`) runs, in the same order::

    first_tick():  pwm = autopilot.step(0.0, [])
    tick():        samples = world.step(pwm, steps_per_tick)
                   pwm     = autopilot.step(world.time_s, samples)

Commands, parameter changes and injections arrive between ticks (the vehicle process calls
the endpoint after each tick), so a run depends on the tick at which each command arrived and
never on wall time. Fault injection reaches the world's fault engine only: the autopilot
learns of a fault through its sensors and the vehicle's motion, as in flight.

Autopilot parameters
--------------------
The autopilot configuration (:class:`fcu.autopilot.AutopilotConfig`) is exposed as
parameters: ``ATT_CTRL`` (0 PD, 1 LQG), ``EST_TYPE`` (0 EKF, 1 TSKF), ``DOB_TYPE`` (0 none,
1 VbDOB, 2 AbDOB), ``HGT_SOURCE`` (0 motion capture, 1 barometer), the position gains
``POS_XY_*``/``POS_Z_*``, the PD gains ``ATT_PD_*``, the LQR weights ``LQR_*``, the DOB cut-off,
the fault detector's threshold and persistence, and the navigator's settings under their
ArduCopter names and units (``WPNAV_SPEED`` cm/s, ``RTL_ALT`` cm, ``DISARM_DELAY`` s...).
A change rebuilds the autopilot with the new configuration (keeping the loaded mission, home
and mode), so it is accepted only disarmed on the ground; in flight it is refused with the
reason, except ``WPNAV_SPEED``, ``WPNAV_SPEED_UP`` and ``WPNAV_SPEED_DN``, which also act at
once like DO_CHANGE_SPEED. ``SCHED_LOOP_RATE`` (the autopilot rate) is read-only.

Simulator parameters (``SIM_*``)
--------------------------------
ArduPilot-SITL style: each of these *is* a fault or a world setting and acts as soon as it is
set (0 = off); a parameter-owned fault stays until its parameter is reset.

=================  ===========  =========================================================
SIM_ENGINE_FAIL    bitmask      motors hit by SIM_ENGINE_MUL (bit 0 = motor 1 ... bit 3)
SIM_ENGINE_MUL     0..1         thrust multiplier of those motors: LOE = 1 - SIM_ENGINE_MUL
SIM_MOT1_LOE..4    0..1         loss of effectiveness of motor n (thesis eq. 4.10)
SIM_BARO_GLITCH    m            barometer bias
SIM_BARO_DRIFT     m/s          barometer drift, ramping from the moment it is set
SIM_BARO_FREEZE    0/1          barometer holds its last reading
SIM_MASS_DROP      kg           mass that has left the airframe (applied now; 0 restores)
SIM_WIND_SPD       m/s          mean wind speed
SIM_WIND_DIR       deg          direction the mean wind blows from
SIM_WIND_TURB      m/s          Dryden turbulence intensity W20 (0 = none)
SIM_PAUSE          0/1          hold simulated time (the link stays up); 0 resumes
SIM_SPEEDUP        read-only    simulated seconds per wall second (``--speedup``)
SIM_FI_LOE         0..1         LOE of an INJECT_FAILURE MOTOR WRONG (peak of DRIFT)
SIM_FI_<S>_BIAS    sensor unit  bias of an INJECT_FAILURE <sensor> WRONG
SIM_FI_<S>_DRIFT   unit/s       drift rate of an INJECT_FAILURE <sensor> DRIFT
=================  ===========  =========================================================

with ``<S>`` one of GYR (rad/s), ACC (m/s^2), MAG (heading, rad), BAR (m), GPS (m).

MAV_CMD_INJECT_FAILURE (420) mapping onto :mod:`sim.world.faults`
-----------------------------------------------------------
param1 unit, param2 type, param3 instance (0 = all motors / the one sensor; motors 1..4 in
the thesis numbering of docs/design.md). Faults start at the current simulated time.

=================  =====================================================================
MOTOR (101)        OK: clear the motor's injected and scheduled faults
                   OFF: ``total_loss`` (no thrust)
                   STUCK: ``lock`` (command frozen at its value at onset)
                   GARBAGE: ``hardover`` (uncommanded full output, a runaway ESC)
                   WRONG: ``loe`` step of SIM_FI_LOE (default 0.3)
                   DRIFT: ``loe`` sinusoid peaking at SIM_FI_LOE (period 20 s)
                   INTERMITTENT: ``loe`` pulse of 1.0 (cut out 0.5 s every 2 s)
GYRO (0), ACCEL    OK: clear the sensor's injected and scheduled faults
(1), BARO (3),     OFF, STUCK: ``freeze`` (the reading stops changing: a dead sensor whose
GPS (4)            driver keeps the last value; the engine cannot drop samples)
-> gyro, accel,    GARBAGE: ``calibration`` (uniform readings over the sensor's full scale)
baro, mocap_pos    WRONG: ``bias`` of SIM_FI_<S>_BIAS
                   DRIFT: ``drift`` at SIM_FI_<S>_DRIFT per second, from 0
MAG (2)            as above, on the heading (yaw, axis 2) of mocap_att only
anything else      UNSUPPORTED (SLOW, DELAYED; BATTERY and the other units: no model)
=================  =====================================================================

An ``OK`` leaves parameter-owned faults alone (reset the parameter instead); a STATUSTEXT
says so. Scenario faults (``--with-faults``) count as scheduled faults.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar

import numpy as np

from fcu.autopilot import Autopilot, AutopilotConfig, AutopilotEvent
from fcu.mavlink.port import (
    AttitudeTarget,
    CommandResult,
    FailureType,
    FailureUnit,
    GeoPoint,
    MavState,
    MissionItem,
    MissionItemReached,
    ParamSpec,
    PositionTarget,
    SensorHealth,
    Severity,
    SimTruth,
    StatusText,
    VehicleEvent,
    VehicleSnapshot,
)
from fcu.navigation.navigator import CommandResult as NavResult
from fcu.navigation.navigator import Mode, mode_name
from flightdata.mission import MissionItem as NavItem
from sim.world import PlantEvent, World, WorldConfig
from sim.world.faults import ActuatorFault, Fault, FaultEvent, SensorFault, StructuralFault
from sim.world.wind import WindConfig

__all__ = ["BRAKE_ARMABLE", "SimParams", "SimVehicle", "VehicleSetup", "vehicle_autopilot_config",
           "warm_up"]

BRAKE_ARMABLE = int(Mode.BRAKE)
"""MAVSDK switches to BRAKE before arming when the vehicle sits in AUTO, RTL or LAND."""

_SEVERITY = {"info": Severity.INFO, "notice": Severity.NOTICE, "warning": Severity.WARNING,
             "critical": Severity.CRITICAL}
_CMD_WAYPOINT, _CMD_RTL, _CMD_LAND, _CMD_TAKEOFF, _CMD_CHANGE_SPEED = 16, 20, 21, 22, 178
_SPEED_TYPES = {0: "ground", 1: "ground", 2: "climb", 3: "descent"}


@dataclass(frozen=True, kw_only=True)
class VehicleSetup:
    """What one vehicle process simulates (everything but the network)."""

    world: WorldConfig
    autopilot: AutopilotConfig
    seed: int  # -, seed of every random stream of the world
    origin: GeoPoint  # home at boot: geodetic position of the NED origin
    speedup: float = 1.0  # simulated s per wall s (reported as SIM_SPEEDUP)
    faults: tuple[Fault, ...] = ()  # scheduled in simulated time at boot
    mission: tuple[NavItem, ...] = ()  # loaded at boot (not started)
    start_paused: bool = False  # SIM_PAUSE = 1 at boot


def vehicle_autopilot_config(config: AutopilotConfig) -> AutopilotConfig:
    """``config`` with BRAKE added to the armable modes (what MAVSDK's arm needs)."""
    nav = config.navigator
    if BRAKE_ARMABLE in nav.armable_modes:
        return config
    return replace(config, navigator=replace(
        nav, armable_modes=(*nav.armable_modes, BRAKE_ARMABLE)))


# ---------------------------------------------------------------------------------------------
# autopilot configuration <-> parameters

Getter = Callable[[AutopilotConfig], float]
Setter = Callable[[AutopilotConfig, float], AutopilotConfig]


@dataclass(frozen=True)
class _ApParam:
    """One autopilot parameter: its definition and how it reads/writes the configuration."""

    name: str
    description: str
    get: Getter
    set: Setter
    min_value: float = -math.inf
    max_value: float = math.inf
    allowed: tuple[float, ...] | None = None
    integer: bool = False
    live_speed: str | None = None  # DO_CHANGE_SPEED type applied at once in flight
    read_only: bool = False


C = TypeVar("C")


def _with(obj: C, name: str, value: Any) -> C:
    """The frozen dataclass ``obj`` with field ``name`` replaced (its checks run again)."""
    changes: dict[str, Any] = {name: value}
    return replace(obj, **changes)  # type: ignore[type-var]


def _enum_param(name: str, attr: str, choices: tuple[str, ...], description: str) -> _ApParam:
    return _ApParam(
        name, description,
        get=lambda c: float(choices.index(getattr(c, attr))),
        set=lambda c, v: _with(c, attr, choices[int(v)]),
        min_value=0, max_value=len(choices) - 1,
        allowed=tuple(float(i) for i in range(len(choices))), integer=True)


def _axes(values: tuple[float, float, float], value: float, axes: tuple[int, ...]
          ) -> tuple[float, float, float]:
    out = list(values)
    for i in axes:
        out[i] = float(value)
    return (out[0], out[1], out[2])


def _gain_param(name: str, group: str, attr: str, axes: tuple[int, ...], unit: str,
                description: str, lo: float = 0.0, hi: float = 1e9) -> _ApParam:
    return _ApParam(
        name, f"{description}, {unit}",
        get=lambda c: float(getattr(getattr(c, group), attr)[axes[0]]),
        set=lambda c, v: _with(c, group, _with(
            getattr(c, group), attr, _axes(getattr(getattr(c, group), attr), v, axes))),
        min_value=lo, max_value=hi)


def _nav_param(name: str, attr: str, scale: float, unit: str, description: str,
               lo: float, hi: float, live_speed: str | None = None) -> _ApParam:
    """A NavigatorConfig field shown in ArduCopter units (``value = field * scale``)."""
    return _ApParam(
        name, f"{description}, {unit}",
        get=lambda c: float(getattr(c.navigator, attr)) * scale,
        set=lambda c, v: replace(c, navigator=_with(c.navigator, attr, v / scale)),
        min_value=lo, max_value=hi, live_speed=live_speed)


def _top_param(name: str, attr: str, unit: str, description: str, lo: float,
               hi: float) -> _ApParam:
    return _ApParam(name, f"{description}, {unit}", get=lambda c: float(getattr(c, attr)),
                    set=lambda c, v: _with(c, attr, float(v)), min_value=lo,
                    max_value=hi)


def _detector_param(name: str, attr: str, unit: str, description: str, lo: float,
                    hi: float) -> _ApParam:
    return _ApParam(name, f"{description}, {unit}",
                    get=lambda c: float(getattr(c.detector, attr)),
                    set=lambda c, v: replace(c, detector=_with(c.detector, attr, float(v))),
                    min_value=lo, max_value=hi)


AUTOPILOT_PARAMS: tuple[_ApParam, ...] = (
    _enum_param("ATT_CTRL", "attitude", ("pd", "lqg"),
                "Attitude controller: 0 PD (eq. 5.6), 1 LQG (LQR + integral, eq. 5.10)"),
    _enum_param("EST_TYPE", "estimator", ("ekf", "tskf"),
                "Estimate fed to the controllers: 0 EKF, 1 TSKF"),
    _enum_param("DOB_TYPE", "dob", ("none", "vbdob", "abdob"),
                "Disturbance observer: 0 none, 1 VbDOB, 2 AbDOB (eq. 6.27-6.30)"),
    _enum_param("HGT_SOURCE", "height_source", ("mocap", "baro"),
                "Height source: 0 motion capture, 1 barometer"),
    _ApParam("ARMING_CHECK", "Pre-arm checks: 1 all, always (read-only; COMPONENT_ARM_DISARM "
             "p2 = 21196 forces)", get=lambda c: 1.0, set=lambda c, v: c, min_value=0,
             max_value=1, integer=True, read_only=True),
    _ApParam("SCHED_LOOP_RATE", "Autopilot loop rate, Hz (read-only)",
             get=lambda c: float(c.loop_rate_hz), set=lambda c, v: c, min_value=0,
             max_value=1e6, read_only=True),
    _top_param("DOB_CUTOFF", "dob_cutoff_rad_s", "rad/s", "DOB Q-filter cut-off", 0.01, 1e3),
    _top_param("ATT_REF_BW", "attitude_ref_bandwidth_rad_s", "rad/s",
               "Attitude reference filter bandwidth", 0.01, 1e3),
    _gain_param("POS_XY_KP", "position", "kp", (0, 1), "1/s^2", "Horizontal position P gain"),
    _gain_param("POS_XY_KD", "position", "kd", (0, 1), "1/s", "Horizontal position D gain"),
    _gain_param("POS_XY_KI", "position", "ki", (0, 1), "1/s^3", "Horizontal position I gain"),
    _gain_param("POS_Z_KP", "position", "kp", (2,), "1/s^2", "Vertical position P gain"),
    _gain_param("POS_Z_KD", "position", "kd", (2,), "1/s", "Vertical position D gain"),
    _gain_param("POS_Z_KI", "position", "ki", (2,), "1/s^3", "Vertical position I gain"),
    _gain_param("ATT_PD_RP_KP", "pd", "kp", (0, 1), "1/s^2", "PD roll/pitch angle gain"),
    _gain_param("ATT_PD_RP_KD", "pd", "kd", (0, 1), "1/s", "PD roll/pitch rate gain"),
    _gain_param("ATT_PD_Y_KP", "pd", "kp", (2,), "1/s^2", "PD yaw angle gain"),
    _gain_param("ATT_PD_Y_KD", "pd", "kd", (2,), "1/s", "PD yaw rate gain"),
    _gain_param("LQR_QINT_RP", "lqr", "q_integral", (0, 1), "1/(rad*s)^2",
                "LQR roll/pitch integral weight", 1e-9),
    _gain_param("LQR_QANG_RP", "lqr", "q_angle", (0, 1), "1/rad^2",
                "LQR roll/pitch angle weight", 1e-9),
    _gain_param("LQR_QRATE_RP", "lqr", "q_rate", (0, 1), "1/(rad/s)^2",
                "LQR roll/pitch rate weight", 1e-9),
    _gain_param("LQR_R_RP", "lqr", "r_torque", (0, 1), "1/(N*m)^2",
                "LQR roll/pitch torque weight", 1e-9),
    _gain_param("LQR_QINT_Y", "lqr", "q_integral", (2,), "1/(rad*s)^2",
                "LQR yaw integral weight", 1e-9),
    _gain_param("LQR_QANG_Y", "lqr", "q_angle", (2,), "1/rad^2", "LQR yaw angle weight", 1e-9),
    _gain_param("LQR_QRATE_Y", "lqr", "q_rate", (2,), "1/(rad/s)^2", "LQR yaw rate weight",
                1e-9),
    _gain_param("LQR_R_Y", "lqr", "r_torque", (2,), "1/(N*m)^2", "LQR yaw torque weight", 1e-9),
    _detector_param("FD_THRESH", "threshold", "fraction",
                    "Fault detector: LOE above which a motor is suspected", 0.01, 0.99),
    _detector_param("FD_PERSIST", "persistence_s", "s",
                    "Fault detector: time above the threshold before a fault is declared",
                    0.0, 60.0),
    _nav_param("WPNAV_SPEED", "speed_horizontal_m_s", 100.0, "cm/s",
               "Horizontal leg speed", 1.0, 500.0, live_speed="ground"),
    _nav_param("WPNAV_SPEED_UP", "speed_up_m_s", 100.0, "cm/s", "Climb speed", 1.0, 500.0,
               live_speed="climb"),
    _nav_param("WPNAV_SPEED_DN", "speed_down_m_s", 100.0, "cm/s", "Descent speed", 1.0,
               500.0, live_speed="descent"),
    _nav_param("WPNAV_ACCEL", "accel_m_s2", 100.0, "cm/s/s", "Peak leg acceleration", 1.0,
               1000.0),
    _nav_param("WPNAV_RADIUS", "wp_radius_m", 100.0, "cm", "Waypoint reached radius", 1.0,
               1000.0),
    _nav_param("RTL_ALT", "rtl_alt_m", 100.0, "cm", "RTL return altitude above home", 10.0,
               1000.0),
    _nav_param("RTL_LOIT_TIME", "rtl_hold_s", 1000.0, "ms", "RTL hold above home", 0.0,
               60000.0),
    _nav_param("LAND_SPEED", "land_creep_speed_m_s", 100.0, "cm/s",
               "Final landing descent speed", 1.0, 200.0),
    _nav_param("DISARM_DELAY", "idle_disarm_delay_s", 1.0, "s",
               "Auto-disarm after arming without take-off (0 never)", 0.0, 127.0),
)


# ---------------------------------------------------------------------------------------------
# fault injection tables

_MOTOR_UNIT = int(FailureUnit.SYSTEM_MOTOR)
# FAILURE_UNIT -> (sensor, axis, SIM_FI_<S> stem, unit)
_SENSOR_UNITS: dict[int, tuple[str, int | None, str, str]] = {
    int(FailureUnit.SENSOR_GYRO): ("gyro", None, "GYR", "rad/s"),
    int(FailureUnit.SENSOR_ACCEL): ("accel", None, "ACC", "m/s^2"),
    int(FailureUnit.SENSOR_MAG): ("mocap_att", 2, "MAG", "rad"),
    int(FailureUnit.SENSOR_BARO): ("baro", None, "BAR", "m"),
    int(FailureUnit.SENSOR_GPS): ("mocap_pos", None, "GPS", "m"),
}
_UNIT_NAMES = {int(u): u.name.removeprefix("SENSOR_").removeprefix("SYSTEM_")
               for u in FailureUnit}
_TYPE_NAMES = {int(t): t.name for t in FailureType}
# (bias default, drift rate default) per SIM_FI stem, sensor units (per s for drifts)
_FI_DEFAULTS = {"GYR": (0.05, 0.005), "ACC": (0.5, 0.05), "MAG": (0.2, 0.02),
                "BAR": (0.5, 0.05), "GPS": (0.3, 0.03)}
_DRIFT_PERIOD_S = 20.0  # s, MOTOR DRIFT: LOE sinusoid period
_INTERMITTENT_PERIOD_S = 2.0  # s, MOTOR INTERMITTENT: cut-out period
_INTERMITTENT_WIDTH_S = 0.5  # s, MOTOR INTERMITTENT: cut-out length
_CONTACT_QUIET_S = 1.0  # s simulated, least time between two touchdown/lift-off STATUSTEXTs


# ---------------------------------------------------------------------------------------------
# the vehicle


class SimVehicle:
    """One simulated vehicle: world, autopilot, and the MAVLink port over them.

    Parameters
    ----------
    setup : VehicleSetup
        World and autopilot configuration, seed, origin, boot faults and mission.

    Notes
    -----
    Call :meth:`first_tick` once, then :meth:`tick` once per autopilot period; call the
    endpoint between ticks. Not thread-safe: everything runs on the vehicle loop's thread.
    """

    def __init__(self, setup: VehicleSetup) -> None:
        config = setup.autopilot
        plant_hz = setup.world.plant_rate_hz
        loop_hz = config.loop_rate_hz
        steps = round(plant_hz / loop_hz)
        if steps < 1 or abs(steps * loop_hz - plant_hz) > 1e-9 * plant_hz:
            raise ValueError(f"autopilot.loop_rate_hz = {loop_hz:g}: must divide the plant "
                             f"rate {plant_hz:g} Hz")
        self.setup = setup
        self.steps_per_tick = steps
        self.tick_s = 1.0 / loop_hz
        self.origin = setup.origin
        self.world = World(setup.world, setup.seed)
        for fault in setup.faults:
            self.world.faults.schedule(fault)
        self._config = config
        self.autopilot = Autopilot(config)
        self.pwm = np.zeros(4)
        self._events: list[VehicleEvent] = []
        self._snap: VehicleSnapshot | None = None
        self._started = False
        self._owned: dict[str, int] = {}  # fault slot (param name / motor) -> fault id
        self._quiet_ids: set[int] = set()  # faults injected here: their engine events are ours
        self._last_contact_s = -math.inf
        self.sim_params = SimParams(self)
        self.ticks = 0

    # ------------------------------------------------------------------ stepping
    @property
    def time_s(self) -> float:
        """Simulated time, s."""
        return self.world.time_s

    @property
    def paused(self) -> bool:
        """SIM_PAUSE is set: the loop holds simulated time."""
        return self.sim_params.paused

    def first_tick(self) -> None:
        """The boot tick at t = 0 (before any plant step), then the boot mission, if any."""
        if self._started:
            return
        self._started = True
        self.pwm = self.autopilot.step(0.0, [])
        if self.setup.mission:
            result = self.autopilot.navigator.load_mission(self.setup.mission)
            if not result.accepted:
                self._status(Severity.WARNING, f"Boot mission refused: {result.reason}")
        self._collect()

    def tick(self) -> None:
        """One autopilot tick: ``steps_per_tick`` plant steps holding the PWM, then the FCU."""
        samples = self.world.step(self.pwm, self.steps_per_tick)
        self.pwm = self.autopilot.step(self.world.time_s, samples)
        self.ticks += 1
        self._collect()

    def _collect(self) -> None:
        self._snap = None
        for ev in self.autopilot.drain_events():
            self._autopilot_event(ev)
        for wev in self.world.drain_events():
            if isinstance(wev, FaultEvent):
                self._fault_event(wev)
            elif isinstance(wev, PlantEvent):
                self._plant_event(wev)

    def _plant_event(self, ev: PlantEvent) -> None:
        if ev.kind == "crash":
            self._status(Severity.CRITICAL, f"SIM: {ev.description}")
            return
        # a vehicle bouncing on the ground would chatter: one contact line per simulated second
        if ev.time_s - self._last_contact_s >= _CONTACT_QUIET_S:
            self._last_contact_s = ev.time_s
            self._status(Severity.DEBUG, f"SIM: {ev.description}")

    def _autopilot_event(self, ev: AutopilotEvent) -> None:
        if ev.kind == "refused":
            return  # the endpoint reports refusals with the command's ACK (no duplicate)
        if ev.kind == "item_reached" and ev.seq is not None:
            self._events.append(MissionItemReached(int(ev.seq)))
        self._status(_SEVERITY.get(ev.severity, Severity.INFO), ev.text)

    def _fault_event(self, ev: FaultEvent) -> None:
        if ev.fault_id in self._quiet_ids:
            if ev.kind in ("cleared", "ended"):
                self._quiet_ids.discard(ev.fault_id)
                self._status(Severity.NOTICE, f"SIM: {ev.kind} {ev.description}")
            return
        if ev.kind == "injected":
            self._status(Severity.INFO, f"SIM: fault scheduled: {ev.description}")
        else:
            severity = Severity.WARNING if ev.kind == "started" else Severity.NOTICE
            self._status(severity, f"SIM: fault {ev.kind}: {ev.description}")

    def _status(self, severity: int, text: str) -> None:
        self._events.append(StatusText(int(severity), text))

    def notice(self, text: str) -> None:
        """Queue a STATUSTEXT of severity NOTICE (for the simulator's own messages)."""
        self._status(Severity.NOTICE, text)

    def owned_fault(self, slot: str) -> Fault | None:
        """The fault parameter ``slot`` currently holds in the engine, if any."""
        fault_id = self._owned.get(slot)
        if fault_id is None:
            return None
        return next((s.fault for s in self.world.faults.scheduled() if s.fault_id == fault_id),
                    None)

    # ------------------------------------------------------------------ VehiclePort: telemetry
    def snapshot(self) -> VehicleSnapshot:
        """Telemetry state after the last tick (cached until the next tick or command)."""
        if self._snap is None:
            self._snap = self._build_snapshot()
        return self._snap

    def _build_snapshot(self) -> VehicleSnapshot:
        ap = self.autopilot
        nav = ap.navigator
        status = ap.status
        t = self.world.time_s
        if status is None:
            return VehicleSnapshot(time_s=t, armed=False, custom_mode=int(nav.mode),
                                   pos_ned=np.zeros(3), vel_ned=np.zeros(3),
                                   euler_rad=np.zeros(3), rate_frd=np.zeros(3),
                                   origin=self.origin, home_pos_ned=nav.home_pos_ned,
                                   system_status=MavState.BOOT,
                                   health=SensorHealth(ahrs=False, prearm=False))
        est = status.estimate
        healthy = bool(np.all(np.isfinite(est.pos_ned)) and np.all(np.isfinite(est.vel_ned))
                       and np.all(np.isfinite(est.euler_rad)))
        detected = any(status.fault_detected)
        failsafe = bool(nav.failsafe_sources)
        armed = nav.armed
        if detected:
            system_status = MavState.CRITICAL
        elif armed:
            system_status = MavState.ACTIVE
        else:
            system_status = MavState.STANDBY
        position_target = None
        if status.reference is not None:
            ref = status.reference
            position_target = PositionTarget(pos_ned=ref.pos_ned, vel_ned=ref.vel_ned,
                                              acc_ned=ref.acc_ned, yaw_rad=ref.yaw_rad)
        attitude_target = None
        if status.attitude_reference is not None:
            att = status.attitude_reference
            model = ap.model
            full_thrust_n = 4.0 * model.thrust_gain * model.pwm_max
            attitude_target = AttitudeTarget(
                euler_rad=att.euler_rad, rate_frd=_body_rates(att.euler_rad, att.rate),
                thrust=min(max(status.thrust_cmd_n / full_thrust_n, 0.0), 1.0))
        progress = nav.mission_progress()
        return VehicleSnapshot(
            time_s=t, armed=armed, custom_mode=int(nav.mode),
            pos_ned=est.pos_ned, vel_ned=est.vel_ned, euler_rad=est.euler_rad,
            rate_frd=est.rate_frd, origin=self.origin, home_pos_ned=nav.home_pos_ned,
            system_status=system_status, landed_state=int(nav.landed_state),
            position_target=position_target, attitude_target=attitude_target,
            pwm=np.array(status.pwm), truth=self._truth(), loe=np.array(status.loe_estimate),
            health=SensorHealth(gps=healthy, ahrs=healthy, motors=not detected,
                                prearm=self._prearm_ok(healthy)),
            mission_seq=progress.current_seq, mission_state=int(progress.state),
            failsafe_active=failsafe)

    def _truth(self) -> SimTruth:
        """Simulator truth for SIM_STATE (never shown to the autopilot)."""
        truth = self.world.truth()
        return SimTruth(pos_ned=truth.pos_ned, vel_ned=truth.vel_ned,
                        quat_wxyz=truth.quat_wxyz, rate_frd=truth.rate_frd,
                        accel_frd=truth.accel_frd)

    def _prearm_ok(self, healthy: bool) -> bool:
        """The navigator's arming checks, as far as they can be judged without arming."""
        nav = self.autopilot.navigator
        if nav.armed:
            return True
        status = self.autopilot.status
        if status is None or not healthy or nav.failsafe_sources:
            return False
        cfg = nav.config
        est = status.estimate
        on_ground = (-float(est.pos_ned[2]) < cfg.land_detect_alt_m
                     and abs(float(est.vel_ned[2])) < cfg.land_detect_speed_m_s)
        return on_ground and int(nav.mode) in cfg.armable_modes

    def drain_events(self) -> list[VehicleEvent]:
        """STATUSTEXT and MISSION_ITEM_REACHED since the previous call, oldest first."""
        events, self._events = self._events, []
        return events

    # ------------------------------------------------------------------ VehiclePort: commands
    def _nav(self, what: str, result: NavResult) -> CommandResult:
        self._snap = None  # the command may have changed mode, arming, targets...
        if result.accepted:
            return CommandResult.ok()
        return CommandResult.denied(f"{what} refused: {result.reason}")

    def arm(self, *, force: bool) -> CommandResult:
        """COMPONENT_ARM_DISARM p1 = 1 (the navigator's pre-arm checks unless forced)."""
        return self._nav("Arm", self.autopilot.navigator.arm(force))

    def disarm(self, *, force: bool) -> CommandResult:
        """COMPONENT_ARM_DISARM p1 = 0 (refused in flight unless forced)."""
        return self._nav("Disarm", self.autopilot.navigator.disarm(force))

    def set_mode(self, custom_mode: int) -> CommandResult:
        """DO_SET_MODE / SET_MODE: the navigator's modes; others refused with the reason."""
        return self._nav(f"Mode {mode_name(custom_mode)}",
                         self.autopilot.navigator.set_mode(int(custom_mode)))

    def takeoff(self, alt_m: float) -> CommandResult:
        """NAV_TAKEOFF in GUIDED, ``alt_m`` above home."""
        return self._nav("Takeoff", self.autopilot.navigator.takeoff(float(alt_m)))

    def land(self) -> CommandResult:
        """NAV_LAND: switch to LAND."""
        return self._nav("Land", self.autopilot.navigator.land())

    def return_to_launch(self) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH: switch to RTL."""
        return self._nav("RTL", self.autopilot.navigator.return_to_launch())

    def goto(self, pos_ned: np.ndarray, yaw_rad: float | None) -> CommandResult:
        """SET_POSITION_TARGET_* / DO_REPOSITION: a cubic leg to ``pos_ned`` (GUIDED only)."""
        return self._nav("Go-to", self.autopilot.navigator.go_to(pos_ned, yaw_rad))

    def set_velocity(self, vel_ned: np.ndarray, yaw_rad: float | None) -> CommandResult:
        """Velocity set-points are not flown by this autopilot (position legs only)."""
        return CommandResult.not_supported(
            "Velocity targets not supported: send a position target")

    def change_speed(self, speed_m_s: float, speed_type: str) -> CommandResult:
        """DO_CHANGE_SPEED for legs planned from now on."""
        return self._nav("Change speed",
                         self.autopilot.navigator.change_speed(float(speed_m_s), speed_type))

    def set_home(self, pos_ned: np.ndarray | None) -> CommandResult:
        """DO_SET_HOME; None = the current estimated position."""
        if pos_ned is None:
            status = self.autopilot.status
            if status is None:
                return CommandResult.denied("Set home refused: no position estimate yet")
            pos_ned = np.array(status.estimate.pos_ned)
        return self._nav("Set home", self.autopilot.navigator.set_home(pos_ned))

    def mission_set(self, items: Sequence[MissionItem]) -> CommandResult:
        """Replace the mission (converted to navigator items; unsupported commands refused)."""
        converted: list[NavItem] = []
        for item in items:
            nav_item = _to_nav_item(item)
            if isinstance(nav_item, CommandResult):
                return nav_item
            converted.append(nav_item)
        nav = self.autopilot.navigator
        result = nav.load_mission(converted) if converted else nav.clear_mission()
        return self._nav("Mission", result)

    def mission_start(self) -> CommandResult:
        """MISSION_START: AUTO from the current item."""
        return self._nav("Mission start", self.autopilot.navigator.start_mission())

    def mission_set_current(self, seq: int) -> CommandResult:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT."""
        return self._nav("Set mission current",
                         self.autopilot.navigator.set_current_item(int(seq)))

    def reboot(self) -> CommandResult:
        """PREFLIGHT_REBOOT_SHUTDOWN: restart the autopilot (the simulated world goes on)."""
        nav = self.autopilot.navigator
        if nav.armed:
            return CommandResult.denied("Reboot refused: disarm first")
        error = self._rebuild(self._config, keep_mode=False)
        if error:
            return CommandResult.denied(f"Reboot failed: {error}")
        self._status(Severity.NOTICE, "Autopilot rebooted")
        return CommandResult.ok()

    def trigger_failsafe(self, source: str, action: str) -> CommandResult:
        """GCS-loss failsafe from the endpoint: LAND/RTL in flight, disarm on the ground."""
        return self._nav("Failsafe", self.autopilot.navigator.trigger_failsafe(source, action))

    def clear_failsafe(self, source: str) -> CommandResult:
        """The failsafe source is over (the mode stays)."""
        return self._nav("Failsafe clear", self.autopilot.navigator.clear_failsafe(source))

    # ------------------------------------------------------------------ autopilot parameters
    @property
    def config(self) -> AutopilotConfig:
        """The autopilot configuration in force."""
        return self._config

    def param_specs(self) -> Sequence[ParamSpec]:
        """The autopilot configuration as parameters (see the module docstring)."""
        return [ParamSpec(name=p.name, value=p.get(self._config), min_value=p.min_value,
                          max_value=p.max_value, allowed=p.allowed, integer=p.integer,
                          description=p.description) for p in AUTOPILOT_PARAMS]

    def set_param(self, name: str, value: float) -> CommandResult:
        """Apply a validated autopilot parameter: rebuild on the ground, refuse in flight."""
        spec = next((p for p in AUTOPILOT_PARAMS if p.name == name), None)
        if spec is None:
            return CommandResult.denied(f"unknown parameter {name}")
        if spec.read_only:
            return CommandResult.denied("read-only")  # the value in force is echoed back
        try:
            new = spec.set(self._config, float(value))
        except (ValueError, TypeError) as err:
            return CommandResult.denied(str(err))
        nav = self.autopilot.navigator
        if nav.armed or not nav.landed:
            if spec.live_speed is None:
                return CommandResult.denied("change it disarmed on the ground (the "
                                            "autopilot is rebuilt with it)")
            speed_m_s = spec.get(new) / 100.0
            result = nav.change_speed(speed_m_s, spec.live_speed)
            if not result.accepted:
                return CommandResult.denied(result.reason)
            self._config = new
            self._snap = None
            return CommandResult.ok()
        error = self._rebuild(new, keep_mode=True)
        if error:
            return CommandResult.denied(error)
        self._status(Severity.INFO, f"{name} = {value:g}: autopilot rebuilt")
        return CommandResult.ok()

    def _rebuild(self, config: AutopilotConfig, *, keep_mode: bool) -> str:
        """Replace the autopilot by one built from ``config`` at the current time.

        Keeps the loaded mission, home and (``keep_mode``) the flight mode. Returns "" or
        why the configuration could not be built (the old autopilot then stays).
        """
        t = self.world.time_s
        old_nav = self.autopilot.navigator
        try:
            ap = Autopilot(config)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
            return f"cannot build the autopilot: {err}"
        ap.reset_estimators(t)
        ap.step(t, [])
        nav = ap.navigator
        if old_nav.mission_items:
            nav.load_mission(old_nav.mission_items)
        home = old_nav.home_pos_ned
        if not np.array_equal(home, nav.home_pos_ned):
            nav.set_home(home)
        if keep_mode and old_nav.mode != nav.mode:
            nav.set_mode(int(old_nav.mode))
        ap.step(t, [])
        ap.drain_events()  # the rebuild's own mode/mission lines: not news to the pilot
        self.autopilot = ap
        self._config = config
        self.pwm = np.array(ap.pwm)
        self._snap = None
        return ""

    # ------------------------------------------------------------------ fault injection
    def inject_failure(self, unit: int, failure_type: int, instance: int) -> CommandResult:
        """MAV_CMD_INJECT_FAILURE onto the world's fault engine (module docstring table)."""
        self._snap = None
        what = f"{_UNIT_NAMES.get(unit, str(unit))} {_TYPE_NAMES.get(failure_type, '?')}"
        if unit == _MOTOR_UNIT:
            if instance not in (0, 1, 2, 3, 4):
                return CommandResult.denied(
                    f"Inject failure: motor instance {instance} (motors 1..4, 0 = all)")
            motors = (1, 2, 3, 4) if instance == 0 else (instance,)
            if failure_type == FailureType.OK:
                return self._clear_unit(f"MOTOR {instance or 'all'}", lambda f: isinstance(
                    f, ActuatorFault) and f.motor in motors)
            faults = [self._motor_fault(m, failure_type) for m in motors]
            if faults[0] is None:
                return CommandResult.not_supported(
                    f"Inject failure: {what} not supported (OK, OFF, STUCK, GARBAGE, WRONG, "
                    "DRIFT, INTERMITTENT are)")
            return self._inject(what, instance, [f for f in faults if f is not None])
        if unit in _SENSOR_UNITS:
            sensor, axis, stem, _ = _SENSOR_UNITS[unit]
            if instance not in (0, 1):
                return CommandResult.denied(
                    f"Inject failure: {_UNIT_NAMES[unit]} instance {instance} (one sensor: "
                    "use 0 or 1)")
            if failure_type == FailureType.OK:
                return self._clear_unit(_UNIT_NAMES[unit], lambda f: isinstance(
                    f, SensorFault) and f.sensor == sensor and (
                        axis is None or f.axis in (None, axis)))
            fault = self._sensor_fault(sensor, axis, stem, failure_type)
            if fault is None:
                return CommandResult.not_supported(
                    f"Inject failure: {what} not supported (OK, OFF, STUCK, GARBAGE, WRONG, "
                    "DRIFT are)")
            return self._inject(what, instance, [fault])
        return CommandResult.not_supported(
            f"Inject failure: unit {_UNIT_NAMES.get(unit, unit)} not simulated (MOTOR, GYRO, "
            "ACCEL, MAG, BARO, GPS are)")

    def _motor_fault(self, motor: int, failure_type: int) -> ActuatorFault | None:
        loe = self.sim_params.value("SIM_FI_LOE")
        if failure_type == FailureType.OFF:
            return ActuatorFault(motor=motor, kind="total_loss")
        if failure_type == FailureType.STUCK:
            return ActuatorFault(motor=motor, kind="lock")
        if failure_type == FailureType.GARBAGE:
            return ActuatorFault(motor=motor, kind="hardover")
        if failure_type == FailureType.WRONG:
            return ActuatorFault(motor=motor, kind="loe", loe=loe)
        if failure_type == FailureType.DRIFT:
            return ActuatorFault(motor=motor, kind="loe", loe=loe, profile="sinusoid",
                                 period_s=_DRIFT_PERIOD_S)
        if failure_type == FailureType.INTERMITTENT:
            return ActuatorFault(motor=motor, kind="loe", loe=1.0, profile="pulse",
                                 period_s=_INTERMITTENT_PERIOD_S,
                                 pulse_width_s=_INTERMITTENT_WIDTH_S)
        return None

    def _sensor_fault(self, sensor: str, axis: int | None, stem: str,
                      failure_type: int) -> SensorFault | None:
        if failure_type in (FailureType.OFF, FailureType.STUCK):
            return SensorFault(sensor=sensor, kind="freeze", axis=axis)  # type: ignore[arg-type]
        if failure_type == FailureType.GARBAGE:
            return SensorFault(sensor=sensor, kind="calibration",  # type: ignore[arg-type]
                               axis=axis)
        if failure_type == FailureType.WRONG:
            return SensorFault(sensor=sensor, kind="bias", axis=axis,  # type: ignore[arg-type]
                               magnitude=self.sim_params.value(f"SIM_FI_{stem}_BIAS"))
        if failure_type == FailureType.DRIFT:
            return SensorFault(sensor=sensor, kind="drift", axis=axis,  # type: ignore[arg-type]
                               rate=self.sim_params.value(f"SIM_FI_{stem}_DRIFT"))
        return None

    def _inject(self, what: str, instance: int, faults: list[Fault]) -> CommandResult:
        t = self.world.time_s
        for fault in faults:
            fault_id = self.world.faults.apply_now(fault, t)
            self._quiet_ids.add(fault_id)
            self._status(Severity.WARNING, f"SIM: injected {fault.describe()}")
        return CommandResult.ok()

    def _clear_unit(self, what: str, match: Callable[[Fault], bool]) -> CommandResult:
        engine = self.world.faults
        owned = set(self._owned.values())
        kept = 0
        cleared = 0
        for scheduled in engine.scheduled():
            if not match(scheduled.fault):
                continue
            if scheduled.fault_id in owned:
                kept += 1
                continue
            self._quiet_ids.add(scheduled.fault_id)
            engine.clear(scheduled.fault_id, self.world.time_s)
            cleared += 1
        text = f"SIM: {what} OK: {cleared} fault{'s' if cleared != 1 else ''} cleared"
        if kept:
            text += f", {kept} kept (set by SIM_* parameters: reset them)"
        self._status(Severity.NOTICE, text)
        return CommandResult.ok()

    # ------------------------------------------------------------------ parameter-owned faults
    def own_fault(self, slot: str, fault: Fault | None) -> None:
        """Replace the fault owned by parameter ``slot`` by ``fault`` (None: just remove it)."""
        engine = self.world.faults
        t = self.world.time_s
        old = self._owned.pop(slot, None)
        if old is not None and any(s.fault_id == old for s in engine.scheduled()):
            self._quiet_ids.add(old)
            engine.clear(old, t)
        if fault is not None:
            fault_id = engine.apply_now(fault, t)
            self._quiet_ids.add(fault_id)
            self._owned[slot] = fault_id
            self._status(Severity.WARNING, f"SIM: {slot}: {fault.describe()}")
        self._snap = None


def warm_up(setup: VehicleSetup, ticks: int = 50) -> None:
    """Fly a throwaway copy of the vehicle for ``ticks`` ticks (boot, arm, take-off).

    The plant, sensors and estimators are numba code whose first call loads (or compiles)
    machine code: about 0.2 s that would otherwise fall on the first real tick, a glitch in
    a real-time run. The copy has its own world and autopilot, so the real ones are
    untouched (determinism is kept).
    """
    world = World(setup.world, setup.seed)
    autopilot = Autopilot(setup.autopilot)
    steps = round(setup.world.plant_rate_hz / setup.autopilot.loop_rate_hz)
    pwm = autopilot.step(0.0, [])
    nav = autopilot.navigator
    nav.set_mode(int(Mode.GUIDED))
    nav.arm()
    nav.takeoff(1.0)
    for _ in range(ticks):
        samples = world.step(pwm, steps)
        pwm = autopilot.step(world.time_s, samples)
    world.truth()
    world.drain_events()
    autopilot.drain_events()


def _body_rates(euler_rad: np.ndarray, euler_rate: np.ndarray) -> np.ndarray:
    """Body rates p, q, r (rad/s) of ZYX Euler angles and their derivatives."""
    phi, theta = float(euler_rad[0]), float(euler_rad[1])
    dphi, dtheta, dpsi = (float(v) for v in euler_rate)
    sp, cp = math.sin(phi), math.cos(phi)
    st, ct = math.sin(theta), math.cos(theta)
    # p = phi' - psi' sin(theta); q = theta' cos(phi) + psi' sin(phi) cos(theta);
    # r = -theta' sin(phi) + psi' cos(phi) cos(theta)
    return np.array([dphi - dpsi * st, dtheta * cp + dpsi * sp * ct,
                     -dtheta * sp + dpsi * cp * ct])


def _to_nav_item(item: MissionItem) -> NavItem | CommandResult:
    """A MAVLink mission item (SI, NED) as a navigator item, or why it cannot be flown."""
    where = f"item {item.seq}"
    cmd = item.command
    try:
        if cmd == _CMD_WAYPOINT:
            hold_s = item.params[0]
            if not (math.isfinite(hold_s) and hold_s >= 0.0):
                return CommandResult.denied(f"{where}: hold time {hold_s} s must be >= 0")
            if item.north_east_m is None:
                if item.down_m is not None:
                    return CommandResult.denied(f"{where}: a waypoint needs a latitude and "
                                                "longitude (0, 0 = here is not supported)")
                pos = None
            else:
                assert item.down_m is not None
                pos = (item.north_east_m[0], item.north_east_m[1], item.down_m)
            return NavItem(command="waypoint", pos_ned=pos, hold_s=float(hold_s),
                           yaw_rad=item.yaw_rad)
        if cmd == _CMD_TAKEOFF:
            if item.alt_m is None:
                return CommandResult.denied(f"{where}: NAV_TAKEOFF needs an altitude")
            return NavItem(command="takeoff", alt_m=float(item.alt_m))
        if cmd == _CMD_LAND:
            land_pos = None if item.north_east_m is None else (
                item.north_east_m[0], item.north_east_m[1], 0.0)
            return NavItem(command="land", pos_ned=land_pos)
        if cmd == _CMD_RTL:
            return NavItem(command="rtl")
        if cmd == _CMD_CHANGE_SPEED:
            kind = item.params[0]
            speed = item.params[1]
            if kind not in _SPEED_TYPES:
                return CommandResult.denied(f"{where}: DO_CHANGE_SPEED speed type {kind} "
                                            "not in 0..3")
            if speed == -1.0:
                return CommandResult.denied(f"{where}: DO_CHANGE_SPEED -1 (no change) is "
                                            "not supported in missions")
            return NavItem(command="change_speed", speed_m_s=float(speed),
                           speed_type=_SPEED_TYPES[int(kind)])  # type: ignore[arg-type]
    except ValueError as err:
        return CommandResult.denied(f"{where}: {err}")
    return CommandResult.not_supported(
        f"{where}: MAV_CMD {cmd} not supported (NAV_WAYPOINT 16, NAV_RETURN_TO_LAUNCH 20, "
        "NAV_LAND 21, NAV_TAKEOFF 22, DO_CHANGE_SPEED 178 are)")


# ---------------------------------------------------------------------------------------------
# SIM_* parameters


@dataclass
class _SimParam:
    spec: ParamSpec
    apply: Callable[[float], CommandResult] | None = None  # None: stored only (magnitudes)


@dataclass
class SimParams:
    """The ``SIM_*`` parameters of one vehicle (see the module docstring).

    A :class:`fcu.mavlink.port.ParamProvider`: pass it to the endpoint in ``extra_params``.
    """

    vehicle: SimVehicle
    _params: dict[str, _SimParam] = field(default_factory=dict)
    _values: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        setup = self.vehicle.setup
        wind = setup.world.wind
        self._wind_config: WindConfig = wind
        mass_kg = setup.world.airframe.mass
        defs: list[_SimParam] = [
            _SimParam(ParamSpec(name="SIM_ENGINE_FAIL", value=0, min_value=0, max_value=15,
                                integer=True, description="Motors hit by SIM_ENGINE_MUL, "
                                "bitmask (bit 0 = motor 1)"),
                      lambda x: self._motors_changed()),
            _SimParam(ParamSpec(name="SIM_ENGINE_MUL", value=1.0, min_value=0.0,
                                max_value=1.0, description="Thrust multiplier of the "
                                "SIM_ENGINE_FAIL motors (LOE = 1 - mul)"),
                      lambda x: self._motors_changed()),
        ]
        for m in (1, 2, 3, 4):
            defs.append(_SimParam(ParamSpec(
                name=f"SIM_MOT{m}_LOE", value=0.0, min_value=0.0, max_value=1.0,
                description=f"Loss of effectiveness of motor {m} (0 healthy, 1 no thrust)"),
                lambda x: self._motors_changed()))
        defs += [
            _SimParam(ParamSpec(name="SIM_BARO_GLITCH", value=0.0, min_value=-100.0,
                                max_value=100.0, description="Barometer bias, m"),
                      lambda x: self._sensor_slot("SIM_BARO_GLITCH", None if x == 0 else
                                                  SensorFault(sensor="baro", kind="bias",
                                                              magnitude=x))),
            _SimParam(ParamSpec(name="SIM_BARO_DRIFT", value=0.0, min_value=-10.0,
                                max_value=10.0, description="Barometer drift, m/s"),
                      lambda x: self._sensor_slot("SIM_BARO_DRIFT", None if x == 0 else
                                                  SensorFault(sensor="baro", kind="drift",
                                                              rate=x))),
            _SimParam(ParamSpec(name="SIM_BARO_FREEZE", value=0, min_value=0, max_value=1,
                                allowed=(0.0, 1.0), integer=True,
                                description="Barometer holds its last reading (0/1)"),
                      lambda x: self._sensor_slot("SIM_BARO_FREEZE", None if x == 0 else
                                                  SensorFault(sensor="baro", kind="freeze"))),
            _SimParam(ParamSpec(name="SIM_MASS_DROP", value=0.0, min_value=0.0,
                                max_value=round(0.5 * mass_kg, 3),
                                description="Mass that has left the airframe, kg"),
                      self._mass_drop),
            _SimParam(ParamSpec(name="SIM_WIND_SPD", value=wind.mean_speed_m_s,
                                min_value=0.0, max_value=30.0,
                                description="Mean wind speed, m/s"),
                      lambda x: self._wind(mean_speed_m_s=x)),
            _SimParam(ParamSpec(name="SIM_WIND_DIR", value=wind.mean_from_deg, min_value=0.0,
                                max_value=360.0,
                                description="Direction the wind blows from, deg"),
                      lambda x: self._wind(mean_from_deg=x)),
            _SimParam(ParamSpec(name="SIM_WIND_TURB", value=wind.w20_effective_m_s,
                                min_value=0.0, max_value=30.0,
                                description="Dryden turbulence W20, m/s (0 none)"),
                      self._turbulence),
            _SimParam(ParamSpec(name="SIM_PAUSE", value=1 if setup.start_paused else 0,
                                min_value=0, max_value=1, allowed=(0.0, 1.0), integer=True,
                                description="Hold simulated time (1) or run (0)"),
                      lambda x: CommandResult.ok()),
            _SimParam(ParamSpec(name="SIM_SPEEDUP", value=setup.speedup, min_value=0.0,
                                description="Simulated s per wall s (read-only, --speedup)"),
                      lambda x: CommandResult.denied("read-only (set by --speedup at start)")),
            _SimParam(ParamSpec(name="SIM_FI_LOE", value=0.3, min_value=0.0, max_value=1.0,
                                description="LOE of INJECT_FAILURE MOTOR WRONG/DRIFT")),
        ]
        units = {stem: unit for _, _, stem, unit in _SENSOR_UNITS.values()}
        for stem, (bias, rate) in _FI_DEFAULTS.items():
            unit = units[stem]
            defs += [
                _SimParam(ParamSpec(name=f"SIM_FI_{stem}_BIAS", value=bias, min_value=-1e3,
                                    max_value=1e3, description=f"Bias of INJECT_FAILURE "
                                    f"{stem} WRONG, {unit}")),
                _SimParam(ParamSpec(name=f"SIM_FI_{stem}_DRIFT", value=rate, min_value=-1e3,
                                    max_value=1e3, description=f"Drift of INJECT_FAILURE "
                                    f"{stem} DRIFT, {unit}/s")),
            ]
        self._params = {d.spec.name: d for d in defs}
        self._values = {d.spec.name: float(d.spec.value) for d in defs}

    @property
    def paused(self) -> bool:
        """SIM_PAUSE is 1."""
        return self._values["SIM_PAUSE"] != 0.0

    def value(self, name: str) -> float:
        """Current value of ``name``."""
        return self._values[name]

    # ParamProvider
    def param_specs(self) -> Sequence[ParamSpec]:
        """Definitions with current values."""
        return [replace(p.spec, value=self._values[n]) for n, p in self._params.items()]

    def set_param(self, name: str, value: float) -> CommandResult:
        """Apply a validated change; the value is kept only when accepted."""
        param = self._params.get(name)
        if param is None:
            return CommandResult.denied(f"unknown parameter {name}")
        old = self._values[name]
        self._values[name] = float(value)
        if param.apply is None:
            return CommandResult.ok()
        try:
            result = param.apply(float(value))
        except ValueError as err:
            result = CommandResult.denied(str(err))
        if not result.accepted:
            self._values[name] = old
        return result

    # appliers
    def _motors_changed(self) -> CommandResult:
        mask = int(self._values["SIM_ENGINE_FAIL"])
        mul = self._values["SIM_ENGINE_MUL"]
        for m in (1, 2, 3, 4):
            eff = 1.0 - self._values[f"SIM_MOT{m}_LOE"]
            if mask & (1 << (m - 1)):
                eff *= mul
            gamma = min(max(1.0 - eff, 0.0), 1.0)
            slot = f"SIM motor {m}"
            held = self.vehicle.owned_fault(slot)
            wanted = None if gamma <= 0.0 else ActuatorFault(motor=m, kind="loe", loe=gamma)
            if held == wanted:
                continue
            self.vehicle.own_fault(slot, wanted)
        return CommandResult.ok()

    def _sensor_slot(self, slot: str, fault: SensorFault | None) -> CommandResult:
        self.vehicle.own_fault(slot, fault)
        return CommandResult.ok()

    def _mass_drop(self, mass_kg: float) -> CommandResult:
        fault = None if mass_kg == 0.0 else StructuralFault(mass_loss_kg=mass_kg)
        self.vehicle.own_fault("SIM_MASS_DROP", fault)
        return CommandResult.ok()

    def _wind(self, **change: Any) -> CommandResult:
        config = replace(self._wind_config, **change)
        self.vehicle.world.set_wind(config)
        self._wind_config = config
        self.vehicle.notice("SIM: wind " + _wind_text(config))
        return CommandResult.ok()

    def _turbulence(self, w20_m_s: float) -> CommandResult:
        cfg = self._wind_config
        if w20_m_s == 0.0:
            return self._wind(turbulence="none", w20_m_s=None)
        named = cfg.turbulence if cfg.turbulence != "none" else "light"
        return self._wind(turbulence=named, w20_m_s=w20_m_s)


def _wind_text(cfg: Any) -> str:
    turb = "no turbulence" if cfg.turbulence == "none" else \
        f"turbulence W20 {cfg.w20_effective_m_s:.2f} m/s"
    return f"{cfg.mean_speed_m_s:.2f} m/s from {cfg.mean_from_deg:.0f} deg, {turb}"
