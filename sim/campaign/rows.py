"""One run's metrics as one flat row: the columns of a campaign's results.

Every row has the identity columns (``run_id``, ``index``, ``campaign``, ``status`` "ok" or
"error", ``error``), the axis columns of :mod:`sim.campaign.axes`, and the columns of the
metric groups the campaign keeps, all computed from the headless runner's metrics
(:func:`sim.runner.flight_metrics`, the same dict ``ftc-scenario run --json`` writes):

==============  ===========================================================================
group           columns (units)
==============  ===========================================================================
``outcome``     ``outcome`` (landed | crashed | flyaway | airborne), ``outcome_time_s`` (s),
                ``outcome_reason``, ``outcome_cause``, ``impact_speed_m_s`` (m/s),
                ``tilt_deg`` (deg), ``distance_m`` (m): :mod:`sim.outcome`
``tracking``    ``rms_<axis>`` and ``max_<axis>`` for x, y, z (m) and roll, pitch, yaw (deg);
                ``window_start_s``, ``window_end_s`` (s, the samples they cover),
                ``flight_s`` (s flown)
``effort``      ``control_effort`` (mean sum of the four PWM commands)
``detection``   ``detections`` (fault detections made), ``false_alarms`` (those no injection
                explains), ``first_false_alarm_s`` (s), ``faults_started``,
                ``faults_detected``; ``fault<k>_latency_s`` (s) from the start of the run's
                k-th fault (scenario order, the base scenario's first) to its first
                detection, None when never detected; ``fault_latency_s``: the same for the
                campaign's own fault
``estimate``    ``loe_final_error_max`` (largest |estimated - injected| loss of effectiveness
                at the end, over motors), ``loe_settled_error_max`` and
                ``loe_settled_error_m1`` .. ``_m4`` (the largest while flying, 3 s after each
                change: :func:`flightdata.metrics.loe_settled_error`)
``response``    how the vehicle met the first actuator fault (:func:`flightdata.metrics.
                fault_response`): ``fault_phase`` (climb | cruise | descent | hover),
                ``fault_alt_m`` (m), ``fault_climb_m_s``, ``fault_ground_speed_m_s`` (m/s)
                when it struck; ``excursion_m`` (largest horizontal distance from that point
                afterwards, m), ``end_from_fault_m`` (m, at the end), ``alt_lost_m``
                (height lost in the 3 s after it, m); ``named_motor`` and
                ``named_kind`` of the first motor detection, ``other_motor_lost`` (1 when
                a motor without an injected fault was declared lost, else 0); all None
                without such a fault
``timing``      ``sim_s`` (s simulated), ``wall_s`` (s of wall clock of the flight),
                ``cpu_s`` (s of CPU time of the run on its worker), ``worker`` (host:pid)
==============  ===========================================================================
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

from flightdata.metrics import matching_fault
from flightdata.records import DetectionRecord, FaultRecord
from flightdata.thesis import AXES as ERROR_AXES
from sim.campaign.axes import AXIS_COLUMNS, COLUMN_AXES

METRIC_GROUPS: tuple[str, ...] = ("outcome", "tracking", "effort", "detection", "estimate",
                                  "response", "timing")
"""The groups of result columns a campaign may keep (``metrics`` in a campaign file)."""

IDENTITY_COLUMNS: tuple[tuple[str, type], ...] = (
    ("run_id", str), ("index", int), ("campaign", str), ("status", str), ("error", str))
"""Columns every row has before the axes: name and type."""

_ERROR_NAMES = tuple(axis for axis, _ in ERROR_AXES)  # x, y, z, roll, pitch, yaw
_GROUP_COLUMNS: dict[str, tuple[tuple[str, type], ...]] = {
    "outcome": (("outcome", str), ("outcome_time_s", float), ("outcome_reason", str),
                ("outcome_cause", str), ("impact_speed_m_s", float), ("tilt_deg", float),
                ("distance_m", float)),
    "tracking": (*((f"rms_{a}", float) for a in _ERROR_NAMES),
                 *((f"max_{a}", float) for a in _ERROR_NAMES),
                 ("window_start_s", float), ("window_end_s", float), ("flight_s", float)),
    "effort": (("control_effort", float),),
    "detection": (("detections", int), ("false_alarms", int), ("first_false_alarm_s", float),
                  ("faults_started", int), ("faults_detected", int),
                  ("fault_latency_s", float)),
    "estimate": (("loe_final_error_max", float), ("loe_settled_error_max", float),
                 *((f"loe_settled_error_m{m}", float) for m in range(1, 5))),
    "response": (("fault_phase", str), ("fault_alt_m", float), ("fault_climb_m_s", float),
                 ("fault_ground_speed_m_s", float), ("excursion_m", float),
                 ("end_from_fault_m", float), ("alt_lost_m", float), ("named_motor", int),
                 ("named_kind", str), ("other_motor_lost", int)),
    "timing": (("sim_s", float), ("wall_s", float), ("cpu_s", float), ("worker", str)),
}
_RESPONSE_KEYS = {"fault_phase": "phase", "fault_alt_m": "alt_m",
                  "fault_climb_m_s": "climb_m_s", "fault_ground_speed_m_s": "ground_speed_m_s",
                  "excursion_m": "excursion_m", "end_from_fault_m": "end_from_fault_m",
                  "alt_lost_m": "alt_lost_m",
                  "named_motor": "named_motor", "named_kind": "named_kind"}


def columns(groups: Sequence[str], n_faults: int) -> list[tuple[str, type]]:
    """The columns of a campaign's rows, in order: identity, axes, then the kept groups
    (``detection`` with one latency column per fault of its largest run)."""
    out = [*IDENTITY_COLUMNS, *((c, COLUMN_AXES[c].kind) for c in AXIS_COLUMNS)]
    for group in METRIC_GROUPS:
        if group in groups:
            out += _GROUP_COLUMNS[group]
            if group == "detection":
                out += [(f"fault{k}_latency_s", float) for k in range(1, n_faults + 1)]
    return out


def _latencies(metrics: Mapping[str, Any]) -> tuple[dict[int, float], int, int, float | None]:
    """Per fault id, the latency of its first detection; detections made, false alarms and
    the time of the first false alarm."""
    faults = [FaultRecord(**_fields(FaultRecord, f)) for f in metrics["faults"]]
    first: dict[int, float] = {}
    made = false = 0
    first_false: float | None = None
    for row in metrics["detections"]:
        if row["action"] != "detected":
            continue
        if row["false_alarm"] is not None:
            made += 1
        if row["false_alarm"]:
            false += 1
            first_false = row["time_s"] if first_false is None else first_false
            continue
        fault = matching_fault(DetectionRecord(**_fields(DetectionRecord, row)), faults)
        if fault is not None and fault.fault_id not in first:
            first[fault.fault_id] = row["time_s"] - fault.time_s
    return first, made, false, first_false


def _fields(cls: type, row: Mapping[str, Any]) -> dict[str, Any]:
    """The dataclass fields of a record's JSON form (None magnitudes back to NaN)."""
    names = {f.name for f in dataclasses.fields(cls)}
    out = {k: v for k, v in row.items() if k in names}
    if out.get("magnitude", 0.0) is None:
        out["magnitude"] = math.nan
    return out


def _max_or_none(values: Sequence[float | None]) -> float | None:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return max(finite) if finite else None


def metric_columns(metrics: Mapping[str, Any], n_faults: int,
                   own_fault: int | None) -> dict[str, Any]:
    """Every group's columns of one run (module docstring).

    Parameters
    ----------
    metrics : mapping
        The runner's metrics of the run (:func:`sim.runner.flight_metrics`, or its JSON).
    n_faults : int
        How many ``fault<k>_latency_s`` columns to fill (the campaign's largest run).
    own_fault : int or None
        1-based position of the campaign's own fault among the run's faults (None: none).
    """
    outcome = metrics["outcome"]
    row: dict[str, Any] = {
        "outcome": outcome["kind"], "outcome_time_s": outcome["time_s"],
        "outcome_reason": outcome["reason"], "outcome_cause": outcome["cause"],
        "impact_speed_m_s": outcome["impact_speed_m_s"], "tilt_deg": outcome["tilt_deg"],
        "distance_m": outcome["distance_m"],
    }
    for axis in _ERROR_NAMES:
        row[f"rms_{axis}"] = metrics["rms"][axis]
        row[f"max_{axis}"] = metrics["max"][axis]
    row["window_start_s"] = metrics["window"]["start_s"]
    row["window_end_s"] = metrics["window"]["end_s"]
    row["flight_s"] = metrics["flight_s"]
    row["control_effort"] = metrics["control_effort"]
    first, made, false, first_false = _latencies(metrics)
    started = {f["fault_id"] for f in metrics["faults"] if f["action"] == "started"}
    row.update(detections=made, false_alarms=false, first_false_alarm_s=first_false,
               faults_started=len(started), faults_detected=len(started & set(first)),
               fault_latency_s=None if own_fault is None else first.get(own_fault))
    for k in range(1, n_faults + 1):
        row[f"fault{k}_latency_s"] = first.get(k)
    loe = metrics["loe_estimate"]
    final_errors = [abs(est - truth) for est, truth in zip(loe["final"], loe["true_final"],
                                                           strict=True)
                    if truth >= 0.0 and math.isfinite(est)]
    row["loe_final_error_max"] = _max_or_none(final_errors)
    settled = loe["settled_error_max"]
    row["loe_settled_error_max"] = _max_or_none(settled)
    for m in range(4):
        row[f"loe_settled_error_m{m + 1}"] = settled[m]
    response = metrics.get("fault_response")
    for column, key in _RESPONSE_KEYS.items():
        row[column] = None if response is None else response[key]
    row["other_motor_lost"] = None if response is None else int(response["other_motor_lost"])
    row["sim_s"] = metrics["sim_s"]
    row["wall_s"] = metrics["wall_s"]
    return row
