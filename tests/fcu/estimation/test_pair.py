"""The EKF and the TSKF stepped together (fcu.estimation.pair) against each stepped alone."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.pair import step_pair
from fcu.estimation.state import group_samples
from fcu.estimation.tskf import TwoStageKalmanFilter
from flightdata.vocabulary import BATTERY_SENSOR
from sim.scenario import load_scenario


def test_the_pair_steps_both_filters_bit_for_bit_as_each_alone(
        takeoff_ticks: Callable[..., list[tuple[float, np.ndarray, Any]]]) -> None:
    ticks = takeoff_ticks(250, seed=7)
    config = load_scenario("lqg_abdob_loe").autopilot
    model, dt_s = config.model, 1.0 / config.loop_rate_hz
    alone = (ExtendedKalmanEstimator(model, dt_s), TwoStageKalmanFilter(model, dt_s))
    paired = (ExtendedKalmanEstimator(model, dt_s), TwoStageKalmanFilter(model, dt_s))
    kinds = alone[0].sensor_kinds | alone[1].sensor_kinds | {BATTERY_SENSOR}
    checked = {"excluded": 0, "baro": 0}
    for k, (time_s, pwm, samples) in enumerate(ticks):
        # exclusions, the rejection flag and the height source change along the flight
        excluded = frozenset({"gyro"}) if 100 <= k < 140 else frozenset()
        reject = k % 3 != 0
        source = "baro" if 150 <= k < 200 else "mocap"
        for ekf, tskf in (alone, paired):
            ekf.height_source = tskf.height_source = source
        grouped_alone = group_samples(samples, kinds)
        grouped_alone.pop_value(BATTERY_SENSOR)
        alone[1].advance_grouped(time_s, pwm, grouped_alone, excluded=excluded, reject=reject)
        est_alone = alone[0].step_grouped(time_s, pwm, grouped_alone, excluded=excluded,
                                          reject=reject)
        grouped_paired = group_samples(samples, kinds)
        grouped_paired.pop_value(BATTERY_SENSOR)
        est_paired = step_pair(paired[0], paired[1], time_s, pwm, grouped_paired,
                               excluded=excluded, reject=reject)
        assert est_paired is paired[0].estimate
        for a, b in zip(alone, paired, strict=True):
            ea, eb = a.estimate, b.estimate
            assert ea.time_s == eb.time_s
            assert np.array_equal(ea.to_vector(), eb.to_vector())
            assert np.array_equal(ea.covariance_diag, eb.covariance_diag)
            assert [(s, c.status, c.nis) for s, c in a.screening.items()] == \
                [(s, c.status, c.nis) for s, c in b.screening.items()]
            for (_, ca), (_, cb) in zip(a.screening.items(), b.screening.items(),
                                          strict=True):
                assert np.array_equal(ca.residual, cb.residual)
                assert np.array_equal(ca.variance, cb.variance)
            checked["excluded"] += sum(c.status == "excluded" for c in b.screening.values())
            checked["baro"] += "baro" in b.screening
        assert np.array_equal(est_alone.to_vector(), est_paired.to_vector())
        assert np.array_equal(alone[1].gamma_raw, paired[1].gamma_raw)
        assert alone[1].on_ground == paired[1].on_ground
        assert alone[0].on_ground == paired[0].on_ground
        assert np.array_equal(alone[1].x_bar, paired[1].x_bar)
        assert np.array_equal(alone[1].P_gamma, paired[1].P_gamma)
        assert np.array_equal(alone[0].P, paired[0].P)
        innovations = alone[0].last_innovation, paired[0].last_innovation
        assert innovations[0].keys() == innovations[1].keys()
        for sensor, inn in innovations[0].items():
            assert np.array_equal(inn.residual, innovations[1][sensor].residual)
            assert inn.nis == innovations[1][sensor].nis
    # the flight went through what it was meant to: exclusions, the baro channel
    assert checked["excluded"] > 0 and checked["baro"] > 0
    assert not paired[0].on_ground  # it took off


def test_the_pair_checks_both_times_before_stepping() -> None:
    model = load_scenario("lqg_abdob_loe").autopilot.model
    ekf, tskf = ExtendedKalmanEstimator(model, 0.01), TwoStageKalmanFilter(model, 0.01)
    step_pair(ekf, tskf, 0.01, np.zeros(4), group_samples([]))
    before = ekf.x, tskf.x_bar
    try:
        step_pair(ekf, tskf, 0.015, np.zeros(4), group_samples([]))  # half a TSKF step
    except ValueError as err:
        assert "whole multiples of dt_s" in str(err)
    else:
        raise AssertionError("a time between the TSKF's steps was taken")
    assert np.array_equal(ekf.x, before[0]) and np.array_equal(tskf.x_bar, before[1])
    assert ekf.time_s == tskf.time_s == 0.01


def test_the_filters_buffers_keep_their_row_updated_matrices_on_cache_lines() -> None:
    # 64-byte buffers, and every matrix the kernels update by whole 16-entry rows (P, the
    # priors, F, Q, the scratch) at a multiple of 8 entries: no vector access straddles two
    # cache lines (jitsupport.layout.aligned_zeros)
    from fcu.estimation import ekf as ekf_module
    from fcu.estimation import tskf_kernel as tskf_module

    model = load_scenario("lqg_abdob_loe").autopilot.model
    for estimator in (ExtendedKalmanEstimator(model), TwoStageKalmanFilter(model)):
        assert estimator._buf.ctypes.data % 64 == 0
    offsets = [ekf_module.B_SCRATCH, ekf_module._P, ekf_module._P_PRIOR, ekf_module._F,
               ekf_module._Q, ekf_module._SC_UPDATE, ekf_module._SC_JAC, tskf_module.B_SCRATCH,
               tskf_module.W_P_X, tskf_module.W_PRIOR + tskf_module.W_P_X, tskf_module.SC_UPDATE,
               tskf_module.SC_P_HAT]
    assert all(at % 8 == 0 for at in offsets)
