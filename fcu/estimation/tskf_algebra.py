"""The Two-Stage Kalman Filter's algebra, compiled and in place: time update of both stages,
measurement update and the outputs (eq. 6.10-6.26).

:mod:`fcu.estimation.tskf` runs them, a tick at a time, in
:func:`fcu.estimation.tskf_kernel.tskf_tick` (whose cached kernels are dropped when this
module changes: :mod:`jitsupport.cache`). The matrices are small (16 states, 4 biases,
at most 16 measurement rows) and sparse (the discrete hover model, the measurement rows): the
products skip zero entries of their left factor (:mod:`fcu.estimation.small_matrix`) and
nothing is allocated.
"""

from __future__ import annotations

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation.kalman_update import UPDATE_SCRATCH, kalman_update_into
from fcu.estimation.small_matrix import (
    add_mul_vec,
    add_scaled_difference_row,
    add_scaled_row,
    mul_at_t_into,
    mul_into,
    mul_nonzero_left,
    mul_sparse_left,
    spd_inverse,
    spd_solve,
    sub_mul_vec_into,
    symmetrize,
    transpose_into,
)
from fcu.estimation.state import STATE_DIM, FloatArray
from fcu.estimation.tskf_model import N_MOTORS
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.views import carve, refcount_free_kernel

# compiles in the kernels of kalman_update and small_matrix and kernel_views
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)

__all__ = ["PREDICT_SCRATCH", "TSKF_UPDATE_SCRATCH", "tskf_output", "tskf_output_into",
           "tskf_predict_into", "tskf_update_into"]

PREDICT_SCRATCH = 2 * 16 * 16 + 6 * 16 * 4 + 4 * 4 * 4 + 2 * 16
"""Size of the scratch :func:`tskf_predict_into` works in (n = 16, 4 biases)."""
_UPDATE_ROOMS = {"R": 16 * 16, "K^x'": 16 * 16, "H^gamma": 16 * 4, "H^gamma P^gamma": 16 * 4,
                 "K^gamma": 4 * 16, "S^-1": 16 * 16, "L": 16 * 16, "K^gamma'": 16 * 4,
                 "(K^x H)'": 4 * 16}
"""The room of each matrix :func:`tskf_update_into` carves after the scratch of
:func:`~fcu.estimation.kalman_update.kalman_update_into` (m <= 16 rows, 16 states, 4
biases), in the order carved."""
TSKF_UPDATE_SCRATCH = sum(_UPDATE_ROOMS.values(), UPDATE_SCRATCH)
"""Size of the scratch :func:`tskf_update_into` works in (n, m <= 16, 4 biases)."""


@njit(cache=True, error_model="numpy")
def _sizes(n: int, n_g: int) -> tuple[int, int]:
    """The states and biases, ``n`` and ``n_g``: 16 and 4 (ValueError otherwise), the
    biases' count returned as a constant, so that the compiler knows the count of the short
    loops over them and unrolls them (the loops along the state it vectorises instead)."""
    if n != STATE_DIM or n_g != N_MOTORS:
        raise ValueError("TSKF kernels: 16 states and 4 biases only")
    return n, N_MOTORS


@refcount_free_kernel
def tskf_predict_into(a: FloatArray, nz_a: FloatArray, b: FloatArray, g_d: FloatArray,
                      q_x: FloatArray, q_gamma: float, u: FloatArray, x_bar: FloatArray,
                      p_x: FloatArray, gamma: FloatArray, p_gamma: FloatArray, v: FloatArray,
                      scratch: FloatArray) -> None:
    """Time update of both stages (eq. 6.10, 6.11, 6.15, 6.16, 6.21, 6.22), in place.

    Parameters
    ----------
    a, b, g_d, q_x : ndarrays, shapes (n, n), (n, 4), (n,), (n, n)
        Discrete model ``A_k``, ``B_k``, gravity input, ``Q^x``.
    nz_a : ndarray, shape (n, n + 1)
        The non-zero entries of each row of ``A_k``
        (:func:`~fcu.estimation.small_matrix.nonzero_columns`'s layout), for its four
        products: listed once with the model, which does not change.
    q_gamma : float
        ``Q^gamma = q_gamma I`` for this step.
    u : ndarray, shape (4,)
        PWM held over the step.
    x_bar, p_x : ndarrays, shapes (n,), (n, n)
        Bias-free posterior ``x_bar_{k|k}``, ``P^x_{k|k}``; become ``x_bar_{k+1|k}``,
        ``P^x_{k+1|k}``.
    gamma : ndarray, shape (4,)
        ``gamma_hat_{k|k}`` (``gamma_hat_{k+1|k} = gamma_hat_{k|k}``, eq. 6.10).
    p_gamma : ndarray, shape (4, 4)
        ``P^gamma_{k|k}``; becomes ``P^gamma_{k+1|k}``.
    v : ndarray, shape (n, 4)
        ``V_{k|k}``; becomes ``V_{k+1|k}``.
    scratch : ndarray
        At least :data:`PREDICT_SCRATCH` entries.
    """
    n, n_g = _sizes(v.shape[0], v.shape[1])
    ap, o = carve(scratch, 0, (n, n))
    ap_t, o = carve(scratch, o, (n, n))
    w, o = carve(scratch, o, (n, n_g))
    wp, o = carve(scratch, o, (n, n_g))
    v_pred, o = carve(scratch, o, (n, n_g))
    vp, o = carve(scratch, o, (n, n_g))
    p_gamma_pred, o = carve(scratch, o, (n_g, n_g))
    pgp_inv, o = carve(scratch, o, (n_g, n_g))
    low, o = carve(scratch, o, (2, n_g, n_g))
    x_pred, o = carve(scratch, o, (n,))
    w_t, o = carve(scratch, o, (n_g, n))  # W', V_{k+1|k}': rows along the state
    v_pred_t, o = carve(scratch, o, (n_g, n))
    row, o = carve(scratch, o, (1, n))
    # W_k = A_k V_{k|k} + E_k,  E_k = -B_k diag(u_k)   (eq. 6.21, 6.6 discrete)
    mul_nonzero_left(w, a, nz_a, v)
    for i in range(n):
        for g in range(n_g):
            w[i, g] += -b[i, g] * u[g]
    # P^gamma_{k+1|k} = P^gamma_{k|k} + Q^gamma   (eq. 6.11)
    for g in range(n_g):
        for h in range(n_g):
            p_gamma_pred[g, h] = p_gamma[g, h]
        p_gamma_pred[g, g] += q_gamma
    # W P^gamma_{k|k}
    mul_into(wp, w, p_gamma)
    # V_{k+1|k} = W_k P^gamma_{k|k} (P^gamma_{k+1|k})^-1   (eq. 6.22)
    spd_inverse(p_gamma_pred, n_g, pgp_inv, low[0], low[1])
    mul_into(v_pred, wp, pgp_inv)
    # x_bar_{k+1|k} = A x_bar + B u + g_k + (W - V_{k+1|k}) gamma_hat   (eq. 6.15)
    for i in range(n):
        acc = 0.0
        for t in range(int(nz_a[i, 0])):
            k = int(nz_a[i, 1 + t])
            acc += a[i, k] * x_bar[k]
        for g in range(n_g):
            acc += b[i, g] * u[g]
        acc += g_d[i]
        for g in range(n_g):
            acc += (w[i, g] - v_pred[i, g]) * gamma[g]
        x_pred[i] = acc
    for i in range(n):
        x_bar[i] = x_pred[i]
    # V_{k+1|k} P^gamma_{k+1|k}
    mul_into(vp, v_pred, p_gamma_pred)
    # A P^x A' = A (A P^x)'   (P^x symmetric; two products by the sparse A)
    mul_nonzero_left(ap, a, nz_a, p_x)
    transpose_into(ap_t, ap)
    mul_nonzero_left(p_x, a, nz_a, ap_t)
    # P^x_{k+1|k} = A P^x A' + Q^x + W P^gamma_{k|k} W' - V P^gamma_{k+1|k} V'   (eq. 6.16),
    # a row at a time: Q^x[i, :] + sum_g (W P^gamma)[i, g] W'[g, :] - (V P^gamma)[i, g] V'[g, :]
    # (whole rows: two vector operations per term, add_scaled_difference_row)
    transpose_into(w_t, w)
    transpose_into(v_pred_t, v_pred)
    for i in range(n):
        for j in range(n):
            row[0, j] = q_x[i, j]
        for g in range(n_g):
            add_scaled_difference_row(row, 0, wp[i, g], w_t, g, vp[i, g], v_pred_t, g)
        add_scaled_row(p_x, i, 1.0, row, 0)  # p + 1.0 row = p + row, to the bit
    symmetrize(p_x)
    for g in range(n_g):
        for h in range(n_g):
            p_gamma[g, h] = p_gamma_pred[g, h]
    for i in range(n):
        for g in range(n_g):
            v[i, g] = v_pred[i, g]


@refcount_free_kernel
def tskf_update_into(c: FloatArray, r: FloatArray, r_diag: FloatArray, x_bar: FloatArray,
                     p_x: FloatArray, gamma: FloatArray, p_gamma: FloatArray, v: FloatArray,
                     s_bar: FloatArray, innovation: FloatArray, s_gamma: FloatArray,
                     scratch: FloatArray) -> None:
    """Measurement update of both stages (eq. 6.12-6.14, 6.17-6.20, 6.23, 6.24), in place.

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
        ``P^gamma_{k+1|k}``, ``V_{k+1|k}``; become the posteriors.
    s_bar, innovation, s_gamma : ndarrays, shapes (m, m), (m,), (m, m)
        Written: ``S_bar_{k+1}`` (eq. 6.20), the full innovation
        ``r - H gamma_hat_{k+1|k}`` and its covariance ``H P^gamma H' + S_bar``.
    scratch : ndarray
        At least :data:`TSKF_UPDATE_SCRATCH` entries.
    """
    m = c.shape[0]
    n, n_g = _sizes(c.shape[1], gamma.shape[0])
    # each matrix keeps the room of its largest size (m <= 16 rows)
    r_mat, o = carve(scratch, UPDATE_SCRATCH, (m, m), 16 * 16)
    k_x_t, o = carve(scratch, o, (m, n), 16 * 16)  # K^x'
    h, o = carve(scratch, o, (m, n_g), 16 * n_g)
    hp, o = carve(scratch, o, (m, n_g), 16 * n_g)
    k_g, o = carve(scratch, o, (n_g, m), 16 * n_g)
    s_inv, o = carve(scratch, o, (m, m), 16 * 16)
    low, o = carve(scratch, o, (m, m), 16 * 16)
    k_g_t, o = carve(scratch, o, (m, n_g), 16 * n_g)
    kh_t, o = carve(scratch, o, (n_g, n))  # (K^x H)', rows along the state
    for i in range(m):
        for j in range(m):
            r_mat[i, j] = 0.0
        r_mat[i, i] = r_diag[i]
    # H_{k+1|k} = C_{k+1} V_{k+1|k}   (eq. 6.23), with the prior V
    mul_sparse_left(h, c, v)
    # S_bar = C P^x C' + R (eq. 6.20);  K^x = P^x C' S_bar^-1 (eq. 6.17);
    # x_bar += K^x r (eq. 6.18);  P^x = (I - K^x C) P^x (I - K^x C)' + K^x R K^x'
    # (eq. 6.19, Joseph form: symmetric, PSD)
    kalman_update_into(x_bar, p_x, r, c, r_mat, s_bar, s_inv, k_x_t, scratch)
    # H P^gamma
    mul_into(hp, h, p_gamma)
    # H P^gamma H' + S_bar
    for i in range(m):
        for j in range(m):
            acc = s_bar[i, j]
            for g in range(n_g):
                acc += hp[i, g] * h[j, g]
            s_gamma[i, j] = acc
    # K^gamma = P^gamma H' (H P^gamma H' + S_bar)^-1   (eq. 6.12), as its transpose
    # K^gamma' = (H P^gamma H' + S_bar)^-1 (H P^gamma) (both factors symmetric): one Cholesky
    # solve with the 4 columns of H P^gamma, no m x m inverse
    spd_solve(s_gamma, m, hp, k_g_t, low)
    transpose_into(k_g, k_g_t)
    # innovation = r - H gamma_hat_{k+1|k}
    sub_mul_vec_into(innovation, r, h, gamma)
    # gamma_hat_{k+1|k+1} = gamma_hat_{k+1|k} + K^gamma innovation   (eq. 6.13)
    add_mul_vec(gamma, k_g, innovation)
    # P^gamma_{k+1|k+1} = (I - K^gamma H) P^gamma_{k+1|k} = P^gamma - K^gamma (H P^gamma)
    # (eq. 6.14), made symmetric
    for g in range(n_g):
        for q in range(n_g):
            acc = 0.0
            for i in range(m):
                acc += k_g[g, i] * hp[i, q]
            p_gamma[g, q] -= acc
    symmetrize(p_gamma)
    # V_{k+1|k+1} = V_{k+1|k} - K^x H   (eq. 6.24), K^x H from (K^x H)' = H' K^x' by whole
    # rows along the state (each entry's sum over the rows of H as a dot product's)
    mul_at_t_into(kh_t, k_x_t, h)
    for i in range(n):
        for g in range(n_g):
            v[i, g] -= kh_t[g, i]


@njit(cache=True, error_model="numpy")
def tskf_output(x_bar: FloatArray, p_x: FloatArray, gamma: FloatArray, p_gamma: FloatArray,
                v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Compensated estimate (eq. 6.25) and the diagonal of its covariance (eq. 6.26), fresh
    arrays of shape (n,) (:func:`tskf_output_into`)."""
    n = x_bar.shape[0]
    out = np.empty(2 * n)
    tskf_output_into(out, x_bar, p_x, gamma, p_gamma, v)
    return out[:n], out[n:]


@refcount_free_kernel
def tskf_output_into(out: FloatArray, x_bar: FloatArray, p_x: FloatArray, gamma: FloatArray,
                     p_gamma: FloatArray, v: FloatArray) -> None:
    """Write ``x_hat = x_bar + V gamma_hat`` (eq. 6.25) to ``out[:n]`` and
    ``diag(V P^gamma V' + P^x)`` (eq. 6.26) to ``out[n:2n]``."""
    n, n_g = _sizes(v.shape[0], v.shape[1])
    for i in range(n):
        # x_hat = x_bar + V gamma_hat   (eq. 6.25)
        acc = 0.0
        for g in range(n_g):
            acc += v[i, g] * gamma[g]
        out[i] = x_bar[i] + acc
        # P = V P^gamma V' + P^x   (eq. 6.26), diagonal: sum_g (V P^gamma)_ig V_ig
        acc = 0.0
        for g in range(n_g):
            vp = 0.0
            for h in range(n_g):
                vp += v[i, h] * p_gamma[h, g]
            acc += vp * v[i, g]
        out[n + i] = p_x[i, i] + acc
