"""Rerun recordings of a flight from its telemetry: a 3-D scene and time series on ``sim_time``.

Built from the aligned arrays of :meth:`gcs.analysis.FlightAnalyzer.series` (the ones behind
the table), so a recording can be made live during a flight (``ftc-gcs fly --rerun``: a
:class:`LiveRecorder` hooked on the ground station's clock) or afterwards from any .tlog
(``ftc-gcs fly --rrd``, ``ftc-gcs report FLIGHT.tlog --rrd PATH``: :func:`write_recording`).
Entity paths and the timeline are those of the headless simulator's recordings
(``sim/recording.py``) wherever telemetry carries the data; the ground station never imports
the simulator, so the few shared helpers are repeated here.

Timeline: ``sim_time``, a duration in simulated seconds on the vehicle clock (``time_boot_ms``,
SERVO_OUTPUT_RAW's unwrapped ``time_usec``), whole nanoseconds rounded from the float time.

Frames: the world is NED, unconverted: ``world`` carries ``ViewCoordinates.FRD`` (X north,
Y east, Z down). The vehicle's ``Transform3D`` is its true pose (SIM_STATE position about the
origin, quaternion of the ZYX roll, pitch, yaw); everything under ``world/vehicle`` is body FRD.

Entity paths
------------
==================================  =========================================================
``world``                           ViewCoordinates FRD (static)
``world/vehicle``                   Transform3D, true pose (scene rate); TransformAxes3D
``world/vehicle/arms``              LineStrips3D (static): centre to each motor, front red
``world/vehicle/rotors``            Cylinders3D: rotor disks of motors 1..4 (front, back,
                                    left, right), colour = commanded PWM, dark blue (0) to
                                    yellow (``pwm_max``), red shades while a fault is in
                                    force on that motor (label shows the injected LOE)
``world/reference``                 Points3D: current position reference (flying samples)
``world/reference_path``            LineStrips3D: the reference so far (re-sent each flush)
``world/flown_path``                LineStrips3D: the true path so far (re-sent each flush)
``plots/position/{x,y,z}/truth``    Scalars: true position, NED, m (every SIM_STATE)
``plots/position/{x,y,z}/ref``      Scalars: position reference, NED, m (flying samples)
``plots/error/{x,y,z}``             Scalars: reference - truth, m (flying samples)
``plots/attitude/{roll,pitch,yaw}/{ref,truth}``  Scalars: deg (ref on flying samples)
``plots/error/{roll,pitch,yaw}``    Scalars: reference - truth wrapped to +-180 deg (flying)
``plots/pwm/{1,2,3,4}``             Scalars: commanded PWM (SERVO_OUTPUT_RAW times)
``plots/loe/{1,2,3,4}/true``        Scalars: injected loss of effectiveness, from the
                                    simulator's STATUSTEXT, on every SIM_STATE sample (NaN:
                                    lock or hard-over)
``plots/loe/{1,2,3,4}/estimate``    Scalars: NAMED_VALUE_FLOAT LOEn (its own times)
``events``                          TextLog: "[KIND] text" of every analyzer event
                                    (injections, detections, modes, arming, mission progress,
                                    STATUSTEXT such as failsafes, ACKs, parameters)
==================================  =========================================================

Not recorded, for want of telemetry: the wind (``world/wind``; SIM_STATE carries no wind and
the vehicle sends no WIND message) and the position estimate (``plots/position/*/estimate``).
The "flying samples" are those the table counts (:attr:`FlightSeries.flying`).

Live streams lag the vehicle by up to ``flush_s`` (1 s simulated) plus ``holdback_s``, and by
at least ``min_wall_s`` (0.5 s wall) between sends at a high speed-up; their
north/east positions are the velocity-aided truth anchored to the geodetic mean of the
samples so far, which may move by a few mm as more arrive. A recording written from the .tlog
after the flight is exact (the same arrays as the table).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from gcs.analysis import FlightAnalyzer, FlightEvent, FlightSeries, replay_tlog

if TYPE_CHECKING:
    import rerun as rr

__all__ = [
    "APPLICATION_ID",
    "SIM_TIMELINE",
    "LiveRecorder",
    "RecordingConfig",
    "SeriesRecorder",
    "open_stream",
    "quat_wxyz_from_euler",
    "rotor_colors",
    "scene_rows",
    "write_recording",
]

#: Name of the simulated-time timeline (a duration, seconds).
SIM_TIMELINE = "sim_time"
#: rerun application id (the same as the simulator's recordings).
APPLICATION_ID = "quadftc"
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
    """Drawing sizes and rates of a recording."""

    scene_rate_hz: float = 25.0  # Hz, 3-D scene: pose, rotor colours, reference marker
    flush_s: float = 1.0  # s simulated between two sends of a live stream
    holdback_s: float = 0.1  # s simulated: live rows this close to the newest wait a flush
    arm_length_m: float = 0.2  # m, centre to rotor axis (Qball-X4, thesis Table 7.1)
    rotor_radius_m: float = 0.08  # m, drawn rotor disk radius

    def __post_init__(self) -> None:
        for name in ("scene_rate_hz", "flush_s", "arm_length_m", "rotor_radius_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} = {value!r}: must be a finite number > 0")
        if not (math.isfinite(self.holdback_s) and self.holdback_s >= 0.0):
            raise ValueError(f"holdback_s = {self.holdback_s!r}: must be a finite number >= 0")


def sim_durations(time_s: npt.ArrayLike) -> npt.NDArray[np.timedelta64]:
    """Simulated times (s) as whole nanoseconds, rounded (rerun would truncate)."""
    return np.rint(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64).astype(
        "timedelta64[ns]")


def _duration(time_s: float) -> np.timedelta64:
    return np.timedelta64(round(time_s * 1e9), "ns")


def quat_wxyz_from_euler(euler_rad: np.ndarray) -> np.ndarray:
    """Quaternions [w, x, y, z] (body FRD to NED) of ZYX roll, pitch, yaw rows, shape (n, 4)."""
    e = np.asarray(euler_rad, dtype=float).reshape(-1, 3)
    cr, sr = np.cos(e[:, 0] / 2), np.sin(e[:, 0] / 2)
    cp, sp = np.cos(e[:, 1] / 2), np.sin(e[:, 1] / 2)
    cy, sy = np.cos(e[:, 2] / 2), np.sin(e[:, 2] / 2)
    # q = q_z(yaw) q_y(pitch) q_x(roll)
    return np.column_stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def rotor_positions_frd(arm_length_m: float) -> np.ndarray:
    """Rotor centres in body FRD, motors 1..4 (front, back, left, right), m."""
    L = arm_length_m
    return np.array([[L, 0.0, 0.0], [-L, 0.0, 0.0], [0.0, -L, 0.0], [0.0, L, 0.0]])


def rotor_colors(pwm: np.ndarray, pwm_max: float, faulted: np.ndarray) -> np.ndarray:
    """RGB (uint8, (k, 3)) of rotor disks: PWM ramp blue to yellow, red ramp where faulted."""
    frac = np.clip(np.asarray(pwm, dtype=float) / pwm_max, 0.0, 1.0)[:, None]
    normal = _PWM_LOW_RGB + frac * (_PWM_HIGH_RGB - _PWM_LOW_RGB)
    fault = _FAULT_LOW_RGB + frac * (_FAULT_HIGH_RGB - _FAULT_LOW_RGB)
    rgb = np.where(np.asarray(faulted, dtype=bool)[:, None], fault, normal)
    return np.rint(rgb).astype(np.uint8)


def scene_rows(time_s: np.ndarray, rate_hz: float) -> np.ndarray:
    """Indices of the samples drawn in the 3-D scene: the first of each 1/rate_hz slot.

    Depends only on each sample's time and its predecessor's, so a live stream picks the
    same rows as a recording written afterwards.
    """
    t = np.asarray(time_s, dtype=float)
    if len(t) == 0:
        return np.zeros(0, dtype=int)
    slot = np.floor(t * rate_hz + 1e-6)
    return np.flatnonzero(np.r_[True, slot[1:] > slot[:-1]])


def _hold_index(t_src: np.ndarray, t_query: np.ndarray) -> np.ndarray:
    """Index of the latest source sample at or before each query (-1: none)."""
    return np.searchsorted(t_src, t_query + 1e-9, side="right") - 1


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
    """A rerun recording stream to an ``.rrd`` file, a viewer, or both.

    Parameters
    ----------
    name : str
        Recording name shown by the viewer.
    rrd_path : path, optional
        Write to this file (parent directories are created).
    spawn : bool
        Start a rerun viewer (``rerun`` from the wheel) and stream to it.
    connect_url : str, optional
        Stream to a running viewer or server instead (``rerun+http://HOST:PORT/proxy``).
    recording_id : str, optional
        Fixed recording id (default: random).
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


def _event_level(event: FlightEvent) -> str:
    import rerun as rr

    lowered = event.text.lower()
    if event.kind == "CRASH" or "crash" in lowered:
        return str(rr.TextLogLevel.ERROR)
    if event.kind in ("INJECT", "DETECT") or any(
            word in lowered for word in ("fault", "failsafe", "effectiveness", "refused",
                                         "denied", "failed")):
        return str(rr.TextLogLevel.WARN)
    return str(rr.TextLogLevel.INFO)


class SeriesRecorder:
    """Sends a growing :class:`FlightSeries` to a rerun stream, the new rows each time.

    Each :meth:`send` logs what was not sent before (rows are append-only: the analyzer's
    samples only grow); the rows up to ``until_s`` when given. The static content goes out
    with the first send.

    Parameters
    ----------
    stream : rerun.RecordingStream
    config : RecordingConfig, optional
    """

    def __init__(self, stream: rr.RecordingStream, config: RecordingConfig | None = None) -> None:
        self.stream = stream
        self.config = config if config is not None else RecordingConfig()
        self._started = False
        self._n_truth = 0
        self._n_pwm = 0
        self._n_loe = [0, 0, 0, 0]
        self._n_events = 0
        self._last_event_s = 0.0
        self._rotor_labels: list[str] = []
        self._was_flying = False

    @property
    def rows_sent(self) -> int:
        """SIM_STATE samples sent so far."""
        return self._n_truth

    def _start(self) -> None:
        import rerun as rr

        self._started = True
        s = self.stream
        s.log("world", rr.ViewCoordinates.FRD, static=True)
        s.log("world/vehicle", rr.TransformAxes3D(axis_length=0.1), static=True)
        rotors = rotor_positions_frd(self.config.arm_length_m)
        s.log("world/vehicle/arms",
              rr.LineStrips3D([[np.zeros(3), p] for p in rotors], radii=0.008,
                              colors=[(220, 50, 50)] + [(120, 120, 120)] * 3), static=True)
        r = self.config.rotor_radius_m
        s.log("world/vehicle/rotors",
              rr.Cylinders3D(lengths=[0.01] * 4, radii=[r] * 4, centers=rotors), static=True)
        s.log("world/reference", rr.Points3D.from_fields(radii=0.02, colors=_REF_RGB),
              static=True)
        for path, rgb, label in (("world/reference_path", _REF_RGB, "reference"),
                                 ("world/flown_path", _TRUTH_RGB, "flown")):
            s.log(path, rr.LineStrips3D.from_fields(colors=rgb, radii=0.006, labels=label),
                  static=True)
        styles: list[tuple[str, tuple[int, int, int], str]] = []
        for axis in POSITION_AXES:
            styles += [(f"plots/position/{axis}/truth", _TRUTH_RGB, f"{axis} truth"),
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

    def send(self, series: FlightSeries, until_s: float | None = None) -> None:
        """Log the rows of ``series`` not sent yet (those at or before ``until_s``)."""
        if not self._started:
            self._start()
        limit = math.inf if until_s is None else until_s + 1e-9
        t = series.time_s
        hi = int(np.searchsorted(t, limit, side="right")) if len(t) else 0
        hi = max(hi, self._n_truth)
        if hi > self._n_truth:
            self._send_samples(series, self._n_truth, hi)
            self._send_scene(series, self._n_truth, hi)
            self._n_truth = hi
        self._send_pwm(series, limit)
        self._send_loe(series, limit)
        self._send_events(series, limit)

    def _send_samples(self, fs: FlightSeries, lo: int, hi: int) -> None:
        import rerun as rr

        s = self.stream
        t = fs.time_s[lo:hi]
        fly = fs.flying[lo:hi]
        every = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t))]
        flying = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t[fly]))]
        has_flying = bool(np.any(fly))

        def send(path: str, index: Sequence[rr.TimeColumn], values: np.ndarray) -> None:
            s.send_columns(path, indexes=index, columns=rr.Scalars.columns(scalars=values))

        pos, ref = fs.pos_ned[lo:hi], fs.ref_pos_ned[lo:hi]
        for i, axis in enumerate(POSITION_AXES):
            send(f"plots/position/{axis}/truth", every, pos[:, i])
            if has_flying:
                send(f"plots/position/{axis}/ref", flying, ref[fly, i])
                send(f"plots/error/{axis}", flying, ref[fly, i] - pos[fly, i])
        euler, ref_e = fs.euler_rad[lo:hi], fs.ref_euler_rad[lo:hi]
        for i, axis in enumerate(ATTITUDE_AXES):
            send(f"plots/attitude/{axis}/truth", every, np.degrees(euler[:, i]))
            if has_flying:
                send(f"plots/attitude/{axis}/ref", flying, np.degrees(ref_e[fly, i]))
                err = ref_e[fly, i] - euler[fly, i]
                send(f"plots/error/{axis}", flying,
                     np.degrees((err + np.pi) % (2.0 * np.pi) - np.pi))
        for j, m in enumerate(MOTORS):
            send(f"plots/loe/{m}/true", every, fs.injected_loe[lo:hi, j])

    def _send_scene(self, fs: FlightSeries, lo: int, hi: int) -> None:
        import rerun as rr

        s = self.stream
        rows = scene_rows(fs.time_s[:hi], self.config.scene_rate_hz)
        rows = rows[rows >= lo]
        if rows.size == 0:
            return
        t = fs.time_s[rows]
        pos = fs.pos_ned[rows]
        index = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t))]
        quat_xyzw = quat_wxyz_from_euler(fs.euler_rad[rows])[:, [1, 2, 3, 0]]
        s.send_columns("world/vehicle", indexes=index,
                       columns=rr.Transform3D.columns(translation=pos, quaternion=quat_xyzw))
        i_pwm = _hold_index(fs.pwm_time_s, t)
        pwm = np.where((i_pwm >= 0)[:, None], fs.pwm[np.maximum(i_pwm, 0)], 0.0) \
            if len(fs.pwm_time_s) else np.zeros((rows.size, 4))
        loe = fs.injected_loe[rows]
        faulted = np.isnan(loe) | (loe > 0.0)
        colors = rotor_colors(pwm.reshape(-1), fs.pwm_max, faulted.reshape(-1))
        s.send_columns("world/vehicle/rotors", indexes=index,
                       columns=rr.Cylinders3D.columns(colors=colors).partition([4] * rows.size))
        flying = fs.flying[rows]
        if np.any(flying):
            s.send_columns("world/reference",
                           indexes=[rr.TimeColumn(SIM_TIMELINE,
                                                  duration=sim_durations(t[flying]))],
                           columns=rr.Points3D.columns(positions=fs.ref_pos_ned[rows][flying]))
        for r in range(rows.size):
            # rare changes, one by one: rotor labels (fault state), the reference marker
            # disappearing on landing
            labels = [f"{m}" + ("" if not f else f" LOE {g:.2f}" if math.isfinite(g)
                                else " locked/hard-over")
                      for m, f, g in zip(MOTORS, faulted[r], loe[r], strict=True)]
            leaving = self._was_flying and not flying[r]
            if labels != self._rotor_labels or leaving:
                s.set_time(SIM_TIMELINE, duration=_duration(float(t[r])))
                if labels != self._rotor_labels:
                    s.log("world/vehicle/rotors", rr.Cylinders3D.from_fields(labels=labels))
                    self._rotor_labels = labels
                if leaving:
                    s.log("world/reference", rr.Clear(recursive=False))
            self._was_flying = bool(flying[r])
        all_rows = scene_rows(fs.time_s[:hi], self.config.scene_rate_hz)
        flown = fs.pos_ned[all_rows]
        ref_path = fs.ref_pos_ned[all_rows][fs.flying[all_rows]]
        s.set_time(SIM_TIMELINE, duration=_duration(float(t[-1])))
        if len(flown) >= 2:
            s.log("world/flown_path", rr.LineStrips3D([flown]))
        if len(ref_path) >= 2:
            s.log("world/reference_path", rr.LineStrips3D([ref_path]))

    def _send_pwm(self, fs: FlightSeries, limit: float) -> None:
        import rerun as rr

        hi = int(np.searchsorted(fs.pwm_time_s, limit, side="right"))
        if hi <= self._n_pwm:
            return
        lo, self._n_pwm = self._n_pwm, hi
        index = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(fs.pwm_time_s[lo:hi]))]
        for j, m in enumerate(MOTORS):
            self.stream.send_columns(f"plots/pwm/{m}", indexes=index,
                                     columns=rr.Scalars.columns(scalars=fs.pwm[lo:hi, j]))

    def _send_loe(self, fs: FlightSeries, limit: float) -> None:
        import rerun as rr

        for j, m in enumerate(MOTORS):
            t = fs.loe_estimate_time_s[j]
            hi = int(np.searchsorted(t, limit, side="right"))
            if hi <= self._n_loe[j]:
                continue
            lo, self._n_loe[j] = self._n_loe[j], hi
            index = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t[lo:hi]))]
            self.stream.send_columns(
                f"plots/loe/{m}/estimate", indexes=index,
                columns=rr.Scalars.columns(scalars=fs.loe_estimate[j][lo:hi]))

    def _send_events(self, fs: FlightSeries, limit: float) -> None:
        import rerun as rr

        for event in fs.events[self._n_events:]:
            if event.time_s is not None and event.time_s > limit:
                break
            # an event the vehicle clock had not dated yet goes with the one before it
            time_s = self._last_event_s if event.time_s is None else event.time_s
            self._last_event_s = time_s
            self.stream.set_time(SIM_TIMELINE, duration=_duration(time_s))
            self.stream.log("events", rr.TextLog(f"[{event.kind}] {event.text}",
                                                 level=_event_level(event)))
            self._n_events += 1


def write_recording(series: FlightSeries, stream: rr.RecordingStream,
                    config: RecordingConfig | None = None) -> None:
    """Log a whole flight to ``stream`` (in ``flush_s`` chunks, as a live stream would)."""
    recorder = SeriesRecorder(stream, config)
    step = recorder.config.flush_s
    end = float(series.time_s[-1]) if len(series.time_s) else 0.0
    t = float(series.time_s[0]) if len(series.time_s) else 0.0
    while t < end:
        t += step
        recorder.send(series, until_s=t)
    recorder.send(series)
    stream.flush()


def write_rrd(tlog: str | Path, rrd_path: str | Path, *, name: str | None = None,
              recording_id: str | None = None,
              config: RecordingConfig | None = None) -> FlightSeries:
    """Write the recording of a recorded flight (.tlog) to ``rrd_path``; returns its series."""
    series = replay_tlog(tlog).series()
    stream = open_stream(name or Path(tlog).stem, rrd_path=rrd_path, recording_id=recording_id)
    try:
        write_recording(series, stream, config)
    finally:
        stream.disconnect()
    return series


class LiveRecorder:
    """Streams a flight while it is flown: hook :meth:`on_clock` on the ground station.

    Every ``flush_s`` of vehicle time, and at most once per ``min_wall_s`` wall seconds,
    takes :meth:`FlightAnalyzer.series` of what arrived and sends the new rows, keeping back
    the last ``holdback_s`` (a sample's references may still be on their way); :meth:`close`
    sends the rest and flushes.

    Parameters
    ----------
    stream : rerun.RecordingStream
    analyzer : FlightAnalyzer
        The ground station's (``GroundStation.analyzer``).
    config : RecordingConfig, optional
    owns_stream : bool
        :meth:`close` also disconnects the stream.
    min_wall_s : float
        Wall seconds between two sends, at least.
    """

    def __init__(self, stream: rr.RecordingStream, analyzer: FlightAnalyzer,
                 config: RecordingConfig | None = None, *, owns_stream: bool = False,
                 min_wall_s: float = 0.5) -> None:
        self.recorder = SeriesRecorder(stream, config)
        self.analyzer = analyzer
        self.owns_stream = owns_stream
        self.min_wall_s = min_wall_s
        self.flushes = 0
        self._next_s: float | None = None
        self._next_wall = -math.inf
        self._closed = False

    def on_clock(self, clock_s: float) -> None:
        """The vehicle clock advanced (``GroundStation.on_clock`` hook)."""
        if self._closed:
            return
        cfg = self.recorder.config
        if self._next_s is None:
            self._next_s = clock_s + cfg.flush_s
            return
        if clock_s >= self._next_s and time.monotonic() >= self._next_wall:
            self._next_s = clock_s + cfg.flush_s
            self.recorder.send(self.analyzer.series(), until_s=clock_s - cfg.holdback_s)
            self.flushes += 1
            # a flush recomputes the series so far: at a high speed-up, not more often than
            # every min_wall_s, or the ground station falls behind the telemetry
            self._next_wall = time.monotonic() + self.min_wall_s

    def close(self) -> None:
        """Send what is left and flush (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self.recorder.send(self.analyzer.series())
        self.recorder.stream.flush()
        if self.owns_stream:
            self.recorder.stream.disconnect()
