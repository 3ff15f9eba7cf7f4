"""One simulated vehicle behind the MAVLink endpoint: the tick loop, the autopilot's port, and
what only the simulator offers (truth, fault injection, ``SIM_*`` parameters).

:class:`SimVehicle` runs the tick loop the headless runner runs (:mod:`sim.stack`), hands
the endpoint the autopilot's port (:class:`fcu.mavlink.autopilot_port.AutopilotPort`, with
simulator truth for SIM_STATE plugged in), and is itself the endpoint's
:class:`fcu.mavlink.port.FailureInjector` (MAV_CMD_INJECT_FAILURE onto the world's fault
engine); :attr:`SimVehicle.sim_params` is the ``SIM_*`` parameter source
(:mod:`sim.sim_params`).

Commands, parameter changes and injections arrive between ticks (the vehicle process calls
the endpoint after each tick), so a run depends on the tick at which each command arrived and
never on wall time. Fault injection reaches the world's fault engine only: the autopilot
learns of a fault through its sensors and the vehicle's motion, as in flight.

The autopilot's own parameters (``ATT_CTRL``, ``POS_*``, ``WPNAV_*``...) are defined with the
autopilot, in :mod:`fcu.mavlink.autopilot_params`; :mod:`fcu.mavlink.autopilot_port` applies
them.

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
SIM_BATT_CAP_AH    Ah           capacity of the simulated pack (the charge used stays used)
SIM_PAUSE          0/1          hold simulated time (the link stays up); 0 resumes
SIM_SPEEDUP        read-only    simulated seconds per wall second (``--speedup``; 0: max)
SIM_FI_LOE         0..1         LOE of an INJECT_FAILURE MOTOR WRONG (peak of DRIFT)
SIM_FI_<S>_BIAS    sensor unit  bias of an INJECT_FAILURE <sensor> WRONG
SIM_FI_<S>_DRIFT   unit/s       drift rate of an INJECT_FAILURE <sensor> DRIFT
SYS_FAILURE_EN     0/1          INJECT_FAILURE accepted (1, default) or DENIED (0)
=================  ===========  =========================================================

with ``<S>`` one of GYR (rad/s), ACC (m/s^2), MAG (heading, rad), BAR (m), GPS (m).
``SYS_FAILURE_EN`` is PX4's name for the gate (ArduPilot SITL has none: its injection is the
``SIM_*`` parameters); MAVSDK's Failure plugin reads it only from a PX4 vehicle, so against
this ArduCopter-style vehicle it just sends the command and reports DENIED when the gate is
closed. It defaults to 1 because injecting faults is what this simulator is for (the ground
station's fault schedules use the same command).

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
from collections.abc import Callable
from dataclasses import dataclass, replace

from fcu.autopilot import AutopilotConfig
from fcu.mavlink.autopilot_port import AutopilotPort
from fcu.mavlink.enums import FailureType, FailureUnit, Severity
from fcu.mavlink.port_records import CommandResult, GeoPoint, SimTruth
from flightdata.mission import MissionItem as NavItem
from sim.outcome import MissionArea, OutcomeJudge, mission_area
from sim.sim_params import SimParams
from sim.stack import SimulatedStack
from sim.world import PlantEvent, World, WorldConfig
from sim.world.esc import EscConfig, esc_readings
from sim.world.fault_types import ActuatorFault, Fault, FaultEvent, SensorFault

__all__ = ["SimVehicle", "VehicleSetup"]


@dataclass(frozen=True, kw_only=True)
class VehicleSetup:
    """What one vehicle process simulates (everything but the network)."""

    world: WorldConfig
    autopilot: AutopilotConfig
    seed: int  # -, seed of every random stream of the world
    origin: GeoPoint  # home at boot: geodetic position of the NED origin
    speedup: float = 1.0  # simulated s per wall s, math.inf = unthrottled (SIM_SPEEDUP 0)
    faults: tuple[Fault, ...] = ()  # scheduled in simulated time at boot
    start_paused: bool = False  # SIM_PAUSE = 1 at boot




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
_DRIFT_PERIOD_S = 20.0  # s, MOTOR DRIFT: LOE sinusoid period
_INTERMITTENT_PERIOD_S = 2.0  # s, MOTOR INTERMITTENT: cut-out period
_INTERMITTENT_WIDTH_S = 0.5  # s, MOTOR INTERMITTENT: cut-out length
_CONTACT_QUIET_S = 1.0  # s simulated, least time between two touchdown/lift-off STATUSTEXTs


class SimVehicle:
    """One simulated vehicle: the tick loop, the autopilot's MAVLink port, the simulator's
    own MAVLink surface (truth, injection, ``SIM_*`` parameters).

    Parameters
    ----------
    setup : VehicleSetup
        World and autopilot configuration, seed, origin and boot faults.

    Attributes
    ----------
    stack : SimulatedStack
        The world and the autopilot on one clock (:mod:`sim.stack`).
    port : AutopilotPort
        What the endpoint talks to (``MavlinkEndpoint(vehicle.port, ...)``).
    sim_params : SimParams
        The ``SIM_*`` parameters (``extra_params`` of the endpoint).

    Notes
    -----
    Call :meth:`first_tick` once, then :meth:`tick` once per autopilot period; call the
    endpoint between ticks. It is the endpoint's :class:`fcu.mavlink.port.FailureInjector`.
    Not thread-safe: everything runs on the vehicle loop's thread.
    """

    def __init__(self, setup: VehicleSetup) -> None:
        self.setup = setup
        self.stack = SimulatedStack(setup.world, setup.autopilot, setup.seed, setup.faults)
        self.judge = OutcomeJudge(MissionArea())
        self._esc = EscConfig()
        self.port = AutopilotPort(self.stack, setup.origin, truth=self._truth,
                                  on_target=self.judge.area.extend)
        self._judged_mission: tuple[NavItem, ...] | None = None
        self._was_armed = False
        # fault slot (param name / motor) -> (fault id, the fault as the parameter asked)
        self._owned: dict[str, tuple[int, Fault]] = {}
        self._quiet_ids: set[int] = set()  # faults injected here: their engine events are ours
        self._silent_ids: set[int] = set()  # parameter-owned faults: own_fault says it all
        self._last_contact_s = -math.inf
        self.sim_params = SimParams(self, speedup=setup.speedup if math.isfinite(setup.speedup)
                                    else 0.0,
                                    start_paused=setup.start_paused)

    # ------------------------------------------------------------------ stepping
    @property
    def world(self) -> World:
        """The simulated world."""
        return self.stack.world

    @property
    def config(self) -> AutopilotConfig:
        """The autopilot configuration in force."""
        return self.port.config

    @property
    def time_s(self) -> float:
        """Simulated time, s."""
        return self.stack.time_s

    @property
    def tick_s(self) -> float:
        """Autopilot period, s simulated."""
        return self.stack.tick_s

    @property
    def ticks(self) -> int:
        """Ticks since the boot tick."""
        return self.stack.ticks

    @property
    def paused(self) -> bool:
        """SIM_PAUSE is set: the loop holds simulated time."""
        return self.sim_params.paused

    def first_tick(self) -> None:
        """The boot tick at t = 0 (before any plant step)."""
        if self.stack.ticks or self.stack.autopilot.status is not None:
            return
        self.stack.first_tick()
        self._collect()

    def tick(self) -> None:
        """One autopilot tick (:meth:`sim.stack.SimulatedStack.tick`) and its events."""
        self.stack.tick()
        self.port.observe(self.stack.samples)
        self._collect()

    def _collect(self) -> None:
        autopilot_events, world_events = self.stack.drain_events()
        self.port.collect(autopilot_events)
        touchdowns = []
        for wev in world_events:
            if isinstance(wev, FaultEvent):
                self.port.post_record(wev.record)
                self._fault_event(wev)
            elif isinstance(wev, PlantEvent):
                self._plant_event(wev)
                if wev.kind in ("touchdown", "crash"):
                    touchdowns.append((wev.time_s, wev.speed_m_s))
        self._judge(touchdowns)

    def _judge(self, touchdowns: list[tuple[float, float]]) -> None:
        """The outcome of each flight, from truth (:mod:`sim.outcome`), announced as a
        record and a STATUSTEXT; a new flight starts when the vehicle is armed again."""
        nav = self.stack.autopilot.navigator
        items = nav.mission_items
        if items is not self._judged_mission:
            self._judged_mission = items
            for point in mission_area(items, nav.home_pos_ned).corners():
                self.judge.area.extend(point)
        if nav.flying_pilot_leg:  # sticks or set-points fly it: where they take it is meant,
            # and where it would stop when they let go
            status = self.stack.autopilot.status
            if status is not None and status.reference is not None:
                self.judge.area.extend(status.reference.pos_ned)
            self.judge.area.extend(nav.stopping_point_ned)
        armed = nav.armed
        if armed and not self._was_armed:
            self.judge.rearm()
            self.judge.area.extend(nav.home_pos_ned)
        self._was_armed = armed
        world = self.stack.world
        plant = world.plant
        n, e, d, _, _, _, w, qx, qy, qz = plant.state[:10].tolist()
        judge = self.judge
        judge.observe(world.time_s, (n, e, d), (w, qx, qy, qz), plant.on_ground, touchdowns,
                      armed)
        if not judge.decided:
            return  # the common tick
        for outcome in judge.drain():
            self.port.post_record(outcome)
            severity = Severity.INFO if outcome.safe else Severity.CRITICAL
            self.port.post(severity, f"SIM: {outcome.text()}")

    def _plant_event(self, ev: PlantEvent) -> None:
        if ev.kind == "crash":
            self.port.post(Severity.CRITICAL, f"SIM: {ev.description}")
            return
        # a vehicle bouncing on the ground would chatter: one contact line per simulated second
        if ev.time_s - self._last_contact_s >= _CONTACT_QUIET_S:
            self._last_contact_s = ev.time_s
            self.port.post(Severity.DEBUG, f"SIM: {ev.description}")

    def _fault_event(self, ev: FaultEvent) -> None:
        if ev.fault_id in self._silent_ids:
            if ev.kind in ("cleared", "ended"):
                self._silent_ids.discard(ev.fault_id)
            return
        if ev.fault_id in self._quiet_ids:
            if ev.kind in ("cleared", "ended"):
                self._quiet_ids.discard(ev.fault_id)
                self.port.post(Severity.NOTICE, f"SIM: {ev.kind} {ev.description}")
            return
        if ev.kind == "injected":
            self.port.post(Severity.INFO, f"SIM: fault scheduled: {ev.description}")
        else:
            severity = Severity.WARNING if ev.kind == "started" else Severity.NOTICE
            self.port.post(severity, f"SIM: fault {ev.kind}: {ev.description}")

    def notice(self, text: str) -> None:
        """Queue a STATUSTEXT of severity NOTICE (for the simulator's own messages)."""
        self.port.post(Severity.NOTICE, text)

    def owned_fault(self, slot: str) -> Fault | None:
        """The fault parameter ``slot`` currently holds in the engine (as it was asked for),
        if any."""
        held = self._owned.get(slot)
        if held is None:
            return None
        fault_id, fault = held
        alive = any(s.fault_id == fault_id for s in self.world.faults.scheduled())
        return fault if alive else None

    def _truth(self) -> SimTruth:
        """Simulator truth for SIM_STATE (never shown to the autopilot)."""
        pos, vel, quat, rate, accel, wind = self.world.motion_truth()
        esc = esc_readings(self.world.motor_thrust_n(), self.world.battery.state.voltage_v,
                           self._esc, self.world.config.battery)
        return SimTruth(pos_ned=pos, vel_ned=vel, quat_wxyz=quat, rate_frd=rate,
                        accel_frd=accel, wind_ned=wind, esc_rpm=esc.rpm,
                        esc_current_a=esc.current_a, esc_voltage_v=esc.voltage_v)

    # ------------------------------------------------------------------ FailureInjector
    def inject_failure(self, unit: int, failure_type: int, instance: int,
                       at_s: float | None = None) -> CommandResult:
        """MAV_CMD_INJECT_FAILURE onto the world's fault engine (module docstring table)."""
        self.port.invalidate()
        what = f"{_UNIT_NAMES.get(unit, str(unit))} {_TYPE_NAMES.get(failure_type, '?')}"
        if not self.sim_params.failure_injection_enabled:
            return CommandResult.denied(f"Inject failure: {what} refused: failure injection "
                                        "disabled (SYS_FAILURE_EN = 0)")
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
            return self._inject([f for f in faults if f is not None], at_s)
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
            return self._inject([fault], at_s)
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

    def _inject(self, faults: list[Fault], at_s: float | None) -> CommandResult:
        t = self.world.time_s
        if at_s is not None and at_s > t:
            return self._schedule(faults, at_s)
        for fault in faults:
            fault_id = self.world.faults.apply_now(fault, t)
            self._quiet_ids.add(fault_id)
            self.port.post(Severity.WARNING, f"SIM: injected {fault.describe()}")
        return CommandResult.ok()

    def _schedule(self, faults: list[Fault], at_s: float) -> CommandResult:
        """Schedule ``faults`` at simulated time ``at_s``; the engine's own events announce
        them ("fault scheduled", then "fault started"). A repeat of a pending identical
        injection (a command re-sent because its ACK was lost) adds nothing."""
        engine = self.world.faults
        pending = {s.fault for s in engine.scheduled()}
        for fault in faults:
            timed = replace(fault, start_s=at_s)  # injected faults have no end (end_s None)
            if timed not in pending:
                engine.schedule(timed)
        return CommandResult.ok()

    def _clear_unit(self, what: str, match: Callable[[Fault], bool]) -> CommandResult:
        engine = self.world.faults
        owned = {fault_id for fault_id, _ in self._owned.values()}
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
        self.port.post(Severity.NOTICE, text)
        return CommandResult.ok()

    # ------------------------------------------------------------------ parameter-owned faults
    def own_fault(self, slot: str, fault: Fault | None) -> None:
        """Replace the fault owned by parameter ``slot`` by ``fault`` (None: just remove it).

        One STATUSTEXT says what happened: ``SIM: set <fault>``, ``SIM: changed <old> ->
        <new>`` or ``SIM: cleared <fault>``; asking again for the fault in force does (and
        says) nothing.
        """
        engine = self.world.faults
        t = self.world.time_s
        old = self.owned_fault(slot)
        if old == fault:
            return
        held = self._owned.pop(slot, None)
        if held is not None and old is not None:
            self._silent_ids.add(held[0])
            engine.clear(held[0], t)
        if fault is not None:
            fault_id = engine.apply_now(fault, t)
            self._silent_ids.add(fault_id)
            self._owned[slot] = (fault_id, fault)
        if old is None and fault is not None:
            self.port.post(Severity.WARNING, f"SIM: set {fault.describe()}")
        elif old is not None and fault is None:
            self.port.post(Severity.NOTICE, f"SIM: cleared {old.describe()}")
        elif old is not None and fault is not None:
            self.port.post(Severity.WARNING, f"SIM: changed {_changed(old, fault)}")
        self.port.invalidate()


def _changed(old: Fault, new: Fault) -> str:
    """``"motor 1: loe 30 % (step) -> loe 65 % (step)"``: the shared part said once."""
    before, after = old.describe(), new.describe()
    where, sep, what = before.partition(": ")
    if sep and after.startswith(where + sep):
        return f"{before} -> {after[len(where + sep):]}"
    return f"{before} -> {after}"
