"""Two-Stage Kalman Filter: state estimate and per-motor loss of effectiveness (eq. 6.1-6.26).

Model
-----
Eq. 6.1 is the hover linearisation; written in NED/FRD it reads (the thesis's first line,
``x' = theta g``, is a typo for ``x'' = theta g`` in its z-up frame; in NED a nose-up pitch
tilts the thrust backwards)::

    x'' = -g theta        y'' = g phi        z'' = g - U1/m
    phi'' = U2/Ixx        theta'' = U3/Iyy   psi'' = U4/Izz

with U = eq. 3.17 applied to the motor thrusts. The state is augmented with the four thrusts,
whose lag is eq. 6.4 (``T_i' = w (K u_i - T_i)``), giving eq. 6.3 with the layout of
:mod:`fcu.estimation.state` (the thesis orders it [x, x', y, y', ...]; same content)::

    x_a = [p (3), v (3), (phi, theta, psi), (p, q, r), T1..T4]                  (16)
    x_a' = A_a x_a + B_a (I - Gamma) u + g_a                                     (eq. 6.5)

``B_a`` is non-zero only in the thrust rows (``K w I``): a PWM command acts on the motion only
through its thrust. Loss of effectiveness in additive form (eq. 6.6):
``B_a (I - Gamma) u = B_a u + E_a gamma`` with ``E_a = -B_a diag(u)``.

Gravity. Linearised about hover, the vertical row keeps the affine term ``g``
(``z'' = g - sum(T)/m``, eq. 6.1) because the thrusts are absolute states, not deviations.
It is handled as a known constant input: the continuous model is discretised with the input
vector ``[u1, u2, u3, u4, 1]`` and input matrix ``[B_a, g e_vz]`` by zero-order hold
(``scipy.signal.cont2discrete``; gravity is constant over a tick, so ZOH is exact for it). The
discrete model is therefore (eq. 6.8, with ``g_k`` the gravity column)::

    x_{k+1} = A_k x_k + B_k u_k + g_k + E_k gamma_k + w_k,    E_k = -B_k diag(u_k)
    gamma_{k+1} = gamma_k + w^gamma_k                                           (eq. 6.9)
    y_k = C_k x_k + v_k

The linear model assumes small roll and pitch and a yaw near zero (the horizontal rows are
those of psi = 0). Its rate states are read as body rates (what the gyro measures) and the
attitude kinematics are linearised to ``eta' = omega``; the second-order kinematic error
(``psi' - r ~ q phi`` while pitching at 2 rad/s with a few hundredths of roll: 0.04 rad/s)
is left to the attitude rows' process noise rather than to the rate rows, where it would read
as a yaw torque and so as a gamma (see :class:`TskfProcessNoise`).

Measurements ``y = C x``: mocap position (x, y only when ``height_source="baro"``), barometric
altitude ``-z`` (baro source only), mocap attitude (yaw innovation wrapped to [-pi, pi)) and
the gyro, stacked into one update per tick. Samples of one kind within a tick are averaged;
their mean time lies ``delta`` before the tick, and the row is mapped back to that time to
first order, ``C (I - delta A_c)`` (``A_c`` continuous). ``R = sigma^2 / n`` for a mean of n.

Ground contact as in :mod:`fcu.estimation.ekf`: while the estimate sits on the ground plane with
thrust
below the weight, a ground model is used (no translational or angular acceleration, no
gravity input) and ``Q^gamma`` is set to zero for that tick: the motion then says nothing
about the motors, and gamma should not wander before take-off.

Filter
------
Bias filter eq. 6.10-6.14, bias-free filter eq. 6.15-6.19, residual covariance eq. 6.20,
coupling eq. 6.21-6.24 (eq. 6.16's last term is ``V P^gamma V'``), outputs eq. 6.25-6.26. It is
algebraically the Kalman filter on the 20-state model [x; gamma] (Hsieh and Chen, 1999), which
``tests/fcu/test_tskf.py`` verifies. Tuning (defaults of :class:`TskfProcessNoise` and
``q_gamma``) is documented there and in the class docstrings.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike
from scipy.linalg import expm
from scipy.signal import cont2discrete

from fcu.estimation.state import (
    EULER,
    POS,
    RATE,
    STATE_DIM,
    THRUST,
    VEL,
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
from fcu.floats import clip
from fcu.hal import SensorSampleLike
from fcu.model import VehicleModel

N_MOTORS = 4


@dataclass(frozen=True, kw_only=True)
class TskfProcessNoise:
    """Continuous process-noise spectral densities ``Q^x`` of the TSKF's linear model.

    Tuned on the closed-loop harness of tests/fcu/test_tskf.py (nonlinear quaternion plant,
    motor lag, drag and gusts, noisy sensors at their own rates, Table 6.1 step profile);
    seeds 1-6, gusts 0.3-1.0 m/s:

    * ``euler`` 1e-3 rad^2/s: absorbs the kinematic linearisation error (module docstring).
      At 1e-7 the error went into gamma: motor 4 read 0.11 before its fault and motor 3 left
      its 0.05 band for 17 s when motor 1 failed (1e-2: no change from 1e-3).
    * ``ang_accel`` 0.3 (rad/s^2)^2/Hz: 0.1 let unmodelled torques into gamma (band left on
      one seed), 1.0 slowed the motors' separation (healthy estimates up to 0.1).
    * ``accel`` 0.05 (m/s^2)^2/Hz: drag and the thrust-tilt term of the z row.
    * ``thrust`` 0.01 N^2/s: small, so that a persistent thrust deficit is explained by
      gamma rather than by thrust-state noise (0.001-0.1 made no measurable difference).
    * ``pos`` 1e-8 m^2/s: the position rows are exact.
    """

    pos: float = 1e-8  # m^2/s
    accel: float = 0.05  # (m/s^2)^2/Hz, each NED axis
    euler: float = 1e-3  # rad^2/s
    ang_accel: float = 0.3  # (rad/s^2)^2/Hz, each axis
    thrust: float = 0.01  # N^2/s, each motor

    def __post_init__(self) -> None:
        for name in ("pos", "accel", "euler", "ang_accel", "thrust"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} = {value!r}: spectral density must be finite, >= 0")

    def diagonal(self) -> FloatArray:
        """``Qc`` diagonal in the state order, shape (16,)."""
        return np.array([self.pos] * 3 + [self.accel] * 3 + [self.euler] * 3
                        + [self.ang_accel] * 3 + [self.thrust] * 4)


@dataclass(frozen=True)
class LinearHoverModel:
    """Continuous and ZOH-discrete matrices of the augmented hover model (module docstring).

    Attributes
    ----------
    a_c : ndarray, shape (16, 16)
        Continuous ``A_a``.
    b_c : ndarray, shape (16, 4)
        Continuous ``B_a`` (PWM to thrust-rate, ``K w`` in the thrust rows).
    g_c : ndarray, shape (16,)
        Continuous gravity input (``g`` in the vz row; zero for the ground model).
    a_d, b_d, g_d : ndarrays, shapes (16, 16), (16, 4), (16,)
        ZOH discretisation over ``dt_s``.
    q_d : ndarray, shape (16, 16)
        Discrete ``Q^x = int_0^dt e^{A s} Qc e^{A' s} ds`` (Van Loan, exact).
    """

    a_c: FloatArray
    b_c: FloatArray
    g_c: FloatArray
    a_d: FloatArray
    b_d: FloatArray
    g_d: FloatArray
    q_d: FloatArray


def hover_model(model: VehicleModel, dt_s: float, qc_diag: FloatArray,
                on_ground: bool = False) -> LinearHoverModel:
    """Build the augmented linear hover model (eq. 6.1, 6.3, 6.4) and discretise it (ZOH).

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe.
    dt_s : float
        Sample period, s.
    qc_diag : ndarray, shape (16,)
        Continuous process-noise spectral densities.
    on_ground : bool
        Build the ground model (no accelerations, no gravity input).

    Returns
    -------
    LinearHoverModel
    """
    g, m, k, w = model.gravity, model.mass, model.thrust_gain, model.motor_bandwidth
    inertia = model.inertia_diag
    torque = model.thrust_mixer()[1:, :]  # (3, 4): thrusts -> roll, pitch, yaw torques
    a = np.zeros((STATE_DIM, STATE_DIM))
    b = np.zeros((STATE_DIM, N_MOTORS))
    gc = np.zeros(STATE_DIM)
    # p' = v
    a[POS, VEL] = np.eye(3)
    # (phi, theta, psi)' = (p, q, r)   (attitude kinematics linearised at hover)
    a[EULER, RATE] = np.eye(3)
    if not on_ground:
        # x'' = -g theta;  y'' = g phi;  z'' = g - sum(T)/m
        a[3, 7] = -g
        a[4, 6] = g
        a[5, THRUST] = -1.0 / m
        gc[5] = g
        # (p, q, r)' = I^-1 (L (T3 - T4), L (T1 - T2), K_psi (T1 + T2 - T3 - T4))
        a[RATE, THRUST] = torque / inertia[:, None]
    # T' = -w T + K w u
    a[THRUST, THRUST] = -w * np.eye(N_MOTORS)
    b[THRUST, :] = k * w * np.eye(N_MOTORS)
    b_ext = np.hstack((b, gc[:, None]))
    a_d, b_ext_d, _, _, _ = cont2discrete((a, b_ext, np.eye(STATE_DIM),
                                           np.zeros((STATE_DIM, N_MOTORS + 1))),
                                          dt_s, method="zoh")
    # Van Loan: expm([[-A, Qc], [0, A']] dt) = [[., Phi^-1 Qd], [0, Phi']]
    n = STATE_DIM
    vl = np.zeros((2 * n, 2 * n))
    vl[:n, :n] = -a
    vl[:n, n:] = np.diag(qc_diag)
    vl[n:, n:] = a.T
    e = expm(vl * dt_s)
    phi = e[n:, n:].T
    q_d = phi @ e[:n, n:]
    q_d = 0.5 * (q_d + q_d.T)

    def contiguous(arr: ArrayLike) -> FloatArray:
        return np.ascontiguousarray(arr, dtype=float)

    return LinearHoverModel(a_c=contiguous(a), b_c=contiguous(b), g_c=contiguous(gc),
                            a_d=contiguous(a_d), b_d=contiguous(b_ext_d[:, :N_MOTORS]),
                            g_d=contiguous(b_ext_d[:, N_MOTORS]), q_d=contiguous(q_d))


@functools.lru_cache(maxsize=16)
def _shared_hover_model(model: VehicleModel, dt_s: float, qc_diag: tuple[float, ...],
                        on_ground: bool) -> LinearHoverModel:
    """:func:`hover_model`, built once per process and configuration (read-only arrays).

    Its discretisation calls scipy's ``expm`` and ``solve``, which wake OpenBLAS's worker
    threads; those then spin for about 0.1 s of CPU time. A process that builds many
    filters (a batch of flights, a benchmark, the tests) pays that once.
    """
    lm = hover_model(model, dt_s, np.array(qc_diag), on_ground)
    for arr in (lm.a_c, lm.b_c, lm.g_c, lm.a_d, lm.b_d, lm.g_d, lm.q_d):
        arr.setflags(write=False)
    return lm


class _Channel:
    """One measurement kind: ``y = S x`` at its sample time, its noise, and ``S A_c``."""

    def __init__(self, sensor: str, selection: FloatArray, sigma: float,
                 value_index: tuple[int, ...], flight: LinearHoverModel,
                 ground: LinearHoverModel) -> None:
        self.sensor = sensor
        self.selection = selection  # S, shape (k, 16)
        self.value_index = np.array(value_index)
        self.sample_var = sigma * sigma  # per sample, divided by n for a mean of n
        # S A_c of the flight and ground models, for C = S (I - delta A_c)
        self.sel_a = {False: selection @ flight.a_c, True: selection @ ground.a_c}
        self.ones = np.ones(selection.shape[0])
        self.rows = selection.shape[0]
        if list(value_index) != list(range(value_index[0], value_index[-1] + 1)):
            raise ValueError(f"value_index = {value_index!r}: must be consecutive")
        self.value_slice = slice(value_index[0], value_index[-1] + 1)  # value_index, a slice


@njit(cache=True, error_model="numpy")
def tskf_predict(a: FloatArray, b: FloatArray, g_d: FloatArray, q_x: FloatArray,
                 q_gamma: float, u: FloatArray, x_bar: FloatArray, p_x: FloatArray,
                 gamma: FloatArray, p_gamma: FloatArray,
                 v: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Time update of both stages (eq. 6.10, 6.11, 6.15, 6.16, 6.21, 6.22).

    Parameters
    ----------
    a, b, g_d, q_x : ndarrays, shapes (n, n), (n, 4), (n,), (n, n)
        Discrete model ``A_k``, ``B_k``, gravity input, ``Q^x``.
    q_gamma : float
        ``Q^gamma = q_gamma I`` for this step.
    u : ndarray, shape (4,)
        PWM held over the step.
    x_bar, p_x : ndarrays, shapes (n,), (n, n)
        Bias-free posterior ``x_bar_{k|k}``, ``P^x_{k|k}``.
    gamma, p_gamma : ndarrays, shapes (4,), (4, 4)
        ``gamma_hat_{k|k}``, ``P^gamma_{k|k}``.
    v : ndarray, shape (n, 4)
        ``V_{k|k}``.

    Returns
    -------
    x_bar_pred, p_x_pred, p_gamma_pred, v_pred
        ``x_bar_{k+1|k}``, ``P^x_{k+1|k}``, ``P^gamma_{k+1|k}``, ``V_{k+1|k}``
        (``gamma_hat_{k+1|k} = gamma_hat_{k|k}``, eq. 6.10).
    """
    n_g = gamma.shape[0]
    # E_k = -B_k diag(u_k)   (eq. 6.6, discrete)
    e = -b * u
    # W_k = A_k V_{k|k} + E_k   (eq. 6.21)
    w = a @ v + e
    # P^gamma_{k+1|k} = P^gamma_{k|k} + Q^gamma   (eq. 6.11)
    p_gamma_pred = p_gamma + q_gamma * np.eye(n_g)
    # V_{k+1|k} = W_k P^gamma_{k|k} (P^gamma_{k+1|k})^-1   (eq. 6.22)
    v_pred = np.ascontiguousarray(np.linalg.solve(p_gamma_pred, (w @ p_gamma).T).T)
    # x_bar_{k+1|k} = A x_bar + B u + g_k + W gamma_hat - V_{k+1|k} gamma_hat   (eq. 6.15)
    x_bar_pred = a @ x_bar + b @ u + g_d + (w - v_pred) @ gamma
    # P^x_{k+1|k} = A P^x A' + Q^x + W P^gamma_{k|k} W' - V P^gamma_{k+1|k} V'   (eq. 6.16)
    p_x_pred = (a @ p_x @ a.T + q_x + w @ p_gamma @ w.T
                - v_pred @ p_gamma_pred @ v_pred.T)
    p_x_pred = 0.5 * (p_x_pred + p_x_pred.T)
    return x_bar_pred, p_x_pred, p_gamma_pred, v_pred


@njit(cache=True, error_model="numpy")
def tskf_update(c: FloatArray, r: FloatArray, r_diag: FloatArray, x_bar: FloatArray,
                p_x: FloatArray, gamma: FloatArray, p_gamma: FloatArray,
                v: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray,
                                        FloatArray, FloatArray, FloatArray, FloatArray]:
    """Measurement update of both stages (eq. 6.12-6.14, 6.17-6.20, 6.23, 6.24).

    Parameters
    ----------
    c : ndarray, shape (m, n)
        ``C_{k+1}`` of the measurements that arrived.
    r : ndarray, shape (m,)
        Residual ``r_{k+1} = y_{k+1} - C_{k+1} x_bar_{k+1|k}`` (yaw wrapped by the caller).
    r_diag : ndarray, shape (m,)
        Diagonal of ``R_{k+1}``.
    x_bar, p_x, gamma, p_gamma, v : ndarrays
        Priors ``x_bar_{k+1|k}``, ``P^x_{k+1|k}``, ``gamma_hat_{k+1|k}``,
        ``P^gamma_{k+1|k}``, ``V_{k+1|k}``.

    Returns
    -------
    x_bar_post, p_x_post, gamma_post, p_gamma_post, v_post, s_bar, innovation, s_gamma
        Posteriors, ``S_bar_{k+1}`` (eq. 6.20), the full innovation
        ``r - H gamma_hat_{k+1|k}`` and its covariance ``H P^gamma H' + S_bar``.
    """
    n = x_bar.shape[0]
    n_g = gamma.shape[0]
    r_mat = np.diag(r_diag)
    pct = p_x @ c.T
    # S_bar_{k+1} = C P^x_{k+1|k} C' + R   (eq. 6.20)
    s_bar = c @ pct + r_mat
    # K^x = P^x_{k+1|k} C' S_bar^-1   (eq. 6.17)
    k_x = np.ascontiguousarray(np.linalg.solve(s_bar, np.ascontiguousarray(pct.T)).T)
    # x_bar_{k+1|k+1} = x_bar_{k+1|k} + K^x r   (eq. 6.18)
    x_bar_post = x_bar + k_x @ r
    # P^x_{k+1|k+1} = (I - K^x C) P^x_{k+1|k}   (eq. 6.19, Joseph form: symmetric, PSD)
    ikc = np.eye(n) - k_x @ c
    p_x_post = ikc @ p_x @ ikc.T + k_x @ r_mat @ k_x.T
    p_x_post = 0.5 * (p_x_post + p_x_post.T)
    # H_{k+1|k} = C_{k+1} V_{k+1|k}   (eq. 6.23)
    h = c @ v
    # K^gamma = P^gamma H' (H P^gamma H' + S_bar)^-1   (eq. 6.12)
    s_gamma = h @ p_gamma @ h.T + s_bar
    k_g = np.ascontiguousarray(np.linalg.solve(s_gamma, h @ p_gamma).T)
    # gamma_hat_{k+1|k+1} = gamma_hat_{k+1|k} + K^gamma (r - H gamma_hat_{k+1|k})   (eq. 6.13)
    innovation = r - h @ gamma
    gamma_post = gamma + k_g @ innovation
    # P^gamma_{k+1|k+1} = (I - K^gamma H) P^gamma_{k+1|k}   (eq. 6.14)
    p_gamma_post = (np.eye(n_g) - k_g @ h) @ p_gamma
    p_gamma_post = 0.5 * (p_gamma_post + p_gamma_post.T)
    # V_{k+1|k+1} = V_{k+1|k} - K^x H   (eq. 6.24)
    v_post = v - k_x @ h
    return x_bar_post, p_x_post, gamma_post, p_gamma_post, v_post, s_bar, innovation, s_gamma


@njit(cache=True, error_model="numpy")
def tskf_correct(sel: FloatArray, sel_a: FloatArray, row_delta: FloatArray, y: FloatArray,
                 r_diag: FloatArray, yaw_row: int, x_bar: FloatArray, p_x: FloatArray,
                 gamma: FloatArray, p_gamma: FloatArray,
                 v: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray,
                                         FloatArray, FloatArray, FloatArray, FloatArray,
                                         FloatArray]:
    """One tick's stacked measurement update in one compiled call (module docstring).

    Parameters
    ----------
    sel, sel_a : ndarrays, shape (m, n)
        Stacked selections ``S`` of the measurements that arrived and ``S A_c``.
    row_delta : ndarray, shape (m,)
        Per row, how long before the tick its batch was taken (``delta``, s).
    y : ndarray, shape (m,)
        The stacked measurements.
    r_diag : ndarray, shape (m,)
        Diagonal of ``R_{k+1}``.
    yaw_row : int
        Row holding the yaw measurement (its residual is wrapped), or -1.
    x_bar, p_x, gamma, p_gamma, v : ndarrays
        Priors, as for :func:`tskf_update`.

    Returns
    -------
    The outputs of :func:`tskf_update` (posterior yaw wrapped to [-pi, pi)), then the
    residual ``r_{k+1}``.
    """
    # C = S (I - delta A_c): each row mapped back to its batch's mean sample time
    c = sel - row_delta.reshape(-1, 1) * sel_a
    # r_{k+1} = y_{k+1} - C_{k+1} x_bar_{k+1|k}   (yaw wrapped)
    r = y - c @ x_bar
    if yaw_row >= 0:
        r[yaw_row] = (r[yaw_row] + math.pi) % (2.0 * math.pi) - math.pi
    # eq. 6.12-6.14, 6.17-6.20, 6.23, 6.24
    (x_bar_post, p_x_post, gamma_post, p_gamma_post, v_post, s_bar, innovation,
     s_gamma) = tskf_update(c, r, r_diag, x_bar, p_x, gamma, p_gamma, v)
    x_bar_post[YAW_INDEX] = (x_bar_post[YAW_INDEX] + math.pi) % (2.0 * math.pi) - math.pi
    return (x_bar_post, p_x_post, gamma_post, p_gamma_post, v_post, s_bar, innovation,
            s_gamma, r)


@njit(cache=True, error_model="numpy")
def tskf_output(x_bar: FloatArray, p_x: FloatArray, gamma: FloatArray, p_gamma: FloatArray,
                v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Compensated estimate (eq. 6.25) and the diagonal of its covariance (eq. 6.26).

    Returns ``x_hat = x_bar + V gamma_hat``, shape (n,), and
    ``diag(V P^gamma V' + P^x)``, shape (n,).
    """
    # x_hat = x_bar + V gamma_hat   (eq. 6.25)
    x_hat = x_bar + v @ gamma
    # P = V P^gamma V' + P^x   (eq. 6.26): diagonal only, diag(V P^g V')_i = sum_j (V P^g)_ij V_ij
    vp = v @ p_gamma
    n, n_g = v.shape
    p_diag = np.empty(n)
    for i in range(n):
        acc = vp[i, 0] * v[i, 0]
        for j in range(1, n_g):
            acc += vp[i, j] * v[i, j]
        p_diag[i] = p_x[i, i] + acc
    return x_hat, p_diag


# Default random-walk variance of gamma per 10 ms step (eq. 6.9): see TwoStageKalmanFilter.
DEFAULT_Q_GAMMA = 1e-4


class TwoStageKalmanFilter:
    """Two-Stage Kalman Filter (eq. 6.10-6.26) at a fixed rate, with per-motor LOE estimates.

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe (Table 7.1).
    dt_s : float
        Filter period, s (thesis: 100 Hz). ``step`` must be called at multiples of it.
    q_gamma : float
        Variance of the per-step random walk of each motor's gamma (``Q^gamma = q_gamma I``,
        eq. 6.9), per ``dt_s`` step. Default 1e-4 (one sigma 0.1 per second). On the harness
        (Table 6.1 step profile, seeds 1-5) a step fault enters its 0.05 band 0.25-0.6 s after
        onset; healthy motors peak at 0.045. Smaller is not quieter: the estimation transient
        when another motor fails lasts longer (2e-5: a healthy motor reaches 0.10; 5e-6: 0.12,
        and a faulty one leaves its band for 17 s). Larger trades the other way (3e-4: healthy
        peak 0.038, but a faulty motor's steady error grows; 2e-4 reached 0.049 on one seed).
    height_source : {"mocap", "baro"}
        Where height comes from.
    noise : SensorNoise
        Assumed measurement noise (``R``).
    process_noise : TskfProcessNoise
        Continuous ``Q^x`` spectral densities; discretised exactly (Van Loan).
    gamma_std0 : float
        Initial one-sigma uncertainty of each gamma, ``P^gamma_0 = gamma_std0^2 I``.
    initial_uncertainty : InitialUncertainty
        Covariance used by :meth:`reset` when the initial estimate carries none.
    ground_z_ned : float or None
        z (NED, m) of the ground plane, or None for no ground contact.
    ground_margin_m : float
        Distance above the ground within which the vehicle counts as on the ground, m.

    Attributes
    ----------
    x_bar, P_x : ndarrays, shapes (16,), (16, 16)
        Bias-free filter's posterior (eq. 6.18, 6.19).
    gamma_raw, P_gamma : ndarrays, shapes (4,), (4, 4)
        Bias filter's posterior (eq. 6.13, 6.14), unclipped.
    V : ndarray, shape (16, 4)
        Coupling ``V_{k|k}`` (eq. 6.24).
    x_bar_prior, P_x_prior, P_gamma_prior, V_prior : ndarrays
        The latest time update's priors (eq. 6.15, 6.16, 6.11, 6.22).
    residual, residual_cov : ndarrays, shapes (m,), (m, m)
        ``r_{k+1} = y - C x_bar_{k+1|k}`` and ``S_bar_{k+1}`` (eq. 6.20) of the latest update.
    innovation, innovation_cov : ndarrays, shapes (m,), (m, m)
        ``r - H gamma_hat_{k+1|k}`` and ``H P^gamma H' + S_bar``: the innovation of the
        equivalent augmented filter (what a consistency or fault test should use).
    on_ground : bool
        Whether the latest time update used the ground model.

    Notes
    -----
    Each tick: ``step(time_s, pwm_applied, samples)`` (or :meth:`step_grouped` with the
    samples already averaged) with the tick time, the PWM held since
    the previous tick (after saturation: the filter's E_k = -B_k diag(u_k) needs what the
    motors were actually asked for) and the samples produced since the previous tick.
    """

    def __init__(self, model: VehicleModel, dt_s: float = 0.01,
                 q_gamma: float = DEFAULT_Q_GAMMA, *,
                 height_source: HeightSource = "mocap",
                 noise: SensorNoise | None = None,
                 process_noise: TskfProcessNoise | None = None,
                 gamma_std0: float = 0.1,
                 initial_uncertainty: InitialUncertainty | None = None,
                 ground_z_ned: float | None = 0.0,
                 ground_margin_m: float = 0.02) -> None:
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be a finite number > 0 s")
        if not (math.isfinite(q_gamma) and q_gamma >= 0):
            raise ValueError(f"q_gamma = {q_gamma!r}: must be a finite number >= 0")
        if not (math.isfinite(gamma_std0) and gamma_std0 > 0):
            raise ValueError(f"gamma_std0 = {gamma_std0!r}: must be a finite number > 0 "
                             "(P^gamma must stay invertible, eq. 6.22)")
        if not (math.isfinite(ground_margin_m) and ground_margin_m >= 0):
            raise ValueError(f"ground_margin_m = {ground_margin_m!r}: must be >= 0 m")
        self.model = model
        self.dt_s = float(dt_s)
        self.q_gamma = float(q_gamma)
        self.height_source = check_height_source(height_source)
        self.noise = noise if noise is not None else SensorNoise()
        self.process_noise = process_noise if process_noise is not None else TskfProcessNoise()
        self.gamma_std0 = float(gamma_std0)
        self.initial_uncertainty = (initial_uncertainty if initial_uncertainty is not None
                                    else InitialUncertainty())
        self.ground_z_ned = ground_z_ned
        self.ground_margin_m = float(ground_margin_m)
        qc = tuple(self.process_noise.diagonal().tolist())
        # designed once per configuration and shared (read-only): _shared_hover_model
        self.flight_model = _shared_hover_model(model, self.dt_s, qc, False)
        self.ground_model = _shared_hover_model(model, self.dt_s, qc, True)
        self._weight_n = model.mass * model.gravity
        self._channels = self._make_channels()
        self._kinds = frozenset(ch.sensor for ch in self._channels)
        # every channel stacked, for the usual tick on which all of them deliver
        self._sel_all = np.ascontiguousarray(np.vstack([ch.selection for ch in self._channels]))
        self._sel_a_all = {g: np.ascontiguousarray(np.vstack([ch.sel_a[g]
                                                              for ch in self._channels]))
                           for g in (False, True)}
        self.reset()

    def _make_channels(self) -> tuple[_Channel, ...]:
        n = self.noise
        fm, gm = self.flight_model, self.ground_model

        def sel(cols: list[int], sign: float = 1.0) -> FloatArray:
            out = np.zeros((len(cols), STATE_DIM))
            out[np.arange(len(cols)), cols] = sign
            return out

        ch: list[_Channel] = []
        if self.height_source == "baro":
            ch.append(_Channel("mocap_pos", sel([0, 1]), n.mocap_pos, (0, 1), fm, gm))
            # alt = -z
            ch.append(_Channel("baro", sel([Z_INDEX], -1.0), n.baro, (0,), fm, gm))
        else:
            ch.append(_Channel("mocap_pos", sel([0, 1, 2]), n.mocap_pos, (0, 1, 2), fm, gm))
        ch.append(_Channel("mocap_att", sel([6, 7, 8]), n.mocap_att, (0, 1, 2), fm, gm))
        ch.append(_Channel("gyro", sel([9, 10, 11]), n.gyro, (0, 1, 2), fm, gm))
        return tuple(ch)

    # ---- life cycle ------------------------------------------------------------------------
    def reset(self, time_s: float = 0.0, initial: StateEstimate | None = None,
              gamma0: ArrayLike | None = None) -> None:
        """Restart the filter.

        Parameters
        ----------
        time_s : float
            Time of the initial estimate, s.
        initial : StateEstimate or None
            Initial state and covariance diagonal; None: at rest at the origin, level, motors
            off, with the covariance of ``initial_uncertainty``.
        gamma0 : array_like, shape (4,), or None
            Initial gamma estimate (default zeros: healthy motors).
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
        self._time_s = float(time_s)
        # bias-free filter: x_bar, P^x (eq. 6.15-6.19)
        self.x_bar = x0.astype(float)
        self.P_x = np.diag(p0)
        # bias filter: gamma_hat, P^gamma (eq. 6.10-6.14)
        self.gamma_raw = (np.zeros(N_MOTORS) if gamma0 is None
                          else np.array(gamma0, dtype=float).reshape(N_MOTORS))
        self.P_gamma = np.eye(N_MOTORS) * self.gamma_std0 ** 2
        # coupling V_{k|k} (eq. 6.24); zero: the initial state and gamma are uncorrelated
        self.V = np.zeros((STATE_DIM, N_MOTORS))
        # priors and the last update's quantities, kept for inspection
        self.x_bar_prior = self.x_bar.copy()
        self.P_x_prior = self.P_x.copy()
        self.P_gamma_prior = self.P_gamma.copy()
        self.V_prior = self.V.copy()
        self.residual = np.zeros(0)  # r_{k+1} = y - C x_bar_{k+1|k}
        self.residual_cov = np.zeros((0, 0))  # S_bar_{k+1} (eq. 6.20)
        self.innovation = np.zeros(0)  # r - H gamma_hat_{k+1|k}: full-state innovation
        self.innovation_cov = np.zeros((0, 0))  # H P^gamma H' + S_bar
        self._blocks: list[tuple[str, int, int]] = []  # (sensor, first row, end row)
        self.on_ground = False
        self._estimate = self._make_estimate()

    def step(self, time_s: float, pwm_applied: ArrayLike,
             samples: Iterable[SensorSampleLike]) -> StateEstimate:
        """Advance to ``time_s`` and update with the tick's samples.

        Parameters
        ----------
        time_s : float
            Tick time, s; the previous tick's plus a whole number of ``dt_s`` (within 25 %
            of ``dt_s``). Zero steps (same time) updates only.
        pwm_applied : array_like, shape (4,)
            PWM held since the previous tick, motors 1..4.
        samples : iterable of SensorSampleLike
            Samples produced since the previous tick.

        Returns
        -------
        StateEstimate
            ``x_hat_{k|k}`` (eq. 6.25) with the diagonal of eq. 6.26.
        """
        return self.step_grouped(time_s, pwm_applied, group_samples(samples, self._kinds))

    def step_grouped(self, time_s: float, pwm_applied: ArrayLike,
                     batches: Mapping[str, SampleBatch]) -> StateEstimate:
        """:meth:`step` with the tick's samples already averaged by
        :func:`fcu.estimation.state.group_samples` (batches of kinds this filter does not use are
        ignored), so that several estimators can share one grouping."""
        time_s = float(time_s)
        u = np.asarray(pwm_applied, dtype=float).reshape(N_MOTORS)
        n_steps_f = (time_s - self._time_s) / self.dt_s
        n_steps = round(n_steps_f)
        if n_steps < 0 or abs(n_steps_f - n_steps) > 0.25:
            raise ValueError(f"time_s = {time_s!r}: the TSKF is discretised at dt_s = "
                             f"{self.dt_s} s and was last stepped at {self._time_s!r} s; "
                             "call it at whole multiples of dt_s")
        for _ in range(n_steps):
            self._predict(u)
        if n_steps == 0:
            self._keep_prior()
        self._time_s = time_s
        self._update(batches)
        self._estimate = self._make_estimate()
        return self._estimate

    # ---- filter maths ----------------------------------------------------------------------
    def _current_model(self) -> LinearHoverModel:
        x_bar, v, gamma, x_hat = self._x_hat_of
        if not (x_bar is self.x_bar and v is self.V and gamma is self.gamma_raw):
            # x_hat = x_bar + V gamma_hat   (eq. 6.25)
            x_hat = self.x_bar + self.V @ self.gamma_raw
        on_ground = (self.ground_z_ned is not None
                     and x_hat[Z_INDEX] >= self.ground_z_ned - self.ground_margin_m
                     and float(np.sum(x_hat[THRUST])) < self._weight_n)
        self.on_ground = bool(on_ground)
        return self.ground_model if on_ground else self.flight_model

    def _predict(self, u: FloatArray) -> None:
        lm = self._current_model()
        q_gamma = 0.0 if self.on_ground else self.q_gamma
        # eq. 6.10, 6.11, 6.15, 6.16, 6.21, 6.22 (tskf_predict)
        self.x_bar, self.P_x, self.P_gamma, self.V = tskf_predict(
            lm.a_d, lm.b_d, lm.g_d, lm.q_d, q_gamma, u, self.x_bar, self.P_x,
            self.gamma_raw, self.P_gamma, self.V)
        self._keep_prior()

    def _keep_prior(self) -> None:
        self.x_bar_prior = self.x_bar.copy()
        self.P_x_prior = self.P_x.copy()
        self.P_gamma_prior = self.P_gamma.copy()
        self.V_prior = self.V.copy()

    def _update(self, batches: Mapping[str, SampleBatch]) -> None:
        present: list[_Channel] = []
        row_delta: list[float] = []
        y_l: list[float] = []
        r_l: list[float] = []
        blocks: list[tuple[str, int, int]] = []
        yaw_row = -1
        m = 0
        for ch in self._channels:
            batch = batches.get(ch.sensor)
            if batch is None:
                continue
            present.append(ch)
            k = ch.rows
            # C = S (I - delta A_c): the rows mapped back to the batch's mean sample time
            row_delta += [self._time_s - batch.time_s] * k
            y_l += batch.value.tolist()[ch.value_slice]
            # R = sigma^2 / n for the mean of n samples
            r_l += [ch.sample_var / batch.count] * k
            if ch.sensor == "mocap_att":
                yaw_row = m + 2
            blocks.append((ch.sensor, m, m + k))
            m += k
        self._blocks = blocks
        if m == 0:
            self.residual = np.zeros(0)
            self.residual_cov = np.zeros((0, 0))
            self.innovation = np.zeros(0)
            self.innovation_cov = np.zeros((0, 0))
            return
        on_ground = self.on_ground
        if len(present) == len(self._channels):
            sel, sel_a = self._sel_all, self._sel_a_all[on_ground]
        else:
            sel = np.vstack([ch.selection for ch in present])
            sel_a = np.vstack([ch.sel_a[on_ground] for ch in present])
        # r = y - C x_bar (yaw wrapped); eq. 6.12-6.14, 6.17-6.20, 6.23, 6.24 (tskf_update)
        (self.x_bar, self.P_x, self.gamma_raw, self.P_gamma, self.V, self.residual_cov,
         self.innovation, self.innovation_cov, self.residual) = tskf_correct(
            sel, sel_a, np.array(row_delta), np.array(y_l), np.array(r_l), yaw_row,
            self.x_bar, self.P_x, self.gamma_raw, self.P_gamma, self.V)

    def _make_estimate(self) -> StateEstimate:
        # x_hat = x_bar + V gamma_hat (eq. 6.25); P = V P^gamma V' + P^x (eq. 6.26), diagonal
        x_hat, p_diag = tskf_output(self.x_bar, self.P_x, self.gamma_raw, self.P_gamma, self.V)
        # kept for the next time update's ground test (same x_hat while nothing changed)
        self._x_hat_of = (self.x_bar, self.V, self.gamma_raw, x_hat.copy())
        return StateEstimate._from_owned(self._time_s, x_hat, p_diag)

    # ---- inspection ------------------------------------------------------------------------
    @property
    def estimate(self) -> StateEstimate:
        """The latest estimate (eq. 6.25, 6.26)."""
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
    def loe_estimate(self) -> FloatArray:
        """Per-motor loss of effectiveness gamma_hat clipped to [0, 1], shape (4,)."""
        return np.array([clip(g, 0.0, 1.0) for g in self.gamma_raw.tolist()])

    @property
    def loe_std(self) -> FloatArray:
        """One-sigma uncertainty of each gamma estimate, shape (4,)."""
        return np.sqrt(np.maximum(np.diag(self.P_gamma), 0.0))

    @property
    def x_hat(self) -> FloatArray:
        """Compensated state estimate ``x_bar + V gamma_hat`` (eq. 6.25), shape (16,)."""
        return self.x_bar + self.V @ self.gamma_raw

    @property
    def P(self) -> FloatArray:  # noqa: N802 (filter notation)
        """Covariance of ``x_hat``: ``V P^gamma V' + P^x`` (eq. 6.26), shape (16, 16)."""
        return self.V @ self.P_gamma @ self.V.T + self.P_x

    @property
    def joint_covariance(self) -> FloatArray:
        """Covariance of ``[x_hat; gamma_hat]``, shape (20, 20).

        ``[[V P^g V' + P^x, V P^g], [P^g V', P^g]]`` (the augmented filter's, Hsieh-Chen).
        """
        vp = self.V @ self.P_gamma
        return np.block([[vp @ self.V.T + self.P_x, vp], [vp.T, self.P_gamma]])

    @property
    def last_innovation(self) -> Mapping[str, Innovation]:
        """Per-sensor blocks of the latest innovation ``r - H gamma_hat`` and its covariance
        ``H P^gamma H' + S_bar`` (the augmented filter's innovation), with each block's NIS
        ``nu' S^-1 nu``. Computed on request."""
        out: dict[str, Innovation] = {}
        if self.innovation.size == 0:
            return out
        for name, i0, i1 in self._blocks:
            blk = self.innovation_cov[i0:i1, i0:i1].copy()
            res = self.innovation[i0:i1].copy()
            out[name] = Innovation(name, self._time_s, res, blk,
                                   float(res @ np.linalg.solve(blk, res)))
        return out

    @property
    def nis(self) -> float:
        """NIS of the latest update as a whole, ``nu' S^-1 nu`` (0.0 when nothing arrived)."""
        if self.innovation.size == 0:
            return 0.0
        return float(self.innovation @ np.linalg.solve(self.innovation_cov, self.innovation))


__all__ = [
    "DEFAULT_Q_GAMMA",
    "LinearHoverModel",
    "TskfProcessNoise",
    "TwoStageKalmanFilter",
    "hover_model",
    "tskf_predict",
    "tskf_update",
]
