"""The EKF's model: eq. 3.18 in NED/FRD, its Jacobian and its discretisation (numba kernels).

Used by the filter in :mod:`fcu.estimation.ekf` (thesis section 6.1.2).

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
which is what their large process noise allows for
(:class:`~fcu.estimation.ekf.EkfProcessNoise`).

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
(tests/fcu/estimation/test_ekf.py; two points would be 2 % off, as the thrust-to-angle
chains make the integrand a degree-4 polynomial). Kernels are numba-compiled.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation.small_matrix import add_scaled_row, set_scaled_row, transpose_into
from fcu.estimation.state import FloatArray
from fcu.model import VehicleModel
from jitsupport.cache import drop_stale_kernels
from jitsupport.views import refcount_free_kernel

# discrete_transition compiles in the kernels of small_matrix
drop_stale_kernels(__file__, fcu.floats.__file__)

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
    """Right-hand side ``dx/dt = f(x, u)`` of the NED/FRD model (module docstring), shape
    (16,): :func:`model_derivative_into` into a fresh array."""
    xd = np.empty(16)
    model_derivative_into(xd, x, u, p, on_ground)
    return xd


# the two helpers below are inlined where they are called: as calls of their own they were
# compiled once per distinct constant block bound (numba types a literal argument as its
# value), 18 times and 3 times over in a cold build
@njit(cache=True, error_model="numpy", inline="always")
def _rows_meet(first: int, end: int, b0: int, b1: int) -> bool:
    """Whether the rows ``first <= i < end`` include one of ``b0 <= i < b1``."""
    return first < b1 and end > b0


@njit(cache=True, error_model="numpy", inline="always")
def _attitude_trig(phi: float, th: float, psi: float, first: int, end: int
                   ) -> tuple[float, float, float, float, float, float]:
    """sin and cos of roll, pitch and yaw, in that order, when the rows ``first <= i < end``
    include a velocity or attitude row (the only ones that read them); zeros otherwise."""
    if not _rows_meet(first, end, 3, 9):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return (math.sin(phi), math.cos(phi), math.sin(th), math.cos(th), math.sin(psi),
            math.cos(psi))


@refcount_free_kernel
def model_derivative_into(xd: FloatArray, x: FloatArray, u: FloatArray, p: FloatArray,
                          on_ground: bool, first: int = 0, end: int = 16) -> None:
    """Right-hand side ``dx/dt = f(x, u)`` of the NED/FRD model (module docstring), written
    into ``xd``.

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
    first, end : int
        Only the entries ``first <= i < end`` are wanted (those of a measurement that reads
        a few states): each block of rows (position, velocity, attitude, rates, thrusts) is
        written when it has one of them, the trigonometry worked out only for the velocity
        and attitude rows. Default: all.

    xd : ndarray, shape (16,)
        Written: the state derivative, SI units per second (the blocks asked for).
    """
    k, w, arm, kpsi, m, g = p[0], p[1], p[2], p[3], p[4], p[5]
    ixx, iyy, izz = p[6], p[7], p[8]
    phi, th, psi = x[6], x[7], x[8]
    pr, qr, rr = x[9], x[10], x[11]
    t1, t2, t3, t4 = x[12], x[13], x[14], x[15]
    sphi, cphi, sth, cth, spsi, cpsi = _attitude_trig(phi, th, psi, first, end)
    if _rows_meet(first, end, 0, 3):
        # dp/dt = v
        xd[0] = x[3]
        xd[1] = x[4]
        xd[2] = x[5]
    if _rows_meet(first, end, 3, 6):
        if not on_ground:
            # dv/dt = g e3 - (U1/m) R e3
            a = -(t1 + t2 + t3 + t4) / m
            xd[3] = a * (cpsi * sth * cphi + spsi * sphi)
            xd[4] = a * (spsi * sth * cphi - cpsi * sphi)
            xd[5] = g + a * cth * cphi
        else:
            xd[3] = xd[4] = xd[5] = 0.0
    if _rows_meet(first, end, 6, 9):
        # deta/dt = W(phi, theta) omega
        xd[6] = pr + (qr * sphi + rr * cphi) * sth / cth
        xd[7] = qr * cphi - rr * sphi
        xd[8] = (qr * sphi + rr * cphi) / cth
    if _rows_meet(first, end, 9, 12):
        if not on_ground:
            # domega/dt = I^-1 (tau - omega x I omega)
            xd[9] = ((iyy - izz) * qr * rr + arm * (t3 - t4)) / ixx
            xd[10] = ((izz - ixx) * pr * rr + arm * (t1 - t2)) / iyy
            xd[11] = ((ixx - iyy) * pr * qr + kpsi * (t1 + t2 - t3 - t4)) / izz
        else:
            xd[9] = xd[10] = xd[11] = 0.0
    if _rows_meet(first, end, 12, 16):
        # dT/dt = w (K u - T)
        for i in range(4):
            xd[12 + i] = w * (k * u[i] - x[12 + i])


@njit(cache=True, error_model="numpy")
def model_jacobian(x: FloatArray, p: FloatArray, on_ground: bool) -> FloatArray:
    """Analytic Jacobian ``A = df/dx`` of :func:`model_derivative`, shape (16, 16)
    (:func:`model_jacobian_into` into a fresh array)."""
    a = np.empty((16, 16))
    model_jacobian_into(a, x, p, on_ground)
    return a


@refcount_free_kernel
def model_jacobian_into(a: FloatArray, x: FloatArray, p: FloatArray, on_ground: bool,
                        first: int = 0, end: int = 16) -> None:
    """Analytic Jacobian ``A = df/dx`` of :func:`model_derivative`, written into ``a``
    (16, 16). (``df/du`` is not needed: the input is known.) ``first``, ``end``: only the
    rows ``first <= i < end`` are wanted, as for :func:`model_derivative_into` (the blocks
    that have one of them are written, zeros included; default: all).

    Its pattern: ``A`` is block upper triangular in the state order (positions follow the
    velocities, velocities the attitude and thrusts, attitude the rates, rates the thrusts,
    thrusts their commands), about 50 of its 256 entries non-zero.
    """
    w, arm, kpsi, m = p[1], p[2], p[3], p[4]
    ixx, iyy, izz = p[6], p[7], p[8]
    phi, th, psi = x[6], x[7], x[8]
    pr, qr, rr = x[9], x[10], x[11]
    u1 = x[12] + x[13] + x[14] + x[15]
    sphi, cphi, sth, cth, spsi, cpsi = _attitude_trig(phi, th, psi, first, end)
    # each block of rows: zeros, then its non-zero entries
    if _rows_meet(first, end, 0, 3):
        a[0:3, :] = 0.0
        # d(dp/dt)/dv = I
        a[0, 3] = 1.0
        a[1, 4] = 1.0
        a[2, 5] = 1.0
    if _rows_meet(first, end, 3, 6):
        a[3:6, :] = 0.0
    if _rows_meet(first, end, 3, 6) and not on_ground:
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
    if _rows_meet(first, end, 6, 9):
        a[6:9, :] = 0.0
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
    if _rows_meet(first, end, 9, 12):
        a[9:12, :] = 0.0
    if _rows_meet(first, end, 9, 12) and not on_ground:
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
    if _rows_meet(first, end, 12, 16):
        a[12:16, :] = 0.0
        # d(dT/dt)/dT = -w I
        for i in range(4):
            a[12 + i, 12 + i] = -w


@njit(cache=True, error_model="numpy")
def rk4_step(x: FloatArray, u: FloatArray, dt: float, p: FloatArray,
             on_ground: bool) -> FloatArray:
    """One RK4 step of :func:`model_derivative` over ``dt`` s with ``u`` held; shape (16,)
    (:func:`rk4_step_into` into a fresh array)."""
    x_next = np.empty(16)
    rk4_step_into(x_next, x, u, dt, p, on_ground, np.empty((5, 16)))
    return x_next


@refcount_free_kernel
def rk4_step_into(x_next: FloatArray, x: FloatArray, u: FloatArray, dt: float, p: FloatArray,
                  on_ground: bool, stages: FloatArray) -> None:
    """One RK4 step of :func:`model_derivative` over ``dt`` s with ``u`` held, written into
    ``x_next`` (16,) (``stages``: scratch, (5, 16); ``x_next`` may be ``x``)."""
    k1, k2, k3, k4, xs = stages[0], stages[1], stages[2], stages[3], stages[4]
    n = x.shape[0]
    half = 0.5 * dt
    # k1 = f(x);  k2 = f(x + dt/2 k1);  k3 = f(x + dt/2 k2);  k4 = f(x + dt k3)
    model_derivative_into(k1, x, u, p, on_ground)
    for i in range(n):
        xs[i] = x[i] + half * k1[i]
    model_derivative_into(k2, xs, u, p, on_ground)
    for i in range(n):
        xs[i] = x[i] + half * k2[i]
    model_derivative_into(k3, xs, u, p, on_ground)
    for i in range(n):
        xs[i] = x[i] + dt * k3[i]
    model_derivative_into(k4, xs, u, p, on_ground)
    # x_next = x + dt/6 (k1 + 2 k2 + 2 k3 + k4)
    sixth = dt / 6.0
    for i in range(n):
        x_next[i] = x[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


TRANSITION_SCRATCH = (10, 16, 16)
"""Shape of the scratch :func:`discrete_transition_into` works in."""


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
    x_next = np.empty(16)
    f_mat = np.empty((16, 16))
    q_mat = np.empty((16, 16))
    discrete_transition_into(x_next, f_mat, q_mat, x, u, dt, p, on_ground, qc_diag,
                             np.empty(TRANSITION_SCRATCH))
    return x_next, f_mat, q_mat


@refcount_free_kernel
def discrete_transition_into(x_next: FloatArray, f_mat: FloatArray, q_mat: FloatArray,
                             x: FloatArray, u: FloatArray, dt: float, p: FloatArray,
                             on_ground: bool, qc_diag: FloatArray, scratch: FloatArray) -> None:
    """:func:`discrete_transition` written into ``x_next`` (16,), ``f_mat`` and ``q_mat``
    (16, 16), with ``scratch`` of shape :data:`TRANSITION_SCRATCH` (``x_next`` may be ``x``).

    The powers of ``A dt`` are products by the sparse ``A dt`` on the left (its non-zero
    entries listed once; the powers commute); ``Phi`` is block upper triangular like ``A``,
    and its zeros (those of every power) are skipped in ``Phi Qc Phi'``, taken a whole row at
    a time (:func:`~fcu.estimation.small_matrix.add_scaled_row`) and its upper triangle
    mirrored. ``F`` and each ``Phi`` are sums of whole rows too (:func:`_series_into`), ``Phi'``
    a transpose of ``Phi`` by vector blocks.
    """
    n = 16
    ad, ad2, ad3, ad4 = scratch[0], scratch[1], scratch[2], scratch[3]
    phi_t, q_rows, phi = scratch[4], scratch[5], scratch[9]
    # a row of flags: non-zero where some power of A dt is (the pattern of Phi)
    flags = scratch[6, 7]
    # the non-zero entries of A dt (row i: count nz_count[i], columns nz_cols[i, :count]) and
    # of Phi (= of any power of A dt, or the diagonal): phi_count, phi_cols
    nz_count, phi_count = scratch[6, 5], scratch[6, 6]
    nz_cols, phi_cols = scratch[7], scratch[8]
    # A at x_{k|k}, before x_next (which may be x) is written
    model_jacobian_into(ad, x, p, on_ground)
    rk4_step_into(x_next, x, u, dt, p, on_ground, scratch[6, :5])
    for i in range(n):
        # (without a branch: each column written at the next free place, kept if non-zero)
        count = 0
        for j in range(n):
            ad[i, j] *= dt  # A dt
            nz_cols[i, count] = j
            count += ad[i, j] != 0.0
        nz_count[i] = count
    # (A dt)^2 = (A dt) (A dt);  (A dt)^3 = (A dt) (A dt)^2;  (A dt)^4 = (A dt) (A dt)^3:
    # row i of each is sum_k (A dt)[i, k] (row k of the previous), over the non-zero (A dt)[i, k]
    for prev, power in ((ad, ad2), (ad2, ad3), (ad3, ad4)):
        for i in range(n):
            for j in range(n):
                power[i, j] = 0.0
            for t in range(int(nz_count[i])):
                k = int(nz_cols[i, t])
                add_scaled_row(power, i, ad[i, k], prev, k)
    # F = Phi(dt) = I + A dt + (A dt)^2/2 + (A dt)^3/6 + (A dt)^4/24
    _series_into(f_mat, 1.0, ad, ad2, ad3, ad4)
    for i in range(n):
        # Phi's non-zero columns: k = i or any power non-zero there (a sum of magnitudes,
        # over the whole row at once), listed without a branch
        for k in range(n):
            flags[k] = abs(ad[i, k]) + abs(ad2[i, k]) + abs(ad3[i, k]) + abs(ad4[i, k])
        flags[i] = 1.0
        count = 0
        for k in range(n):
            phi_cols[i, count] = k
            count += flags[k] != 0.0
        phi_count[i] = count
    # Q = int_0^dt Phi(s) Qc Phi(s)' ds  by 3-point Gauss-Legendre on s = c dt,
    #     Phi(s) = sum_{n<=4} (A s)^n / n!
    for i in range(n):
        for j in range(n):
            q_rows[i, j] = 0.0
    r = math.sqrt(0.6) / 2.0
    for c, weight in ((0.5 - r, 5.0 / 18.0), (0.5, 8.0 / 18.0), (0.5 + r, 5.0 / 18.0)):
        # Phi(c dt) = I + (A dt) c + (A dt)^2 c^2/2 + (A dt)^3 c^3/6 + (A dt)^4 c^4/24, and Phi'
        _series_into(phi, c, ad, ad2, ad3, ad4)
        transpose_into(phi_t, phi)
        # Q += w Phi Qc Phi':  Q[i, :] += sum_k (w Phi[i, k] Qc[k]) Phi'[k, :]  (Qc
        # diagonal; k over the non-zero Phi[i, k]), whole rows
        for i in range(n):
            for t in range(int(phi_count[i])):
                k = int(phi_cols[i, t])
                add_scaled_row(q_rows, i, weight * phi[i, k] * qc_diag[k], phi_t, k)
    # Q *= dt; its upper triangle, mirrored (Q is symmetric)
    for i in range(n):
        for j in range(i, n):
            q_mat[i, j] = q_rows[i, j] * dt
            q_mat[j, i] = q_mat[i, j]


@njit(cache=True, error_model="numpy")
def _series_into(out: FloatArray, c: float, ad: FloatArray, ad2: FloatArray, ad3: FloatArray,
                 ad4: FloatArray) -> None:
    """``Phi(c dt) = I + (A dt) c + (A dt)^2 c^2/2 + (A dt)^3 c^3/6 + (A dt)^4 c^4/24`` (the
    fourth-order series of ``expm(A c dt)``; ``F`` at ``c = 1``) into ``out`` (16, 16), from
    the powers ``ad`` ... ``ad4`` of ``A dt``, row by row as whole rows: off the diagonal
    with the identity's 0, ``0.0 + (A dt)[i, :] c + (A dt)^2[i, :] c^2/2 + ...``, then the
    diagonal entry with its 1."""
    c2, c3, c4 = c * c / 2.0, c ** 3 / 6.0, c ** 4 / 24.0
    for i in range(out.shape[0]):
        set_scaled_row(out, i, c, ad, i)
        add_scaled_row(out, i, c2, ad2, i)
        add_scaled_row(out, i, c3, ad3, i)
        add_scaled_row(out, i, c4, ad4, i)
        out[i, i] = 1.0 + ad[i, i] * c + ad2[i, i] * c2 + ad3[i, i] * c3 + ad4[i, i] * c4


@njit(cache=True, error_model="numpy")
def transition_pattern_into(nz: FloatArray, scratch: FloatArray) -> None:
    """The non-zero columns of each row of ``Phi`` (``k = i``, or a power of ``A dt`` non-zero
    there), as :func:`discrete_transition_into` left them in its ``scratch``, written into
    ``nz`` (16, 17) in the layout of :func:`~fcu.estimation.small_matrix.nonzero_columns`:
    ``F = Phi(dt)``'s non-zero entries are among them (an entry that cancels to 0.0 is listed
    too, and then adds exact zeros to a product)."""
    phi_count, phi_cols = scratch[6, 6], scratch[8]
    for i in range(phi_count.shape[0]):
        count = int(phi_count[i])
        nz[i, 0] = count
        for t in range(count):
            nz[i, 1 + t] = phi_cols[i, t]


__all__ = [
    "TRANSITION_SCRATCH",
    "discrete_transition",
    "discrete_transition_into",
    "model_derivative",
    "model_derivative_into",
    "model_jacobian",
    "model_jacobian_into",
    "pack_params",
    "rk4_step",
    "rk4_step_into",
    "transition_pattern_into",
]
