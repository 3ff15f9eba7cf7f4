"""Fault engine: each fault changes exactly what it should, at the simulated times it should."""

from __future__ import annotations

import math
import re
import tomllib
from typing import get_args

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightdata.config import ConfigError, from_mapping
from flightdata.vocabulary import ACTUATOR_FAULT_KINDS, LOE_PROFILES, SENSOR_FAULT_KINDS
from sim.world.fault_types import (
    ADDITIVE_KINDS,
    DEFAULT_GARBAGE_RANGE,
    DRAWING_KINDS,
    OVERRIDE_KINDS,
    ActuatorFault,
    ActuatorKind,
    FaultKind,
    FaultProfile,
    LoeProfile,
    SensorFault,
    SensorKind,
    StructuralFault,
    fault_from_mapping,
)
from sim.world.faults import FaultEngine

PWM_MAX = 0.05  # thesis Table 7.1
MASS_KG = 1.42  # thesis Table 7.1
DT = 1.0 / 500.0  # s, plant step
U = np.array([0.021, 0.019, 0.020, 0.018])  # near-hover PWM commands, distinct per motor


def make_engine(seed: int = 0) -> FaultEngine:
    return FaultEngine(np.random.default_rng(seed), PWM_MAX, MASS_KG)


def grid(t0_s: float, t1_s: float) -> np.ndarray:
    """Plant step times k / 500 in [t0, t1), computed as the plant does (k / rate)."""
    return np.arange(round(t0_s * 500), round(t1_s * 500)) / 500.0


# ---------------------------------------------------------------- actuator faults
def test_loe_step_scales_its_motor_only_from_its_start() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=1, kind="loe", loe=0.3, start_s=38.0))
    before = eng.actuator_inputs(37.998, U)
    assert before is U  # no active fault: the command itself, untouched
    out = eng.actuator_inputs(38.0, U)
    assert out[0] == (1.0 - 0.3) * U[0]  # eq. 4.10, exact
    np.testing.assert_array_equal(out[1:], U[1:])
    np.testing.assert_array_equal(U, [0.021, 0.019, 0.020, 0.018])  # input not modified


@given(motor=st.integers(1, 4), gamma=st.floats(0.0, 1.0),
       u=st.lists(st.floats(0.0, PWM_MAX), min_size=4, max_size=4))
@settings(derandomize=True, database=None, max_examples=200)
def test_loe_is_eq_4_10_for_any_motor_gamma_and_command(
        motor: int, gamma: float, u: list[float]) -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=motor, kind="loe", loe=gamma))
    cmd = np.array(u)
    out = eng.actuator_inputs(0.0, cmd)
    expected = cmd.copy()
    expected[motor - 1] = (1.0 - gamma) * cmd[motor - 1]
    np.testing.assert_array_equal(out, expected)


def test_lock_holds_the_command_at_onset() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=2, kind="lock", start_s=1.0))
    eng.actuator_inputs(0.998, U)
    onset = U.copy()
    out = eng.actuator_inputs(1.0, onset)
    assert out[1] == onset[1]
    for k, t in enumerate(grid(1.002, 1.1)):
        cmd = U + 0.001 * (k + 1)  # the autopilot keeps changing every command
        out = eng.actuator_inputs(float(t), cmd)
        assert out[1] == onset[1]
        np.testing.assert_array_equal(out[[0, 2, 3]], cmd[[0, 2, 3]])


@pytest.mark.parametrize(("kind", "expected"),
                         [("float", 0.0), ("hardover", PWM_MAX), ("total_loss", 0.0)])
def test_float_hardover_and_total_loss_set_their_motor(kind: str, expected: float) -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=4, kind=kind, start_s=5.0))  # type: ignore[arg-type]
    for cmd in (U, U * 0.5, np.full(4, PWM_MAX)):
        out = eng.actuator_inputs(5.0, cmd)
        assert out[3] == expected
        np.testing.assert_array_equal(out[:3], cmd[:3])


def test_sinusoid_profile_range_phase_and_period() -> None:
    loe, period = 0.4, 4.0  # Table 6.1 motor 3 amplitude; a period that fits the test
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=3, kind="loe", loe=loe, profile="sinusoid",
                               period_s=period, start_s=2.0))
    times = grid(2.0, 10.0)
    gamma = np.array([eng.true_loe(float(t))[2] for t in times])
    assert gamma[0] == 0.0  # starts from full effectiveness, no jump
    assert gamma.min() >= 0.0
    assert gamma.max() <= loe
    half = round(period / 2 * 500)
    assert gamma[half] == pytest.approx(loe, abs=1e-12)  # peak half a period in; rounding
    steps = round(period * 500)
    # one period later the profile repeats; 1e-9 absorbs rounding of t - t0 near 10 s
    np.testing.assert_allclose(gamma[steps:], gamma[:-steps], atol=1e-9)
    # the motor sees (1 - gamma) u; 1e-12 relative covers 1 - (1 - x) rounding
    out = eng.actuator_inputs(3.0, U)
    assert out[2] == pytest.approx((1.0 - eng.true_loe(3.0)[2]) * U[2], rel=1e-12)


def random_gammas(seed: int, times: np.ndarray) -> np.ndarray:
    eng = make_engine(seed)
    eng.schedule(ActuatorFault(motor=1, kind="loe", loe=0.2, low=0.05, profile="random",
                               hold_s=1.0))
    return np.array([eng.true_loe(float(t))[0] for t in times])


def test_random_profile_bounds_hold_and_seeding() -> None:
    times = grid(0.0, 200.0)
    gamma = random_gammas(7, times)
    assert gamma.min() >= 0.05
    assert gamma.max() <= 0.2
    held = gamma.reshape(200, 500)  # 500 steps per 1 s hold
    assert np.all(held == held[:, :1])  # constant within each hold interval
    assert len(np.unique(held[:, 0])) == 200  # a fresh draw every hold
    # uniform on [0.05, 0.2]: mean 0.125, sd 0.043; 200 draws -> s.e. 0.003, allow 5 s.e.
    assert held[:, 0].mean() == pytest.approx(0.125, abs=0.015)
    np.testing.assert_array_equal(random_gammas(7, times[:5000]), gamma[:5000])
    assert not np.array_equal(random_gammas(8, times[:5000]), gamma[:5000])


def test_random_profile_does_not_depend_on_how_often_it_is_asked() -> None:
    times = grid(0.0, 60.0)
    dense = random_gammas(3, times)
    sparse = make_engine(3)
    sparse.schedule(ActuatorFault(motor=1, kind="loe", loe=0.2, low=0.05, profile="random",
                                  hold_s=1.0))
    sparse.true_loe(0.0)
    k = round(41.3 * 500)
    assert sparse.true_loe(float(times[k]))[0] == dense[k]


def test_pulse_profile_timing() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=2, kind="loe", loe=0.25, profile="pulse", period_s=10.0,
                               pulse_width_s=5.0, start_s=22.0))  # Table 6.1 motor 2
    assert eng.true_loe(21.998)[1] == 0.0
    for t, expected in [(22.0, 0.25), (26.998, 0.25), (27.0, 0.0), (31.998, 0.0),
                        (32.0, 0.25), (36.998, 0.25), (37.0, 0.0)]:
        assert eng.true_loe(t)[1] == expected, t
    times = grid(42.0, 62.0)
    on = np.array([eng.actuator_inputs(float(t), U)[1] for t in times])
    assert set(on.tolist()) == {0.75 * U[1], U[1]}
    assert np.mean(on != U[1]) == 0.5  # 5 s on per 10 s period, exact on the step grid


def test_end_s_restores_and_reports() -> None:
    eng = make_engine()
    fid = eng.schedule(ActuatorFault(motor=1, kind="hardover", start_s=1.0, end_s=2.0))
    assert eng.actuator_inputs(0.998, U) is U
    assert eng.actuator_inputs(1.0, U)[0] == PWM_MAX
    assert eng.actuator_inputs(1.998, U)[0] == PWM_MAX
    assert eng.actuator_inputs(2.0, U) is U
    assert [(e.kind, e.time_s, e.fault_id) for e in eng.events] == [
        ("injected", 0.0, fid), ("started", 1.0, fid), ("ended", 2.0, fid)]
    assert eng.active(2.0) == []


def test_clear_restores() -> None:
    eng = make_engine()
    fid = eng.schedule(ActuatorFault(motor=3, kind="float"))
    assert eng.actuator_inputs(0.0, U)[2] == 0.0
    eng.clear(fid, time_s=0.5)
    assert eng.actuator_inputs(0.502, U) is U
    assert eng.events[-1].kind == "cleared"
    assert eng.events[-1].time_s == 0.5
    with pytest.raises(KeyError, match="fault 1 is not scheduled"):
        eng.clear(fid)


def test_clear_matching_clears_one_motor_only() -> None:
    eng = make_engine()
    on_two = [eng.schedule(ActuatorFault(motor=2, kind="loe", loe=0.3)),
              eng.schedule(ActuatorFault(motor=2, kind="lock", start_s=9.0))]  # pending too
    eng.schedule(ActuatorFault(motor=1, kind="loe", loe=0.5))
    baro = eng.schedule(SensorFault(sensor="baro", kind="bias", magnitude=0.1))
    eng.actuator_inputs(1.0, U)
    assert eng.clear_matching(2, time_s=1.0) == on_two
    out = eng.actuator_inputs(1.002, U)
    assert out[1] == U[1]
    assert out[0] == 0.5 * U[0]
    assert eng.clear_matching("baro") == [baro]
    assert [f.fault_id for f in eng.scheduled()] == [3]
    with pytest.raises(ConfigError, match=r"target = 5: must be a motor 1..4"):
        eng.clear_matching(5)


def test_clear_all() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=1, kind="total_loss"))
    eng.schedule(StructuralFault(mass_loss_kg=0.3))
    assert eng.mass_kg(0.0) == MASS_KG - 0.3
    assert eng.clear_all(1.0) == [1, 2]
    assert eng.actuator_inputs(1.0, U) is U
    assert eng.mass_kg(1.0) == MASS_KG


def test_effectivenesses_multiply_and_the_latest_override_wins() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=3, kind="loe", loe=0.2))
    eng.schedule(ActuatorFault(motor=3, kind="loe", loe=0.5))
    eng.schedule(ActuatorFault(motor=1, kind="lock", start_s=1.0))
    eng.schedule(ActuatorFault(motor=1, kind="loe", loe=0.5, start_s=2.0))
    eng.schedule(ActuatorFault(motor=2, kind="hardover", start_s=1.0))
    eng.schedule(ActuatorFault(motor=2, kind="float", start_s=3.0, end_s=4.0))
    out = eng.actuator_inputs(0.0, U)
    assert out[2] == (1.0 - 0.2) * (1.0 - 0.5) * U[2]
    eng.actuator_inputs(1.0, U)
    out = eng.actuator_inputs(2.0, U * 2.0)
    assert out[0] == 0.5 * U[0]  # locked at the onset command, then half effective
    assert out[1] == PWM_MAX
    assert eng.actuator_inputs(3.0, U)[1] == 0.0  # float started later: it decides
    assert eng.actuator_inputs(4.0, U)[1] == PWM_MAX  # float ended: hard-over again
    np.testing.assert_allclose(eng.true_loe(4.0), [math.nan, math.nan, 0.6, 0.0])


def test_true_loe_mapping() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=1, kind="loe", loe=0.3))
    eng.schedule(ActuatorFault(motor=2, kind="float"))
    eng.schedule(ActuatorFault(motor=3, kind="hardover"))
    eng.schedule(ActuatorFault(motor=4, kind="total_loss"))
    np.testing.assert_array_equal(eng.true_loe(0.0), [0.3, 1.0, math.nan, 1.0])
    eng.clear_all()
    eng.schedule(ActuatorFault(motor=4, kind="lock"))
    np.testing.assert_array_equal(eng.true_loe(0.0), [0.0, 0.0, 0.0, math.nan])


def test_true_loe_follows_step_faults_as_they_start_end_and_are_cleared() -> None:
    # a step loss is worked out once while the faults stay as they are: what is kept must
    # still follow every change of the active faults
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=2, kind="loe", loe=0.4, start_s=1.0, end_s=3.0))
    fid = eng.schedule(ActuatorFault(motor=2, kind="loe", loe=0.5, start_s=2.0))
    seen = [eng.true_loe_values(t) for t in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5)]
    assert [v[1] for v in seen] == [0.0, 0.4, 0.4, 1.0 - 0.6 * 0.5, 1.0 - 0.6 * 0.5, 0.5, 0.5]
    assert all(v[0] == v[2] == v[3] == 0.0 for v in seen)
    np.testing.assert_array_equal(eng.true_loe(3.5), seen[-1])
    eng.clear(fid, 4.0)
    assert eng.true_loe_values(4.0) == (0.0, 0.0, 0.0, 0.0)


def test_true_loe_of_a_varying_profile_is_not_kept() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=1, kind="loe", loe=0.6, start_s=0.0, profile="sinusoid",
                               period_s=2.0))
    # gamma = loe (1 - cos(2 pi t / T)) / 2: 0 at the start, loe half a period later
    assert eng.true_loe_values(0.0)[0] == 0.0
    assert eng.true_loe_values(1.0)[0] == pytest.approx(0.6, rel=1e-15)


def test_structural_fault_changes_mass_only_from_its_start() -> None:
    eng = make_engine()
    fid = eng.schedule(StructuralFault(mass_loss_kg=0.3, start_s=22.0))  # thesis battery
    assert eng.mass_kg(21.998) == MASS_KG
    assert eng.actuator_inputs(22.0, U) is U  # no effect on the motors
    assert eng.mass_kg(22.0) == MASS_KG - 0.3
    eng.clear(fid)
    assert eng.mass_kg(22.002) == MASS_KG
    eng.schedule(StructuralFault(mass_loss_kg=1.0))
    with pytest.raises(ConfigError, match=re.escape(
            "mass_loss_kg = 0.5: must be less than the remaining airframe mass 0.42 kg")):
        eng.schedule(StructuralFault(mass_loss_kg=0.5))


def test_apply_now_and_late_schedule() -> None:
    eng = make_engine()
    eng.actuator_inputs(10.0, U)
    fid = eng.apply_now(ActuatorFault(motor=1, kind="float", end_s=5.0), 10.0)
    assert eng.actuator_inputs(10.0, U)[0] == 0.0
    assert eng.actuator_inputs(14.998, U)[0] == 0.0
    assert eng.actuator_inputs(15.0, U) is U  # duration 5 s kept
    late = eng.schedule(ActuatorFault(motor=2, kind="float", start_s=3.0))  # start is past
    assert eng.actuator_inputs(15.002, U)[1] == 0.0
    started = [(e.fault_id, e.time_s) for e in eng.events if e.kind == "started"]
    assert started == [(fid, 10.0), (late, 15.002)]


def test_drain_events_returns_only_new_events() -> None:
    eng = make_engine()
    eng.schedule(SensorFault(sensor="gyro", kind="bias", magnitude=0.1, start_s=1.0))
    first = eng.drain_events()
    assert [e.kind for e in first] == ["injected"]
    assert first[0].description == "gyro: bias 0.1"
    assert eng.drain_events() == []
    eng.corrupt("gyro", 1.0, np.zeros(3), 0.0)
    assert [(e.kind, e.time_s) for e in eng.drain_events()] == [("started", 1.0)]
    assert len(eng.events) == 2  # history kept


def test_reset_forgets_everything() -> None:
    eng = make_engine()
    eng.schedule(ActuatorFault(motor=1, kind="float"))
    eng.actuator_inputs(1.0, U)
    eng.reset()
    assert eng.events == []
    assert eng.actuator_inputs(0.0, U) is U
    assert eng.schedule(ActuatorFault(motor=1, kind="float")) == 1


# ---------------------------------------------------------------- sensor faults
def test_bias_changes_only_the_targeted_sensor_and_axis() -> None:
    eng = make_engine()
    eng.schedule(SensorFault(sensor="gyro", kind="bias", axis=1, magnitude=0.1, start_s=1.0))
    v = np.array([0.01, -0.02, 0.03])
    assert eng.corrupt("gyro", 0.996, v, 0.003) is v
    out = eng.corrupt("gyro", 1.0, v, 0.003)
    np.testing.assert_array_equal(out, [0.01, -0.02 + 0.1, 0.03])
    assert eng.corrupt("accel", 1.0, v, 0.03) is v
    assert eng.actuator_inputs(1.0, U) is U


def test_drift_is_a_ramp_from_its_start() -> None:
    eng = make_engine()
    eng.schedule(SensorFault(sensor="baro", kind="drift", magnitude=1e-3, rate=2e-3,
                             start_s=10.0))
    alt = np.array([0.6])
    assert eng.corrupt("baro", 10.0, alt, 0.02)[0] == 0.6 + 1e-3
    # offset = magnitude + rate (t - t0); 1e-15 absorbs the sum's rounding
    assert eng.corrupt("baro", 15.0, alt, 0.02)[0] == pytest.approx(
        0.6 + 1e-3 + 2e-3 * 5.0, abs=1e-15)


def test_freeze_holds_the_last_reading_before_it_started() -> None:
    eng = make_engine()
    eng.schedule(SensorFault(sensor="mocap_pos", kind="freeze", axis=2, start_s=1.0))
    rng = np.random.default_rng(5)
    last = None
    for t in grid(0.0, 1.0)[::5]:  # 100 Hz readings
        last = rng.normal(size=3)
        eng.corrupt("mocap_pos", float(t), last, 5e-4)
    assert last is not None
    for t in grid(1.0, 2.0)[::5]:
        v = rng.normal(size=3)
        out = eng.corrupt("mocap_pos", float(t), v, 5e-4)
        assert out[2] == last[2]
        np.testing.assert_array_equal(out[:2], v[:2])


def test_freeze_from_the_start_holds_the_first_reading() -> None:
    eng = make_engine()
    eng.schedule(SensorFault(sensor="baro", kind="freeze"))
    first = eng.corrupt("baro", 0.0, np.array([0.1]), 0.02)
    assert eng.corrupt("baro", 0.02, np.array([0.7]), 0.02)[0] == first[0] == 0.1


def test_loss_of_accuracy_scales_the_noise() -> None:
    sigma = 0.003
    n = 40_000
    rng = np.random.default_rng(11)
    eng = make_engine()
    eng.schedule(SensorFault(sensor="gyro", kind="loss_of_accuracy", axis=0, magnitude=200.0))
    readings = sigma * rng.standard_normal((n, 3))
    out = np.array([eng.corrupt("gyro", k * 0.004, r, sigma)
                    for k, r in enumerate(readings)])
    # 200 % more noise -> 3 sigma; the std of 40 000 samples is within 0.4 %, allow 10 %
    assert out[:, 0].std() / readings[:, 0].std() == pytest.approx(3.0, rel=0.1)
    assert abs(out[:, 0].mean()) < 5 * 3 * sigma / math.sqrt(n)  # no bias: 5 s.e.
    np.testing.assert_array_equal(out[:, 1:], readings[:, 1:])


def test_calibration_error_is_uncorrelated_and_bounded() -> None:
    n = 20_000
    eng = make_engine()
    eng.schedule(SensorFault(sensor="accel", kind="calibration", axis=2, low=-20.0, high=5.0))
    eng.schedule(SensorFault(sensor="mocap_att", kind="calibration"))
    truth = np.stack([np.zeros(n), np.zeros(n), -9.81 + np.sin(np.arange(n) * 0.01)], axis=1)
    out = np.array([eng.corrupt("accel", k * 0.004, v, 0.03)
                    for k, v in enumerate(truth)])
    z = out[:, 2]
    assert z.min() >= -20.0
    assert z.max() <= 5.0
    # independent of the truth: |r| of 20 000 pairs has s.e. 0.007, allow 7 s.e.
    assert abs(np.corrcoef(z, truth[:, 2])[0, 1]) < 0.05
    assert z.std() == pytest.approx(25.0 / math.sqrt(12.0), rel=0.05)  # uniform; s.e. 0.5 %
    np.testing.assert_array_equal(out[:, :2], truth[:, :2])
    low, high = DEFAULT_GARBAGE_RANGE["mocap_att"]
    att = np.array([eng.corrupt("mocap_att", k * 0.01, np.zeros(3), 0.002)
                    for k in range(2000)])
    assert att.min() >= low
    assert att.max() <= high
    assert att.max() - att.min() > 0.9 * (high - low)  # spreads over the default range


# ---------------------------------------------------------------- configuration
@pytest.mark.parametrize(("make", "message"), [
    (lambda: ActuatorFault(motor=5, kind="loe"), "motor = 5: must be 1, 2, 3 or 4"),
    (lambda: ActuatorFault(motor=1, kind="loe", loe=1.3), "loe = 1.3: must be within [0, 1]"),
    (lambda: ActuatorFault(motor=1, kind="jam"),  # type: ignore[arg-type]
     "kind = 'jam': must be one of 'loe', 'lock', 'float', 'hardover', 'total_loss'"),
    (lambda: ActuatorFault(motor=1, kind="loe", start_s=10.0, end_s=5.0),
     "end_s = 5.0: must be later than start_s = 10.0 s"),
    (lambda: ActuatorFault(motor=1, kind="loe", loe=0.2, period_s=3.0),
     "period_s = 3.0: does not apply to profile 'step'; leave it out"),
    (lambda: ActuatorFault(motor=1, kind="lock", loe=0.2),
     "loe = 0.2: does not apply to kind 'lock'; leave it out"),
    (lambda: ActuatorFault(motor=1, kind="loe", loe=0.2, profile="random", low=0.3),
     "low = 0.3: must be within [0, loe = 0.2]"),
    (lambda: ActuatorFault(motor=1, kind="loe", loe=0.2, profile="pulse", pulse_width_s=12.0),
     "pulse_width_s = 12.0: must be within (0, period_s = 10.0] s"),
    (lambda: SensorFault(sensor="lidar", kind="bias"),  # type: ignore[arg-type]
     "sensor = 'lidar': must be one of 'gyro', 'accel', 'mocap_pos', 'mocap_att', 'baro'"),
    (lambda: SensorFault(sensor="gyro", kind="spike"),  # type: ignore[arg-type]
     "kind = 'spike': must be one of 'bias', 'loss_of_accuracy', 'drift', 'freeze', "
     "'calibration'"),
    (lambda: SensorFault(sensor="gyro", kind="bias", axis=3),
     "axis = 3: must be 0 to 2 for sensor 'gyro'"),
    (lambda: SensorFault(sensor="baro", kind="bias", axis=1),
     "axis = 1: must be 0 for sensor 'baro'"),
    (lambda: SensorFault(sensor="baro", kind="freeze", magnitude=1.0),
     "magnitude = 1.0: does not apply to kind 'freeze'; leave it out"),
    (lambda: SensorFault(sensor="baro", kind="calibration", low=1.0),
     "low = 1.0: give both low and high, or neither"),
    (lambda: SensorFault(sensor="baro", kind="calibration", low=1.0, high=0.0),
     "high = 0.0: must be a finite number > low = 1.0"),
    (lambda: SensorFault(sensor="gyro", kind="loss_of_accuracy", magnitude=-5.0),
     "magnitude = -5.0: must be >= 0"),
    (lambda: StructuralFault(mass_loss_kg=-0.3), "mass_loss_kg = -0.3: must be > 0 kg"),
])
def test_bad_faults_are_rejected_with_key_value_and_range(make: object, message: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(message)):
        make()  # type: ignore[operator]


def test_faults_load_from_toml_tables() -> None:
    text = """
    [[faults]]
    motor = 1
    kind = "loe"
    loe = 0.3
    start_s = 38
    [[faults]]
    sensor = "baro"
    kind = "drift"
    magnitude = 1e-3
    rate = 1e-4
    [[faults]]
    mass_loss_kg = 0.3
    start_s = 22
    """
    faults = [fault_from_mapping(t) for t in tomllib.loads(text)["faults"]]
    assert faults == [ActuatorFault(motor=1, kind="loe", loe=0.3, start_s=38.0),
                      SensorFault(sensor="baro", kind="drift", magnitude=1e-3, rate=1e-4),
                      StructuralFault(mass_loss_kg=0.3, start_s=22.0)]
    with pytest.raises(ConfigError, match=re.escape("motor = 5: must be 1, 2, 3 or 4")):
        from_mapping(ActuatorFault, {"motor": 5, "kind": "loe"})
    with pytest.raises(ConfigError, match=re.escape("sensor = 'lidar': must be one of")):
        fault_from_mapping({"sensor": "lidar", "kind": "bias"})
    with pytest.raises(ConfigError, match="needs a 'motor'"):
        fault_from_mapping({"kind": "bias"})
    with pytest.raises(ConfigError, match=re.escape(
            "kind = 'jam': must be one of 'loe', 'lock', 'float', 'hardover', 'total_loss'")):
        fault_from_mapping({"motor": 1, "kind": "jam"})


def test_fault_kinds_and_profiles_are_one_table() -> None:
    """The numbered kinds and profiles the kernels read are the vocabulary's names, those a
    fault accepts; each kind composes one way (fault_types docstring)."""
    actuator, sensor = set(get_args(ActuatorKind)), set(get_args(SensorKind))
    assert actuator == set(ACTUATOR_FAULT_KINDS) and sensor == set(SENSOR_FAULT_KINDS)
    assert {k.name.lower() for k in FaultKind} == actuator | sensor
    assert all(FaultKind.of(k.name.lower()) is k for k in FaultKind)
    assert [p.name.lower() for p in FaultProfile] == list(LOE_PROFILES) == \
        list(get_args(LoeProfile))
    assert all(FaultProfile.of(p.name.lower()) is p for p in FaultProfile)
    assert {k.name.lower() for k in OVERRIDE_KINDS} < actuator
    assert {k.name.lower() for k in ADDITIVE_KINDS | DRAWING_KINDS} < sensor
    with pytest.raises(KeyError):
        FaultKind.of("mass_loss")  # structural faults have no row in the compiled table
