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
import struct
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fcu.autopilot import Autopilot
from fcu.navigation.navigator import LandedState
from flightdata.geometry import eulers_from_quats
from flightdata.metrics import detection_rows, fault_response, series_metrics
from flightdata.recording import LiveRecorder, RecordingConfig, open_stream
from flightdata.records import DetectionRecord, FaultRecord, OutcomeRecord
from flightdata.series import FlightEvent, FlightSeries
from sim.outcome import OutcomeJudge, mission_area
from sim.scenario import Scenario
from sim.stack import SimulatedStack
from sim.world import PlantEvent, World
from sim.world.fault_types import FaultEvent

if TYPE_CHECKING:
    import rerun as rr

AUTO_MODE = 3  # ArduCopter AUTO


@dataclass
class FlightResult:
    """What a run produced: metrics, events, records and the log."""

    scenario: Scenario
    log: FlightSeries  # every tick, with simulator truth, the estimate and the wind
    events: list[tuple[float, str, str]]  # (time_s, source, text), for people
    outcome: OutcomeRecord  # how the flight really ended (simulator truth, sim.outcome)
    detections: list[DetectionRecord]  # what the autopilot concluded, in time order
    faults: list[FaultRecord]  # what the simulator injected, in time order
    sim_s: float
    wall_s: float
    metrics: dict[str, Any] = field(default_factory=dict)
    interrupted: bool = False  # ended early by Ctrl-C (``fly(..., interruptible=True)``)


# the columns of a TickLog row: name, first column, width. The attitude is stored as the
# plant's quaternion (w, x, y, z) and turned into Euler angles for the whole log at once
# (series); "flying" and "free_flight" are 1.0 or 0.0; a tick not flying leaves the
# reference columns for series to fill with the truth.
_COLUMNS = (("t", 0, 1), ("pos", 1, 3), ("quat", 4, 4), ("est_pos", 8, 3), ("pwm", 11, 4),
            ("loe_est", 15, 4), ("loe_injected", 19, 4), ("wind", 23, 3), ("ref_pos", 26, 3),
            ("ref_euler", 29, 3), ("flying", 32, 1), ("free_flight", 33, 1),
            ("euler", 34, 3))
_WIDTH = 37  # the row appended per tick: the first 34 columns (the Euler angles: series)
_NOT_FLYING = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # ref_pos, ref_euler, the two flags
_CHUNK_TICKS = 6000  # rows added when the log is full (60 s at 100 Hz)
# a row's floats written straight into the table's buffer (float64, native order, as
# numpy stores them): a third of the cost of assigning a list to a row of the array
_PACK_ROW = struct.Struct(f"{_WIDTH - 3}d").pack_into
_ROW_BYTES = _WIDTH * 8


class TickLog:
    """Preallocated per-tick storage of a headless flight (the runner's and the recorder's).

    One float table, a row per tick, written with one call; its columns are the attributes
    ``t`` (s), ``pos``, ``quat`` (true attitude, [w, x, y, z]), ``est_pos``, ``pwm``,
    ``loe_est``, ``loe_injected``, ``wind``, ``ref_pos``, ``ref_euler``, ``flying`` and
    ``free_flight`` (views; the flags 1.0 or 0.0), and ``euler`` (roll, pitch, yaw, rad, of
    the rows :meth:`series` has seen). Full, it grows by a chunk of rows.

    Parameters
    ----------
    capacity : int
        Ticks it holds before it first grows.
    pwm_max : float
        Full-power motor command of the airframe (unit duty).
    """

    t: np.ndarray
    pos: np.ndarray
    quat: np.ndarray
    est_pos: np.ndarray
    pwm: np.ndarray
    loe_est: np.ndarray
    loe_injected: np.ndarray
    wind: np.ndarray
    ref_pos: np.ndarray
    ref_euler: np.ndarray
    flying: np.ndarray
    free_flight: np.ndarray
    euler: np.ndarray

    def __init__(self, capacity: int, pwm_max: float) -> None:
        self.n = 0
        self._converted = 0  # rows whose Euler angles and ground references series wrote
        self.pwm_max = pwm_max
        self._rows = np.zeros((0, _WIDTH))
        self._grow(max(capacity, 1))

    def _grow(self, capacity: int) -> None:
        """Room for ``capacity`` rows, the rows so far kept."""
        k = self.n
        rows = np.zeros((capacity, _WIDTH))
        rows[:k] = self._rows[:k]
        self._rows = rows
        self._row_bytes = rows.data.cast("B")  # the table's memory, for _PACK_ROW
        for name, first, width in _COLUMNS:
            setattr(self, name, rows[:, first] if width == 1 else rows[:, first:first + width])

    def append(self, world: World, autopilot: Autopilot) -> tuple[list[float], bool]:
        """Store the tick just flown: truth, estimate, references, commands, wind; returns
        the row stored (:data:`_COLUMNS` layout: the true position is ``row[1:4]``, m NED,
        the true attitude ``row[4:8]``, a quaternion [w, x, y, z]) and the ground contact."""
        status = autopilot.status
        assert status is not None
        k = self.n
        if k == self._rows.shape[0]:
            self._grow(k + _CHUNK_TICKS)
        x = world.plant.state.tolist()
        t = world.time_s
        reference = status.reference
        att_ref = status.attitude_reference
        on_ground = world.plant.on_ground
        if reference is not None and att_ref is not None and not on_ground:
            free = 1.0 if status.nav.landed_state == LandedState.IN_AIR else 0.0
            flight: Sequence[float] = [*reference.pos_ned.tolist(),
                                       *att_ref.euler_rad.tolist(), 1.0, free]
        else:
            flight = _NOT_FLYING
        # one row: t, pos, quat, est_pos, pwm, loe_est, loe_injected, wind, ref_pos,
        # ref_euler, flying, free_flight
        row = [t, x[0], x[1], x[2], x[6], x[7], x[8], x[9],
               *status.estimate.pos_ned.tolist(), *status.pwm.tolist(),
               *status.loe_estimate.tolist(), *world.faults.true_loe_values(t),
               *world.wind_ned.tolist(), *flight]
        _PACK_ROW(self._row_bytes, k * _ROW_BYTES, *row)  # self._rows[k] = row
        self.n = k + 1  # the row counts only once complete (an interrupt may land anywhere)
        return row, on_ground

    def series(self, events: Sequence[tuple[float, str, str]] = (),
               faults: Sequence[FaultRecord] = ()) -> FlightSeries:
        """The ticks so far as a :class:`FlightSeries` (views, not copies, but the two
        flags), with the onsets of the injected ``faults``. The Euler angles of the new rows
        and the references of those not flying (the truth) are written into the table
        here."""
        k = self.n
        t = self.t[:k]
        done = self._converted  # (a live recorder asks again and again: the new rows only)
        if done < k:
            self.euler[done:k] = euler = eulers_from_quats(self.quat[done:k])
            ground = self.flying[done:k] == 0.0
            self.ref_pos[done:k][ground] = self.pos[done:k][ground]
            self.ref_euler[done:k][ground] = euler[ground]
            self._converted = k
        return FlightSeries(
            time_s=t, flying=self.flying[:k] != 0.0, pos_ned=self.pos[:k],
            euler_rad=self.euler[:k],
            ref_pos_ned=self.ref_pos[:k], ref_euler_rad=self.ref_euler[:k],
            pwm_time_s=t, pwm=self.pwm[:k], pwm_max=self.pwm_max,
            loe_estimate_time_s=(t,) * 4,
            loe_estimate=tuple(self.loe_est[:k, j] for j in range(4)),
            loe_injected=self.loe_injected[:k], free_flight=self.free_flight[:k] != 0.0,
            est_pos_ned=self.est_pos[:k], wind_ned=self.wind[:k],
            fault_times_s=tuple(sorted({f.time_s for f in faults if f.action == "started"})),
            events=tuple(FlightEvent(t_s, source, text) for t_s, source, text in events))


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
    rec = TickLog(n_ticks + 1, scenario.world.airframe.pwm_max)
    flight = _Records(on_event, OutcomeJudge(mission_area(scenario.mission)))
    wall0 = time.perf_counter()
    stack.first_tick()
    for refusal in start_mission(autopilot, scenario):
        flight.event(0.0, "runner", refusal)
    interrupted = False
    stop = _StopRequest(interruptible)
    try:
        for _ in range(n_ticks):
            stack.tick()
            flight.collect(stack, *rec.append(world, autopilot))
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
    outcome = flight.finish(world.time_s)
    result = FlightResult(scenario, rec.series(flight.events, flight.faults), flight.events,
                          outcome, flight.detections, flight.faults, world.time_s, wall_s,
                          interrupted=interrupted)
    result.metrics = flight_metrics(result)
    return result


class _Records:
    """A run's events, detections, faults and outcome, collected tick by tick."""

    def __init__(self, on_event: EventCallback | None, judge: OutcomeJudge) -> None:
        self._on_event = on_event
        self.judge = judge
        self.events: list[tuple[float, str, str]] = []
        self.detections: list[DetectionRecord] = []
        self.faults: list[FaultRecord] = []

    def event(self, time_s: float, source: str, text: str) -> None:
        self.events.append((time_s, source, text))
        if self._on_event is not None:
            self._on_event(time_s, source, text)

    def collect(self, stack: SimulatedStack, row: Sequence[float], on_ground: bool) -> None:
        """The tick's autopilot and world events, and the truth for the outcome judge (the
        tick's :class:`TickLog` ``row``: true position and attitude; the ground contact)."""
        autopilot_events, world_events = stack.drain_events()
        for ev in autopilot_events:
            if ev.record is not None:
                self.detections.append(ev.record)
            self.event(ev.time_s, "autopilot", ev.text)
        touchdowns = []
        for wev in world_events:
            if isinstance(wev, FaultEvent):
                self.faults.append(wev.record)
                self.event(wev.time_s, "sim", wev.record.text())
            elif isinstance(wev, PlantEvent):
                self.event(wev.time_s, "sim", wev.description)
                if wev.kind in ("touchdown", "crash"):
                    touchdowns.append((wev.time_s, wev.speed_m_s))
        self.judge.observe(row[0], row[1:4], row[4:8], on_ground, touchdowns,
                           stack.autopilot.navigator.armed)
        if self.judge.decided:
            self._outcomes()

    def _outcomes(self) -> None:
        for outcome in self.judge.drain():
            self.event(outcome.time_s, "sim", outcome.text())

    def finish(self, time_s: float) -> OutcomeRecord:
        outcome = self.judge.finish(time_s)
        self._outcomes()
        return outcome


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


def flight_metrics(result: FlightResult) -> dict[str, Any]:
    """The ``--json`` metrics of one run (units: m, deg, PWM, s).

    Errors and control effort are taken over the flight: the ticks where a reference was
    tracked and the vehicle was off the ground (the thesis's runs are all flight; the
    seconds on the ground before take-off and after touchdown would only dilute them); see
    :func:`flightdata.metrics.series_metrics`. ``outcome`` says how the flight ended (a
    flight that did not land makes them the figures of the part flown, not a result);
    ``detections`` and ``faults`` are the autopilot's and the simulator's records
    (:mod:`flightdata.records`), each detection with its latency after the latest injection
    on the same motor or sensor.
    """
    return {
        "name": result.scenario.name,
        "outcome": result.outcome.to_dict(),
        **series_metrics(result.log, result.scenario.autopilot.loop_rate_hz),
        "detections": detection_rows(result.detections, result.faults),
        "fault_response": fault_response(result.log, result.faults, result.detections),
        "faults": [f.to_dict() for f in result.faults],
        "sim_s": result.sim_s,
        "wall_s": result.wall_s,
        "seed": result.scenario.seed,
    }


class FlightRecording:
    """Records a headless flight to rerun while it is flown.

    Use as ``fly(scenario, on_tick=rec.on_tick, on_event=rec.on_event)`` and call
    :meth:`close` afterwards (also after an interrupt) to send the rest and flush. Each tick
    is copied into a :class:`TickLog`; every ``config.flush_s`` of simulated time the new
    rows go out (:class:`flightdata.recording.LiveRecorder`), with the entities of
    :mod:`flightdata.recording`.

    Parameters
    ----------
    stream : rerun.RecordingStream
        Where to log (:func:`flightdata.recording.open_stream`).
    scenario : Scenario
        The scenario flown (airframe geometry, PWM range, loop rate, mission).
    config : RecordingConfig, optional
        Rates and drawing sizes (the arm length is the airframe's; nothing is held back).
    owns_stream : bool
        When True, :meth:`close` also disconnects the stream (:func:`open_recording` sets it).
    """

    def __init__(self, stream: rr.RecordingStream, scenario: Scenario,
                 config: RecordingConfig | None = None, *, owns_stream: bool = False) -> None:
        airframe = scenario.world.airframe
        cfg = replace(config if config is not None else RecordingConfig(),
                      arm_length_m=airframe.arm_length, holdback_s=0.0)
        n_ticks = int(round(scenario.duration_s * scenario.autopilot.loop_rate_hz))
        self.log = TickLog(n_ticks + 1, airframe.pwm_max)
        self.events: list[tuple[float, str, str]] = []
        waypoints = [(seq, item.pos_ned) for seq, item in enumerate(scenario.mission, 1)
                     if item.pos_ned is not None]
        self.live = LiveRecorder(stream, lambda: self.log.series(self.events), cfg,
                                 owns_stream=owns_stream, min_wall_s=0.0,
                                 waypoints_ned=waypoints)

    def on_tick(self, world: World, autopilot: Autopilot) -> None:
        """Store this tick; send the new rows when ``flush_s`` has passed (``fly``'s on_tick)."""
        self.log.append(world, autopilot)
        self.live.on_clock(world.time_s)

    def on_event(self, time_s: float, source: str, text: str) -> None:
        """Note one event; it goes out with the next rows (``fly``'s on_event)."""
        self.events.append((time_s, source, text))

    def close(self) -> None:
        """Send the rest and flush the stream (idempotent; safe after Ctrl-C)."""
        self.live.close()


def open_recording(scenario: Scenario, *, rrd_path: str | Path | None = None,
                   spawn: bool = False, connect_url: str | None = None,
                   config: RecordingConfig | None = None,
                   recording_id: str | None = None) -> FlightRecording:
    """A :class:`FlightRecording` on a new stream (:func:`flightdata.recording.open_stream`
    for the arguments)."""
    stream = open_stream(scenario.name, rrd_path=rrd_path, spawn=spawn,
                         connect_url=connect_url, recording_id=recording_id)
    return FlightRecording(stream, scenario, config, owns_stream=True)
