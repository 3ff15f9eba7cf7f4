"""The Kalman measurement update both filters run, compiled and in place.

:func:`kalman_update_into` is the EKF's sequential update of one channel
(:mod:`fcu.estimation.ekf`) and the TSKF's bias-free stage, eq. 6.17-6.20
(:mod:`fcu.estimation.tskf`); :func:`kalman_update` is the same on copies, as filterpy's
update (:mod:`fcu.estimation.ekf_filterpy`). Its products run over the rank-m structure of an
update of m rows (m <= 16), with zero entries of ``H`` skipped: a measurement row picks one
or a few state entries.
"""

from __future__ import annotations

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation.small_matrix import (
    ROW,
    add_scaled_row,
    mul_at_t_into,
    mul_bt_nonzero_into,
    mul_nonzero_left,
    nonzero_columns,
    spd_inverse,
)
from fcu.estimation.state import FloatArray
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.views import carve

# kalman_update_into compiles in the kernels of small_matrix and kernel_views
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)

__all__ = ["UPDATE_SCRATCH", "kalman_update", "kalman_update_into"]

UPDATE_SCRATCH = 3 * 16 * 16 + 16 * 17
"""Size of the scratch :func:`kalman_update_into` works in (n, m <= 16)."""


@njit(cache=True, error_model="numpy")
def kalman_update_into(x: FloatArray, p_mat: FloatArray, y: FloatArray, h_mat: FloatArray,
                       r_mat: FloatArray, s_mat: FloatArray, s_inv: FloatArray,
                       k_gain_t: FloatArray, scratch: FloatArray) -> None:
    """Kalman measurement update in place: ``x`` (n,) and ``p_mat`` (n, n) become the
    posterior; ``S``, ``S^-1`` (m, m) and the gain transposed, ``K'`` (m, n), are written to
    the top-left blocks of ``s_mat``, ``s_inv``, ``k_gain_t`` (``scratch``:
    :data:`UPDATE_SCRATCH` entries, n <= 16). ``K'`` is the form the update computes (its
    rows along the state); a caller that needs ``K`` itself transposes what it reads.

    ``y`` (m,), ``h_mat`` (m, n) and ``r_mat`` (m, m) as for :func:`kalman_update`. The
    products run over the rank-m structure of the update (zero entries of ``H`` skipped).
    With the optimal gain the Joseph form ``(I - K H) P (I - K H)' + K R K'`` equals
    ``P - K (H P) = P - (H P)' S^-1 (H P)``, a symmetric rank-m downdate: only its upper
    triangle is computed, and mirrored, so ``P`` stays exactly symmetric.
    """
    n, m = p_mat.shape[0], y.shape[0]
    # each matrix keeps the room of its largest size (m, n <= 16)
    ut, o = carve(scratch, 0, (m, n), 16 * 16)
    low, o = carve(scratch, o, (m, m), 16 * 16)
    low_inv, o = carve(scratch, o, (m, m), 16 * 16)
    nz, o = carve(scratch, o, (m, n + 1))
    k_t = k_gain_t  # K', rows along the state
    # the non-zero entries of each row of H (the products below skip the others)
    nonzero_columns(nz, h_mat)
    # (P H')' = H P   (P symmetric)
    mul_nonzero_left(ut, h_mat, nz, p_mat)
    # S = H P H' + R
    mul_bt_nonzero_into(s_mat, ut, h_mat, nz)
    for r in range(m):
        for q in range(m):
            s_mat[r, q] += r_mat[r, q]
    # S^-1
    spd_inverse(s_mat, m, s_inv, low, low_inv)
    # K = P H' S^-1 = (H P)' S^-1, kept as K' = S^-1' (H P)
    mul_at_t_into(k_t, ut, s_inv)
    # x = x + K y
    for i in range(n):
        acc = 0.0
        for r in range(m):
            acc += k_t[r, i] * y[r]
        x[i] += acc
    # P = P - K (H P): whole rows (16 entries: two vector operations each), then the upper
    # triangle j >= i mirrored onto the lower
    for i in range(n):
        for r in range(m):
            if n == ROW:
                add_scaled_row(p_mat, i, -k_t[r, i], ut, r)  # p - k u, to the bit
            else:
                kir = k_t[r, i]
                for j in range(i, n):
                    p_mat[i, j] -= kir * ut[r, j]
    for i in range(n):
        for j in range(i):
            p_mat[i, j] = p_mat[j, i]


@njit(cache=True, error_model="numpy")
def kalman_update(x: FloatArray, p_mat: FloatArray, y: FloatArray, h_mat: FloatArray,
                  r_mat: FloatArray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                              np.ndarray]:
    """Kalman measurement update for a given innovation (the maths of filterpy's update):
    :func:`kalman_update_into` on copies.

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
    n, m = x.shape[0], y.shape[0]
    x_post = x.copy()
    p_post = p_mat.copy()
    s_mat = np.empty((m, m))
    s_inv = np.empty((m, m))
    k_gain_t = np.empty((m, n))
    kalman_update_into(x_post, p_post, y, h_mat, r_mat, s_mat, s_inv, k_gain_t,
                       np.empty(UPDATE_SCRATCH))
    return x_post, p_post, s_mat, s_inv, k_gain_t.T.copy()
