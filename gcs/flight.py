"""The whole flight a researcher or a CI job runs: connect, configure, upload, fly, inject, land.

:func:`fly` reads top to bottom like the flight::

    wait for the vehicle's HEARTBEAT           -> VehicleNotFound
    refuse a vehicle found armed                -> VehicleBusy
    a mode that allows arming (STABILIZE unless it is in one), seen in its HEARTBEAT
    wait until armable; a vehicle that arms only after a restart (a failure detected in
    an earlier flight) is restarted when the plan allows it  -> RestartNeeded
    ask for the table's telemetry at 100 Hz
    read the parameters; set the autopilot configuration (ATT_CTRL, EST_TYPE, DOB_TYPE...)
    wait for HOME_POSITION and the armable (PREARM_CHECK) flag
    upload the mission                          -> MissionRejected
    arm, AUTO, MISSION_START                    -> CommandRefused
    if the vehicle was started paused (SIM_PAUSE = 1), start simulated time
    until landed and disarmed: inject each fault on time (vehicle clock), watch for a crash,
    a lost link, or a mission that does not end  -> Crashed, FlightTimeout
    clear the faults this flight injected (also after a failed flight, while the vehicle
    answers), so the next flight starts healthy

A simulator found running (SIM_PAUSE offered and 0) is held (SIM_PAUSE = 1) from the arm
command to the mission start, as a vehicle started paused is: the vehicle disarms on the
ground 10 s (simulated) after arming when it does not take off, which at a speed-up of 20 is
half a wall second, less than arm, AUTO and MISSION_START can take over a lossy link. A
flight that fails in between lets it run again.

A vehicle found armed is refused, never taken over: it is flying someone else's flight (or
about to), and a ground station that uploads a mission over it or changes its mode would
take it from them.

Fault timing: each fault is sent when the vehicle clock (100 Hz ATTITUDE) reaches its target
minus the measured command lag (:meth:`gcs.station.GroundStation.lead_s`), with a TIMESYNC in
the same datagram so the time it took effect is known exactly; the error is logged.

A vehicle started paused (``ftc-vehicle --start-paused``) flies exactly the headless runner's
timeline: everything up to MISSION_START happens at simulated time 0, as in
``sim.runner.fly``.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from flightdata import vocabulary
from flightdata.steps import Steps
from gcs.analysis import FlightAnalyzer, replay_tlog
from gcs.errors import (
    CommandRefused,
    Crashed,
    FlightError,
    FlightTimeout,
    MissionRejected,
    RestartNeeded,
    VehicleBusy,
)
from gcs.faults import FaultSpec, sorted_schedule
from gcs.injection import InjectionTiming
from gcs.mavlink import mavlink2
from gcs.mission import WireItem
from gcs.parameters import same_float32
from gcs.station import COPTER_MODE_AUTO, TELEMETRY_HZ, GroundStation, mode_name
from gcs.table import FlightReport

__all__ = ["FlightOutcome", "FlightPlan", "config_params", "fly"]

MAV_MISSION_TYPE_FENCE = mavlink2.MAV_MISSION_TYPE_FENCE
MAV_MISSION_TYPE_RALLY = mavlink2.MAV_MISSION_TYPE_RALLY
MAV_MISSION_UNSUPPORTED = mavlink2.MAV_MISSION_UNSUPPORTED



def config_params(*, attitude: str | None = None, estimator: str | None = None,
                  dob: str | None = None) -> dict[str, float]:
    """The parameters selecting an autopilot configuration (only the ones given), with the
    values of :mod:`flightdata.vocabulary`.

    Raises
    ------
    ValueError
        A name that is not one of the choices.
    """
    out: dict[str, float] = {}
    for key, value in (("attitude", attitude), ("estimator", estimator), ("dob", dob)):
        if value is not None:
            out[vocabulary.CONFIG_PARAMS[key]] = float(vocabulary.choice_value(key, value))
    return out


@dataclass(frozen=True, kw_only=True)
class FlightPlan:
    """What to fly and how long to wait for things.

    Attributes
    ----------
    mission : list of WireItem
        Items seq 1..n (home is added).
    fence, rally : list of WireItem
        A geofence and rally points (a QGC plan's, :func:`gcs.mission.load_plan`), uploaded
        after the mission when given; a vehicle that keeps none (MAV_MISSION_UNSUPPORTED)
        flies without them, and the event log says so.
    faults : list of FaultSpec
        Injections, at simulated seconds after the mission start.
    params : dict of str to float
        Parameters to set before arming (configuration first, in the given order).
    inject_via : {"command", "param"}
        How motor faults are sent (:meth:`GroundStation.inject`): scheduled on the vehicle's
        clock (exact) or set as a parameter when due.
    telemetry_hz : dict of str to float
        Stream rates to ask for (simulated Hz).
    max_flight_s : float
        Simulated seconds after the mission start before the flight counts as timed out.
    connect_timeout_s, link_timeout_s, ready_timeout_s, wall_timeout_s : float
        Wall-clock limits: finding the vehicle, silence in flight, becoming armable, the
        whole flight.
    reboot : bool
        Restart the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN) when it arms only after a
        restart (a failure it detected in an earlier flight); without it such a vehicle ends
        the flight with :class:`gcs.errors.RestartNeeded`.
    """

    mission: Sequence[WireItem]
    fence: Sequence[WireItem] = ()
    rally: Sequence[WireItem] = ()
    faults: Sequence[FaultSpec] = ()
    params: dict[str, float] = field(default_factory=dict)
    inject_via: str = "command"
    telemetry_hz: dict[str, float] = field(default_factory=lambda: dict(TELEMETRY_HZ))
    max_flight_s: float = 120.0  # s simulated
    connect_timeout_s: float = 10.0  # s wall
    link_timeout_s: float = 5.0  # s wall
    ready_timeout_s: float = 30.0  # s wall
    wall_timeout_s: float = 900.0  # s wall
    reboot: bool = False

    def __post_init__(self) -> None:
        if self.inject_via not in ("command", "param"):
            raise ValueError(f"inject_via = {self.inject_via!r}: must be 'command' or 'param'")
        for name in ("max_flight_s", "connect_timeout_s", "link_timeout_s", "ready_timeout_s",
                     "wall_timeout_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} = {value!r}: must be a finite number > 0")


@dataclass
class FlightOutcome:
    """How a flight went.

    Attributes
    ----------
    report : FlightReport
        The table, computed from the flight's .tlog (what ``ftc-gcs report`` prints).
    timing : list of InjectionTiming
        Each injection against its target.
    error : FlightError or None
        Why the flight failed (None: flown and landed).
    tlog : Path or None
    event_log : Path or None
    replayed : FlightAnalyzer or None
        The .tlog read back (its :meth:`~gcs.analysis.FlightAnalyzer.series` feeds the
        figures and recordings); None without a .tlog.
    """

    report: FlightReport
    timing: list[InjectionTiming]
    error: FlightError | None
    tlog: Path | None
    event_log: Path | None
    replayed: FlightAnalyzer | None = None

    @property
    def exit_code(self) -> int:
        """0, or the error's exit code."""
        return 0 if self.error is None else self.error.exit_code

    def to_json(self) -> dict[str, object]:
        """Report, injection timing and result, JSON-ready."""
        out = self.report.to_json()
        out["injection_timing"] = [
            {"motor": t.fault.motor, "param": t.fault.param, "loe": t.fault.loe,
             "at_s": t.fault.at_s, "target_s": t.target_s, "sent_at_s": t.sent_at_s,
             "achieved_s": t.achieved_s, "error_s": t.error_s} for t in self.timing]
        out["result"] = "ok" if self.error is None else self.error.one_line()
        out["exit_code"] = self.exit_code
        out["tlog"] = None if self.tlog is None else str(self.tlog)
        out["event_log"] = None if self.event_log is None else str(self.event_log)
        return out


class _Injector:
    """Delivers the schedule's faults: motor faults sent as commands are scheduled on the
    vehicle's clock as soon as the mission starts; the others are sent as the vehicle clock
    reaches them (a clock hook, ``lead_s`` ahead)."""

    def __init__(self, gs: GroundStation, faults: Sequence[FaultSpec], via: str) -> None:
        self._gs = gs
        self._queue = list(sorted_schedule(list(faults)))
        self._via = via
        self._start_s: float | None = None

    def _scheduled_on_vehicle(self, fault: FaultSpec) -> bool:
        return self._via == "command" and fault.motor is not None and fault.loe > 0

    def start(self, mission_start_s: float) -> None:
        self._start_s = mission_start_s
        for fault in [f for f in self._queue if self._scheduled_on_vehicle(f)]:
            self._gs.inject(fault, mission_start_s + fault.at_s, via=self._via)
            self._queue.remove(fault)
        self._gs.on_clock(self)

    def __call__(self, clock_s: float) -> None:
        if self._start_s is None:
            return
        self._gs.resend_lost_injections(clock_s)
        if not self._queue:
            return
        lead = self._gs.lead_s()
        while self._queue and clock_s >= self._start_s + self._queue[0].at_s - lead:
            fault = self._queue.pop(0)
            self._gs.inject(fault, self._start_s + fault.at_s, via=self._via)

    @property
    def left(self) -> list[FaultSpec]:
        return list(self._queue)


def fly(gs: GroundStation, plan: FlightPlan,
        progress: Callable[[GroundStation], None] | None = None,
        vehicle_gone: Callable[[], str | None] | None = None,
        steps: Steps | None = None) -> FlightOutcome:
    """Fly ``plan`` with the vehicle on ``gs``; the records are closed at the end.

    Parameters
    ----------
    gs : GroundStation
        An open ground station (nothing flown yet).
    plan : FlightPlan
    progress : callable or None
        Called about once per wall second during the flight.
    vehicle_gone : callable or None
        For a vehicle we started: why it can no longer answer (it exited), else None.
    steps : Steps or None
        Where to say what is being done after the flight (reading the .tlog back).

    Returns
    -------
    FlightOutcome
        Always (a failed flight carries its error); the report comes from the .tlog when
        one is written, else from the live telemetry.
    """
    error: FlightError | None = None
    wall0 = time.monotonic()
    try:
        _fly(gs, plan, progress, wall0, vehicle_gone)
    except FlightError as err:
        error = err
        gs.log("RESULT", f"FAILED: {err.one_line()}")
    except KeyboardInterrupt:
        gs.log("RESULT", "interrupted")
        gs.close()
        raise
    else:
        gs.log("RESULT", "mission flown, vehicle landed and disarmed")
    _release_time(gs, plan)
    _clear_faults(gs, plan)
    live = gs.report()
    gs.close()
    report = live
    tlog = gs.tlog.path if gs.tlog is not None else None
    replayed = None
    if tlog is not None and tlog.exists() and gs.analyzer.vehicle is not None:
        with (steps or Steps(None)).step(f"reading the flight back from {tlog}",
                                         total=gs.tlog.packets if gs.tlog else None) as step:
            replayed = replay_tlog(tlog, on_packet=step.advance)
        report = replayed.report()
    return FlightOutcome(report=report, timing=list(gs.injection_timing), error=error,
                         tlog=tlog, event_log=gs.events.path, replayed=replayed)


def _release_time(gs: GroundStation, plan: FlightPlan) -> None:
    """A flight that failed between holding simulated time and the mission start lets it
    run again (SIM_PAUSE = 0), while the vehicle is still heard."""
    if not gs.held_time or gs.closed or gs.wall_since_vehicle_s() > plan.link_timeout_s:
        return
    try:
        gs.set_param("SIM_PAUSE", 0.0)
        gs.held_time = False
        gs.log("FLIGHT", "simulated time let go again (SIM_PAUSE = 0)")
    except FlightError as err:
        gs.log("FLIGHT", f"simulated time still held: {err.one_line()}")


def _clear_faults(gs: GroundStation, plan: FlightPlan) -> None:
    """Clear what the flight injected (:meth:`GroundStation.clear_injected_faults`) while the
    vehicle is still heard; a failure to do so is logged, never the flight's result."""
    if not gs.injected_anything or gs.closed:
        return
    if gs.wall_since_vehicle_s() > plan.link_timeout_s:
        gs.log("INJECT", "faults not cleared: the vehicle is not heard any more")
        return
    try:
        gs.clear_injected_faults()
    except FlightError as err:
        gs.log("INJECT", f"faults not cleared: {err.one_line()}")


def _restart_summary(reason: str) -> str:
    """The pre-arm reason in a few words: the motors declared failed, else the reason."""
    motors = re.findall(r"motor (\d+) detected failed", reason)
    if motors:
        return (f"motor{'s' if len(motors) > 1 else ''} {', '.join(motors)} detected failed "
                "in an earlier flight")
    return reason


def _ready_to_arm(gs: GroundStation, plan: FlightPlan) -> bool:
    """A mode that allows arming, then armable; a vehicle that arms only after a restart is
    restarted when ``plan.reboot`` (else :class:`RestartNeeded`). Returns whether the
    vehicle reported ready to arm within ``plan.ready_timeout_s``."""
    gs.ensure_arming_mode()
    if gs.wait_armable(plan.ready_timeout_s):
        return True
    if not gs.restart_needed():
        return False
    summary = _restart_summary(gs.prearm_reason or "")
    if not plan.reboot:
        raise RestartNeeded(f"the vehicle arms only after its autopilot restarts ({summary}); "
                            "add --reboot to restart it first")
    gs.log("FLIGHT", f"{summary}: restarting the autopilot (--reboot)")
    gs.reboot(plan.connect_timeout_s)
    gs.ensure_arming_mode()
    if gs.wait_armable(plan.ready_timeout_s):
        return True
    if gs.restart_needed():
        raise RestartNeeded(f"the vehicle still refuses to arm after a restart: "
                            f"{gs.prearm_reason}")
    return False


def _fly(gs: GroundStation, plan: FlightPlan,
         progress: Callable[[GroundStation], None] | None, wall0: float,
         vehicle_gone: Callable[[], str | None] | None) -> None:
    if not gs.vehicle_ready:
        gs.wait_vehicle(plan.connect_timeout_s, vehicle_gone)
    gs.wait_clock()
    if gs.analyzer.armed:
        mode = gs.analyzer.custom_mode
        raise VehicleBusy(f"the vehicle is armed (mode {mode_name(mode)}): another flight is "
                          "under way; land and disarm it first")
    armable = _ready_to_arm(gs, plan)
    gs.request_streams(plan.telemetry_hz)
    params = gs.fetch_params()
    for name, value in plan.params.items():
        if name not in params and gs.read_param(name) is None:
            offered = ", ".join(n for n in sorted(params) if n[:4] == name[:4]) or "none alike"
            raise CommandRefused(f"parameter {name} is not offered by the vehicle "
                                 f"(similar: {offered})")
        if same_float32(gs.param_names[name], value):
            gs.log("PARAM", f"{name} = {value:g} (already)")
            continue
        gs.set_param(name, value)
    if "SIM_PAUSE" not in gs.param_names:
        gs.read_param("SIM_PAUSE")  # a simulator held at t = 0 must be told to go
    gs.wait_home()
    if armable:  # (a parameter change may rebuild the autopilot: wait for it again)
        gs.wait_armable(plan.ready_timeout_s)
    gs.upload_mission(plan.mission)
    for items, mission_type, what in ((plan.fence, MAV_MISSION_TYPE_FENCE, "geofence"),
                                      (plan.rally, MAV_MISSION_TYPE_RALLY, "rally points")):
        if items:
            try:
                gs.upload_mission(items, mission_type=mission_type)
            except MissionRejected as err:
                if err.result != MAV_MISSION_UNSUPPORTED:
                    raise
                gs.log("MISSION", f"the vehicle keeps no {what} (MAV_MISSION_UNSUPPORTED): "
                       f"flying without the plan's {what} ({len(items)} items)")
    injector = _Injector(gs, plan.faults, plan.inject_via)
    # the takeoff is counted from here: on a slow link the vehicle may be in the air before
    # the last start-up step (SIM_PAUSE = 0 below) is confirmed
    takeoffs_before = gs.analyzer.takeoffs
    if gs.param_names.get("SIM_PAUSE") == 0.0:  # a simulator running: hold it (docstring)
        gs.set_param("SIM_PAUSE", 1.0)
        gs.held_time = True
        gs.log("FLIGHT", "simulated time held (SIM_PAUSE = 1) from arming to the mission start")
    gs.arm()
    gs.set_mode(COPTER_MODE_AUTO)
    start_s = gs.start_mission()
    gs.log("FLIGHT", f"mission started at vehicle t = {start_s:.3f} s; "
           f"{len(plan.faults)} fault(s) scheduled")
    injector.start(start_s)
    if gs.param_names.get("SIM_PAUSE", 0.0) != 0.0:
        gs.set_param("SIM_PAUSE", 0.0)
        gs.held_time = False
        gs.log("FLIGHT", "simulated time started (SIM_PAUSE = 0)")
    _watch(gs, plan, injector, start_s, progress, wall0, takeoffs_before)


def _watch(gs: GroundStation, plan: FlightPlan, injector: _Injector, start_s: float,
           progress: Callable[[GroundStation], None] | None, wall0: float,
           takeoffs_before: int) -> None:
    """Pump until landed and disarmed; raise on a crash, a lost link or a time-out.

    ``takeoffs_before`` is the analyzer's takeoff count before the arm command: takeoffs are
    counted as the messages are handled, since one pump may cover the whole flight when the
    station runs behind the vehicle (a loaded machine), and sampling the landed state here
    could miss the time in the air."""
    a = gs.analyzer
    last_progress = time.monotonic()
    while True:
        gs.pump(0.02)
        gs.confirm_param_faults()
        clock = a.clock_s if a.clock_s is not None else start_s
        if a.crashed:
            raise Crashed(f"{a.crash_text} at vehicle t = {clock:.2f} s "
                          f"(mission +{clock - start_s:.2f} s)")
        if a.armed is False:
            if injector.left:
                gs.log("INJECT", "not sent (the flight ended first): "
                       + ", ".join(f.describe() for f in injector.left))
            if a.takeoffs == takeoffs_before:
                raise FlightError(f"the vehicle disarmed at t = {clock:.2f} s without taking "
                                  "off")
            return
        silent = gs.wall_since_vehicle_s()
        if silent > plan.link_timeout_s:
            raise FlightTimeout(f"no telemetry from the vehicle for {silent:.1f} s (link lost) "
                                f"at vehicle t = {clock:.2f} s (mission +{clock - start_s:.2f} s)")
        if clock - start_s > plan.max_flight_s:
            raise FlightTimeout(f"mission not finished {plan.max_flight_s:g} s (simulated) "
                                "after its start")
        if time.monotonic() - wall0 > plan.wall_timeout_s:
            raise FlightTimeout(f"flight not finished after {plan.wall_timeout_s:g} s of wall "
                                "time")
        if progress is not None and time.monotonic() - last_progress >= 1.0:
            last_progress = time.monotonic()
            progress(gs)
