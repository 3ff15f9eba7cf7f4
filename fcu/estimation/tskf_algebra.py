"""The Two-Stage Kalman Filter's algebra, compiled: time update of both stages, measurement
update, the stacked correction of a tick and the outputs (eq. 6.10-6.26).

:mod:`fcu.estimation.tskf` runs them, a tick at a time, in :func:`fcu.estimation.tskf.tskf_tick`
(whose cached kernels are dropped when this module changes: :mod:`flightdata.kernel_cache`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fcu.estimation.state import YAW_INDEX, FloatArray

__all__ = ["tskf_correct", "tskf_output", "tskf_predict", "tskf_update"]


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
