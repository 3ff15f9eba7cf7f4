"""Extended Kalman filter on the full nonlinear quadrotor model (thesis section 6.1.2).

Model: eq. 3.18 rewritten in NED/FRD
------------------------------------
State ``x`` (16): pos_ned p, vel_ned v, Euler angles eta = (phi, theta, psi), body rates
omega = (p, q, r), motor thrusts T1..T4 (layout in :mod:`fcu.estimation.state`). Input: the four PWM
commands ``u`` held over the tick (zero-order hold). Derivation, with R = Rz(psi) Ry(theta)
Rx(phi) (body FRD to NED) and thrust along -z_body:

    dp/dt     = v
    dv/dt     = g e3 - (U1 / m) R e3,    U1 = T1 + T2 + T3 + T4                 (eq. 3.5)
                R e3 = (c_psi s_theta c_phi + s_psi s_phi,
                        s_psi s_theta c_phi - c_psi s_phi,
                        c_theta c_phi)
    deta/dt   = W(phi, theta) omega,     W = [[1, s_phi t_theta, c_phi t_theta],
                                              [0, c_phi,         -s_phi       ],
                                              [0, s_phi/c_theta, c_phi/c_theta]]  (eq. 3.10)
    domega/dt = I^-1 (tau - omega x I omega),
                tau = (L (T3 - T4), L (T1 - T2), K_psi (T1 + T2 - T3 - T4))   (eq. 3.6, 3.17)
    dT_i/dt   = w (K u_i - T_i)                                                (eq. 3.1)

Against eq. 3.18 (z up): thesis Z = -z, so its ``Z'' = c_phi c_theta U1/m - g`` becomes
``z'' = g - c_phi c_theta U1/m``; its x and y rows use the corrupted R of eq. 3.9, replaced here
by the third column of the standard ZYX R (at hover ``x'' = -g theta``, ``y'' = g phi``); its
``q'`` and ``r'`` rows read ``I_x``/``I_y`` for ``I_xx``/``I_yy``. Gyroscopic rotor moments
are neglected as in the thesis. The wind force is not modelled: it is what the velocity
process noise stands for. Loss of effectiveness is not a state either (thesis section 6.1.2):
a motor that delivers less than ``K u`` (or a wind torque) is taken up by the thrust states,
which is what their large process noise allows for (:class:`EkfProcessNoise`).

Ground contact mirrors the simulator's ground plane: when the estimated vehicle is within
``ground_margin_m`` of ``ground_z_ned`` and its estimated thrust is below its weight at the
start of a tick, the ground holds it, so dv/dt = 0 and domega/dt = 0 over that tick (and
their Jacobian rows are zero). Without this, a vehicle idling on the ground would look like a
free fall and drag the thrust states up to the weight.

Discretisation and Jacobians
----------------------------
The mean is propagated over the tick by one RK4 step of the model (``w dt = 0.15`` for the
motor lag at 100 Hz, so the RK4 local error is ~(w dt)^5/120 = 6e-7 of the state). The
analytic Jacobian ``A = df/dx`` is recomputed every tick at ``x_{k|k}`` and the transition
matrix is its fourth-order exponential series ``F = sum_{n<=4} (A dt)^n / n!``. For a linear
model that is exactly the matrix RK4 applies, so mean and covariance use one discretisation;
the truncation error against ``expm(A dt)`` is below ``(0.15)^5/120``. ``I + A dt`` would be
off by 1.2 % on the motor lag alone (``e^-0.15`` versus 0.85). The discrete process noise is
Van Loan's integral ``Q = int_0^dt Phi(s) Qc Phi(s)' ds``, evaluated by three-point
Gauss-Legendre quadrature with ``Phi(s)`` the fourth-order series of ``expm(A s)``: positive
semi-definite by construction (a sum of ``Phi Qc Phi'``) and, on the correlation scale
``sqrt(Q_ii Q_jj)``, within 1e-4 of Van Loan's exact matrix exponential at 100 Hz
(tests/fcu/test_ekf.py; two points would be 2 % off, as the thrust-to-angle chains make the
integrand a degree-4 polynomial). Kernels are numba-compiled.

Measurements
------------
All sensors are linear in the state at their own sample time, ``h = S x``; a batch averaged
over a tick (mean time ``t_k - delta``) is mapped to the tick by
``h(x) = S (x - delta f(x, u))``, with Jacobian ``H = S (I - delta A)``. Sequential updates,
in the order mocap_pos (x, y only when height comes from the baro), baro (``alt = -z``; only
with ``height_source="baro"``), mocap_att (yaw innovation wrapped to [-pi, pi)), gyro, and the
accelerometer's body-z axis: thrust is along -z_body whatever the attitude, so the specific
force there is ``-(T1 + T2 + T3 + T4)/m`` plus drag. It pins the total thrust, which mocap
height alone leaves to a double differentiation (without it a 45 % loss biases vz by 3 cm/s).
Its R adds ``accel_z_model_sigma^2`` for the drag, and it is skipped on the ground (the
accelerometer then feels the ground reaction). Each update uses ``R = sigma^2 / n`` for a batch
of ``n`` samples. The accelerometer's x and y axes (drag only) are not used.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from numba import njit
from numpy.typing import ArrayLike

from fcu.estimation.state import (
    STATE_DIM,
    THRUST,
    YAW_INDEX,
    Z_INDEX,
    FloatArray,
    HeightSource,
    InitialUncertainty,
    Innovation,
    SampleBatch,
    SensorNoise,
    StateEstimate,
    check_height_source,
    group_samples,
)
from fcu.hal import SensorSampleLike
from fcu.model import VehicleModel

# ---- packed parameter vector of the numba kernels ------------------------------------------
_P_K, _P_W, _P_L, _P_KPSI, _P_M, _P_G, _P_IXX, _P_IYY, _P_IZZ = range(9)


def pack_params(model: VehicleModel) -> FloatArray:
    """Pack the nominal model for the numba kernels.

    Returns
    -------
    ndarray, shape (9,)
        [K (N), w (rad/s), L (m), K_psi (m), m (kg), g (m/s^2), Ixx, Iyy, Izz (kg m^2)].
    """
    ixx, iyy, izz = model.inertia
    return np.array([model.thrust_gain, model.motor_bandwidth, model.arm_length,
                     model.yaw_gain, model.mass, model.gravity, ixx, iyy, izz])


@njit(cache=True, error_model="numpy")
def model_derivative(x: FloatArray, u: FloatArray, p: FloatArray,
                     on_ground: bool) -> FloatArray:
    """Right-hand side ``dx/dt = f(x, u)`` of the NED/FRD model (module docstring).

    Parameters
    ----------
    x : ndarray, shape (16,)
        State (layout of :mod:`fcu.estimation.state`).
    u : ndarray, shape (4,)
        PWM commands held over the step.
    p : ndarray, shape (9,)
        Packed parameters (:func:`pack_params`).
    on_ground : bool
        The ground holds the vehicle: no translational or angular acceleration.

    Returns
    -------
    ndarray, shape (16,)
        State derivative, SI units per second.
    """
    k, w, arm, kpsi, m, g = p[0], p[1], p[2], p[3], p[4], p[5]
    ixx, iyy, izz = p[6], p[7], p[8]
    phi, th, psi = x[6], x[7], x[8]
    pr, qr, rr = x[9], x[10], x[11]
    t1, t2, t3, t4 = x[12], x[13], x[14], x[15]
    sphi, cphi = math.sin(phi), math.cos(phi)
    sth, cth = math.sin(th), math.cos(th)
    spsi, cpsi = math.sin(psi), math.cos(psi)
    xd = np.zeros(16)
    # dp/dt = v
    xd[0] = x[3]
    xd[1] = x[4]
    xd[2] = x[5]
    if not on_ground:
        # dv/dt = g e3 - (U1/m) R e3
        a = -(t1 + t2 + t3 + t4) / m
        xd[3] = a * (cpsi * sth * cphi + spsi * sphi)
        xd[4] = a * (spsi * sth * cphi - cpsi * sphi)
        xd[5] = g + a * cth * cphi
    # deta/dt = W(phi, theta) omega
    xd[6] = pr + (qr * sphi + rr * cphi) * sth / cth
    xd[7] = qr * cphi - rr * sphi
    xd[8] = (qr * sphi + rr * cphi) / cth
    if not on_ground:
        # domega/dt = I^-1 (tau - omega x I omega)
        xd[9] = ((iyy - izz) * qr * rr + arm * (t3 - t4)) / ixx
        xd[10] = ((izz - ixx) * pr * rr + arm * (t1 - t2)) / iyy
        xd[11] = ((ixx - iyy) * pr * qr + kpsi * (t1 + t2 - t3 - t4)) / izz
    # dT/dt = w (K u - T)
    for i in range(4):
        xd[12 + i] = w * (k * u[i] - x[12 + i])
    return xd


@njit(cache=True, error_model="numpy")
def model_jacobian(x: FloatArray, p: FloatArray, on_ground: bool) -> FloatArray:
    """Analytic Jacobian ``A = df/dx`` of :func:`model_derivative`, shape (16, 16).

    (``df/du`` is not needed: the input is known.)
    """
    w, arm, kpsi, m = p[1], p[2], p[3], p[4]
    ixx, iyy, izz = p[6], p[7], p[8]
    phi, th, psi = x[6], x[7], x[8]
    pr, qr, rr = x[9], x[10], x[11]
    u1 = x[12] + x[13] + x[14] + x[15]
    sphi, cphi = math.sin(phi), math.cos(phi)
    sth, cth = math.sin(th), math.cos(th)
    spsi, cpsi = math.sin(psi), math.cos(psi)
    a = np.zeros((16, 16))
    # d(dp/dt)/dv = I
    a[0, 3] = 1.0
    a[1, 4] = 1.0
    a[2, 5] = 1.0
    if not on_ground:
        s = -u1 / m
        # d(dv/dt)/d(phi, theta, psi) = -(U1/m) d(R e3)/d(eta)
        a[3, 6] = s * (-cpsi * sth * sphi + spsi * cphi)
        a[3, 7] = s * (cpsi * cth * cphi)
        a[3, 8] = s * (-spsi * sth * cphi + cpsi * sphi)
        a[4, 6] = s * (-spsi * sth * sphi - cpsi * cphi)
        a[4, 7] = s * (spsi * cth * cphi)
        a[4, 8] = s * (cpsi * sth * cphi + spsi * sphi)
        a[5, 6] = s * (-cth * sphi)
        a[5, 7] = s * (-sth * cphi)
        # d(dv/dt)/dT_i = -(R e3)/m
        for i in range(4):
            a[3, 12 + i] = -(cpsi * sth * cphi + spsi * sphi) / m
            a[4, 12 + i] = -(spsi * sth * cphi - cpsi * sphi) / m
            a[5, 12 + i] = -(cth * cphi) / m
    # d(deta/dt)/d(phi, theta)
    tth = sth / cth
    qs_rc = qr * sphi + rr * cphi
    qc_rs = qr * cphi - rr * sphi
    a[6, 6] = qc_rs * tth
    a[6, 7] = qs_rc / (cth * cth)
    a[7, 6] = -qs_rc
    a[8, 6] = qc_rs / cth
    a[8, 7] = qs_rc * sth / (cth * cth)
    # d(deta/dt)/d(omega) = W
    a[6, 9] = 1.0
    a[6, 10] = sphi * tth
    a[6, 11] = cphi * tth
    a[7, 10] = cphi
    a[7, 11] = -sphi
    a[8, 10] = sphi / cth
    a[8, 11] = cphi / cth
    if not on_ground:
        # d(domega/dt)/d(omega): gyroscopic coupling
        a[9, 10] = (iyy - izz) * rr / ixx
        a[9, 11] = (iyy - izz) * qr / ixx
        a[10, 9] = (izz - ixx) * rr / iyy
        a[10, 11] = (izz - ixx) * pr / iyy
        a[11, 9] = (ixx - iyy) * qr / izz
        a[11, 10] = (ixx - iyy) * pr / izz
        # d(domega/dt)/dT = I^-1 (rows 2-4 of eq. 3.17)
        a[9, 14] = arm / ixx
        a[9, 15] = -arm / ixx
        a[10, 12] = arm / iyy
        a[10, 13] = -arm / iyy
        a[11, 12] = kpsi / izz
        a[11, 13] = kpsi / izz
        a[11, 14] = -kpsi / izz
        a[11, 15] = -kpsi / izz
    # d(dT/dt)/dT = -w I
    for i in range(4):
        a[12 + i, 12 + i] = -w
    return a


@njit(cache=True, error_model="numpy")
def rk4_step(x: FloatArray, u: FloatArray, dt: float, p: FloatArray,
             on_ground: bool) -> FloatArray:
    """One RK4 step of :func:`model_derivative` over ``dt`` s with ``u`` held; shape (16,)."""
    k1 = model_derivative(x, u, p, on_ground)
    k2 = model_derivative(x + 0.5 * dt * k1, u, p, on_ground)
    k3 = model_derivative(x + 0.5 * dt * k2, u, p, on_ground)
    k4 = model_derivative(x + dt * k3, u, p, on_ground)
    return x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@njit(cache=True, error_model="numpy")
def discrete_transition(x: FloatArray, u: FloatArray, dt: float, p: FloatArray,
                        on_ground: bool,
                        qc_diag: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Propagate the mean and build ``F`` and ``Q`` for one step (module docstring).

    Parameters
    ----------
    x : ndarray, shape (16,)
        Posterior state ``x_{k|k}``.
    u : ndarray, shape (4,)
        PWM held over the step.
    dt : float
        Step, s.
    p : ndarray, shape (9,)
        Packed parameters.
    on_ground : bool
        Ground holds the vehicle over this step.
    qc_diag : ndarray, shape (16,)
        Continuous process-noise spectral densities (state units squared per second).

    Returns
    -------
    x_next : ndarray, shape (16,)
        ``x_{k+1|k}`` by RK4.
    f_mat : ndarray, shape (16, 16)
        ``F = sum_{n<=4} (A dt)^n / n!`` with ``A`` at ``x_{k|k}``.
    q_mat : ndarray, shape (16, 16)
        ``Q = dt sum_j w_j Phi(c_j dt) Qc Phi(c_j dt)'`` (3-point Gauss-Legendre on [0, 1]),
        ``Phi(s) = sum_{n<=4} (A s)^n / n!``.
    """
    n = 16
    x_next = rk4_step(x, u, dt, p, on_ground)
    ad = model_jacobian(x, p, on_ground)
    ad *= dt  # A dt
    ad2 = ad @ ad
    ad3 = ad2 @ ad
    ad4 = ad3 @ ad
    # (the element-wise sums below are written as loops: the same operations in the same
    # order as the matrix expressions in the comments, without their temporaries)
    # F = I + A dt + (A dt)^2/2 + (A dt)^3/6 + (A dt)^4/24
    f_mat = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            eye_ij = 1.0 if i == j else 0.0
            f_mat[i, j] = (eye_ij + ad[i, j] + ad2[i, j] / 2.0 + ad3[i, j] / 6.0
                           + ad4[i, j] / 24.0)
    # Q = int_0^dt Phi(s) Qc Phi(s)' ds  by 3-point Gauss-Legendre on s = c dt,
    #     Phi(s) = sum_{n<=4} (A s)^n / n!
    q_mat = np.zeros((n, n))
    phi = np.empty((n, n))
    phi_qc = np.empty((n, n))
    r = math.sqrt(0.6) / 2.0
    for c, weight in ((0.5 - r, 5.0 / 18.0), (0.5, 8.0 / 18.0), (0.5 + r, 5.0 / 18.0)):
        c2, c3, c4 = c * c / 2.0, c ** 3 / 6.0, c ** 4 / 24.0
        for i in range(n):
            for j in range(n):
                eye_ij = 1.0 if i == j else 0.0
                # Phi = I + A dt c + (A dt)^2 c^2/2 + (A dt)^3 c^3/6 + (A dt)^4 c^4/24
                phi_ij = (eye_ij + ad[i, j] * c + ad2[i, j] * c2 + ad3[i, j] * c3
                          + ad4[i, j] * c4)
                phi[i, j] = phi_ij
                phi_qc[i, j] = phi_ij * qc_diag[j]  # Phi Qc (Qc diagonal)
        # Q += w Phi Qc Phi'
        term = phi_qc @ phi.T
        for i in range(n):
            for j in range(n):
                q_mat[i, j] += weight * term[i, j]
    q_mat *= dt
    return x_next, f_mat, q_mat


@njit(cache=True, error_model="numpy")
def kalman_update(x: FloatArray, p_mat: FloatArray, y: FloatArray, h_mat: FloatArray,
                  r_mat: FloatArray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                              np.ndarray]:
    """Kalman measurement update for a given innovation (the maths of filterpy's update).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Prior state.
    p_mat : ndarray, shape (n, n)
        Prior covariance.
    y : ndarray, shape (m,)
        Innovation ``z - h(x)``.
    h_mat : ndarray, shape (m, n)
        Measurement Jacobian.
    r_mat : ndarray, shape (m, m)
        Measurement noise covariance.

    Returns
    -------
    x_post, p_post, s_mat, s_inv, k_gain : ndarrays, shapes (n,), (n, n), (m, m), (m, m), (n, m)
    """
    # P H'
    pht = p_mat @ h_mat.T
    # S = H P H' + R
    s_mat = h_mat @ pht + r_mat
    # S^-1
    s_inv = np.linalg.inv(s_mat)
    # K = P H' S^-1
    k_gain = pht @ s_inv
    # x = x + K y
    x_post = x + k_gain @ y
    # P = (I - K H) P (I - K H)' + K R K'   (Joseph form)
    ikh = np.eye(x.shape[0]) - k_gain @ h_mat
    p_post = ikh @ p_mat @ ikh.T + k_gain @ r_mat @ k_gain.T
    p_post = 0.5 * (p_post + p_post.T)
    return x_post, p_post, s_mat, s_inv, k_gain


@njit(cache=True, error_model="numpy")
def predict_covariance(x: FloatArray, p_mat: FloatArray, u: FloatArray, dt: float,
                       p: FloatArray, on_ground: bool, qc_diag: FloatArray
                       ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """One filterpy ``predict`` of the EKF in a single compiled call.

    Returns ``x_{k+1|k}`` (RK4, yaw wrapped to [-pi, pi)), ``F``, ``Q``
    (:func:`discrete_transition`) and ``P_{k+1|k} = F P F' + Q``.
    """
    # x_{k+1|k} = RK4(f, x_{k|k}, u_k, dt);  F = sum (A dt)^n/n!;  Q = Van Loan (see module)
    x_next, f_mat, q_mat = discrete_transition(x, u, dt, p, on_ground, qc_diag)
    x_next[YAW_INDEX] = (x_next[YAW_INDEX] + math.pi) % (2.0 * math.pi) - math.pi
    # P = F P F' + Q
    p_next = (f_mat @ p_mat) @ f_mat.T + q_mat
    return x_next, f_mat, q_mat, p_next


@njit(cache=True, error_model="numpy")
def channel_update(x: FloatArray, p_mat: FloatArray, z: FloatArray, sel: FloatArray,
                   delta: float, u: FloatArray, p: FloatArray, on_ground: bool,
                   r_mat: FloatArray, wrap_yaw: bool
                   ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
                              FloatArray, float]:
    """One sequential measurement update of a channel ``h(x) = S (x - delta f(x, u))``.

    One of the estimator's sequential updates in one compiled call (module docstring,
    "Measurements"): ``H = S (I - delta A(x))`` (``S`` when ``|delta| < 1e-9``),
    ``y = z - h(x)`` (yaw wrapped when ``wrap_yaw``), :func:`kalman_update`, posterior yaw
    wrapped, and the NIS.

    Returns
    -------
    x_post, p_post, y, s_mat, s_inv, k_gain, nis
        Shapes (16,), (16, 16), (m,), (m, m), (m, m), (16, m); ``nis = y' S^-1 y``.
    """
    if abs(delta) < 1e-9:
        h_mat = sel
        hx = sel @ x
    else:
        # H = S (I - delta A(x))
        h_mat = sel - delta * (sel @ model_jacobian(x, p, on_ground))
        # h(x) = S (x - delta f(x, u))
        hx = sel @ (x - delta * model_derivative(x, u, p, on_ground))
    # y = z - h(x)  (attitude: yaw difference wrapped)
    y = z - hx
    if wrap_yaw:
        y[2] = (y[2] + math.pi) % (2.0 * math.pi) - math.pi
    # K = P H' (H P H' + R)^-1;  x = x + K y;  P = (I-KH) P (I-KH)' + K R K'
    x_post, p_post, s_mat, s_inv, k_gain = kalman_update(x, p_mat, y, h_mat, r_mat)
    x_post[YAW_INDEX] = (x_post[YAW_INDEX] + math.pi) % (2.0 * math.pi) - math.pi
    # NIS = y' S^-1 y
    nis = y @ s_inv @ y
    return x_post, p_post, y, s_mat, s_inv, k_gain, nis


@njit(cache=True, error_model="numpy")
def sequential_updates(x: FloatArray, p_mat: FloatArray, u: FloatArray, p: FloatArray,
                       on_ground: bool, sel_stack: FloatArray, rows: np.ndarray,
                       sample_var: FloatArray, model_var: FloatArray, wrap_yaw: np.ndarray,
                       counts: np.ndarray, deltas: FloatArray, z_stack: FloatArray
                       ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
                                  FloatArray, FloatArray, int]:
    """A tick's sequential updates, channel after channel, each by :func:`channel_update`.

    Parameters
    ----------
    x, p_mat : ndarrays, shapes (16,), (16, 16)
        Prior state and covariance.
    u, p, on_ground
        As for :func:`channel_update`.
    sel_stack : ndarray, shape (rows_total, 16)
        Every channel's selection ``S``, stacked in update order.
    rows : ndarray of int, shape (n_ch, 2)
        First and end row of each channel in ``sel_stack`` and ``z_stack``.
    sample_var, model_var : ndarrays, shape (n_ch,)
        Noise variance of one sample (divided by the count) and the model error (not), so
        ``R = (sample_var / count + model_var) I``.
    wrap_yaw : ndarray of bool, shape (n_ch,)
        The channel's third entry is a yaw (its innovation is wrapped).
    counts : ndarray of int, shape (n_ch,)
        Samples averaged into each channel's measurement; 0 = no update this tick.
    deltas : ndarray, shape (n_ch,)
        How long before the tick each channel's batch was taken, s.
    z_stack : ndarray, shape (rows_total,)
        The measurements (entries of channels without an update are ignored).

    Returns
    -------
    x_post, p_post, y_stack, s_stack, nis, s_inv, k_gain, last
        Posterior; innovations stacked like ``z_stack``; each channel's ``S`` in the
        top-left block of ``s_stack[c]`` (shape (n_ch, m_max, m_max)); each NIS; ``S^-1`` and
        ``K`` of the last update; the index of the last channel updated (-1: none).
    """
    n_ch = rows.shape[0]
    m_max = 1
    for c in range(n_ch):
        m_max = max(m_max, rows[c, 1] - rows[c, 0])
    y_stack = np.zeros(z_stack.shape[0])
    s_stack = np.zeros((n_ch, m_max, m_max))
    nis = np.zeros(n_ch)
    s_inv = np.zeros((0, 0))
    k_gain = np.zeros((x.shape[0], 0))
    last = -1
    for c in range(n_ch):
        if counts[c] <= 0:
            continue
        i0, i1 = rows[c, 0], rows[c, 1]
        m = i1 - i0
        # R = sigma^2 / n for the mean of n samples (+ model error, not reduced)
        r_mat = np.zeros((m, m))
        for i in range(m):
            r_mat[i, i] = sample_var[c] / counts[c] + model_var[c]
        x, p_mat, y, s_mat, s_inv, k_gain, nis[c] = channel_update(
            x, p_mat, z_stack[i0:i1].copy(), np.ascontiguousarray(sel_stack[i0:i1]),
            deltas[c], u, p, on_ground, r_mat, wrap_yaw[c])
        y_stack[i0:i1] = y
        s_stack[c, :m, :m] = s_mat
        last = c
    return x, p_mat, y_stack, s_stack, nis, s_inv, k_gain, last


@dataclass(frozen=True, kw_only=True)
class EkfProcessNoise:
    """Continuous-time process-noise spectral densities of the EKF (white noise on each row).

    The thrust states double as the estimator of everything that pushes or twists the
    airframe other than ``K u`` through the lag: loss of effectiveness (not a state, thesis
    section 6.1.2), wind torque, inertia error. So the thrust rows carry the large noise and
    the angular-acceleration rows a small one: a persistent torque error then shows up as a
    thrust-state correction (which the next prediction keeps) instead of being re-absorbed
    tick after tick as rate noise. Because ``dT/dt = w (K u - T)`` pulls the thrust back to
    ``K u`` at w = 15 rad/s, holding an offset ``dT`` takes a large density: its stationary
    spread is ``sqrt(q / 2 w)`` = 1.4 N at q = 60, about a 40 % loss of one motor at hover.

    * ``thrust``: 60 N^2/s (above).
    * ``ang_accel``: 0.01 (rad/s^2)^2/Hz: the rigid-body rotation given the thrusts is exact up
      to the gyroscopic rotor moments (neglected, tiny).
    * ``accel``: unmodelled specific force, mostly wind drag: 0.25 N/(m/s) rotor drag on
      0.3 m/s gusts of ~1 s correlation is 0.05 m/s^2 on 1.42 kg, a spectral density of
      ~2 sigma^2 tau = 0.005; 0.02 leaves room for mass error.
    * ``pos``, ``euler``: the kinematic rows are exact; a floor keeps ``Q`` well conditioned.
    """

    pos: float = 1e-8  # m^2/s
    accel: float = 0.02  # (m/s^2)^2/Hz, each NED axis
    euler: float = 1e-7  # rad^2/s
    ang_accel: float = 0.01  # (rad/s^2)^2/Hz, each body axis
    thrust: float = 60.0  # N^2/s, each motor

    def __post_init__(self) -> None:
        for name in ("pos", "accel", "euler", "ang_accel", "thrust"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} = {value!r}: spectral density must be finite, >= 0")

    def diagonal(self) -> FloatArray:
        """``Qc`` diagonal in the state order, shape (16,)."""
        return np.array([self.pos] * 3 + [self.accel] * 3 + [self.euler] * 3
                        + [self.ang_accel] * 3 + [self.thrust] * 4)


class _Channel:
    """A measurement channel: ``h(x) = S x`` at the sample time, and its noise."""

    def __init__(self, sensor: str, selection: FloatArray, sigma: float,
                 value_index: tuple[int, ...], model_sigma: float = 0.0) -> None:
        self.sensor = sensor
        self.selection = np.ascontiguousarray(selection, dtype=float)  # S, shape (m, 16)
        self.value_index = np.array(value_index)  # entries of the sample value used
        if list(value_index) != list(range(value_index[0], value_index[-1] + 1)):
            raise ValueError(f"value_index = {value_index!r}: must be consecutive")
        self.value_slice = slice(value_index[0], value_index[-1] + 1)  # the same, as a slice
        m = self.selection.shape[0]
        self.sample_r = np.eye(m) * sigma ** 2  # R of one sample; divided by n for a mean
        self.model_r = np.eye(m) * model_sigma ** 2  # model error, not reduced by averaging
        self.wrap_yaw = sensor == "mocap_att"  # innovation's third entry is a yaw difference
        self.no_value = [0.0] * m  # placeholder measurement of a tick without an update


def _select(columns: tuple[int, ...], signs: tuple[float, ...] | None = None) -> FloatArray:
    """Selection matrix picking ``columns`` of the state (with ``signs``), shape (m, 16)."""
    sel = np.zeros((len(columns), STATE_DIM))
    sel[np.arange(len(columns)), list(columns)] = 1.0 if signs is None else signs
    return sel


class _QuadrotorEKF(ExtendedKalmanFilter):
    """filterpy's EKF with the nonlinear prediction of this module and a compiled update.

    filterpy's ``predict(u)`` calls :meth:`predict_x`, then applies ``P = F P F' + Q`` with the
    ``F`` and ``Q`` that :meth:`predict_x` just set, and stores ``x_prior``, ``P_prior``;
    :meth:`predict` here does the same in one compiled call (:func:`predict_covariance`).

    :meth:`update` keeps filterpy's signature and effects (``y``, ``S``, ``SI``, ``K``, ``z``,
    ``x_post``, ``P_post``; Joseph-form covariance) but runs the matrix algebra in
    :func:`kalman_update`: filterpy's own version (scipy ``inv`` with its argument checks,
    ``deepcopy``) costs 16-35 us per call on this machine, and a tick has three or four.
    ``tests/fcu/test_ekf.py`` checks the two against each other. The estimator goes one step
    further and runs a whole tick's updates in one compiled call (:func:`sequential_updates`,
    the same algebra), then sets the same attributes as the last :meth:`update` would.
    """

    x: FloatArray
    P: FloatArray
    F: FloatArray
    Q: FloatArray
    y: FloatArray
    S: FloatArray
    SI: FloatArray
    K: FloatArray
    z: FloatArray
    x_prior: FloatArray
    P_prior: FloatArray
    x_post: FloatArray
    P_post: FloatArray

    def __init__(self, params: FloatArray, qc_diag: FloatArray) -> None:
        super().__init__(dim_x=STATE_DIM, dim_z=3)
        self.params = params
        self.qc_diag = qc_diag
        self.x = np.zeros(STATE_DIM)
        self.step_dt_s = 0.0  # set before each predict()
        self.on_ground = False  # set before each predict()

    def predict(self, u: FloatArray = 0) -> None:  # type: ignore[assignment]
        """filterpy's ``predict`` (``predict_x``, ``P = F P F' + Q``, priors), compiled."""
        self.x, self.F, self.Q, self.P = predict_covariance(
            self.x, self.P, u, self.step_dt_s, self.params, self.on_ground, self.qc_diag)
        self.x_prior = self.x.copy()
        self.P_prior = self.P.copy()

    def predict_x(self, u: FloatArray = 0) -> None:  # type: ignore[assignment]
        # x_{k+1|k} = RK4(f, x_{k|k}, u_k, dt);  F = sum (A dt)^n/n!;  Q = Van Loan (see module)
        x_next, f_mat, q_mat = discrete_transition(self.x, u, self.step_dt_s, self.params,
                                                   self.on_ground, self.qc_diag)
        x_next[YAW_INDEX] = (x_next[YAW_INDEX] + math.pi) % (2.0 * math.pi) - math.pi
        self.x = x_next
        self.F = f_mat
        self.Q = q_mat

    def update(self, z: FloatArray | None, HJacobian: Callable[..., FloatArray],  # noqa: N803
               Hx: Callable[..., FloatArray], R: FloatArray | float | None = None,  # noqa: N803
               args: tuple[object, ...] = (), hx_args: tuple[object, ...] = (),
               residual: Callable[[FloatArray, FloatArray], FloatArray] = np.subtract,
               ) -> None:
        """filterpy's ``ExtendedKalmanFilter.update`` contract, compiled algebra."""
        if z is None:
            self.x_post = self.x.copy()
            self.P_post = self.P.copy()
            return
        r_mat: FloatArray
        if R is None:
            r_mat = np.asarray(self.R, dtype=float)
        elif isinstance(R, (int, float)):
            r_mat = np.eye(len(z)) * float(R)
        else:
            r_mat = np.asarray(R, dtype=float)
        h_mat = HJacobian(self.x, *args)
        # y = z - h(x)
        self.y = residual(z, Hx(self.x, *hx_args))
        # K = P H' (H P H' + R)^-1;  x = x + K y;  P = (I-KH) P (I-KH)' + K R K'
        self.x, self.P, self.S, self.SI, self.K = kalman_update(
            self.x, self.P, self.y, h_mat, r_mat)
        self.z = np.array(z, dtype=float)
        self.x_post = self.x.copy()
        self.P_post = self.P.copy()


class ExtendedKalmanEstimator:
    """EKF state estimator of the autopilot (thesis section 6.1.2), built on filterpy.

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe (Table 7.1).
    dt_s : float
        Nominal control-tick period, s (100 Hz: 0.01). A longer gap between two ticks is
        covered by several RK4 steps of at most ``dt_s``.
    height_source : {"mocap", "baro"}
        Where height comes from (module :mod:`fcu.estimation.state`).
    noise : SensorNoise
        Assumed measurement noise.
    process_noise : EkfProcessNoise
        Continuous process-noise spectral densities.
    initial_uncertainty : InitialUncertainty
        Covariance used by :meth:`reset` when the initial estimate carries none.
    ground_z_ned : float or None
        z (NED, m) of the ground plane, or None for no ground contact.
    ground_margin_m : float
        Distance above the ground plane within which the vehicle counts as on the ground, m.
    accel_z_model_sigma : float or None
        Model error of the accelerometer's thrust measurement, m/s^2 (vertical drag: 0.35
        N/(m/s) on 0.3 m/s of vertical gust is 0.07 m/s^2 on 1.42 kg); None leaves the
        accelerometer out.

    Notes
    -----
    Each tick the autopilot calls ``step(time_s, pwm_applied, samples)`` (or
    :meth:`step_grouped` with the samples already averaged) with the tick time,
    the PWM that was held since the previous tick (the command returned by the previous tick,
    after saturation) and the samples produced since the previous tick.
    """

    def __init__(self, model: VehicleModel, dt_s: float = 0.01,
                 height_source: HeightSource = "mocap", *,
                 noise: SensorNoise | None = None,
                 process_noise: EkfProcessNoise | None = None,
                 initial_uncertainty: InitialUncertainty | None = None,
                 ground_z_ned: float | None = 0.0,
                 ground_margin_m: float = 0.02,
                 accel_z_model_sigma: float | None = 0.1) -> None:
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be a finite number > 0 s")
        if not (math.isfinite(ground_margin_m) and ground_margin_m >= 0):
            raise ValueError(f"ground_margin_m = {ground_margin_m!r}: must be >= 0 m")
        self.model = model
        self.dt_s = float(dt_s)
        self.height_source = check_height_source(height_source)
        self.noise = noise if noise is not None else SensorNoise()
        self.process_noise = process_noise if process_noise is not None else EkfProcessNoise()
        self.initial_uncertainty = (initial_uncertainty if initial_uncertainty is not None
                                    else InitialUncertainty())
        self.ground_z_ned = ground_z_ned
        self.ground_margin_m = float(ground_margin_m)
        if accel_z_model_sigma is not None and not (math.isfinite(accel_z_model_sigma)
                                                    and accel_z_model_sigma >= 0):
            raise ValueError(f"accel_z_model_sigma = {accel_z_model_sigma!r}: must be >= 0 "
                             "m/s^2, or None to leave the accelerometer out")
        self.accel_z_model_sigma = accel_z_model_sigma
        self._params = pack_params(model)
        self._weight_n = model.mass * model.gravity
        self._channels = self._make_channels()
        self._kinds = frozenset(c.sensor for c in self._channels)
        # the channels stacked for the compiled update of a whole tick (sequential_updates)
        self._sel_stack = np.ascontiguousarray(np.vstack([c.selection for c in self._channels]))
        sizes = np.array([c.selection.shape[0] for c in self._channels])
        ends = np.cumsum(sizes)
        self._rows = np.ascontiguousarray(np.column_stack((ends - sizes, ends)), dtype=np.int64)
        self._rows_list: list[tuple[int, int]] = [(int(a), int(b)) for a, b in self._rows]
        self._sample_var = np.array([float(c.sample_r[0, 0]) for c in self._channels])
        self._model_var = np.array([float(c.model_r[0, 0]) for c in self._channels])
        self._wrap_yaw = np.array([c.wrap_yaw for c in self._channels])
        self.filter = _QuadrotorEKF(self._params, self.process_noise.diagonal())
        self._innovations: dict[str, Innovation] = {}
        # (sensor, y, S, NIS) of this tick's updates, turned into _innovations on request
        self._innovation_parts: list[tuple[str, FloatArray, FloatArray, float]] = []
        self._time_s = 0.0
        self._estimate: StateEstimate | None = None
        self.reset()

    def _make_channels(self) -> tuple[_Channel, ...]:
        n = self.noise
        channels = []
        if self.height_source == "baro":
            channels.append(_Channel("mocap_pos", _select((0, 1)), n.mocap_pos, (0, 1)))
            # alt = -z
            channels.append(_Channel("baro", _select((Z_INDEX,), (-1.0,)), n.baro, (0,)))
        else:
            channels.append(_Channel("mocap_pos", _select((0, 1, 2)), n.mocap_pos, (0, 1, 2)))
        channels.append(_Channel("mocap_att", _select((6, 7, 8)), n.mocap_att, (0, 1, 2)))
        channels.append(_Channel("gyro", _select((9, 10, 11)), n.gyro, (0, 1, 2)))
        if self.accel_z_model_sigma is not None:
            # body-z specific force f_z = -(T1 + T2 + T3 + T4)/m (thrust along -z_body)
            sel = np.zeros((1, STATE_DIM))
            sel[0, THRUST] = -1.0 / self.model.mass
            channels.append(_Channel("accel", sel, n.accel, (2,), self.accel_z_model_sigma))
        return tuple(channels)

    # ---- life cycle ------------------------------------------------------------------------
    def reset(self, time_s: float = 0.0, initial: StateEstimate | None = None) -> None:
        """Restart the filter.

        Parameters
        ----------
        time_s : float
            Time of the initial estimate, s; the next ``step`` predicts from here.
        initial : StateEstimate or None
            Initial state and covariance diagonal. None: at rest at the origin, level, motors
            off, with the covariance of ``initial_uncertainty`` (the first mocap updates pin
            position and attitude).
        """
        if initial is None:
            x0 = np.zeros(STATE_DIM)
            p0 = self.initial_uncertainty.diagonal()
        else:
            x0 = initial.to_vector()
            p0 = np.array(initial.covariance_diag, dtype=float)
            if p0.shape != (STATE_DIM,) or not np.all(p0 > 0):
                raise ValueError(f"initial.covariance_diag = {p0.tolist()}: must be 16 "
                                 "numbers > 0")
        f = self.filter
        f.x = x0.astype(float)
        f.P = np.diag(p0)
        f.x_prior = f.x.copy()
        f.P_prior = f.P.copy()
        f.x_post = f.x.copy()
        f.P_post = f.P.copy()
        self._time_s = float(time_s)
        self._innovations = {}
        self._innovation_parts = []
        self._estimate = self._make_estimate()

    def step(self, time_s: float, pwm_applied: ArrayLike,
             samples: Iterable[SensorSampleLike]) -> StateEstimate:
        """Predict to ``time_s`` and update with the tick's samples.

        Parameters
        ----------
        time_s : float
            Tick time, s (>= the previous tick's).
        pwm_applied : array_like, shape (4,)
            PWM held over (previous tick, time_s], motors 1..4.
        samples : iterable of SensorSampleLike
            Samples produced since the previous tick.

        Returns
        -------
        StateEstimate
            Posterior at ``time_s``.
        """
        return self.step_grouped(time_s, pwm_applied, group_samples(samples, self._kinds))

    def step_grouped(self, time_s: float, pwm_applied: ArrayLike,
                     batches: Mapping[str, SampleBatch]) -> StateEstimate:
        """:meth:`step` with the tick's samples already averaged by
        :func:`fcu.estimation.state.group_samples` (batches of kinds this filter does not use are
        ignored), so that several estimators can share one grouping."""
        time_s = float(time_s)
        u = np.asarray(pwm_applied, dtype=float).reshape(4)
        dt = time_s - self._time_s
        if dt < -1e-9:
            raise ValueError(f"time_s = {time_s!r}: earlier than the previous tick "
                             f"({self._time_s!r})")
        f = self.filter
        if dt > 1e-9:
            n_sub = max(1, math.ceil(dt / self.dt_s - 1e-6))
            f.on_ground = self._on_ground()
            f.step_dt_s = dt / n_sub
            for _ in range(n_sub):
                # x = RK4(f, x, u, dt); P = F P F' + Q   (filterpy predict)
                f.predict(u=u)
        else:
            f.x_prior = f.x.copy()
            f.P_prior = f.P.copy()
        self._time_s = time_s
        self._innovations = {}
        self._innovation_parts = []
        counts: list[int] = []
        deltas: list[float] = []
        z_l: list[float] = []
        for channel in self._channels:
            batch = batches.get(channel.sensor)
            # on the ground the accelerometer feels the ground reaction, not the thrust
            if batch is not None and not (channel.sensor == "accel" and f.on_ground):
                counts.append(batch.count)
                # s, how long before the tick the batch was taken
                deltas.append(time_s - batch.time_s)
                z_l += batch.value.tolist()[channel.value_slice]
            else:
                counts.append(0)
                deltas.append(0.0)
                z_l += channel.no_value
        if any(counts):
            self._update_all(counts, np.array(deltas), np.array(z_l), u)
        self._estimate = self._make_estimate()
        return self._estimate

    # ---- internals -------------------------------------------------------------------------
    def _on_ground(self) -> bool:
        if self.ground_z_ned is None:
            return False
        x = self.filter.x
        near = x[Z_INDEX] >= self.ground_z_ned - self.ground_margin_m
        return bool(near and float(np.sum(x[THRUST])) < self._weight_n)

    def _update_all(self, counts: list[int], deltas: FloatArray, z_stack: FloatArray,
                    u: FloatArray) -> None:
        """The tick's sequential updates (module docstring, "Measurements") in one call."""
        f = self.filter
        # per channel: h(x) = S (x - delta f(x, u)), H = S (I - delta A(x));  y = z - h(x);
        # S = H P H' + R;  K = P H' S^-1;  x = x + K y;  P = (I - K H) P (I - K H)' + K R K'
        # (filterpy's update contract, as _QuadrotorEKF.update)
        x, p_mat, y_stack, s_stack, nis, s_inv, k_gain, last = sequential_updates(
            f.x, f.P, u, self._params, f.on_ground, self._sel_stack, self._rows,
            self._sample_var, self._model_var, self._wrap_yaw, np.array(counts), deltas,
            z_stack)
        f.x, f.P = x, p_mat
        rows = self._rows_list
        i0, i1 = rows[last]
        f.y, f.S, f.SI, f.K = y_stack[i0:i1], s_stack[last, :i1 - i0, :i1 - i0], s_inv, k_gain
        f.z = z_stack[i0:i1].copy()
        f.x_post = x.copy()
        f.P_post = p_mat.copy()
        # the Innovation records are built on request (last_innovation)
        nis_l = nis.tolist()
        for c, channel in enumerate(self._channels):
            if counts[c] > 0:
                i0, i1 = rows[c]
                self._innovation_parts.append((channel.sensor, y_stack[i0:i1],
                                               s_stack[c, :i1 - i0, :i1 - i0], nis_l[c]))

    def _make_estimate(self) -> StateEstimate:
        f = self.filter
        return StateEstimate._from_owned(self._time_s, f.x.copy(), f.P.diagonal().copy())

    # ---- inspection ------------------------------------------------------------------------
    @property
    def estimate(self) -> StateEstimate:
        """The latest posterior estimate."""
        assert self._estimate is not None
        return self._estimate

    @property
    def time_s(self) -> float:
        """Time of the latest estimate, s."""
        return self._time_s

    @property
    def sensor_kinds(self) -> frozenset[str]:
        """The sensor kinds this estimator uses (samples of other kinds are ignored)."""
        return self._kinds

    @property
    def x(self) -> FloatArray:
        """Posterior state ``x_{k|k}``, shape (16,) (a copy)."""
        return np.array(self.filter.x, dtype=float)

    @property
    def P(self) -> FloatArray:  # noqa: N802 (filter notation)
        """Posterior covariance ``P_{k|k}``, shape (16, 16) (a copy)."""
        return np.array(self.filter.P, dtype=float)

    @property
    def x_prior(self) -> FloatArray:
        """Prior state ``x_{k|k-1}`` of the latest tick, shape (16,) (a copy)."""
        return np.array(self.filter.x_prior, dtype=float)

    @property
    def P_prior(self) -> FloatArray:  # noqa: N802 (filter notation)
        """Prior covariance ``P_{k|k-1}`` of the latest tick, shape (16, 16) (a copy)."""
        return np.array(self.filter.P_prior, dtype=float)

    @property
    def on_ground(self) -> bool:
        """Whether the latest prediction held the vehicle on the ground."""
        return bool(self.filter.on_ground)

    @property
    def last_innovation(self) -> Mapping[str, Innovation]:
        """Innovation, its covariance and NIS of each sensor updated at the latest tick."""
        if self._innovation_parts:
            for sensor, y, s_mat, nis in self._innovation_parts:
                self._innovations[sensor] = Innovation(sensor, self._time_s, y.copy(),
                                                       s_mat.copy(), float(nis))
            self._innovation_parts = []
        return dict(self._innovations)


__all__ = [
    "EkfProcessNoise",
    "ExtendedKalmanEstimator",
    "discrete_transition",
    "kalman_update",
    "model_derivative",
    "model_jacobian",
    "pack_params",
    "rk4_step",
]
