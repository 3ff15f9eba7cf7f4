"""Attitude control: eq. 5.6 PD, the discrete LQR of eq. 5.7-5.10, the motor lead, the
reference filter, and the loop with the unmodelled 15 rad/s motor lag."""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg
from axis_plant import discrete_axes
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fcu.control.attitude import euler_rates, wrap_angle
from fcu.control.attitude_lqr import AttitudeLQR, LqrWeights, design_axis_lqr
from fcu.control.attitude_pd import AttitudePD, AttitudePdGains
from fcu.control.attitude_reference import AttitudeReferenceFilter
from fcu.control.motor_lead import MotorLead
from fcu.model import VehicleModel

MODEL = VehicleModel()
DT = 0.01  # s, the 100 Hz autopilot loop


def simulate_axes(controller, *, steps: int, disturbance_nm: np.ndarray,
                  motor_rad_s: float = MODEL.motor_bandwidth, delay_ticks: int = 0,
                  start_rad: np.ndarray | None = None) -> np.ndarray:
    """Three decoupled axes I th'' = tau_motor + d, tau_motor' = w (tau_cmd - tau_motor).

    Exact ZOH discretisation of the plant at the loop rate; the measurement may be delayed by
    whole ticks. Returns the angles, shape (steps, 3).
    """
    a_s, b_s = discrete_axes(MODEL, DT, motor_rad_s)
    x = np.zeros((3, 3))  # axis x [angle, rate, motor torque]
    if start_rad is not None:
        x[:, 0] = start_rad
    history = [x.copy()] * (delay_ticks + 1)
    angles = np.empty((steps, 3))
    zero = np.zeros(3)
    for k in range(steps):
        seen = history[0]
        torque = controller.step(seen[:, 0], seen[:, 1], zero, zero, zero)
        for i in range(3):
            x[i] = a_s[i] @ x[i] + b_s[i] @ np.array([torque[i], disturbance_nm[i]])
        history = history[1:] + [x.copy()]
        angles[k] = x[:, 0]
    return angles


# --------------------------------------------------------------------------------------------
# kinematics and eq. 5.6
# --------------------------------------------------------------------------------------------
@settings(max_examples=50, deadline=None)
@given(phi=st.floats(-1.0, 1.0), theta=st.floats(-1.2, 1.2), psi=st.floats(-3.0, 3.0),
       p=st.floats(-2.0, 2.0), q=st.floats(-2.0, 2.0), r=st.floats(-2.0, 2.0))
def test_euler_rates_match_differentiated_zyx_angles(phi: float, theta: float, psi: float,
                                                      p: float, q: float, r: float) -> None:
    omega = np.array([p, q, r])
    rot0 = Rotation.from_euler("ZYX", [psi, theta, phi])  # R = Rz Ry Rx, body -> NED
    h = 1e-6  # s; central difference error O(h^2) ~ 1e-12 rad/s
    ahead = (rot0 * Rotation.from_rotvec(omega * h)).as_euler("ZYX")[::-1]
    behind = (rot0 * Rotation.from_rotvec(-omega * h)).as_euler("ZYX")[::-1]
    numeric = wrap_angle(ahead - behind) / (2 * h)
    # 1e-6 rad/s: difference-quotient round-off (1e-16 / 1e-6) amplified by 1/cos(theta) <= 3
    np.testing.assert_allclose(euler_rates(np.array([phi, theta, psi]), omega), numeric,
                               atol=1e-6)


def test_pd_without_lead_is_eq_5_6_with_wrapped_yaw() -> None:
    gains = AttitudePdGains(kp=(16.0, 16.0, 9.0), kd=(7.0, 7.0, 6.0), motor_lead_rad_s=None)
    pd = AttitudePD(MODEL, gains, DT)
    euler = np.array([0.0, 0.0, np.radians(-179.0)])
    ref = np.array([0.1, -0.05, np.radians(179.0)])
    rate, ref_rate, ref_acc = np.array([0.2, -0.1, 0.05]), np.array([0.0, 0.1, 0.0]), \
        np.array([1.0, 2.0, 3.0])
    torque = pd.step(euler, rate, ref, ref_rate, ref_acc)
    e = np.array([0.1, -0.05, np.radians(-2.0)])  # yaw error wraps to -2 deg, not 358 deg
    expected = MODEL.inertia_diag * (ref_acc + np.array(gains.kp) * e
                                     + np.array(gains.kd) * (ref_rate - rate))
    np.testing.assert_allclose(torque, expected, rtol=1e-12)  # level attitude: W = identity


def test_pd_with_lead_reaches_eq_5_6_at_steady_state() -> None:
    pd = AttitudePD(MODEL)
    args = (np.zeros(3), np.zeros(3), np.array([0.02, -0.01, 0.03]), np.zeros(3), np.zeros(3))
    first = pd.step(*args)
    for _ in range(200):
        last = pd.step(*args)
    plain = MODEL.inertia_diag * np.array(pd.gains.kp) * args[2]
    np.testing.assert_allclose(last, plain, rtol=1e-9)  # lead DC gain 1, pole 0.55^200 = 0
    lead = MotorLead(MODEL.motor_bandwidth, pd.gains.motor_lead_rad_s, DT)
    np.testing.assert_allclose(first, lead._d * plain, rtol=1e-12)  # first sample: step gain
    assert lead._d == pytest.approx(3.24, abs=0.01)  # (1 - e^-0.6)/(1 - e^-0.15)


# --------------------------------------------------------------------------------------------
# motor lead
# --------------------------------------------------------------------------------------------
def test_motor_lead_turns_the_motor_lag_into_the_target_lag() -> None:
    w, wd = MODEL.motor_bandwidth, 60.0
    lead = MotorLead(w, wd, DT)
    motor = control.c2d(control.tf([w], [1.0, w]), DT)
    target = control.c2d(control.tf([wd], [1.0, wd]), DT)
    n = 60
    u = np.ones(n)  # a torque step through lead then the (sampled) motor
    led = np.array([lead.step(np.full(3, v))[0] for v in u])
    through_motor = control.forced_response(motor, T=np.arange(n) * DT, U=led).outputs
    wanted = control.forced_response(target, T=np.arange(n) * DT, U=u).outputs
    np.testing.assert_allclose(through_motor, wanted, atol=1e-12)  # pole-zero cancellation
    assert lead.high_frequency_gain == pytest.approx(3.89, abs=0.01)  # G (1 + a)/(1 + b)
    with pytest.raises(ValueError, match="motor_lead_rad_s"):
        MotorLead(w, 10.0, DT)


# --------------------------------------------------------------------------------------------
# LQR design
# --------------------------------------------------------------------------------------------
def test_lqr_gain_solves_the_discrete_riccati_equation() -> None:
    lqr = AttitudeLQR(MODEL, LqrWeights(), DT)
    for design in lqr.designs:
        a, b, q, r, p, k = design.a, design.b, design.q, design.r, design.riccati, design.gain
        # P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q
        residual = a.T @ p @ a - a.T @ p @ b @ np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a) \
            + q - p
        assert np.max(np.abs(residual)) <= 1e-8 * np.max(np.abs(p))  # solver round-off
        # K = (R + B'PB)^-1 B'PA and P matches SciPy's independent solver
        np.testing.assert_allclose(k, np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a),
                                   rtol=1e-9)
        np.testing.assert_allclose(p, scipy.linalg.solve_discrete_are(a, b, q, r), rtol=1e-7)
        assert np.all(np.abs(np.linalg.eigvals(a - b @ k)) < 1.0)  # closed loop stable
        assert np.all(np.linalg.eigvalsh(p) > 0.0)  # stabilising solution is positive definite
    np.testing.assert_allclose(lqr.gain, np.vstack([d.gain for d in lqr.designs]))
    assert lqr.riccati.shape == (3, 3, 3)


def test_discrete_lqr_tends_to_the_continuous_design_as_dt_shrinks() -> None:
    inertia, q, r = 0.03, (1.0e6, 6.0e5, 3000.0), 4.0e4
    a_c = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])  # z' = e, e'' = u/I
    b_c = np.array([[0.0], [0.0], [1.0 / inertia]])
    k_c, _, _ = control.lqr(a_c, b_c, np.diag(q), np.array([[r]]))
    # per-step weights Q, R equal dt Q, dt R per unit time: same ratio, same limit
    k_d = design_axis_lqr(inertia, 1e-4, q, r).gain
    np.testing.assert_allclose(k_d, k_c, rtol=0.02)  # O(w dt) = 1e-3..1e-2 discretisation
    k_loop = design_axis_lqr(inertia, DT, q, r).gain
    assert not np.allclose(k_loop, k_c, rtol=0.02)  # at 100 Hz the hold matters


def test_default_lqr_gains_and_poles_are_as_documented() -> None:
    lqr = AttitudeLQR(MODEL)
    per_inertia = lqr.gain / MODEL.inertia_diag[:, None]
    np.testing.assert_allclose(per_inertia[0], [256.0, 195.0, 22.2], rtol=0.01)  # docstring
    np.testing.assert_allclose(per_inertia[2], [37.4, 47.1, 10.7], rtol=0.01)
    poles_s = np.log(lqr.designs[0].closed_loop_poles.astype(complex)) / DT
    np.testing.assert_allclose(np.sort_complex(poles_s), [-11.17 - 7.54j, -11.17 + 7.54j, -1.59],
                               atol=0.01)  # rad/s, as printed in LqrWeights


def test_lqr_integral_removes_a_standing_error_that_pd_keeps() -> None:
    d = np.array([0.05, -0.04, 0.01])  # N*m, constant disturbance torque
    steps = 1500  # 15 s, > 15 time constants of the slowest pole (yaw integral, 1 s)
    pd_angles = simulate_axes(AttitudePD(MODEL), steps=steps, disturbance_nm=d)
    lqr_angles = simulate_axes(AttitudeLQR(MODEL), steps=steps, disturbance_nm=d)
    standing = d / (MODEL.inertia_diag * np.array(AttitudePdGains().kp))  # PD: I kp e = d
    np.testing.assert_allclose(pd_angles[-1], standing, rtol=1e-6)  # settled, exact
    np.testing.assert_allclose(lqr_angles[-1], 0.0, atol=1e-6)  # rad; e^(-1.0 * 15) residue


def test_lqr_integral_is_clamped_by_the_torque_limit() -> None:
    lqr = AttitudeLQR(MODEL)
    for _ in range(1000):
        lqr.step(np.full(3, 0.3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    k_int = lqr.gain[:, 0]
    np.testing.assert_allclose(np.abs(k_int * lqr.integral), LqrWeights().integral_torque_limit_nm,
                               rtol=1e-12)  # sits exactly on the clamp
    lqr.reset()
    np.testing.assert_array_equal(lqr.integral, 0.0)


# --------------------------------------------------------------------------------------------
# the loop with the unmodelled motor lag
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make", [lambda: AttitudePD(MODEL), lambda: AttitudeLQR(MODEL)],
                         ids=["pd", "lqr"])
@pytest.mark.parametrize(("motor_rad_s", "delay_ticks"), [(15.0, 0), (10.0, 1), (20.0, 2)])
def test_attitude_loop_with_motor_lag_recovers_from_an_offset(make, motor_rad_s: float,
                                                              delay_ticks: int) -> None:
    start = np.radians([5.0, -4.0, 10.0])
    angles = simulate_axes(make(), steps=2000, disturbance_nm=np.zeros(3),
                           motor_rad_s=motor_rad_s, delay_ticks=delay_ticks, start_rad=start)
    assert np.max(np.abs(angles)) <= np.max(np.abs(start)) * 1.6  # bounded overshoot
    # rad: the slowest pole (LQR yaw integral, -1.0 rad/s) leaves ~e^-20 of 0.17 rad at 20 s
    np.testing.assert_allclose(angles[-1], 0.0, atol=1e-6)


def test_default_pd_poles_with_the_lead_are_well_damped() -> None:
    """Closed loop of one axis: plant + real motor lag + lead + PD, spectral radius < 1."""
    inertia, w, gains = MODEL.inertia[0], MODEL.motor_bandwidth, AttitudePdGains()
    a_c = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0 / inertia], [0.0, 0.0, -w]])
    plant = control.c2d(control.ss(a_c, [[0.0], [0.0], [w]], np.eye(3), np.zeros((3, 1))), DT)
    lead = control.ss(MotorLead(w, gains.motor_lead_rad_s, DT).transfer_function)
    pd = control.ss([], [], [], [[-inertia * gains.kp[0], -inertia * gains.kd[0], 0.0]], DT)
    loop = control.feedback(plant, lead * pd, sign=+1)
    poles = np.log(np.linalg.eigvals(np.asarray(loop.A)).astype(complex)) / DT
    damping = -poles.real / np.abs(poles)
    assert np.all(np.abs(np.linalg.eigvals(np.asarray(loop.A))) < 1.0)
    assert damping.min() > 0.6  # the lead keeps the poles damped; without it ~0.3 at kp=100
    without = control.feedback(plant, pd, sign=+1)
    poles_w = np.log(np.linalg.eigvals(np.asarray(without.A)).astype(complex)) / DT
    assert (-poles_w.real / np.abs(poles_w)).min() < 0.35  # stiff PD needs the lead


# --------------------------------------------------------------------------------------------
# reference filter
# --------------------------------------------------------------------------------------------
def test_reference_filter_step_matches_the_closed_form() -> None:
    wf = 15.0
    filt = AttitudeReferenceFilter(DT, wf)
    filt.reset(np.zeros(3))
    out = [filt.step(np.array([0.1, -0.2, 0.05])) for _ in range(100)]
    t = np.arange(100) * DT
    # critically damped: theta_f = 1 - (1 + w t) e^(-w t), rate = w^2 t e^(-w t)
    angle = 1.0 - (1.0 + wf * t) * np.exp(-wf * t)
    rate = wf**2 * t * np.exp(-wf * t)
    acc = wf**2 * (1.0 - angle) - 2.0 * wf * rate
    got = np.array([[o.euler_rad[0], o.rate[0], o.acc[0]] for o in out]) / 0.1
    np.testing.assert_allclose(got, np.c_[angle, rate, acc], atol=1e-10)  # ZOH exact on steps


def test_reference_filter_takes_the_short_way_through_pi() -> None:
    filt = AttitudeReferenceFilter(DT)
    filt.step(np.array([0.0, 0.0, np.radians(179.0)]))
    for _ in range(300):
        out = filt.step(np.array([0.0, 0.0, np.radians(-179.0)]))
    assert out.euler_rad[2] == pytest.approx(np.radians(-179.0), abs=1e-9)  # settled
    assert abs(out.rate[2]) < 1e-9
    filt.reset()
    first = filt.step(np.array([0.0, 0.0, np.radians(179.0)]))
    second = filt.step(np.array([0.0, 0.0, np.radians(-179.0)]))
    assert first.acc[2] == 0.0 and second.acc[2] > 0.0  # +2 deg, not -358 deg
    assert second.acc[2] == pytest.approx(15.0**2 * np.radians(2.0), rel=1e-9)


def test_configuration_errors_name_the_key() -> None:
    with pytest.raises(ValueError, match="kp"):
        AttitudePdGains(kp=(1.0, -1.0, 1.0))
    with pytest.raises(ValueError, match="r_torque"):
        LqrWeights(r_torque=(1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="dt_s"):
        AttitudeLQR(MODEL, dt_s=0.0)
