"""Headless composition root: world and autopilot fly a scenario as fast as the CPU allows.

The loop is the same one the MAVLink vehicle process runs, minus the network::

    every autopilot tick (loop_rate_hz):
        samples = world.step(pwm, plant_steps_per_tick)   # plant at plant_rate_hz
        pwm     = autopilot.step(world.time_s, samples)

The run starts with one tick on the ground, then loads the mission, arms, switches to AUTO and
starts the mission through the same navigator commands a ground station would send.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fcu.autopilot import Autopilot
from fcu.navigation.navigator import LandedState
from sim.metrics import control_effort, tracking_errors
from sim.scenario import Scenario
from sim.stack import SimulatedStack
from sim.world import PlantEvent, World
from sim.world.dynamics import quat_to_euler
from sim.world.faults import FaultEvent

AUTO_MODE = 3  # ArduCopter AUTO


@dataclass
class FlightLog:
    """Per-tick arrays of a run (n ticks), SI units, NED."""

    time_s: np.ndarray  # (n,)
    flying: np.ndarray  # (n,) bool, a reference was tracked and the vehicle was airborne
    free_flight: np.ndarray  # (n,) bool, the navigator was in the air (not taking off/landing)
    ref_pos_ned: np.ndarray  # (n, 3)
    pos_ned: np.ndarray  # (n, 3) truth
    est_pos_ned: np.ndarray  # (n, 3) estimate fed to the controllers
    ref_euler_rad: np.ndarray  # (n, 3) attitude reference tracked
    euler_rad: np.ndarray  # (n, 3) truth
    pwm: np.ndarray  # (n, 4) commanded
    loe_estimate: np.ndarray  # (n, 4) TSKF
    loe_true: np.ndarray  # (n, 4) injected
    wind_ned: np.ndarray  # (n, 3)


@dataclass
class FlightResult:
    """What a run produced: metrics, events and the log."""

    scenario: Scenario
    log: FlightLog
    events: list[tuple[float, str, str]]  # (time_s, source, text)
    crashed: bool
    sim_s: float
    wall_s: float
    metrics: dict[str, Any] = field(default_factory=dict)
    interrupted: bool = False  # ended early by Ctrl-C (``fly(..., interruptible=True)``)


class _Recorder:
    """Preallocated per-tick storage."""

    def __init__(self, n: int) -> None:
        self.n = 0
        self.t = np.zeros(n)
        self.flying = np.zeros(n, dtype=bool)
        self.free_flight = np.zeros(n, dtype=bool)
        self.ref_pos = np.zeros((n, 3))
        self.pos = np.zeros((n, 3))
        self.est_pos = np.zeros((n, 3))
        self.ref_euler = np.zeros((n, 3))
        self.euler = np.zeros((n, 3))
        self.pwm = np.zeros((n, 4))
        self.loe_est = np.zeros((n, 4))
        self.loe_true = np.zeros((n, 4))
        self.wind = np.zeros((n, 3))

    def log(self) -> FlightLog:
        k = self.n
        return FlightLog(self.t[:k], self.flying[:k], self.free_flight[:k], self.ref_pos[:k],
                         self.pos[:k],
                         self.est_pos[:k], self.ref_euler[:k], self.euler[:k], self.pwm[:k],
                         self.loe_est[:k], self.loe_true[:k], self.wind[:k])


def start_mission(autopilot: Autopilot, scenario: Scenario) -> list[str]:
    """Load the scenario's mission, arm, switch to AUTO and start; returns refusals (if any)."""
    nav = autopilot.navigator
    refusals = []
    for what, result in (("load mission", nav.load_mission(scenario.mission)),
                         ("arm", nav.arm()),
                         ("set mode AUTO", nav.set_mode(AUTO_MODE)),
                         ("start mission", nav.start_mission())):
        if not result.accepted:
            refusals.append(f"{what}: {result.reason}")
    return refusals


TickCallback = Callable[[World, Autopilot], None]
EventCallback = Callable[[float, str, str], None]


def fly(scenario: Scenario, *, on_tick: TickCallback | None = None,
        on_event: EventCallback | None = None, interruptible: bool = False) -> FlightResult:
    """Fly ``scenario`` headless and return its log, events and thesis-style metrics.

    Parameters
    ----------
    scenario : Scenario
        What to fly.
    on_tick : callable, optional
        Called after every autopilot tick with the world and the autopilot (recorders,
        progress display). Must not change either.
    on_event : callable, optional
        Called with ``(time_s, source, text)`` as each event is recorded (the same tuples
        as :attr:`FlightResult.events`, as they happen), before ``on_tick`` of that tick.
    interruptible : bool
        When True, a KeyboardInterrupt (Ctrl-C) after the first tick ends the flight there:
        the result covers the ticks flown and has ``interrupted = True``. When False (the
        default) the interrupt propagates.
    """
    stack = SimulatedStack(scenario.world, scenario.autopilot, scenario.seed,
                           scenario.faults)
    world, autopilot = stack.world, stack.autopilot
    loop_hz = scenario.autopilot.loop_rate_hz
    n_ticks = int(round(scenario.duration_s * loop_hz))
    rec = _Recorder(n_ticks + 1)
    events: list[tuple[float, str, str]] = []

    def record(time_s: float, source: str, text: str) -> None:
        events.append((time_s, source, text))
        if on_event is not None:
            on_event(time_s, source, text)

    wall0 = time.perf_counter()
    stack.first_tick()
    for refusal in start_mission(autopilot, scenario):
        record(0.0, "runner", refusal)
    interrupted = False
    stop = _StopRequest(interruptible)
    try:
        for _ in range(n_ticks):
            stack.tick()
            _record(stack, rec, record)
            if on_tick is not None:
                on_tick(world, autopilot)
            if stop.requested:
                interrupted = True
                break
    except KeyboardInterrupt:
        if not interruptible or rec.n == 0:
            raise
        interrupted = True
    finally:
        stop.restore()
    wall_s = time.perf_counter() - wall0
    log = rec.log()
    result = FlightResult(scenario, log, events, world.plant.crashed, world.time_s, wall_s,
                          interrupted=interrupted)
    result.metrics = flight_metrics(result, autopilot)
    return result


class _StopRequest:
    """Ctrl-C as a request to stop between ticks, never inside one.

    An interrupt raised asynchronously could land inside a compiled (numba) kernel, where it
    surfaces as a SystemError, or between two half-updated parts of the stack. While an
    interruptible flight runs in the main thread, SIGINT only sets :attr:`requested`; the loop
    ends after the tick in progress.
    """

    def __init__(self, enabled: bool) -> None:
        self.requested = False
        self._previous: Any = None
        if enabled and threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handle)

    def _handle(self, signum: int, frame: Any) -> None:
        self.requested = True

    def restore(self) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None


def _record(stack: SimulatedStack, rec: _Recorder, record: EventCallback) -> None:
    """Log the tick just taken and pass its events on."""
    world, autopilot = stack.world, stack.autopilot
    t = world.time_s
    pwm = stack.pwm
    status = autopilot.status
    assert status is not None
    x = world.plant.state
    k = rec.n
    rec.t[k] = t
    rec.pos[k] = x[0:3]
    rec.euler[k] = _euler_of(x)
    rec.est_pos[k] = status.estimate.pos_ned
    rec.pwm[k] = pwm
    rec.loe_est[k] = status.loe_estimate
    rec.loe_true[k] = world.faults.true_loe(t)
    rec.wind[k] = world.wind_ned
    if (status.reference is not None and status.attitude_reference is not None
            and not world.plant.on_ground):
        rec.flying[k] = True
        rec.free_flight[k] = status.nav.landed_state == LandedState.IN_AIR
        rec.ref_pos[k] = status.reference.pos_ned
        rec.ref_euler[k] = status.attitude_reference.euler_rad
    else:
        rec.ref_pos[k] = rec.pos[k]
        rec.ref_euler[k] = rec.euler[k]
    rec.n += 1
    autopilot_events, world_events = stack.drain_events()
    for ev in autopilot_events:
        record(ev.time_s, "autopilot", ev.text)
    for wev in world_events:
        if isinstance(wev, FaultEvent):
            record(wev.time_s, "sim", f"{wev.kind}: {wev.description}")
        elif isinstance(wev, PlantEvent):
            record(wev.time_s, "sim", wev.description)


def _euler_of(x: np.ndarray) -> np.ndarray:
    return np.asarray(quat_to_euler(np.ascontiguousarray(x[6:10])))


def loe_convergence_times(log: FlightLog, tolerance: float = 0.05) -> list[dict[str, Any]]:
    """For each step change of the injected LOE, when the estimate settled within tolerance.

    Judged in free flight only, between take-off and landing (on or near the ground the
    effectiveness is unobservable; the autopilot's detector is gated the same way). Returns one
    entry per (motor, change): motor (1..4), time of the change, injected gamma, and the delay
    (s) after which |estimate - truth| <= tolerance held until the next change or the end of
    the flight (None if it never settled).
    """
    out: list[dict[str, Any]] = []
    free = np.flatnonzero(log.free_flight)
    if free.size == 0:
        return out
    window = slice(free[0], free[-1] + 1)
    truth = np.nan_to_num(log.loe_true[window], nan=1.0)
    estimate = log.loe_estimate[window]
    time_s = log.time_s[window]
    for m in range(4):
        changes = np.flatnonzero(np.abs(np.diff(truth[:, m])) > 1e-9) + 1
        for j, k in enumerate(changes):
            end = changes[j + 1] if j + 1 < len(changes) else len(truth)
            outside = np.flatnonzero(np.abs(estimate[k:end, m] - truth[k:end, m]) > tolerance)
            if outside.size == 0:
                delay: float | None = 0.0
            elif outside[-1] + 1 < end - k:
                delay = float(time_s[k + outside[-1] + 1] - time_s[k])
            else:
                delay = None
            out.append({"motor": m + 1, "time_s": float(time_s[k]),
                        "loe": float(truth[k, m]), "settled_after_s": delay})
    return out


def flight_metrics(result: FlightResult, autopilot: Autopilot | None = None) -> dict[str, Any]:
    """The ``--json`` metrics of one run (units: m, deg, PWM, s).

    Errors and control effort are taken over the flight: the ticks where a reference was
    tracked and the vehicle was off the ground (the thesis's runs are all flight; the
    seconds on the ground before take-off and after touchdown would only dilute them).
    """
    log = result.log
    flying = log.flying
    if not np.any(flying):
        flying = np.ones_like(flying)
    errs = tracking_errors(log.ref_pos_ned[flying], log.pos_ned[flying],
                           log.ref_euler_rad[flying], log.euler_rad[flying])
    detections = [{"time_s": t, "text": text} for t, src, text in result.events
                  if src == "autopilot" and "effectiveness" in text]
    return {
        "name": result.scenario.name,
        "rms": {axis: fig.rms for axis, fig in errs.items()},
        "max": {axis: fig.max for axis, fig in errs.items()},
        "control_effort": control_effort(log.pwm[flying]),
        "flight_s": float(np.count_nonzero(log.flying)) / result.scenario.autopilot.loop_rate_hz,
        "loe_estimate": {
            "final": [float(v) for v in log.loe_estimate[-1]],
            "true_final": [float(v) for v in np.nan_to_num(log.loe_true[-1], nan=-1.0)],
            "convergence": loe_convergence_times(log),
        },
        "detections": detections,
        "crashed": result.crashed,
        "sim_s": result.sim_s,
        "wall_s": result.wall_s,
        "seed": result.scenario.seed,
    }
