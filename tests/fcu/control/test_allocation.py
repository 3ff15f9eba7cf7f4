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
