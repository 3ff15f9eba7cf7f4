"""Allocation: the inverse of eq. 3.2 and the attitude-first saturation strategy."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fcu.control.allocation import Allocator
from fcu.model import VehicleModel

MODEL = VehicleModel()
ALLOC = Allocator(MODEL)
LO, HI = MODEL.pwm_min, MODEL.pwm_max
# 1e-12 of a PWM range of 0.05 is far below float64 round-off of the 4x4 products (~1e-17)
PWM_TOL = 1e-12
# U is O(10) N and O(0.1) N*m; products of O(100) gains with O(0.01) PWM round off at ~1e-14
WRENCH_TOL = 1e-10


def _wrench(pwm: np.ndarray) -> np.ndarray:
    return MODEL.mixer() @ pwm


def test_hover_allocates_hover_pwm_on_every_motor() -> None:
    pwm = ALLOC.allocate(MODEL.mass * MODEL.gravity, np.zeros(3))
    np.testing.assert_allclose(pwm, MODEL.hover_pwm, rtol=1e-12)  # exact linear algebra
    assert MODEL.hover_pwm == pytest.approx(0.0199, abs=5e-5)  # thesis-notes value


@settings(max_examples=200, deadline=None)
@given(thrust=st.floats(8.0, 25.0), roll=st.floats(-0.3, 0.3), pitch=st.floats(-0.3, 0.3),
       yaw=st.floats(-0.05, 0.05))
def test_unsaturated_allocation_inverts_eq_3_2(thrust: float, roll: float, pitch: float,
                                               yaw: float) -> None:
    request = np.array([thrust, roll, pitch, yaw])
    exact = np.linalg.solve(MODEL.mixer(), request)
    report = ALLOC.allocate_report(thrust, request[1:])
    if np.all((exact >= LO) & (exact <= HI)):
        np.testing.assert_allclose(_wrench(report.pwm), request, atol=WRENCH_TOL)
        np.testing.assert_allclose(report.pwm, exact, atol=PWM_TOL)
        assert not report.saturated
    else:
        assert report.saturated


def test_mix_returns_thrust_and_torques_of_eq_3_2() -> None:
    pwm = np.array([0.021, 0.018, 0.025, 0.015])
    thrust, torque = ALLOC.mix(pwm)
    k, kl, kk = MODEL.thrust_gain, MODEL.thrust_gain * MODEL.arm_length, \
        MODEL.thrust_gain * MODEL.yaw_gain
    assert thrust == pytest.approx(k * pwm.sum(), rel=1e-12)  # eq. 3.2 row 1
    np.testing.assert_allclose(torque, [kl * (pwm[2] - pwm[3]), kl * (pwm[0] - pwm[1]),
                                        kk * (pwm[0] + pwm[1] - pwm[2] - pwm[3])], rtol=1e-12)


def test_yaw_is_given_up_first_and_roll_pitch_and_thrust_are_kept() -> None:
    thrust, tau = MODEL.mass * MODEL.gravity, np.array([0.2, -0.15, 0.5])  # yaw far too big
    report = ALLOC.allocate_report(thrust, tau)
    got = _wrench(report.pwm)
    assert report.saturated and 0.0 < report.yaw_scale < 1.0
    assert report.roll_pitch_scale == 1.0 and report.collective_shift_pwm == 0.0
    np.testing.assert_allclose(got[:3], [thrust, tau[0], tau[1]], atol=WRENCH_TOL)
    assert 0.0 < got[3] < tau[2]  # yaw kept in sign, reduced
    assert np.all(report.pwm >= LO - PWM_TOL) and np.all(report.pwm <= HI + PWM_TOL)
    # the largest yaw that fits: some motor sits on a bound
    assert np.isclose(report.pwm, LO, atol=PWM_TOL).any() \
        or np.isclose(report.pwm, HI, atol=PWM_TOL).any()


def test_collective_is_shifted_when_roll_pitch_alone_does_not_fit() -> None:
    # low thrust with a big pitch torque: motor 2 would go below pwm_min
    thrust, tau = 4.0, np.array([0.0, 0.5, -0.05])
    assert np.linalg.solve(MODEL.mixer(), np.r_[thrust, tau]).min() < LO
    report = ALLOC.allocate_report(thrust, tau)
    got = _wrench(report.pwm)
    np.testing.assert_allclose(got[1:3], tau[:2], atol=WRENCH_TOL)  # roll/pitch kept
    assert report.collective_shift_pwm > 0.0 and got[0] > thrust  # thrust raised to fit
    assert report.roll_pitch_scale == 1.0
    assert np.all(report.pwm >= LO - PWM_TOL) and np.all(report.pwm <= HI + PWM_TOL)


def test_roll_pitch_scaled_last_and_direction_kept() -> None:
    tau = np.array([2.0, -1.5, 0.1])  # spread 2 * 2.0 / (2 K L) = 0.057 > PWM range 0.05
    report = ALLOC.allocate_report(15.0, tau)
    got = _wrench(report.pwm)
    assert 0.0 < report.roll_pitch_scale < 1.0 and report.yaw_scale == 0.0
    np.testing.assert_allclose(got[1:3], report.roll_pitch_scale * tau[:2], atol=WRENCH_TOL)
    assert np.all(report.pwm >= LO - PWM_TOL) and np.all(report.pwm <= HI + PWM_TOL)


@settings(max_examples=300, deadline=None)
@given(thrust=st.floats(0.0, 40.0), roll=st.floats(-3.0, 3.0), pitch=st.floats(-3.0, 3.0),
       yaw=st.floats(-1.0, 1.0))
def test_any_request_stays_in_bounds_and_keeps_tilt_direction(thrust: float, roll: float,
                                                              pitch: float, yaw: float) -> None:
    report = ALLOC.allocate_report(thrust, np.array([roll, pitch, yaw]))
    assert np.all(report.pwm >= LO - PWM_TOL) and np.all(report.pwm <= HI + PWM_TOL)
    got = _wrench(report.pwm)
    # roll/pitch realised = scale * requested with 0 <= scale <= 1 (direction preserved)
    np.testing.assert_allclose(got[1:3], report.roll_pitch_scale * np.array([roll, pitch]),
                               atol=WRENCH_TOL)
    np.testing.assert_allclose(got[3], report.yaw_scale * yaw, atol=WRENCH_TOL)
    assert 0.0 <= report.yaw_scale <= 1.0 and 0.0 <= report.roll_pitch_scale <= 1.0


# --------------------------------------------------------------------------------------------
# active FTC: allocation for the estimated effectiveness (module docstring)
# --------------------------------------------------------------------------------------------
@settings(max_examples=200, deadline=None)
@given(thrust=st.floats(10.0, 20.0), roll=st.floats(-0.1, 0.1), pitch=st.floats(-0.1, 0.1),
       yaw=st.floats(-0.02, 0.02), e=st.lists(st.floats(0.3, 1.0), min_size=4, max_size=4))
def test_reconfigured_allocation_delivers_the_wrench_through_weakened_motors(
        thrust: float, roll: float, pitch: float, yaw: float, e: list[float]) -> None:
    alloc = Allocator(MODEL)
    alloc.set_effectiveness(np.array(e))
    request = np.array([thrust, roll, pitch, yaw])
    effective = np.linalg.solve(MODEL.mixer(), request)  # v = diag(e) u
    report = alloc.allocate_report(thrust, request[1:])
    delivered = MODEL.mixer() @ (report.pwm * np.array(e))  # what the weakened motors give
    if np.all((effective >= LO * np.array(e)) & (effective <= HI * np.array(e))):
        np.testing.assert_allclose(delivered, request, atol=WRENCH_TOL)
        assert not report.saturated
    assert np.all(report.pwm >= LO - PWM_TOL) and np.all(report.pwm <= HI + PWM_TOL)
    # mix() reports what the allocation believes the motors give
    thrust_out, torque_out = alloc.mix(report.pwm)
    np.testing.assert_allclose([thrust_out, *torque_out], delivered, atol=WRENCH_TOL)


def test_full_effectiveness_is_the_nominal_allocation_to_the_bit() -> None:
    rng = np.random.default_rng(5)
    alloc = Allocator(MODEL)
    alloc.set_effectiveness(np.ones(4))
    for _ in range(500):
        thrust = float(rng.uniform(0.0, 30.0))
        tau = rng.uniform(-0.5, 0.5, 3) * np.array([1.0, 1.0, 0.1])
        assert np.array_equal(alloc.allocate(thrust, tau), ALLOC.allocate(thrust, tau))


def test_a_weak_motor_gives_up_yaw_before_roll_and_pitch() -> None:
    alloc = Allocator(MODEL)
    alloc.set_effectiveness(np.array([0.4, 1.0, 1.0, 1.0]))
    weight = MODEL.mass * MODEL.gravity
    report = alloc.allocate_report(weight, np.array([0.0, 0.05, 0.05]))
    thrust, torque = alloc.mix(report.pwm)
    assert report.pwm[0] == pytest.approx(HI)  # motor 1 at full power: 40 % of its thrust
    assert report.roll_pitch_scale == 1.0 and torque[1] == pytest.approx(0.05)  # pitch kept
    assert report.yaw_scale < 1.0  # yaw gave way


def test_effectiveness_is_clipped_and_none_restores_the_nominal() -> None:
    alloc = Allocator(MODEL)
    alloc.set_effectiveness(np.array([0.0, 1.5, 0.5, 1.0]))
    np.testing.assert_array_equal(alloc.effectiveness, [0.05, 1.0, 0.5, 1.0])
    alloc.set_effectiveness(None)
    np.testing.assert_array_equal(alloc.effectiveness, np.ones(4))
