"""Disturbance observers (eq. 6.27-6.30) on a simulated 1/(I s^2) plant with motor lag."""

from __future__ import annotations

import numpy as np
import pytest
from axis_plant import discrete_axes

from fcu.config import AutopilotConfig
from fcu.control.attitude_lqr import AttitudeLQR, LqrWeights
from fcu.control.attitude_pd import AttitudePD, AttitudePdGains
from fcu.control.dob import AccelerationDob, NoDob, VelocityDob
from fcu.control.registry import DOB_REGISTRY, DisturbanceObserver
from fcu.model import VehicleModel

MODEL = VehicleModel()
DT = 0.01  # s, the 100 Hz autopilot loop
W_Q = 5.0  # rad/s, the thesis's Q-filter bandwidth (section 6.2)
D_STEP = np.array([0.14, -0.21, 0.02])  # N*m: what a 20 % / 30 % motor LOE produces at hover
T_STEP = 0.5  # s, when the disturbance starts
THESIS_FORM = {"vbdob": VelocityDob, "abdob": AccelerationDob}  # no motor model in G_n


def make_dob(kind: str, cutoff_rad_s: float = 5.0, *, motor_model: bool = True
             ) -> DisturbanceObserver:
    """Observer ``kind`` as the autopilot builds it (fcu.control.registry: the motor lag in
    its nominal plant), or in the thesis's form of eq. 6.27/6.29 (``motor_model=False``)."""
    if motor_model:
        config = AutopilotConfig(model=MODEL, dob_cutoff_rad_s=cutoff_rad_s)
        return DOB_REGISTRY.factory(kind)(config, DT)
    return THESIS_FORM[kind](MODEL, DT, cutoff_rad_s)


def closed_loop(controller, dob, *, seconds: float, motor_rad_s: float = MODEL.motor_bandwidth,
                delay_ticks: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three axes I th'' = tau_motor + d with tau_motor' = w (tau_cmd - tau_motor).

    The autopilot side, per tick: d_hat = dob.step(meas, rate, tau applied over the last
    tick), tau_cmd = controller - d_hat. The plant is the exact ZOH discretisation at the
    loop rate, with D_STEP from T_STEP on. Returns time (s), angles (rad) and d_hat (N*m).
    """
    a_s, b_s = discrete_axes(MODEL, DT, motor_rad_s)
    steps = int(round(seconds / DT))
    x = np.zeros((3, 3))  # per axis [angle, rate, motor torque]
    history = [x.copy()] * (delay_ticks + 1)
    tau_prev, zero = np.zeros(3), np.zeros(3)
    time = np.arange(steps) * DT
    angles, d_hats = np.empty((steps, 3)), np.empty((steps, 3))
    for k in range(steps):
        seen = history[0]
        d_hat = dob.step(seen[:, 0], seen[:, 1], tau_prev)
        tau = controller.step(seen[:, 0], seen[:, 1], zero, zero, zero) - d_hat
        disturbance = D_STEP if time[k] >= T_STEP else zero
        for i in range(3):
            x[i] = a_s[i] @ x[i] + b_s[i] @ np.array([tau[i], disturbance[i]])
        history = history[1:] + [x.copy()]
        tau_prev = tau
        angles[k], d_hats[k] = seen[:, 0], d_hat
    return time, angles, d_hats


def _at(time: np.ndarray, t: float) -> int:
    return int(np.searchsorted(time, t - 1e-9))


@pytest.mark.parametrize(("kind", "settle_wq"), [("vbdob", 3.9), ("abdob", 5.8)])
@pytest.mark.parametrize("make_ctrl", [lambda: AttitudePD(MODEL), lambda: AttitudeLQR(MODEL)],
                         ids=["pd", "lqr"])
def test_dob_recovers_a_torque_step_within_2_percent(kind: str, settle_wq: float,
                                                     make_ctrl) -> None:
    """With the motor model in G_n, d_hat = Q d: 2 % after 3.9/w (VbDOB), 5.8/w (AbDOB)."""
    time, _, d_hat = closed_loop(make_ctrl(), make_dob(kind, W_Q), seconds=4.0)
    settled = _at(time, T_STEP + (settle_wq + 0.3) / W_Q)  # + 0.3/w: two ticks of sampling
    early = _at(time, T_STEP + 0.5 / W_Q)
    err = np.abs(d_hat - D_STEP) / np.abs(D_STEP)
    assert np.all(err[settled:] < 0.02)  # converged and stays
    assert np.all(err[early] > 0.2)  # but not faster than Q allows: it is a low-pass


@pytest.mark.parametrize("kind", ["vbdob", "abdob"])
def test_dob_rescues_pd_from_its_standing_error(kind: str) -> None:
    gains = AttitudePdGains()
    _, pd_alone, _ = closed_loop(AttitudePD(MODEL), NoDob(), seconds=5.0)
    _, pd_dob, _ = closed_loop(AttitudePD(MODEL), make_dob(kind), seconds=5.0)
    standing = D_STEP / (MODEL.inertia_diag * np.array(gains.kp))  # I kp e = d
    np.testing.assert_allclose(pd_alone[-1], standing, rtol=1e-4)  # settled closed form
    # rad: the DOB's slowest mode (w = 5 rad/s) leaves < 1e-6 of the 0.03 rad standing error
    np.testing.assert_allclose(pd_dob[-1], 0.0, atol=1e-6)
    assert np.max(np.abs(pd_dob)) < np.max(np.abs(pd_alone))  # smaller transient too


@pytest.mark.parametrize("motor_model", [True, False], ids=["motor-model", "thesis-form"])
@pytest.mark.parametrize("kind", ["vbdob", "abdob"])
@pytest.mark.parametrize("make_ctrl", [
    lambda: AttitudePD(MODEL),
    lambda: AttitudeLQR(MODEL),
    lambda: AttitudePD(MODEL, AttitudePdGains(kp=(16.0, 16.0, 9.0), kd=(7.0, 7.0, 6.0),
                                              motor_lead_rad_s=None)),
    lambda: AttitudeLQR(MODEL, LqrWeights(q_integral=(3000.0, 3000.0, 1000.0),
                                          q_angle=(6000.0, 6000.0, 4000.0),
                                          q_rate=(300.0, 300.0, 300.0),
                                          motor_lead_rad_s=None)),
], ids=["pd", "lqr", "pd-no-lead", "lqr-no-lead"])
def test_loop_with_unmodelled_or_modelled_motor_lag_is_stable(make_ctrl, kind: str,
                                                              motor_model: bool) -> None:
    """The real 15 rad/s lag is in the plant; the DOB may or may not model it."""
    dob = make_dob(kind, W_Q, motor_model=motor_model)
    time, angles, d_hat = closed_loop(make_ctrl(), dob, seconds=25.0)
    # N*m: every mode decays (slowest, LQR integral with a DOB, ~0.7 rad/s), so d_hat
    # settles on the true torque
    np.testing.assert_allclose(d_hat[-1], D_STEP, atol=1e-4)
    np.testing.assert_allclose(angles[-1], 0.0, atol=1e-5)  # rad, same reason
    assert np.max(np.abs(angles)) < np.radians(30.0)  # within the tilt limit, no blow-up


@pytest.mark.parametrize("kind", ["vbdob", "abdob"])
def test_motor_model_dob_survives_a_slower_motor_and_a_delay(kind: str) -> None:
    time, angles, d_hat = closed_loop(AttitudeLQR(MODEL), make_dob(kind),
                                      seconds=15.0, motor_rad_s=10.0, delay_ticks=1)
    np.testing.assert_allclose(d_hat[-1], D_STEP, atol=1e-4)  # N*m, settled (stable)
    assert np.max(np.abs(angles)) < np.radians(10.0)


def test_discrete_filters_have_the_right_static_gains() -> None:
    """Constant torque with a constant angle: d_hat = -tau (Q(0) = 1, nominal inverse 0)."""
    for dob in (AccelerationDob(MODEL, DT, W_Q), VelocityDob(MODEL, DT, W_Q),
                AccelerationDob(MODEL, DT, W_Q, MODEL.motor_bandwidth)):
        tau = np.array([0.1, -0.2, 0.05])
        for _ in range(500):
            d_hat = dob.step(np.array([0.1, 0.2, 0.3]), np.zeros(3), tau)
        np.testing.assert_allclose(d_hat, -tau, rtol=1e-9)  # 5 s = 25/w: transient gone
        np.testing.assert_allclose(np.asarray(dob.discrete_torque.D), 0.0)  # no feedthrough


def test_first_step_after_reset_is_quiet() -> None:
    for dob in (AccelerationDob(MODEL), VelocityDob(MODEL)):
        euler, rate = np.array([0.2, -0.1, 3.0]), np.array([0.5, 0.0, -0.3])
        np.testing.assert_allclose(dob.step(euler, rate, np.zeros(3)), 0.0, atol=1e-15)
        dob.step(euler + 0.01, rate, np.zeros(3))
        dob.reset()
        np.testing.assert_allclose(dob.step(euler, rate, np.zeros(3)), 0.0, atol=1e-15)


def test_abdob_unwraps_yaw_through_pi() -> None:
    dob = AccelerationDob(MODEL, DT, W_Q)
    yaw_rate = 1.0  # rad/s, constant: no angular acceleration, no torque
    worst = 0.0
    for k in range(600):  # 6 s: passes +pi once
        yaw = (np.pi - 1.0 + yaw_rate * k * DT + np.pi) % (2 * np.pi) - np.pi
        d_hat = dob.step(np.array([0.0, 0.0, yaw]), np.zeros(3), np.zeros(3))
        if k > 300:
            worst = max(worst, abs(d_hat[2]))
    # the ramp's start transient has decayed (e^-15); a 2 pi jump would give ~I w^2 2 pi = 6
    assert worst < 1e-6


def test_dob_registry_builds_each_kind_and_rejects_unknown_names_naming_the_key() -> None:
    assert isinstance(make_dob("none"), NoDob)
    assert make_dob("vbdob").kind == "vbdob"
    abdob = make_dob("abdob")
    assert isinstance(abdob, AccelerationDob)
    assert abdob.motor_bandwidth_rad_s == MODEL.motor_bandwidth  # the autopilot's wiring
    assert make_dob("abdob", motor_model=False).motor_bandwidth_rad_s is None
    with pytest.raises(ValueError, match="dob = 'kalman'"):
        DOB_REGISTRY.factory("kalman")
