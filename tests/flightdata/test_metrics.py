"""Figures of merit (:mod:`flightdata.metrics`), the series they read
(:mod:`flightdata.series`) and the Markdown helpers (:mod:`flightdata.report`), on synthetic
series with known answers. The runner's and the ground station's use of them is checked in
tests/sim/test_scenario.py, tests/gcs/test_gcs_analysis.py and the integration tests."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from flightdata.metrics import (
    attitude_rms_norm,
    control_effort,
    detection_latency_s,
    error_figure,
    fault_response,
    flying_mask,
    loe_convergence_times,
    series_metrics,
    tracking_errors,
)
from flightdata.records import DetectionRecord, FaultRecord
from flightdata.report import fmt, image_lines, relative_paths, section_lines, table_lines
from flightdata.series import FlightSeries

HOVER_PWM = 0.0796 / 4  # per motor: 4 x hover PWM = m g / K (thesis Table 7.2 note)


def hover_series(n: int = 1000, rate_hz: float = 100.0) -> FlightSeries:
    """n ticks of hover with a square-wave north error of +-2 mm and a 1 deg roll error;
    motor 2 loses 30 % at tick 400 and the estimate follows 0.2 s later."""
    t = np.arange(1, n + 1) / rate_hz
    pos = np.zeros((n, 3))
    pos[:, 2] = -0.6
    ref = pos.copy()
    ref[:, 0] = np.where(np.arange(n) % 2 == 0, 0.002, -0.002)
    euler = np.zeros((n, 3))
    ref_euler = euler.copy()
    ref_euler[:, 0] = math.radians(1.0)
    injected = np.zeros((n, 4))
    injected[400:, 1] = 0.3
    estimate = np.zeros((n, 4))
    estimate[420:, 1] = 0.3
    flying = np.ones(n, dtype=bool)
    flying[:10] = False  # on the ground first
    return FlightSeries(
        time_s=t, flying=flying, pos_ned=pos, euler_rad=euler, ref_pos_ned=ref,
        ref_euler_rad=ref_euler, pwm_time_s=t, pwm=np.full((n, 4), HOVER_PWM), pwm_max=0.05,
        loe_estimate_time_s=(t,) * 4, loe_estimate=tuple(estimate[:, j] for j in range(4)),
        loe_injected=injected, free_flight=flying.copy())


def test_error_figure_of_a_square_wave() -> None:
    fig = error_figure(np.array([0.002, -0.002] * 50))
    assert fig.rms == pytest.approx(0.002, rel=1e-12) and fig.max == 0.002


def test_tracking_errors_wrap_attitude_across_the_seam() -> None:
    n = 10
    zeros = np.zeros((n, 3))
    ref_euler = np.tile([0.0, 0.0, math.radians(179.0)], (n, 1))
    euler = np.tile([0.0, 0.0, math.radians(-179.0)], (n, 1))
    errs = tracking_errors(zeros, zeros, ref_euler, euler)
    assert errs["yaw"].rms == pytest.approx(2.0, rel=1e-9)  # not 358 deg
    assert errs["x"].rms == errs["roll"].max == 0.0


def test_series_metrics_of_a_hover() -> None:
    s = hover_series()
    m = series_metrics(s, loop_rate_hz=100.0)
    assert m["rms"]["x"] == pytest.approx(0.002, rel=1e-12)
    assert m["rms"]["roll"] == pytest.approx(1.0, rel=1e-12)
    assert m["max"]["y"] == 0.0
    assert m["control_effort"] == pytest.approx(0.0796, rel=1e-12)
    assert m["flight_s"] == pytest.approx(9.9)  # 990 flying ticks at 100 Hz
    assert m["loe_estimate"]["final"] == [0.0, 0.3, 0.0, 0.0]
    assert m["loe_estimate"]["true_final"] == [0.0, 0.3, 0.0, 0.0]
    [conv] = m["loe_estimate"]["convergence"]
    assert (conv["motor"], conv["time_s"], conv["loe"]) == (2, pytest.approx(4.01), 0.3)
    assert conv["settled_after_s"] == pytest.approx(0.2)


def test_convergence_never_settled_and_nan_truth() -> None:
    s = hover_series()
    late = [e.copy() for e in s.loe_estimate]
    late[1][:] = 0.0  # the estimate never moves
    assert loe_convergence_times(replace(s, loe_estimate=tuple(late)))[0][
        "settled_after_s"] is None
    locked = s.loe_injected.copy()
    locked[400:, 1] = np.nan  # a lock has no gamma: judged against 1 (no thrust change)
    [conv] = loe_convergence_times(replace(s, loe_injected=locked))
    assert conv["loe"] == 1.0 and conv["settled_after_s"] is None


def test_loe_estimates_at_their_own_times_are_held_on_the_samples() -> None:
    s = hover_series()
    ramp = np.linspace(0.0, 0.5, 1000)
    t_est = s.time_s[10::10]  # 10 Hz, the first estimate at tick 10
    held = replace(s, loe_estimate_time_s=(t_est,) * 4,
                   loe_estimate=(ramp[10::10],) * 4).loe_estimate_held()
    assert held.shape == (1000, 4)
    np.testing.assert_array_equal(held[10::10, 0], ramp[10::10])
    assert held[425, 3] == ramp[420] != ramp[425]  # held between estimates
    assert np.all(np.isnan(held[:10]))  # nothing to hold before the first


def test_flying_mask_falls_back_to_every_sample() -> None:
    assert flying_mask(np.array([False, False])).tolist() == [True, True]
    assert flying_mask(np.array([False, True])).tolist() == [False, True]


def test_fault_onsets_from_the_injected_loe_when_unknown() -> None:
    s = hover_series()
    assert s.fault_onsets_s() == [pytest.approx(4.01)]
    assert replace(s, fault_times_s=(3.0,)).fault_onsets_s() == [3.0]


def test_pwm_is_held_and_zero_before_the_first_command() -> None:
    s = replace(hover_series(), pwm_time_s=np.array([1.0, 2.0]),
                pwm=np.array([[0.01] * 4, [0.02] * 4]))
    held = s.pwm_held(np.array([0.5, 1.0, 1.5, 2.5]))
    np.testing.assert_array_equal(held[:, 0], [0.0, 0.01, 0.01, 0.02])


def test_control_effort_and_attitude_norm() -> None:
    assert control_effort(np.full((5, 4), HOVER_PWM)) == pytest.approx(0.0796, rel=1e-12)
    assert attitude_rms_norm({"roll": 3.0, "pitch": 4.0, "yaw": 12.0}) == 13.0


def test_detection_latency_counts_from_the_latest_injection_on_that_motor() -> None:
    injections = [(3, 0.2, 22.0), (1, 0.3, 38.0), (3, 0.0, 40.0), (3, 0.45, 50.0)]
    assert detection_latency_s(22.71, 3, injections) == pytest.approx(0.71)
    assert detection_latency_s(45.0, 3, injections) == pytest.approx(23.0)  # not the clearing
    assert detection_latency_s(50.5, 3, injections) == pytest.approx(0.5)
    assert detection_latency_s(30.0, 2, injections) is None  # a false alarm
    assert detection_latency_s(10.0, 3, injections) is None  # before any injection


def test_markdown_tables_and_numbers() -> None:
    assert fmt(None) == "-" and fmt(0.123456) == "0.1235" and fmt(1.0, 2) == "1.00"
    assert table_lines(("a", "b", "c"), [["x", "1", ""]], "lrr") == [
        "| a | b | c |", "|---|---:|---:|", "| x | 1 | |"]
    with pytest.raises(ValueError, match="align"):
        table_lines(("a", "b"), [], "l")


def test_figures_are_embedded_by_relative_path(tmp_path: Path) -> None:
    written = {"xyz": [tmp_path / "f" / "xyz.png", tmp_path / "f" / "xyz.pdf"],
               "pwm": [tmp_path / "f" / "pwm.png"]}
    rel = relative_paths(written, tmp_path)
    assert rel == {"xyz": ["f/xyz.png", "f/xyz.pdf"], "pwm": ["f/pwm.png"]}
    # registry order (pwm after xyz), captions from the registry
    assert image_lines(rel, alt_prefix="run: ") == [
        "![run: X, Y, Z and errors (Fig. 7.4-7.6)](f/xyz.png)",
        "![run: motor PWM (Fig. 7.9)](f/pwm.png)", "", "PDF: [xyz](f/xyz.pdf)", ""]
    assert image_lines({}) == []
    assert section_lines(rel) == [
        "## X, Y, Z and errors (Fig. 7.4-7.6)", "",
        "![X, Y, Z and errors (Fig. 7.4-7.6)](f/xyz.png)", "", "PDF: [xyz](f/xyz.pdf)", "",
        "## motor PWM (Fig. 7.9)", "", "![motor PWM (Fig. 7.9)](f/pwm.png)", ""]


def test_fault_response_reports_where_the_fault_struck_and_what_it_cost() -> None:
    """A hover at 0.6 m that, after a loss at 4 s, drops 0.25 m and drifts 1.5 m north
    within 3 s, then climbs back and drifts further: the height lost counts the transient
    only, the excursion the whole flight after the fault."""
    s = hover_series()
    pos = s.pos_ned.copy()
    t = s.time_s
    after = t >= 4.0
    dt = t - 4.0
    pos[after, 2] = -0.6 + 0.25 * np.sin(np.pi * np.clip(dt[after], 0.0, 2.0) / 4.0)
    pos[after, 0] = 1.5 * np.clip(dt[after] / 2.0, 0.0, 1.0) + 0.5 * (dt[after] > 5.0)
    s = replace(s, pos_ned=pos)
    fault = FaultRecord(time_s=4.0, action="started", kind="total_loss", motor=2)
    found = DetectionRecord(time_s=4.04, action="detected", kind="motor_lost", motor=2,
                            magnitude=1.0)
    r = fault_response(s, [fault], [found])
    assert r is not None
    assert r["phase"] == "hover" and r["alt_m"] == pytest.approx(0.6)
    assert r["alt_lost_m"] == pytest.approx(0.25, abs=1e-3)  # the sine's top at 2 s
    assert r["excursion_m"] == pytest.approx(2.0) and r["end_from_fault_m"] == pytest.approx(2.0)
    assert r["named_motor"] == 2 and not r["other_motor_lost"]
    assert fault_response(s, [], []) is None
    # a second injected loss declared is no other motor's; a motor without a fault is
    second = FaultRecord(time_s=4.5, action="started", kind="total_loss", motor=1)
    second_found = DetectionRecord(time_s=4.55, action="detected", kind="motor_lost", motor=1,
                                   magnitude=1.0)
    r = fault_response(s, [fault, second], [found, second_found])
    assert r is not None and not r["other_motor_lost"]
    r = fault_response(s, [fault], [found, second_found])
    assert r is not None and r["other_motor_lost"]
