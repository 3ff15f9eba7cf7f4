"""The EKF's prediction step, compiled (thesis section 6.1.2).

:func:`predict_covariance_into` propagates the estimate over one step in place: the state by
RK4 on the nonlinear model (yaw wrapped to [-pi, pi)), the covariance as
``P = F P F' + Q`` with ``F`` and ``Q`` the model's discretisation
(:func:`fcu.estimation.ekf_model.discrete_transition_into`), over the sparsity of ``F``.
:func:`fcu.estimation.ekf.ekf_tick` runs it each tick; :func:`predict_covariance` is the same
on copies, one filterpy ``predict`` (:mod:`fcu.estimation.ekf_filterpy`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation.ekf_model import (
    TRANSITION_SCRATCH,
    discrete_transition_into,
    transition_pattern_into,
)
from fcu.estimation.small_matrix import add_scaled_row, mul_nonzero_left, transpose_into
from fcu.estimation.state import STATE_DIM, YAW_INDEX, FloatArray
from fcu.floats import wrap_pi
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.views import refcount_free_kernel

# the kernels compile in those of ekf_model, small_matrix and kernel_views
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)

__all__ = ["predict_covariance", "predict_covariance_into"]

N = STATE_DIM


@njit(cache=True, error_model="numpy")
def predict_covariance(x: FloatArray, p_mat: FloatArray, u: FloatArray, dt: float,
                       p: FloatArray, on_ground: bool, qc_diag: FloatArray
                       ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """One filterpy ``predict`` of the EKF in a single compiled call
    (:func:`predict_covariance_into` on copies).

    Returns ``x_{k+1|k}`` (RK4, yaw wrapped to [-pi, pi)), ``F``, ``Q``
    (:func:`discrete_transition`) and ``P_{k+1|k} = F P F' + Q``.
    """
    x_next = x.copy()
    p_next = p_mat.copy()
    f_mat = np.empty((N, N))
    q_mat = np.empty((N, N))
    predict_covariance_into(x_next, p_next, u, dt, p, on_ground, qc_diag, f_mat, q_mat,
                            np.empty(TRANSITION_SCRATCH), np.empty((N, N + 1)))
    return x_next, f_mat, q_mat, p_next


@refcount_free_kernel
def predict_covariance_into(x: FloatArray, p_mat: FloatArray, u: FloatArray, dt: float,
                            p: FloatArray, on_ground: bool, qc_diag: FloatArray,
                            f_mat: FloatArray, q_mat: FloatArray, scratch: FloatArray,
                            nz_f: FloatArray) -> None:
    """One filterpy ``predict`` in place: ``x`` (16,), ``p_mat`` (16, 16) become the prior,
    ``F`` and ``Q`` are written to ``f_mat``, ``q_mat`` (``scratch``: shape
    :data:`~fcu.estimation.ekf_model.TRANSITION_SCRATCH`; ``nz_f``: (16, 17), written with
    the columns of ``F`` that may be non-zero).

    ``F`` is block upper triangular like ``A``: ``F P F'`` is taken as ``F (F P)'`` (``P``
    symmetric), two products by the sparse ``F`` (its non-zero entries listed once), the
    second one over the upper triangle only.
    """
    # x_{k+1|k} = RK4(f, x_{k|k}, u_k, dt);  F = sum (A dt)^n/n!;  Q = Van Loan (see module)
    discrete_transition_into(x, f_mat, q_mat, x, u, dt, p, on_ground, qc_diag, scratch)
    x[YAW_INDEX] = wrap_pi(x[YAW_INDEX])
    fp, fp_t = scratch[0], scratch[1]
    # F's non-zero columns: among those of Phi, listed by discrete_transition_into (a
    # listed entry that is 0.0 adds exact zeros: the same sums)
    transition_pattern_into(nz_f, scratch)
    # F P
    mul_nonzero_left(fp, f_mat, nz_f, p_mat)
    # (F P)' = P F'
    transpose_into(fp_t, fp)
    # P = F (P F') + Q: whole rows (the products two vector operations each), then the
    # upper triangle j >= i mirrored (the result is symmetric)
    for i in range(N):
        for j in range(N):
            p_mat[i, j] = 0.0
        for t in range(int(nz_f[i, 0])):
            k = int(nz_f[i, 1 + t])
            add_scaled_row(p_mat, i, f_mat[i, k], fp_t, k)
        for j in range(N):
            p_mat[i, j] += q_mat[i, j]
    for i in range(N):
        for j in range(i):
            p_mat[i, j] = p_mat[j, i]
