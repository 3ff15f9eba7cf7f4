"""Rerun recordings of headless flights: a 3-D scene and time series on simulated time.

A :class:`FlightRecorder` is fed by the headless loop (``sim.runner.fly(on_tick=...,
on_event=...)``) and writes to a rerun recording stream: an ``.rrd`` file, a live viewer, or
both. Everything is stamped on one timeline, ``sim_time``, a duration in simulated seconds
(``RecordingStream.set_time("sim_time", duration=...)`` and ``rr.TimeColumn("sim_time",
duration=...)``, given whole nanoseconds rounded from the float time, :func:`sim_duration`),
so a recording replays at simulated, not wall-clock, time. Written against rerun-sdk 0.29
(``TransformAxes3D``, ``Cylinders3D``, ``send_columns`` with ``TimeColumn``).

Frames
------
The world is logged in **NED**, unconverted: ``world`` carries the static view coordinates
``ViewCoordinates.FRD`` (X forward = north, Y right = east, Z down), a right-handed frame
whose "up" the viewer takes as -Z. The vehicle's ``Transform3D`` is its true pose (position
NED, quaternion of body FRD to NED); everything under ``world/vehicle`` is in body FRD.

Entity paths
------------
==================================  =========================================================
``world``                           ViewCoordinates FRD (static): NED world
``world/mission``                   Points3D (static): mission waypoints, labelled by seq
``world/vehicle``                   Transform3D, true pose (scene rate); TransformAxes3D
``world/vehicle/arms``              LineStrips3D (static): centre to each motor, front arm red
``world/vehicle/rotors``            Cylinders3D: the four rotor disks (motor numbering of
                                    docs/design.md), colour = commanded PWM from dark blue
                                    (0) to yellow (``pwm_max``); red shades while a fault is
                                    injected on that motor (label shows the injected LOE)
``world/reference``                 Points3D: current position reference (while flying)
``world/reference_path``            LineStrips3D: the reference so far (re-sent each flush)
``world/flown_path``                LineStrips3D: the true path so far (re-sent each flush)
``world/wind``                      Arrows3D: wind velocity at the vehicle, 1 m per m/s
``plots/position/{x,y,z}/truth``    Scalars: true position, NED, m (every tick)
``plots/position/{x,y,z}/estimate`` Scalars: the estimate fed to the controllers, NED, m
``plots/position/{x,y,z}/ref``      Scalars: position reference, NED, m (flying ticks)
``plots/error/{x,y,z}``             Scalars: reference - truth, m (flying ticks)
``plots/attitude/{roll,pitch,yaw}/{ref,truth}``  Scalars: deg (ref on flying ticks)
``plots/error/{roll,pitch,yaw}``    Scalars: reference - truth wrapped to +-180, deg (flying)
``plots/pwm/{1,2,3,4}``             Scalars: commanded PWM (unit duty, 0..pwm_max)
``plots/loe/{1,2,3,4}/true``        Scalars: injected loss of effectiveness (NaN: lock or
                                    hard-over, which no gamma describes)
``plots/loe/{1,2,3,4}/estimate``    Scalars: the TSKF's estimate
``events``                          TextLog: injections, detections, mode changes,
                                    failsafes, touchdowns, "[source] text"
==================================  =========================================================

"Flying ticks" are those of :attr:`sim.runner.FlightLog.flying`: a reference was tracked and
the vehicle was off the ground; the reference series have no rows elsewhere (the FlightLog
fills those ticks with the truth, which the metrics then ignore).

Cost
----
Per tick the recorder copies a few arrays into a buffer; every ``flush_s`` (1 s) of simulated
time it sends the buffer column-wise (``send_columns``): the time series at the loop rate,
the 3-D scene decimated to ``scene_rate_hz`` (25 Hz), and the two growing paths once. A live
viewer therefore lags the simulation by up to ``flush_s`` of simulated time. Measured on a
60 s thesis run (lqg_abdob_loe), median of 5: +0.9 s wall, +0.6 s CPU, a 9 MB ``.rrd``.

Opening a recording: ``rerun flight.rrd`` (the ``rerun`` CLI ships in the rerun-sdk wheel,
``python -m rerun_cli flight.rrd`` works too); ``rerun rrd print -vvv --entity
/plots/pwm/1 flight.rrd`` lists rows; ``rerun.recording.load_recording(path).schema()``
lists entities, components and timelines from Python.
"""

from __future__ import annotations

import math
import signal
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from sim.metrics import wrap_angle_rad
from sim.world.dynamics import quat_to_euler

if TYPE_CHECKING:
    import rerun as rr

    from fcu.autopilot import Autopilot
    from sim.scenario import Scenario
    from sim.world import World

#: Name of the simulated-time timeline (a duration, seconds).
SIM_TIMELINE = "sim_time"
#: rerun application id of every recording made here.
APPLICATION_ID = "quadftc"
#: Position and attitude axis names, in log column order.
POSITION_AXES = ("x", "y", "z")
ATTITUDE_AXES = ("roll", "pitch", "yaw")
MOTORS = (1, 2, 3, 4)

_REF_RGB = (40, 40, 40)
_TRUTH_RGB = (31, 119, 180)
_EST_RGB = (255, 127, 14)
_ERROR_RGB = (214, 39, 40)
_MOTOR_RGB = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40))
_PWM_LOW_RGB = np.array([30.0, 50.0, 150.0])  # PWM 0: dark blue
_PWM_HIGH_RGB = np.array([250.0, 220.0, 40.0])  # PWM pwm_max: yellow
_FAULT_LOW_RGB = np.array([110.0, 0.0, 0.0])  # faulted motor at PWM 0: dark red
_FAULT_HIGH_RGB = np.array([255.0, 70.0, 70.0])  # faulted motor at pwm_max: bright red


@dataclass(frozen=True, kw_only=True)
class RecordingConfig:
    """How much of a flight goes into a recording, and how often."""

    scene_rate_hz: float = 25.0  # Hz, 3-D scene: pose, rotor colours, wind, reference marker
    flush_s: float = 1.0  # s of simulated time buffered before it is sent (viewer latency)
    wind_arrow_m_per_m_s: float = 1.0  # m of arrow per m/s of wind
    rotor_radius_m: float = 0.08  # m, drawn rotor disk radius

    def __post_init__(self) -> None:
        for name in ("scene_rate_hz", "flush_s",
                     "wind_arrow_m_per_m_s", "rotor_radius_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} = {value!r}: must be a finite number > 0")


def sim_duration(time_s: float) -> np.timedelta64:
    """Simulated time as whole nanoseconds, rounded (``sim_time`` stores integer ns).

    rerun truncates float seconds to nanoseconds, which turns 2.11 s (a float just below)
    into 2.109999999 s; rounding first keeps the tick times exact on the timeline.
    """
    return np.timedelta64(round(time_s * 1e9), "ns")


def sim_durations(time_s: np.ndarray) -> npt.NDArray[np.timedelta64]:
    """:func:`sim_duration` of each element of ``time_s`` (s)."""
    return np.rint(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64).astype(
        "timedelta64[ns]")


def rotor_positions_frd(arm_length_m: float) -> np.ndarray:
    """Rotor centres in body FRD, motors 1..4 (docs/design.md: front, back, left, right), m."""
    L = arm_length_m
    return np.array([[L, 0.0, 0.0], [-L, 0.0, 0.0], [0.0, -L, 0.0], [0.0, L, 0.0]])


def rotor_colors(pwm: np.ndarray, pwm_max: float, faulted: np.ndarray) -> np.ndarray:
    """RGB (uint8, shape (4, 3)) of the rotor disks: PWM ramp, red ramp where faulted.

    Parameters
    ----------
    pwm : numpy.ndarray, shape (4,)
        Commanded PWM of motors 1..4 (unit duty).
    pwm_max : float
        Full-power PWM (colour saturates there).
    faulted : numpy.ndarray of bool, shape (4,)
        True where a fault is injected on that motor.
    """
    frac = np.clip(np.asarray(pwm, dtype=float) / pwm_max, 0.0, 1.0)[:, None]
    normal = _PWM_LOW_RGB + frac * (_PWM_HIGH_RGB - _PWM_LOW_RGB)
    fault = _FAULT_LOW_RGB + frac * (_FAULT_HIGH_RGB - _FAULT_LOW_RGB)
    rgb = np.where(np.asarray(faulted, dtype=bool)[:, None], fault, normal)
    return np.rint(rgb).astype(np.uint8)


def default_blueprint() -> rr.blueprint.Blueprint:
    """The viewer layout: the 3-D scene and the event log left, time-series tabs right."""
    import rerun.blueprint as rrb

    def series(origin: str, name: str) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(origin=origin, name=name)

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(rrb.Spatial3DView(origin="world", name="scene (NED)"),
                         rrb.TextLogView(origin="events", name="events"), row_shares=[3, 1]),
            rrb.Tabs(
                rrb.Vertical(*(series(f"plots/position/{a}", f"{a} NED (m)")
                               for a in POSITION_AXES), name="position"),
                rrb.Vertical(*(series(f"plots/attitude/{a}", f"{a} (deg)")
                               for a in ATTITUDE_AXES), name="attitude"),
                rrb.Vertical(series("plots/error", "errors (m, deg)"), name="errors"),
                rrb.Vertical(series("plots/pwm", "PWM"), name="PWM"),
                rrb.Grid(*(series(f"plots/loe/{m}", f"motor {m} LOE") for m in MOTORS),
                         name="LOE"),
            ),
            column_shares=[1, 1],
        ),
        collapse_panels=True,
    )


def open_stream(name: str, *, rrd_path: str | Path | None = None, spawn: bool = False,
                connect_url: str | None = None,
                recording_id: str | None = None) -> rr.RecordingStream:
    """A rerun recording stream writing to a file, a viewer, or both.

    Parameters
    ----------
    name : str
        Recording name shown by the viewer (the scenario name).
    rrd_path : path, optional
        Write the recording to this ``.rrd`` file (parent directories are created).
    spawn : bool
        Start a rerun viewer process (``rerun`` from the wheel) and stream to it live.
    connect_url : str, optional
        Stream to an already running viewer or server at this gRPC URL instead
        (e.g. ``rerun+http://127.0.0.1:9876/proxy``).
    recording_id : str, optional
        Fixed recording id (default: a random one).

    Returns
    -------
    rerun.RecordingStream
        With no destination at all, a stream that buffers in memory (nothing is written).
    """
    import rerun as rr

    stream = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
    sinks: list[rr.FileSink | rr.GrpcSink] = []
    if spawn:
        stream.spawn(connect=False, default_blueprint=default_blueprint())
        sinks.append(rr.GrpcSink())
    elif connect_url is not None:
        sinks.append(rr.GrpcSink(connect_url))
    if rrd_path is not None:
        path = Path(rrd_path)
        path.parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(str(path)))
    if sinks:
        stream.set_sinks(*sinks, default_blueprint=default_blueprint())
    stream.send_recording_name(name)
    return stream


class _Columns:
    """Per-tick rows buffered between two flushes (scene frames are a subset of the rows)."""

    def __init__(self, capacity: int) -> None:
        self.n = 0
        self.t = np.zeros(capacity)
        self.flying = np.zeros(capacity, dtype=bool)
        self.scene = np.zeros(capacity, dtype=bool)
        self.pos = np.zeros((capacity, 3))
        self.quat_wxyz = np.zeros((capacity, 4))
        self.est_pos = np.zeros((capacity, 3))
        self.ref_pos = np.zeros((capacity, 3))
        self.euler_deg = np.zeros((capacity, 3))
        self.ref_euler_deg = np.zeros((capacity, 3))
        self.pwm = np.zeros((capacity, 4))
        self.loe_true = np.zeros((capacity, 4))
        self.loe_est = np.zeros((capacity, 4))
        self.wind = np.zeros((capacity, 3))

    @property
    def full(self) -> bool:
        return self.n == len(self.t)


class FlightRecorder:
    """Streams one headless flight to a rerun recording (see the module docstring).

    Use as ``fly(scenario, on_tick=recorder.on_tick, on_event=recorder.on_event)`` and call
    :meth:`close` afterwards (also after an interrupt) to send the buffered rows and flush.
    Per tick it only copies a few arrays; everything is sent column-wise every
    ``config.flush_s`` of simulated time.

    Parameters
    ----------
    stream : rerun.RecordingStream
        Where to log (:func:`open_stream`).
    scenario : Scenario
        The scenario flown (airframe geometry, PWM range, loop rate, mission).
    config : RecordingConfig, optional
        Rates and drawing sizes.
    owns_stream : bool
        When True, :meth:`close` also disconnects the stream (closing its file or viewer
        connection); :func:`open_recorder` sets it.
    """

    def __init__(self, stream: rr.RecordingStream, scenario: Scenario,
                 config: RecordingConfig | None = None, *, owns_stream: bool = False) -> None:
        self.stream = stream
        self.owns_stream = owns_stream
        self.scenario = scenario
        self.config = config if config is not None else RecordingConfig()
        cfg = self.config
        loop_hz = scenario.autopilot.loop_rate_hz
        self._airframe = scenario.world.airframe
        self._scene_every = max(1, round(loop_hz / cfg.scene_rate_hz))
        self._cols = _Columns(max(1, round(loop_hz * cfg.flush_s)))
        self._ticks = 0
        self._started = False
        self._closed = False
        self._was_flying = False
        self._rotor_labels: list[str] = []
        self._flown: list[np.ndarray] = []
        self._ref_path: list[np.ndarray] = []

    # ------------------------------------------------------------------ static content
    def _start(self) -> None:
        import rerun as rr

        self._started = True
        s = self.stream
        s.log("world", rr.ViewCoordinates.FRD, static=True)
        s.log("world/vehicle", rr.TransformAxes3D(axis_length=0.1), static=True)
        rotors = rotor_positions_frd(self._airframe.arm_length)
        s.log("world/vehicle/arms",
              rr.LineStrips3D([[np.zeros(3), p] for p in rotors], radii=0.008,
                              colors=[(220, 50, 50)] + [(120, 120, 120)] * 3), static=True)
        r = self.config.rotor_radius_m
        s.log("world/vehicle/rotors",
              rr.Cylinders3D(lengths=[0.01] * 4, radii=[r] * 4, centers=rotors), static=True)
        s.log("world/wind", rr.Arrows3D.from_fields(colors=(90, 170, 220), radii=0.005,
                                                    labels="wind"), static=True)
        s.log("world/reference", rr.Points3D.from_fields(radii=0.02, colors=_REF_RGB),
              static=True)
        waypoints = [(seq, item.pos_ned) for seq, item in enumerate(self.scenario.mission, 1)
                     if item.pos_ned is not None]
        if waypoints:
            s.log("world/mission", rr.Points3D([p for _, p in waypoints], radii=0.02,
                                               colors=(150, 150, 150),
                                               labels=[f"wp{seq}" for seq, _ in waypoints]),
                  static=True)
        for path, rgb, label in (("world/reference_path", _REF_RGB, "reference"),
                                 ("world/flown_path", _TRUTH_RGB, "flown")):
            s.log(path, rr.LineStrips3D.from_fields(colors=rgb, radii=0.006, labels=label),
                  static=True)
        styles: list[tuple[str, tuple[int, int, int], str]] = []
        for axis in POSITION_AXES:
            styles += [(f"plots/position/{axis}/truth", _TRUTH_RGB, f"{axis} truth"),
                       (f"plots/position/{axis}/estimate", _EST_RGB, f"{axis} estimate"),
                       (f"plots/position/{axis}/ref", _REF_RGB, f"{axis} ref"),
                       (f"plots/error/{axis}", _ERROR_RGB, f"e_{axis} (m)")]
        for axis in ATTITUDE_AXES:
            styles += [(f"plots/attitude/{axis}/truth", _TRUTH_RGB, f"{axis} truth"),
                       (f"plots/attitude/{axis}/ref", _REF_RGB, f"{axis} ref"),
                       (f"plots/error/{axis}", _ERROR_RGB, f"e_{axis} (deg)")]
        for m, rgb in zip(MOTORS, _MOTOR_RGB, strict=True):
            styles += [(f"plots/pwm/{m}", rgb, f"PWM {m}"),
                       (f"plots/loe/{m}/true", _REF_RGB, f"LOE {m} injected"),
                       (f"plots/loe/{m}/estimate", _EST_RGB, f"LOE {m} estimate")]
        for path, rgb, name in styles:
            s.log(path, rr.SeriesLines(colors=rgb, names=name, widths=1.5), static=True)

    # ------------------------------------------------------------------ per tick
    def on_tick(self, world: World, autopilot: Autopilot) -> None:
        """Buffer this tick; send the buffer when ``flush_s`` is full (``fly``'s on_tick)."""
        if self._closed:
            return
        if not self._started:
            self._start()
        status = autopilot.status
        assert status is not None
        x = world.plant.state
        t = world.time_s
        ref, att_ref = status.reference, status.attitude_reference
        c = self._cols
        k = c.n
        c.t[k] = t
        c.pos[k] = x[0:3]
        c.quat_wxyz[k] = x[6:10]
        c.euler_deg[k] = np.degrees(quat_to_euler(np.ascontiguousarray(x[6:10])))
        c.est_pos[k] = status.estimate.pos_ned
        if ref is not None and att_ref is not None and not world.plant.on_ground:
            c.flying[k] = True
            c.ref_pos[k] = ref.pos_ned
            c.ref_euler_deg[k] = np.degrees(att_ref.euler_rad)
        else:
            c.flying[k] = False
        c.pwm[k] = status.pwm
        c.loe_true[k] = world.faults.true_loe(t)
        c.loe_est[k] = status.loe_estimate
        c.wind[k] = world.wind_ned
        c.scene[k] = self._ticks % self._scene_every == 0
        c.n = k + 1  # the row counts only once complete (an interrupt may land anywhere)
        self._ticks += 1
        if c.full:
            self._flush()

    def on_event(self, time_s: float, source: str, text: str) -> None:
        """Log one event to ``events`` at once (``fly``'s on_event)."""
        import rerun as rr

        if self._closed:
            return
        if not self._started:
            self._start()
        lowered = text.lower()
        if "crash" in lowered:
            level = rr.TextLogLevel.ERROR
        elif source in ("sim", "runner") or any(
                word in lowered for word in ("fault", "failsafe", "effectiveness", "refused")):
            level = rr.TextLogLevel.WARN
        else:
            level = rr.TextLogLevel.INFO
        self.stream.set_time(SIM_TIMELINE, duration=sim_duration(time_s))
        self.stream.log("events", rr.TextLog(f"[{source}] {text}", level=level))

    def close(self) -> None:
        """Send the buffered rows and flush the stream (idempotent; safe after Ctrl-C)."""
        if self._closed:
            return
        if self._started:
            self._flush()
        self._closed = True
        self.stream.flush()
        if self.owns_stream:
            self.stream.disconnect()

    # ------------------------------------------------------------------ sending
    def _flush(self) -> None:
        """Send the buffered rows as one unit: Ctrl-C waits until they are all sent.

        An interrupt in the middle would leave some entities sent and others not, and the
        final :meth:`close` would then send the sent ones twice (duplicate rows).
        """
        c = self._cols
        n = c.n
        if n == 0:
            return
        blocked = _block_sigint()
        try:
            self._send_series(n)
            self._send_scene(n)
            c.n = 0
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})

    def _send_series(self, n: int) -> None:
        import rerun as rr

        c = self._cols
        s = self.stream
        t = c.t[:n]
        fly = c.flying[:n]
        every = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t))]
        flying = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t[fly]))]
        has_flying = bool(np.any(fly))

        def send(path: str, index: Sequence[rr.TimeColumn], values: np.ndarray) -> None:
            s.send_columns(path, indexes=index, columns=rr.Scalars.columns(scalars=values))

        for i, axis in enumerate(POSITION_AXES):
            send(f"plots/position/{axis}/truth", every, c.pos[:n, i])
            send(f"plots/position/{axis}/estimate", every, c.est_pos[:n, i])
            if has_flying:
                ref = c.ref_pos[:n][fly, i]
                send(f"plots/position/{axis}/ref", flying, ref)
                send(f"plots/error/{axis}", flying, ref - c.pos[:n][fly, i])
        for i, axis in enumerate(ATTITUDE_AXES):
            send(f"plots/attitude/{axis}/truth", every, c.euler_deg[:n, i])
            if has_flying:
                ref = c.ref_euler_deg[:n][fly, i]
                send(f"plots/attitude/{axis}/ref", flying, ref)
                err = np.degrees(wrap_angle_rad(np.radians(ref - c.euler_deg[:n][fly, i])))
                send(f"plots/error/{axis}", flying, err)
        for j, m in enumerate(MOTORS):
            send(f"plots/pwm/{m}", every, c.pwm[:n, j])
            send(f"plots/loe/{m}/true", every, c.loe_true[:n, j])
            send(f"plots/loe/{m}/estimate", every, c.loe_est[:n, j])

    def _send_scene(self, n: int) -> None:
        import rerun as rr

        c = self._cols
        s = self.stream
        rows = np.flatnonzero(c.scene[:n])
        if rows.size == 0:
            return
        t = c.t[rows]
        pos = c.pos[rows]
        index = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t))]
        quat_xyzw = c.quat_wxyz[rows][:, [1, 2, 3, 0]]
        s.send_columns("world/vehicle", indexes=index,
                       columns=rr.Transform3D.columns(translation=pos, quaternion=quat_xyzw))
        loe_true = c.loe_true[rows]
        faulted = np.isnan(loe_true) | (loe_true > 0.0)
        colors = rotor_colors(c.pwm[rows].reshape(-1), self._airframe.pwm_max,
                              faulted.reshape(-1))
        s.send_columns("world/vehicle/rotors", indexes=index,
                       columns=rr.Cylinders3D.columns(colors=colors).partition([4] * rows.size))
        s.send_columns("world/wind", indexes=index, columns=rr.Arrows3D.columns(
            origins=pos, vectors=c.wind[rows] * self.config.wind_arrow_m_per_m_s))
        flying = c.flying[rows]
        if np.any(flying):
            s.send_columns("world/reference",
                           indexes=[rr.TimeColumn(SIM_TIMELINE,
                                                         duration=sim_durations(t[flying]))],
                           columns=rr.Points3D.columns(positions=c.ref_pos[rows][flying]))
        for r, row in enumerate(rows):
            # rare changes, logged one by one: rotor labels (fault state) and the reference
            # marker disappearing on the ground
            labels = [f"{m}" + ("" if not f else f" LOE {g:.2f}" if math.isfinite(g)
                                else " locked/hard-over")
                      for m, f, g in zip(MOTORS, faulted[r], loe_true[r], strict=True)]
            if labels != self._rotor_labels or (self._was_flying and not flying[r]):
                s.set_time(SIM_TIMELINE, duration=sim_duration(float(c.t[row])))
                if labels != self._rotor_labels:
                    s.log("world/vehicle/rotors", rr.Cylinders3D.from_fields(labels=labels))
                    self._rotor_labels = labels
                if self._was_flying and not flying[r]:
                    s.log("world/reference", rr.Clear(recursive=False))
            self._was_flying = bool(flying[r])
        self._flown.extend(pos)
        self._ref_path.extend(c.ref_pos[rows][flying])
        s.set_time(SIM_TIMELINE, duration=sim_duration(float(t[-1])))
        if len(self._flown) >= 2:
            s.log("world/flown_path", rr.LineStrips3D([np.asarray(self._flown)]))
        if len(self._ref_path) >= 2:
            s.log("world/reference_path", rr.LineStrips3D([np.asarray(self._ref_path)]))


def open_recorder(scenario: Scenario, *, rrd_path: str | Path | None = None,
                  spawn: bool = False, connect_url: str | None = None,
                  config: RecordingConfig | None = None,
                  recording_id: str | None = None) -> FlightRecorder:
    """A :class:`FlightRecorder` on a new stream (:func:`open_stream` for the arguments)."""
    stream = open_stream(scenario.name, rrd_path=rrd_path, spawn=spawn,
                         connect_url=connect_url, recording_id=recording_id)
    return FlightRecorder(stream, scenario, config, owns_stream=True)


def _block_sigint() -> bool:
    """Hold SIGINT back (delivered when unblocked) where the platform allows; True if done."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not \
            threading.main_thread():
        return False
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    return True
