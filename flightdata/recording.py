"""Rerun recordings of a flight: a 3-D scene and time series on simulated time.

One recorder for every source of a :class:`~flightdata.series.FlightSeries`. A
:class:`SeriesRecorder` sends the rows of a growing series that it has not sent yet, so the
same code records a flight while it is flown (:class:`LiveRecorder`: the headless runner's
ticks, ``sim.runner.open_recording``; the ground station's telemetry, ``ftc-gcs fly --rerun``)
and afterwards (:func:`write_recording`: ``ftc-gcs report FLIGHT.tlog --rrd PATH``). Written
against rerun-sdk 0.29 (``TransformAxes3D``, ``Cylinders3D``, ``send_columns`` with
``TimeColumn``); rerun is imported when something is recorded, not with this module.

Timeline: ``sim_time``, a duration in simulated seconds on the vehicle clock, stored as whole
nanoseconds rounded from the float time (:func:`sim_duration`), so a recording replays at
simulated, not wall-clock, time.

Frames: the world is logged in **NED**, unconverted: ``world`` carries the static view
coordinates ``ViewCoordinates.FRD`` (X forward = north, Y right = east, Z down), a
right-handed frame whose "up" the viewer takes as -Z. The vehicle's ``Transform3D`` is its
true pose (position NED, quaternion of the true roll, pitch, yaw); everything under
``world/vehicle`` is in body FRD.

Entity paths
------------
==================================  =========================================================
``world``                           ViewCoordinates FRD (static): NED world
``world/mission``                   Points3D (static): mission waypoints, labelled by seq
                                    (when the recorder is given them)
``world/vehicle``                   Transform3D, true pose (scene rate); TransformAxes3D
``world/vehicle/arms``              LineStrips3D (static): centre to each motor, front arm red
``world/vehicle/rotors``            Cylinders3D: the four rotor disks (motor numbering of
                                    docs/design.md: front, back, left, right), colour =
                                    commanded PWM from dark blue (0) to yellow (``pwm_max``);
                                    red shades while a fault is injected on that motor
                                    (label shows the injected LOE)
``world/reference``                 Points3D: current position reference (flying samples)
``world/reference_path``            LineStrips3D: the reference so far (re-sent each send)
``world/flown_path``                LineStrips3D: the true path so far (re-sent each send)
``world/wind``                      Arrows3D: wind velocity at the vehicle, 1 m per m/s
``plots/position/{x,y,z}/truth``    Scalars: true position, NED, m (every sample)
``plots/position/{x,y,z}/estimate`` Scalars: the estimate fed to the controllers, NED, m
``plots/position/{x,y,z}/ref``      Scalars: position reference, NED, m (flying samples)
``plots/error/{x,y,z}``             Scalars: reference - truth, m (flying samples)
``plots/attitude/{roll,pitch,yaw}/{ref,truth}``  Scalars: deg (ref on flying samples)
``plots/error/{roll,pitch,yaw}``    Scalars: reference - truth wrapped to +-180, deg (flying)
``plots/pwm/{1,2,3,4}``             Scalars: commanded PWM (unit duty, at its own times)
``plots/loe/{1,2,3,4}/true``        Scalars: injected loss of effectiveness, every sample
                                    (NaN: lock or hard-over, which no gamma describes)
``plots/loe/{1,2,3,4}/estimate``    Scalars: the estimated loss (at its own times)
``events``                          TextLog: "[kind] text" of every :class:`FlightEvent`
==================================  =========================================================

A series without wind or without a position estimate (the ground station's) records no
``world/wind`` and no ``plots/position/*/estimate``. "Flying samples" are
:attr:`FlightSeries.flying`; the reference series have no rows elsewhere.

The 3-D scene is decimated to ``scene_rate_hz`` (:func:`scene_rows`, which depends only on
the samples up to each one, so a live stream draws the same frames as a recording written
afterwards); time series keep every sample. A live stream lags by up to ``flush_s`` of
simulated time, plus ``holdback_s``.

Opening a recording: ``rerun flight.rrd`` (the ``rerun`` CLI ships in the rerun-sdk wheel,
``python -m rerun_cli flight.rrd`` works too); ``rerun rrd print -vvv --entity
/plots/pwm/1 flight.rrd`` lists rows; ``rerun.recording.load_recording(path).schema()``
lists entities, components and timelines from Python.
"""

from __future__ import annotations

import math
import signal
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from flightdata.geometry import quats_from_euler, wrap_pi_array
from flightdata.series import FlightEvent, FlightSeries
from flightdata.vocabulary import MOTORS

if TYPE_CHECKING:
    import rerun as rr

__all__ = ["APPLICATION_ID", "SIM_TIMELINE", "LiveRecorder", "RecordingConfig",
           "SeriesRecorder", "default_blueprint", "event_level", "open_stream",
           "rotor_colors", "rotor_positions_frd", "scene_rows", "sim_duration",
           "sim_durations", "write_recording"]

#: Name of the simulated-time timeline (a duration, seconds).
SIM_TIMELINE = "sim_time"
#: rerun application id of every recording.
APPLICATION_ID = "quadftc"
#: Position and attitude axis names, in column order.
POSITION_AXES = ("x", "y", "z")
ATTITUDE_AXES = ("roll", "pitch", "yaw")

_REF_RGB = (40, 40, 40)
_TRUTH_RGB = (31, 119, 180)
_EST_RGB = (255, 127, 14)
_ERROR_RGB = (214, 39, 40)
_MOTOR_RGB = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40))
_PWM_LOW_RGB = np.array([30.0, 50.0, 150.0])  # PWM 0: dark blue
_PWM_HIGH_RGB = np.array([250.0, 220.0, 40.0])  # PWM pwm_max: yellow
_FAULT_LOW_RGB = np.array([110.0, 0.0, 0.0])  # faulted motor at PWM 0: dark red
_FAULT_HIGH_RGB = np.array([255.0, 70.0, 70.0])  # faulted motor at pwm_max: bright red
_WARN_KINDS = ("sim", "runner", "INJECT", "DETECT")
_WARN_WORDS = ("fault", "failsafe", "effectiveness", "refused", "denied", "failed")


@dataclass(frozen=True, kw_only=True)
class RecordingConfig:
    """How a flight is drawn and how often a live stream sends."""

    scene_rate_hz: float = 25.0  # Hz, 3-D scene: pose, rotor colours, wind, reference marker
    flush_s: float = 1.0  # s simulated between two sends of a live stream
    holdback_s: float = 0.1  # s simulated: live rows this close to the newest wait a send
    arm_length_m: float = 0.2  # m, centre to rotor axis (Qball-X4, thesis Table 7.1)
    rotor_radius_m: float = 0.08  # m, drawn rotor disk radius
    wind_arrow_m_per_m_s: float = 1.0  # m of arrow per m/s of wind

    def __post_init__(self) -> None:
        for name in ("scene_rate_hz", "flush_s", "arm_length_m", "rotor_radius_m",
                     "wind_arrow_m_per_m_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} = {value!r}: must be a finite number > 0")
        if not (math.isfinite(self.holdback_s) and self.holdback_s >= 0.0):
            raise ValueError(f"holdback_s = {self.holdback_s!r}: must be a finite number >= 0")


def sim_duration(time_s: float) -> np.timedelta64:
    """Simulated time as whole nanoseconds, rounded (``sim_time`` stores integer ns).

    rerun truncates float seconds to nanoseconds, which turns 2.11 s (a float just below)
    into 2.109999999 s; rounding first keeps the sample times exact on the timeline.
    """
    return np.timedelta64(round(time_s * 1e9), "ns")


def sim_durations(time_s: npt.ArrayLike) -> npt.NDArray[np.timedelta64]:
    """:func:`sim_duration` of each element of ``time_s`` (s)."""
    return np.rint(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64).astype(
        "timedelta64[ns]")


def rotor_positions_frd(arm_length_m: float) -> np.ndarray:
    """Rotor centres in body FRD, motors 1..4 (docs/design.md: front, back, left, right), m."""
    L = arm_length_m
    return np.array([[L, 0.0, 0.0], [-L, 0.0, 0.0], [0.0, -L, 0.0], [0.0, L, 0.0]])


def rotor_colors(pwm: np.ndarray, pwm_max: float, faulted: np.ndarray) -> np.ndarray:
    """RGB (uint8, shape (k, 3)) of rotor disks: PWM ramp, red ramp where faulted.

    Parameters
    ----------
    pwm : numpy.ndarray, shape (k,)
        Commanded PWM of the motors (unit duty).
    pwm_max : float
        Full-power PWM (colour saturates there).
    faulted : numpy.ndarray of bool, shape (k,)
        True where a fault is injected on that motor.
    """
    frac = np.clip(np.asarray(pwm, dtype=float) / pwm_max, 0.0, 1.0)[:, None]
    normal = _PWM_LOW_RGB + frac * (_PWM_HIGH_RGB - _PWM_LOW_RGB)
    fault = _FAULT_LOW_RGB + frac * (_FAULT_HIGH_RGB - _FAULT_LOW_RGB)
    rgb = np.where(np.asarray(faulted, dtype=bool)[:, None], fault, normal)
    return np.rint(rgb).astype(np.uint8)


def scene_rows(time_s: np.ndarray, rate_hz: float) -> np.ndarray:
    """Indices of the samples drawn in the 3-D scene: the first of each 1/rate_hz slot,
    slots counted from the first sample's time.

    Depends only on each sample's time, its predecessor's and the first one's, so a live
    stream picks the same rows as a recording written afterwards. On a regular 100 Hz tick
    at 25 Hz: every fourth sample from the first.
    """
    t = np.asarray(time_s, dtype=float)
    if len(t) == 0:
        return np.zeros(0, dtype=int)
    slot = np.floor((t - t[0]) * rate_hz + 1e-6)
    return np.flatnonzero(np.r_[True, slot[1:] > slot[:-1]])


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
        Recording name shown by the viewer (the scenario or flight name).
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


def event_level(event: FlightEvent) -> str:
    """The rerun TextLog level of an event: ERROR for crashes, WARN for faults, injections,
    detections, failsafes and refusals (and whatever the simulator or the runner says),
    INFO otherwise."""
    import rerun as rr

    lowered = event.text.lower()
    if event.kind == "CRASH" or "crash" in lowered:
        return str(rr.TextLogLevel.ERROR)
    if event.kind in _WARN_KINDS or any(word in lowered for word in _WARN_WORDS):
        return str(rr.TextLogLevel.WARN)
    return str(rr.TextLogLevel.INFO)


class SeriesRecorder:
    """Sends a growing :class:`FlightSeries` to a rerun stream, the new rows each time.

    Each :meth:`send` logs what was not sent before (rows are append-only: a source's
    samples only grow); the rows up to ``until_s`` when given. The static content goes out
    with the first send, shaped by that series (no wind entity without wind, ...).

    Parameters
    ----------
    stream : rerun.RecordingStream
    config : RecordingConfig, optional
    waypoints_ned : sequence of (seq, (3,) position NED, m), optional
        Mission waypoints drawn as ``world/mission``.
    """

    def __init__(self, stream: rr.RecordingStream, config: RecordingConfig | None = None, *,
                 waypoints_ned: Sequence[tuple[int, Sequence[float]]] = ()) -> None:
        self.stream = stream
        self.config = config if config is not None else RecordingConfig()
        self.waypoints_ned = list(waypoints_ned)
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
        """Truth samples sent so far."""
        return self._n_truth

    def send(self, series: FlightSeries, until_s: float | None = None) -> None:
        """Log the rows of ``series`` not sent yet (those at or before ``until_s``).

        The rows go out as one unit: Ctrl-C is held back until they are all sent (an
        interrupt in the middle would leave some entities sent and others not, and the next
        send would then repeat them).
        """
        blocked = _block_sigint()
        try:
            self._send(series, until_s)
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})

    def _send(self, series: FlightSeries, until_s: float | None) -> None:
        if not self._started:
            self._start(series)
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

    # ------------------------------------------------------------------ static content
    def _start(self, fs: FlightSeries) -> None:
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
        if fs.wind_ned is not None:
            s.log("world/wind", rr.Arrows3D.from_fields(colors=(90, 170, 220), radii=0.005,
                                                        labels="wind"), static=True)
        s.log("world/reference", rr.Points3D.from_fields(radii=0.02, colors=_REF_RGB),
              static=True)
        if self.waypoints_ned:
            s.log("world/mission",
                  rr.Points3D([p for _, p in self.waypoints_ned], radii=0.02,
                              colors=(150, 150, 150),
                              labels=[f"wp{seq}" for seq, _ in self.waypoints_ned]),
                  static=True)
        for path, rgb, label in (("world/reference_path", _REF_RGB, "reference"),
                                 ("world/flown_path", _TRUTH_RGB, "flown")):
            s.log(path, rr.LineStrips3D.from_fields(colors=rgb, radii=0.006, labels=label),
                  static=True)
        styles: list[tuple[str, tuple[int, int, int], str]] = []
        for axis in POSITION_AXES:
            styles.append((f"plots/position/{axis}/truth", _TRUTH_RGB, f"{axis} truth"))
            if fs.est_pos_ned is not None:
                styles.append((f"plots/position/{axis}/estimate", _EST_RGB,
                               f"{axis} estimate"))
            styles += [(f"plots/position/{axis}/ref", _REF_RGB, f"{axis} ref"),
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

    # ------------------------------------------------------------------ rows
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
            if fs.est_pos_ned is not None:
                send(f"plots/position/{axis}/estimate", every, fs.est_pos_ned[lo:hi, i])
            if has_flying:
                send(f"plots/position/{axis}/ref", flying, ref[fly, i])
                send(f"plots/error/{axis}", flying, ref[fly, i] - pos[fly, i])
        euler, ref_e = fs.euler_rad[lo:hi], fs.ref_euler_rad[lo:hi]
        for i, axis in enumerate(ATTITUDE_AXES):
            send(f"plots/attitude/{axis}/truth", every, np.degrees(euler[:, i]))
            if has_flying:
                send(f"plots/attitude/{axis}/ref", flying, np.degrees(ref_e[fly, i]))
                send(f"plots/error/{axis}", flying,
                     np.degrees(wrap_pi_array(ref_e[fly, i] - euler[fly, i])))
        for j, m in enumerate(MOTORS):
            send(f"plots/loe/{m}/true", every, fs.loe_injected[lo:hi, j])

    def _send_scene(self, fs: FlightSeries, lo: int, hi: int) -> None:
        import rerun as rr

        s = self.stream
        all_rows = scene_rows(fs.time_s[:hi], self.config.scene_rate_hz)
        rows = all_rows[all_rows >= lo]
        if rows.size == 0:
            return
        t = fs.time_s[rows]
        pos = fs.pos_ned[rows]
        index = [rr.TimeColumn(SIM_TIMELINE, duration=sim_durations(t))]
        quat_xyzw = quats_from_euler(fs.euler_rad[rows])[:, [1, 2, 3, 0]]
        s.send_columns("world/vehicle", indexes=index,
                       columns=rr.Transform3D.columns(translation=pos, quaternion=quat_xyzw))
        loe = fs.loe_injected[rows]
        faulted = np.isnan(loe) | (loe > 0.0)
        colors = rotor_colors(fs.pwm_held(t).reshape(-1), fs.pwm_max, faulted.reshape(-1))
        s.send_columns("world/vehicle/rotors", indexes=index,
                       columns=rr.Cylinders3D.columns(colors=colors).partition([4] * rows.size))
        if fs.wind_ned is not None:
            s.send_columns("world/wind", indexes=index, columns=rr.Arrows3D.columns(
                origins=pos, vectors=fs.wind_ned[rows] * self.config.wind_arrow_m_per_m_s))
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
                s.set_time(SIM_TIMELINE, duration=sim_duration(float(t[r])))
                if labels != self._rotor_labels:
                    s.log("world/vehicle/rotors", rr.Cylinders3D.from_fields(labels=labels))
                    self._rotor_labels = labels
                if leaving:
                    s.log("world/reference", rr.Clear(recursive=False))
            self._was_flying = bool(flying[r])
        flown = fs.pos_ned[all_rows]
        ref_path = fs.ref_pos_ned[all_rows][fs.flying[all_rows]]
        s.set_time(SIM_TIMELINE, duration=sim_duration(float(t[-1])))
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
            self.stream.set_time(SIM_TIMELINE, duration=sim_duration(time_s))
            self.stream.log("events", rr.TextLog(f"[{event.kind}] {event.text}",
                                                 level=event_level(event)))
            self._n_events += 1


def write_recording(series: FlightSeries, stream: rr.RecordingStream,
                    config: RecordingConfig | None = None, *,
                    waypoints_ned: Sequence[tuple[int, Sequence[float]]] = ()) -> None:
    """Log a whole flight to ``stream`` (in ``flush_s`` chunks, as a live stream would)."""
    recorder = SeriesRecorder(stream, config, waypoints_ned=waypoints_ned)
    step = recorder.config.flush_s
    end = float(series.time_s[-1]) if len(series.time_s) else 0.0
    t = float(series.time_s[0]) if len(series.time_s) else 0.0
    while t < end:
        t += step
        recorder.send(series, until_s=t)
    recorder.send(series)
    stream.flush()


class LiveRecorder:
    """Streams a flight while it is flown: call :meth:`on_clock` as its clock advances.

    Every ``flush_s`` of vehicle time, and at most once per ``min_wall_s`` wall seconds,
    takes the series so far from ``source`` and sends the new rows, keeping back the last
    ``holdback_s`` (a sample's references may still be on their way); :meth:`close` sends
    the rest and flushes.

    Parameters
    ----------
    stream : rerun.RecordingStream
    source : callable
        Returns the flight's :class:`FlightSeries` so far (e.g.
        ``GroundStation.analyzer.series``, or the runner's tick log).
    config : RecordingConfig, optional
    owns_stream : bool
        :meth:`close` also disconnects the stream (closing its file or viewer connection).
    min_wall_s : float
        Wall seconds between two sends, at least (a source that rebuilds its series on each
        call should not be asked too often at a high speed-up).
    waypoints_ned : sequence of (seq, position), optional
        Mission waypoints (:class:`SeriesRecorder`).
    """

    def __init__(self, stream: rr.RecordingStream, source: Callable[[], FlightSeries],
                 config: RecordingConfig | None = None, *, owns_stream: bool = False,
                 min_wall_s: float = 0.5,
                 waypoints_ned: Sequence[tuple[int, Sequence[float]]] = ()) -> None:
        self.recorder = SeriesRecorder(stream, config, waypoints_ned=waypoints_ned)
        self.source = source
        self.owns_stream = owns_stream
        self.min_wall_s = min_wall_s
        self.flushes = 0
        self._next_s: float | None = None
        self._next_wall = -math.inf
        self._closed = False

    def on_clock(self, clock_s: float) -> None:
        """The vehicle clock advanced to ``clock_s`` (s): send when due."""
        if self._closed:
            return
        cfg = self.recorder.config
        if self._next_s is None:
            self._next_s = clock_s + cfg.flush_s
            return
        if clock_s >= self._next_s and time.monotonic() >= self._next_wall:
            self._next_s = clock_s + cfg.flush_s
            self.recorder.send(self.source(), until_s=clock_s - cfg.holdback_s)
            self.flushes += 1
            self._next_wall = time.monotonic() + self.min_wall_s

    def close(self) -> None:
        """Send what is left and flush (idempotent; safe after Ctrl-C)."""
        if self._closed:
            return
        self._closed = True
        self.recorder.send(self.source())
        self.recorder.stream.flush()
        if self.owns_stream:
            self.recorder.stream.disconnect()


def _block_sigint() -> bool:
    """Hold SIGINT back (delivered when unblocked) where the platform allows; True if done."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not \
            threading.main_thread():
        return False
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    return True
