"""A campaign's results without flying: metrics as rows, the Parquet store, the report."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest

from flightdata.config import ConfigError
from flightdata.metrics import detection_rows
from flightdata.records import DetectionRecord, FaultRecord
from sim.campaign.report import write_report
from sim.campaign.rows import METRIC_GROUPS, columns, metric_columns
from sim.campaign.store import RUNS_DIR, ResultStore, finished_runs, read_rows


def _metrics() -> dict[str, Any]:
    """Runner metrics of a made-up flight: three faults, four detections, one false."""
    faults = [FaultRecord(time_s=5.0, action="started", kind="loe", motor=1, magnitude=0.25,
                          fault_id=1),
              FaultRecord(time_s=8.0, action="started", kind="loe", motor=3, magnitude=0.2,
                          fault_id=2),
              FaultRecord(time_s=9.0, action="started", kind="bias", sensor="baro",
                          magnitude=0.1, fault_id=3)]
    detections = [DetectionRecord(time_s=5.3, action="detected", kind="loe", motor=1,
                                  magnitude=0.24),
                  DetectionRecord(time_s=6.0, action="detected", kind="loe", motor=1,
                                  magnitude=0.26),
                  DetectionRecord(time_s=7.0, action="detected", kind="loe", motor=2,
                                  magnitude=0.1),
                  DetectionRecord(time_s=8.5, action="detected", kind="loe", motor=3,
                                  magnitude=0.2),
                  DetectionRecord(time_s=12.0, action="detected", kind="crash")]
    axes = ("x", "y", "z", "roll", "pitch", "yaw")
    return {
        "name": "made_up", "seed": 1, "sim_s": 20.0, "wall_s": 2.5, "flight_s": 14.0,
        "outcome": {"record": "outcome", "kind": "crashed", "time_s": 12.0, "reason": "fell",
                    "cause": "impact_speed", "impact_speed_m_s": 2.0, "tilt_deg": 10.0,
                    "distance_m": 0.5},
        "window": {"start_s": 0.2, "end_s": 12.0, "samples": 1181},
        "rms": {a: 0.01 * (i + 1) for i, a in enumerate(axes)},
        "max": {a: 0.1 * (i + 1) for i, a in enumerate(axes)},
        "control_effort": 0.081,
        "loe_estimate": {"final": [0.3, 0.01, 0.0, 0.02], "true_final": [0.25, 0.0, -1.0, 0.0],
                         "convergence": [], "settled_error_max": [0.05, 0.01, None, 0.02]},
        "detections": detection_rows(detections, faults),
        "faults": [f.to_dict() for f in faults],
    }


def test_metric_columns_score_each_fault_of_the_run() -> None:
    row = metric_columns(json.loads(json.dumps(_metrics())), n_faults=4, own_fault=2)
    assert row["outcome"] == "crashed" and row["outcome_time_s"] == 12.0
    assert row["rms_pitch"] == 0.05 and row["max_yaw"] == pytest.approx(0.6)
    # fault 1: first motor-1 detection (5.3 s), not the repeat; fault 2: 8.5 s; fault 3 never
    assert row["fault1_latency_s"] == pytest.approx(0.3)
    assert row["fault2_latency_s"] == pytest.approx(0.5)
    assert row["fault3_latency_s"] is None and row["fault4_latency_s"] is None
    assert row["fault_latency_s"] == row["fault2_latency_s"]
    # the crash report is not a fault detection; motor 2 is explained by no injection
    assert (row["detections"], row["false_alarms"], row["first_false_alarm_s"]) == (4, 1, 7.0)
    assert (row["faults_started"], row["faults_detected"]) == (3, 2)
    # final error over motors with a numeric truth (motor 3's -1 = locked is skipped)
    assert row["loe_final_error_max"] == pytest.approx(0.05)
    assert row["loe_settled_error_max"] == 0.05 and row["loe_settled_error_m3"] is None


def test_columns_follow_the_kept_groups() -> None:
    names = [n for n, _ in columns(("outcome",), 2)]
    assert "outcome" in names and "rms_x" not in names and "fault1_latency_s" not in names
    every = [n for n, _ in columns(METRIC_GROUPS, 2)]
    assert {"rms_x", "control_effort", "fault2_latency_s", "loe_settled_error_m4",
            "wall_s"} <= set(every)
    assert len(every) == len(set(every))


def _row(index: int, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys((n for n, _ in columns(METRIC_GROUPS, 1)))
    row.update(run_id=f"r{index:03d}", index=index, campaign="t", status="ok", seed=1,
               fault_kind="loe", fault_motor=1, fault_start_s=30.0, wind="indoor",
               attitude="lqg", estimator="ekf", dob="abdob", height_source="mocap",
               outcome="landed", detections=1, false_alarms=0, faults_started=1,
               faults_detected=1, fault1_latency_s=0.3, loe_settled_error_max=0.02,
               loe_final_error_max=0.03, max_z=0.05, rms_z=0.01, rms_x=0.004)
    row.update(values)
    return row


def test_store_appends_whole_parts_and_the_later_row_wins(tmp_path: Path) -> None:
    cols = columns(METRIC_GROUPS, 1)
    with ResultStore(tmp_path, cols, flush_s=math.inf) as store:
        store.add(_row(0))  # the first row is written at once
        store.add(_row(1, status="error", error="ValueError: boom", outcome=None))
        assert len(list((tmp_path / RUNS_DIR).glob("part-*.parquet"))) == 1
        assert [r["run_id"] for r in read_rows(tmp_path)] == ["r000"]
    rows = read_rows(tmp_path)
    assert [r["status"] for r in rows] == ["ok", "error"]
    assert rows[1]["error"] == "ValueError: boom" and rows[1]["rms_y"] is None
    with ResultStore(tmp_path, cols) as store:  # a retried run replaces its error row
        store.add(_row(1, outcome="crashed"))
    parts = list((tmp_path / RUNS_DIR).glob("part-*.parquet"))
    assert len(parts) == 1  # merged when the store closed
    assert pq.read_table(parts[0]).num_rows == 2
    assert [(r["status"], r["outcome"]) for r in read_rows(tmp_path)] == [
        ("ok", "landed"), ("ok", "crashed")]


def test_one_writer_per_directory(tmp_path: Path) -> None:
    cols = columns(("outcome",), 0)
    with ResultStore(tmp_path, cols), pytest.raises(ConfigError, match="another ftc-campaign"):
        with ResultStore(tmp_path, cols):
            pass


def _manifest(out: Path, rows: list[dict[str, Any]], swept: list[str]) -> None:
    axes = ("seed", "fault_kind", "fault_motor", "fault_sensor", "fault_magnitude",
            "fault_start_s", "fault_profile", "wind", "attitude", "estimator", "dob", "ftc",
            "height_source")
    out.mkdir(parents=True, exist_ok=True)
    (out / "campaign.json").write_text(json.dumps({
        "campaign": "t", "description": "made-up rows", "source": "", "scenario": "x",
        "base_faults": "drop", "swept": swept, "metrics": list(METRIC_GROUPS), "n_faults": 1,
        "runs": [{"run_id": r["run_id"], "index": r["index"], "own_fault": 1,
                  **{a: r[a] for a in axes}} for r in rows]}))


def test_report_tables_envelope_and_active_against_passive(tmp_path: Path) -> None:
    rows = []
    for mode in ("passive", "active"):
        for magnitude, passive_outcome in ((0.2, "landed"), (0.4, "airborne"),
                                           (0.6, "crashed")):
            for motor in (1, 2):
                outcome = passive_outcome if mode == "passive" else "landed"
                rows.append(_row(len(rows), ftc=mode, fault_magnitude=magnitude,
                                 fault_motor=motor, outcome=outcome,
                                 false_alarms=1 if motor == 2 else 0))
    rows.append(_row(len(rows), ftc="active", fault_magnitude=0.8, status="error",
                     error="ConfigError: mass | too large\ntraceback", outcome=None))
    _manifest(tmp_path, rows, ["fault.magnitude", "fault.motor", "autopilot.ftc"])
    with ResultStore(tmp_path, columns(METRIC_GROUPS, 1)) as store:
        for row in rows:
            store.add(row)
    text = write_report(tmp_path).read_text()
    lines = text.splitlines()
    assert "| ftc = passive | 6 | 2 | 2 | 2 | 0 | 0 | 67 % |" in lines
    assert "| ftc = active | 7 | 6 | 0 | 0 | 0 | 1 | 86 % |" in lines
    # passive: every run survived up to 40 %, 60 % failed; active: only the error failed
    assert "| ftc = passive | 40.0 | 60.0 |" in lines
    assert "| ftc = active | 60.0 | 80.0 |" in lines
    assert "6 runs were flown both ways (every other axis and the seed equal)." in lines
    assert "| survived | 67 % | 100 % |" in lines
    assert "| ftc = passive | 6 | 6 | 0.30 | 0.30 | 0.30 | 3 | 3 of 6 |" in lines
    assert any(line.startswith("| `r012` |") and "ConfigError: mass \\| too large |" in line
               for line in lines)
    for name in ("envelope", "latency", "false_alarms", "estimate_error", "active_passive"):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 1000
        assert f"(figures/{name}.png)" in text


def test_report_response_by_phase_and_kind(tmp_path: Path) -> None:
    rows = []
    for phase, kind, outcome, speed, excursion, named in (
            ("climb", "total_loss", "landed", 0.3, 1.0, 1),
            ("climb", "total_loss", "landed", 1.4, 3.0, 1),  # too hard: not soft
            ("cruise", "total_loss", "flyaway", None, 40.0, 1),
            ("cruise", "hardover", "crashed", 6.0, 5.0, 2),
            ("hover", "total_loss", "flyaway", None, 3.0, 1),  # back: 1.5 m from the fault
            ("hover", "total_loss", "flyaway", None, 8.0, 1)):  # 4 m from it
        rows.append(_row(len(rows), fault_kind=kind, fault_phase=phase, outcome=outcome,
                         impact_speed_m_s=speed, tilt_deg=10.0, excursion_m=excursion,
                         end_from_fault_m=0.5 * excursion, named_motor=named,
                         other_motor_lost=int(named != 1)))
    _manifest(tmp_path, rows, ["fault.kind", "fault.start_s"])
    with ResultStore(tmp_path, columns(METRIC_GROUPS, 1)) as store:
        for row in rows:
            store.add(row)
    lines = write_report(tmp_path).read_text().splitlines()
    assert "## Response to the fault" in lines
    assert ("| fault_phase = climb, fault_kind = total_loss | 2 | 100 % | 50 % | 2.0 | 3.0 "
            "| 1.0 | 100 % | 0 | - |") in lines
    assert ("| fault_phase = cruise, fault_kind = hardover | 1 | 0 % | 0 % | 5.0 | 5.0 | - "
            "| 0 % | 1 | - |") in lines
    assert ("| fault_phase = cruise, fault_kind = total_loss | 1 | 0 % | 0 % | 40.0 | 40.0 "
            "| - | 100 % | 0 | 0 of 1 |") in lines
    assert ("| fault_phase = hover, fault_kind = total_loss | 2 | 0 % | 0 % | 5.5 | 8.0 "
            "| - | 100 % | 0 | 1 of 2 |") in lines
    assert (tmp_path / "figures" / "excursion.png").stat().st_size > 1000


def test_report_of_a_directory_without_a_campaign_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="holds no campaign"):
        write_report(tmp_path)


def test_rows_without_the_kept_columns_do_not_count_as_finished(tmp_path: Path) -> None:
    with ResultStore(tmp_path, columns(("outcome",), 0)) as store:
        store.add({"run_id": "a", "index": 0, "status": "ok", "outcome": "landed"})
    every = [name for name, _ in columns(METRIC_GROUPS, 0)]
    assert finished_runs(tmp_path) == {"a"}
    assert finished_runs(tmp_path, required=every) == set()
