"""Thesis-style figures of merit of a flight (chapter 7), from a :class:`FlightSeries` or arrays.

Errors are reference minus true state; RMS and maximum absolute value over the samples flown
(m for x, y, z; deg for roll, pitch, yaw, wrapped to +-180). Control effort is the mean of the
sum of the four PWM commands over those samples (thesis Table 7.2 note: 4 x hover PWM =
m g / K = 0.0796 for the Qball-X4). The headless runner (``sim.runner.flight_metrics``), the
chapter-7 report (``sim.thesis_report``) and the ground station's table
(``gcs.analysis.FlightAnalyzer.report``) all compute them here.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from flightdata.geometry import wrap_pi_array
from flightdata.records import DetectionRecord, FaultRecord
from flightdata.series import FlightSeries
from flightdata.thesis import AXES

__all__ = [
    "ATTITUDE_AXES",
    "AXES",
    "POSITION_AXES",
    "ErrorFigure",
    "attitude_rms_norm",
    "control_effort",
    "detection_latency_s",
    "error_figure",
    "fault_response",
    "flying_mask",
    "loe_convergence_times",
    "loe_settled_error",
    "series_metrics",
    "tracking_errors",
]

POSITION_AXES = ("x", "y", "z")  # m
ATTITUDE_AXES = ("roll", "pitch", "yaw")  # deg


@dataclass(frozen=True)
class ErrorFigure:
    """RMS and maximum absolute value of one error channel."""

    rms: float
    max: float


def error_figure(error: np.ndarray) -> ErrorFigure:
    """RMS and max |e| of a sampled error signal (uniform sampling assumed)."""
    e = np.asarray(error, dtype=float)
    return ErrorFigure(rms=float(np.sqrt(np.mean(e * e))), max=float(np.max(np.abs(e))))


def tracking_errors(ref_pos_ned: np.ndarray, pos_ned: np.ndarray, ref_euler_rad: np.ndarray,
                    euler_rad: np.ndarray) -> dict[str, ErrorFigure]:
    """Per-axis error figures: x, y, z in metres, roll, pitch, yaw in degrees.

    Parameters
    ----------
    ref_pos_ned, pos_ned : (n, 3) arrays, m
    ref_euler_rad, euler_rad : (n, 3) arrays, rad
    """
    out: dict[str, ErrorFigure] = {}
    pos_err = np.asarray(ref_pos_ned) - np.asarray(pos_ned)
    att_err = np.degrees(wrap_pi_array(np.asarray(ref_euler_rad) - np.asarray(euler_rad)))
    for i, axis in enumerate(POSITION_AXES):
        out[axis] = error_figure(pos_err[:, i])
    for i, axis in enumerate(ATTITUDE_AXES):
        out[axis] = error_figure(att_err[:, i])
    return out


def control_effort(pwm: np.ndarray) -> float:
    """Time mean of the sum of the four PWM commands, shape (n, 4) uniformly sampled."""
    return float(np.mean(np.sum(np.asarray(pwm, dtype=float), axis=1)))


def flying_mask(flying: np.ndarray) -> np.ndarray:
    """The samples the figures of merit are taken over: the flying ones, or all when none
    flew (a run that never left the ground is judged over all of it)."""
    flying = np.asarray(flying, dtype=bool)
    return flying if np.any(flying) else np.ones_like(flying)


def attitude_rms_norm(rms: Mapping[str, float]) -> float:
    """Combined RMS attitude error sqrt(roll^2 + pitch^2 + yaw^2) of the per-axis RMS, deg."""
    return math.sqrt(rms["roll"] ** 2 + rms["pitch"] ** 2 + rms["yaw"] ** 2)


def loe_convergence_times(series: FlightSeries,
                          tolerance: float = 0.05) -> list[dict[str, Any]]:
    """For each step change of the injected LOE, when the estimate settled within tolerance.

    Judged in free flight only (:attr:`FlightSeries.free_flight`, else the flying samples),
    between take-off and landing: on or near the ground the effectiveness is unobservable
    (the autopilot's detector is gated the same way). Returns one entry per (motor, change):
    motor (1..4), time of the change, injected gamma, and the delay (s) after which
    |estimate - truth| <= tolerance held until the next change or the end of the flight
    (None if it never settled).
    """
    out: list[dict[str, Any]] = []
    window_mask = series.free_flight if series.free_flight is not None else series.flying
    free = np.flatnonzero(window_mask)
    if free.size == 0:
        return out
    window = slice(free[0], free[-1] + 1)
    truth = np.nan_to_num(series.loe_injected[window], nan=1.0)
    estimate = series.loe_estimate_held()[window]
    time_s = series.time_s[window]
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


def loe_settled_error(series: FlightSeries, settle_s: float = 3.0) -> list[float | None]:
    """Per motor, the largest |estimate - truth| of the LOE while flying, once settled.

    Over the flying samples (take-off to touchdown, the landing descent included) except the
    ``settle_s`` seconds after each change of the injected LOE of any motor (the estimator's
    convergence, which :func:`loe_convergence_times` times). A motor locked or hard-over
    (no gamma, NaN truth) counts from its last numeric truth. None for a motor without a
    sample to judge.
    """
    flying = np.asarray(series.flying, dtype=bool)
    truth = np.nan_to_num(series.loe_injected, nan=1.0)
    estimate = series.loe_estimate_held()
    time_s = series.time_s
    changes = np.flatnonzero(np.any(np.abs(np.diff(truth, axis=0)) > 1e-9, axis=1)) + 1
    settled = flying.copy()
    for k in changes:
        settled &= ~((time_s >= time_s[k]) & (time_s < time_s[k] + settle_s))
    out: list[float | None] = []
    for m in range(4):
        error = np.abs(estimate[settled, m] - truth[settled, m])
        error = error[np.isfinite(error)]
        out.append(float(error.max()) if error.size else None)
    return out


def detection_latency_s(time_s: float, motor: int,
                        injections: Iterable[tuple[int, float, float]]) -> float | None:
    """Time from the latest injection on ``motor`` to a detection of it at ``time_s``, s.

    Parameters
    ----------
    time_s : float
        When the fault was reported, s.
    motor : int
        1..4.
    injections : iterable of (motor, loe, time_s)
        The changes of injected loss of effectiveness in time order; clearings (loe 0) and
        later ones do not count. None when no injection on that motor preceded the report.
    """
    before = [t for m, loe, t in injections if m == motor and t <= time_s and loe != 0.0]
    return time_s - before[-1] if before else None


_ACTUATOR_DETECTIONS = ("loe", "motor_lost", "motor_hard_over", "motor_stuck")
_SENSOR_DETECTIONS = ("sensor_rejected", "sensor_frozen", "sensor_inconsistent")


def matching_fault(detection: DetectionRecord, faults: Sequence[FaultRecord]
                   ) -> FaultRecord | None:
    """The latest injected fault that ``detection`` is about, started at or before it: the
    same motor for motor detections, the same sensor for sensor detections, a mass loss for a
    mass change; None when there is none (a false alarm) or the detection is of another kind
    (a crash, a thrust loss)."""
    def about(f: FaultRecord) -> bool:
        if detection.kind in _ACTUATOR_DETECTIONS:
            return f.motor is not None and f.motor == detection.motor
        if detection.kind in _SENSOR_DETECTIONS:
            return f.sensor is not None and f.sensor == detection.sensor
        return detection.kind == "mass_change" and f.kind == "mass_loss"
    started = [f for f in faults
               if f.action == "started" and f.time_s <= detection.time_s + 1e-9 and about(f)]
    return started[-1] if started else None


@dataclass(frozen=True)
class ScoredDetection:
    """A detection with what the injected faults say of it.

    Attributes
    ----------
    record : DetectionRecord
    latency_s : float or None
        Time from the injection it is about to it, s (None: no such injection, or a clearing).
    false_alarm : bool or None
        A fault detection that no injection explains; None for crash and thrust-loss
        reports and for clearings.
    """

    record: DetectionRecord
    latency_s: float | None
    false_alarm: bool | None

    @property
    def motor(self) -> int | None:
        """Motor 1..4 of a motor detection."""
        return self.record.motor

    @property
    def time_s(self) -> float:
        """Simulated time of the decision, s."""
        return self.record.time_s

    @property
    def kind(self) -> str:
        """The detection kind (:data:`flightdata.vocabulary.DETECTION_KINDS`)."""
        return self.record.kind

    @property
    def percent(self) -> float:
        """The estimated magnitude in percent (a loss of effectiveness), rounded."""
        return float(round(100.0 * self.record.magnitude))

    def text(self) -> str:
        """The record's sentence."""
        return self.record.text()

    def to_dict(self) -> dict[str, Any]:
        """The record's JSON form plus ``latency_s`` and ``false_alarm``."""
        return {**self.record.to_dict(), "latency_s": self.latency_s,
                "false_alarm": self.false_alarm}


def score_detection(detection: DetectionRecord, faults: Sequence[FaultRecord]
                    ) -> ScoredDetection:
    """``detection`` scored against the injected ``faults`` (:class:`ScoredDetection`)."""
    fault = matching_fault(detection, faults) if detection.action == "detected" else None
    fault_kind = detection.kind in (*_ACTUATOR_DETECTIONS, *_SENSOR_DETECTIONS, "mass_change")
    false_alarm = (fault is None) if (detection.action == "detected" and fault_kind) else None
    return ScoredDetection(detection, None if fault is None else
                           detection.time_s - fault.time_s, false_alarm)


def detection_rows(detections: Sequence[DetectionRecord], faults: Sequence[FaultRecord]
                   ) -> list[dict[str, Any]]:
    """The detections as JSON rows (:meth:`ScoredDetection.to_dict`)."""
    return [score_detection(d, faults).to_dict() for d in detections]


def series_metrics(series: FlightSeries, loop_rate_hz: float) -> dict[str, Any]:
    """The errors, control effort, time flown and LOE figures of one run (m, deg, PWM, s).

    Over the flying samples (:func:`flying_mask`), the motor commands held on them. The
    headless runner's ``--json`` metrics (``sim.runner.flight_metrics``) are these plus the
    run's identity, events and outcome.
    """
    flying = flying_mask(series.flying)
    errs = tracking_errors(series.ref_pos_ned[flying], series.pos_ned[flying],
                           series.ref_euler_rad[flying], series.euler_rad[flying])
    loe_final = [float(est[-1]) if len(est) else math.nan for est in series.loe_estimate]
    times = series.time_s[flying]
    return {
        # the samples the errors and the effort are taken over
        "window": {"start_s": float(times[0]) if len(times) else None,
                   "end_s": float(times[-1]) if len(times) else None,
                   "samples": int(len(times))},
        "rms": {axis: fig.rms for axis, fig in errs.items()},
        "max": {axis: fig.max for axis, fig in errs.items()},
        "control_effort": control_effort(series.pwm_held(series.time_s[flying])),
        "flight_s": float(np.count_nonzero(series.flying)) / loop_rate_hz,
        "loe_estimate": {
            "final": loe_final,
            "true_final": [float(v) for v in np.nan_to_num(series.loe_injected[-1],
                                                           nan=-1.0)],
            "convergence": loe_convergence_times(series),
            # per motor, the largest error while flying, 3 s after any change of the truth
            "settled_error_max": loe_settled_error(series),
        },
    }


MOTOR_DETECTIONS = ("loe", "motor_lost", "motor_hard_over", "motor_stuck")
"""Detection kinds that name a motor."""


def flight_phase(climb_m_s: float, ground_speed_m_s: float) -> str:
    """The phase of flight of a vehicle climbing at ``climb_m_s`` (m/s, + up) and moving at
    ``ground_speed_m_s`` (m/s, horizontal): ``"climb"`` or ``"descent"`` beyond 0.5 m/s
    vertically, else ``"cruise"`` beyond 1 m/s horizontally, else ``"hover"``."""
    if climb_m_s > 0.5:
        return "climb"
    if climb_m_s < -0.5:
        return "descent"
    return "cruise" if ground_speed_m_s > 1.0 else "hover"


TRANSIENT_S = 3.0
"""s after an actuator fault: the transient whose height loss :func:`fault_response` reports
(the spin of a relaxed hover builds up to 90 % in about that)."""


def fault_response(series: FlightSeries, faults: Sequence[FaultRecord],
                   detections: Sequence[DetectionRecord]) -> dict[str, Any] | None:
    """How the vehicle met the first actuator fault that started (None: none started).

    From simulator truth: where and how it flew when the fault struck (altitude m, climb
    and ground speed m/s, :func:`flight_phase`), the largest horizontal distance from that
    point afterwards (``excursion_m``), the horizontal distance from it at the end of the
    log (``end_from_fault_m``) and the height lost within ``TRANSIENT_S`` of it
    (``alt_lost_m``: the fault's height less the lowest point, m); from the autopilot's
    records, the motor its first motor detection named and whether a motor without an
    injected fault of its own was declared lost.
    """
    started = [f for f in faults if f.action == "started" and f.motor is not None]
    if not started:
        return None
    fault = started[0]
    t = series.time_s
    i = min(int(np.searchsorted(t, fault.time_s)), len(t) - 1)
    pos = series.pos_ned
    j = max(i - 1, 0)
    dt = float(t[i] - t[j]) if i > j else 1.0
    vel = (pos[i] - pos[j]) / dt
    after = np.hypot(pos[i:, 0] - pos[i, 0], pos[i:, 1] - pos[i, 1])
    # the height the transient costs: the lowest point within TRANSIENT_S of the fault
    k = int(np.searchsorted(t, fault.time_s + TRANSIENT_S))
    alt_lost = float(np.max(pos[i:max(k, i + 1), 2]) - pos[i, 2])
    faulted = {f.motor for f in started}  # motors with an injected fault of their own
    named = [d for d in detections
             if d.action == "detected" and d.kind in MOTOR_DETECTIONS and d.motor is not None
             and d.time_s >= fault.time_s]
    return {
        "motor": fault.motor, "kind": fault.kind, "time_s": fault.time_s,
        "alt_m": float(-pos[i, 2]), "climb_m_s": float(-vel[2]),
        "ground_speed_m_s": float(np.hypot(vel[0], vel[1])),
        "phase": flight_phase(float(-vel[2]), float(np.hypot(vel[0], vel[1]))),
        "excursion_m": float(after.max()), "end_from_fault_m": float(after[-1]),
        "alt_lost_m": alt_lost,
        "named_motor": named[0].motor if named else None,
        "named_kind": named[0].kind if named else None,
        "other_motor_lost": any(d.kind == "motor_lost" and d.motor not in faulted
                                for d in named),
    }
