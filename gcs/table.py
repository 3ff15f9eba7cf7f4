"""The thesis table of one flight from telemetry: :class:`FlightReport` and its text form.

:class:`gcs.analysis.FlightAnalyzer` fills it (its module docstring says from which messages
and over which samples); ``ftc-gcs fly`` and ``ftc-gcs report`` print it with
:func:`format_report`, ``--json`` writes :meth:`FlightReport.to_json`, ``--report`` embeds it
in Markdown (:mod:`gcs.report`). Errors are reference minus truth: RMS and maximum of |error|
in x, y, z (m) and roll, pitch, yaw (deg, wrapped to +-180); control effort is the mean over
those samples of the sum of the four motor commands (thesis Table 7.2: 0.0796 at hover).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from flightdata.metrics import ScoredDetection
from flightdata.records import FaultRecord, OutcomeRecord
from flightdata.report import fmt
from flightdata.thesis import AXES

__all__ = ["FlightReport", "Injection", "format_report"]


@dataclass(frozen=True)
class Injection:
    """A loss of effectiveness the vehicle accepted.

    Attributes
    ----------
    motor : int
        1..4.
    loe : float
        Loss of effectiveness now in force (0 clears).
    time_s : float
        Vehicle time at which it took effect, s.
    text : str
        The simulator's STATUSTEXT.
    """

    motor: int
    loe: float
    time_s: float
    text: str


@dataclass
class FlightReport:
    """The thesis-style result of one flight (units: m, deg, PWM, s)."""

    rms: dict[str, float | None]
    max: dict[str, float | None]
    control_effort: float | None
    flight_s: float
    samples: int
    mission_start_s: float | None
    loe: list[dict[str, Any]]
    injections: list[Injection]
    detections: list[ScoredDetection]  # the vehicle's detection records, scored
    crashed: bool  # the outcome is a crash or a fly-away
    vehicle_time_s: float | None
    params: dict[str, float] = field(default_factory=dict)
    outcome: OutcomeRecord | None = None  # the simulator's verdict on the flight
    faults: list[FaultRecord] = field(default_factory=list)  # the simulator's fault records
    # the spin after the loss of a rotor (yaw given up), from ATTITUDE yawspeed: start_s,
    # end_s (vehicle s), yaw_rate_rad_s (mean over its second half), peak_rad_s; None if none
    spin: dict[str, float] | None = None

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (keys as ``ftc-scenario run --json`` where they overlap:
        ``outcome``, ``detections`` and ``faults`` are the same records)."""
        out = {k: v for k, v in asdict(self).items()
               if k not in ("detections", "outcome", "faults")}
        out["injections"] = [asdict(i) for i in self.injections]
        out["detections"] = [d.to_dict() for d in self.detections]
        out["faults"] = [f.to_dict() for f in self.faults]
        out["outcome"] = None if self.outcome is None else self.outcome.to_dict()
        return out


def format_report(report: FlightReport, title: str = "flight") -> str:
    """The table as text: errors, control effort, LOE per motor, detections."""
    lines = []
    start = report.mission_start_s
    head = f"{title}: {report.samples} in-flight samples, {report.flight_s:.2f} s in the air"
    if start is not None:
        head += f", mission started at vehicle t = {start:.2f} s"
    lines.append(head)
    if report.outcome is not None:
        outcome = report.outcome
        lines.append(f"outcome: {outcome.kind.upper()} at {outcome.time_s:.2f} s: "
                     f"{outcome.reason}" + ("" if outcome.safe else
                                            "  (the errors cover the part flown)"))
    config = [f"{k} {report.params[k]:g}" for k in ("ATT_CTRL", "EST_TYPE", "DOB_TYPE")
              if k in report.params]
    if config:
        lines.append("configuration: " + ", ".join(config))
    lines.append(f"{'error':<10}{'RMS':>10}{'max':>10}")
    for axis, unit in AXES:
        lines.append(f"{axis + ' ' + unit:<10}{fmt(report.rms[axis]):>10}"
                     f"{fmt(report.max[axis]):>10}")
    lines.append(f"control effort {fmt(report.control_effort, 5)} (mean sum of the 4 PWM)")
    lines.append(f"{'motor':<7}{'injected':>9}{'at s':>9}{'estimated':>11}{'detected s':>12}"
                 f"{'latency s':>11}")

    def rel(t: float | None) -> str:
        if t is None:
            return "-"
        return f"{t - start:.2f}" if start is not None else f"{t:.2f}"

    for row in report.loe:
        lines.append(f"{row['motor']:<7}{row['injected']:>9.3f}{rel(row['injected_at_s']):>9}"
                     f"{fmt(row['estimated'], 3):>11}{rel(row['detected_at_s']):>12}"
                     f"{fmt(row['latency_s'], 2):>11}")
    if start is not None:
        lines.append("(times in s after the mission start)")
    if report.spin is not None:
        spin = report.spin
        rate = spin["yaw_rate_rad_s"]
        lines.append(f"spin (yaw given up) from {rel(spin['start_s'])} to {rel(spin['end_s'])}: "
                     f"yaw rate {rate:.1f} rad/s ({abs(rate) / (2 * math.pi):.1f} rev/s) over "
                     f"its second half, peak {spin['peak_rad_s']:.1f} rad/s")
    others = [d for d in report.detections if d.motor is None or d.false_alarm]
    for d in others:
        alarm = "  FALSE ALARM" if d.false_alarm else ""
        lines.append(f"detection at {rel(d.time_s)}: {d.text()}{alarm}")
    return "\n".join(lines)
