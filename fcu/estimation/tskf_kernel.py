"""The TSKF's tick, compiled: its workspace layout and :func:`tskf_tick`, which runs the
time updates, the screening and the stacked measurement update of one tick in one call
(eq. 6.10-6.26; the algebra is :mod:`fcu.estimation.tskf_algebra`'s, the filter around it
:class:`fcu.estimation.tskf.TwoStageKalmanFilter`).

The filter keeps its float arrays in one buffer (offsets ``B_*``): the workspace (offsets
``W_*``: posteriors, priors and the latest update's residual and innovation), the scratch
(offsets ``SC_*``, nothing kept from tick to tick), the packed models (offsets ``_M_*``) and
the channel tables (:class:`~fcu.estimation.tskf_channels.TskfChannelSet`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation import screening
from fcu.estimation.small_matrix import sub_mul_vec_into
from fcu.estimation.state import STATE_DIM, YAW_INDEX, FloatArray
from fcu.estimation.tskf_algebra import (
    PREDICT_SCRATCH,
    TSKF_UPDATE_SCRATCH,
    tskf_output_into,
    tskf_predict_into,
    tskf_update_into,
)
from fcu.estimation.tskf_channels import MAPPED
from fcu.estimation.tskf_model import N_MOTORS
from fcu.floats import wrap_pi
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import Layout
from jitsupport.views import refcount_free_kernel, shaped

# tskf_tick compiles in the kernels of tskf_algebra, screening and what they call
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)


# ---- the filter's state: one float array, these layouts (jitsupport.layout) --------------
N, G = STATE_DIM, N_MOTORS
MAX_M = STATE_DIM  # measurement rows of one update at the most
WORK = Layout("TSKF work (tskf_tick's state)")
W_X_BAR = WORK.field("x_bar", N)  # x_bar
W_P_X = WORK.field("P_x", N * N)  # P^x (N x N, row-major)
W_P_GAMMA = WORK.field("P_gamma", G * G)  # P^gamma (G x G)
W_V = WORK.field("V", N * G)  # V (N x G)
W_PRIOR = WORK.field("priors", WORK.size)  # the same four, priors (at W_PRIOR + W_*)
W_RES = WORK.field("r", MAX_M)  # residual r (m)
W_RES_COV = WORK.field("S_bar", MAX_M * MAX_M)  # S_bar (m x m)
W_INN = WORK.field("innovation", MAX_M)  # innovation r - H gamma (m)
W_INN_COV = WORK.field("innovation_cov", MAX_M * MAX_M)  # its covariance (m x m)
WORK_SIZE = WORK.size
SCRATCH = Layout("TSKF scratch (within one tskf_tick)")
_SC_PREDICT = SCRATCH.field("predict", PREDICT_SCRATCH)  # tskf_predict_into's
SC_UPDATE = SCRATCH.field("update", TSKF_UPDATE_SCRATCH)  # tskf_update_into's
_SC_X_HAT = SCRATCH.field("x_hat", 2 * N)  # x_hat and its covariance's diagonal (2 N)
SC_P_HAT = SCRATCH.field("P_hat", N * N)  # its covariance (N x N)
_SC_C = SCRATCH.field("C", MAX_M * N)  # C (MAX_M x N)
_SC_Y = SCRATCH.field("y", MAX_M)  # y, then r (MAX_M)
_SC_R_DIAG = SCRATCH.field("R_diagonal", MAX_M)  # diagonal of R (MAX_M)
_SC_ROW_DELTA = SCRATCH.field("row_delta", MAX_M)  # delta of each row (MAX_M)
_SC_USED = SCRATCH.field("used", N)  # the state entries the channels read (N at the most)
# the tick's measurement table, when gathered here (pair_tick)
SC_MEAS = SCRATCH.field("measurements", screening.MAX_CHANNELS * screening.MEAS_WIDTH)
SCRATCH_SIZE = SCRATCH.size
MODEL = Layout("TSKF model (tskf_tick's constants)")
_M_A = MODEL.field("A_d", 2 * N * N)  # A_d of the flight and ground models (2 x N x N)
_M_B = MODEL.field("B_d", 2 * N * G)  # B_d (2 x N x G)
_M_G = MODEL.field("g_d", 2 * N)  # g_d (2 x N)
_M_Q = MODEL.field("Q_d", 2 * N * N)  # Q_d (2 x N x N)
_M_Q_GAMMA = MODEL.field("Q_gamma", 1)  # Q^gamma per step in flight
_M_DT = MODEL.field("dt", 1)  # filter period, s
_M_GROUND = MODEL.field("ground", 3)  # the ground plane (on_ground_at)
_M_NZ_A = MODEL.field("A_d_nonzero", 2 * N * (N + 1))  # A_d's non-zero columns, both models
MODEL_SIZE = MODEL.size
# the filter's float arrays, kept in one (TwoStageKalmanFilter._buf), so that a compiled call
# takes them as one argument (fcu.estimation.pair); then every height source's channel
# tables (ChannelSet.tables_at)
BUFFER = Layout("TSKF buffer (TwoStageKalmanFilter._buf)")
B_WORK = BUFFER.field("work", WORK_SIZE)
B_SCRATCH = BUFFER.field("scratch", SCRATCH_SIZE)
B_MODEL = BUFFER.field("model", MODEL_SIZE)
B_TABLES = BUFFER.size


@njit(cache=True, error_model="numpy", inline="always")
def buffer_views(buf: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`tskf_tick`'s ``work``, ``scratch`` and ``model``: views of the filter's buffer
    ``buf`` (offsets ``B_*``)."""
    return (buf[B_WORK:B_WORK + WORK_SIZE], buf[B_SCRATCH:B_SCRATCH + SCRATCH_SIZE],
            buf[B_MODEL:B_MODEL + MODEL_SIZE])


@refcount_free_kernel
def tskf_tick(work: FloatArray, scratch: FloatArray, gamma: FloatArray, out: FloatArray,
              model: FloatArray, tables: FloatArray, layout: np.ndarray, u: FloatArray,
              meas: FloatArray, excluded: np.ndarray, n_steps: int, time_s: float,
              reject: bool, on_ground: bool, accel_power: float) -> tuple[bool, float, int]:
    """One tick of the TSKF in one compiled call (class and module docstrings).

    ``n_steps`` time updates (:func:`~fcu.estimation.tskf_algebra.tskf_predict_into`, each
    with the flight or ground model by the ground test on ``x_hat``), the screening of the
    tick's measurements against the prior
    (:func:`~fcu.estimation.screening.screen_channels`), the accelerometer's innovation
    power, and one stacked measurement update of the channels applied
    (:func:`~fcu.estimation.tskf_algebra.tskf_update_into`).

    Parameters
    ----------
    work : ndarray, shape (WORK_SIZE,)
        The filter's workspace, updated in place: read are the previous posteriors
        ``x_bar``, ``P^x``, ``P^gamma``, ``V`` (eq. 6.14, 6.18, 6.19, 6.24); written are the
        new ones, the priors (eq. 6.11, 6.15, 6.16, 6.22), and the update's residual,
        ``S_bar``, innovation and its covariance (first ``m`` rows).
    scratch : ndarray, shape (SCRATCH_SIZE,)
        Room for the tick's intermediate results (nothing kept from tick to tick).
    gamma : ndarray, shape (4,)
        ``gamma_hat`` (eq. 6.13), updated in place.
    out : ndarray, shape (32 + 2 rows_total + 2 n_ch,)
        Written: ``x_hat`` (eq. 6.25, yaw wrapped to [-pi, pi)) and the diagonal of its
        covariance (eq. 6.26), then the screening
        (:func:`~fcu.estimation.screening.screen_channels`' table).
    model : ndarray, shape (MODEL_SIZE,)
        The discrete flight (index 0) and ground (index 1) models ``A_d``, ``B_d``, ``g_d``,
        ``Q_d`` (shapes (2, 16, 16), (2, 16, 4), (2, 16), (2, 16, 16)), ``Q^gamma`` per step
        in flight (zero on the ground), the filter period (s), the ground plane
        (:func:`~fcu.estimation.estimator.on_ground_at`) and ``A_d``'s non-zero columns
        (:func:`~fcu.estimation.small_matrix.nonzero_columns`, (2, 16, 17)), packed (offsets
        ``_M_*``).
    tables, layout : ndarrays
        The channels (:class:`~fcu.estimation.tskf_channels.TskfChannelSet`).
    u : ndarray, shape (4,)
        PWM held over the time updates.
    meas, excluded, reject
        The tick's measurements, exclusions, and whether a lone outlier may be rejected
        (:func:`~fcu.estimation.screening.screen_channels`).
    n_steps : int
        Time updates of the filter period since the previous tick.
    time_s : float
        Tick time, s.
    on_ground : bool
        The previous time update's ground flag (kept when ``n_steps`` is 0).
    accel_power : float
        The accelerometer's measured innovation power so far, (m/s^2)^2.

    Returns
    -------
    on_ground, accel_power, m
        The ground flag; the innovation power; the rows of the update (0: none).
    """
    a_d = shaped(model[_M_A:_M_A + 2 * N * N], (2, N, N))
    b_d = shaped(model[_M_B:_M_B + 2 * N * G], (2, N, G))
    g_d = shaped(model[_M_G:_M_G + 2 * N], (2, N))
    q_d = shaped(model[_M_Q:_M_Q + 2 * N * N], (2, N, N))
    q_gamma = model[_M_Q_GAMMA]
    dt_s = model[_M_DT]
    ground = model[_M_GROUND:_M_GROUND + 3]
    nz_a = shaped(model[_M_NZ_A:_M_NZ_A + 2 * N * (N + 1)], (2, N, N + 1))
    sel_stack, noise, at = screening.channel_tables(tables, layout)
    rows = sel_stack.shape[0]
    sel_a = shaped(tables[at:at + 2 * rows * N], (2, rows, N))  # S A_c
    at += 2 * rows * N
    sel_b = shaped(tables[at:at + 2 * rows * G], (2, rows, G))  # S B_c
    at += 2 * rows * G
    sel_g = shaped(tables[at:at + 2 * rows], (2, rows))  # S g_c
    x_bar = work[W_X_BAR:W_X_BAR + N]
    p_x = shaped(work[W_P_X:W_P_X + N * N], (N, N))
    p_gamma = shaped(work[W_P_GAMMA:W_P_GAMMA + G * G], (G, G))
    v = shaped(work[W_V:W_V + N * G], (N, G))
    x_hat = scratch[_SC_X_HAT:_SC_X_HAT + N]
    sc_predict = scratch[_SC_PREDICT:_SC_PREDICT + PREDICT_SCRATCH]
    for _ in range(n_steps):
        # x_hat = x_bar + V gamma_hat (eq. 6.25): the ground test picks the model
        for i in range(N):
            acc = 0.0
            for g in range(G):
                acc += v[i, g] * gamma[g]
            x_hat[i] = x_bar[i] + acc
        on_ground = screening.on_ground_at(x_hat, ground)
        g = 1 if on_ground else 0
        # eq. 6.10, 6.11, 6.15, 6.16, 6.21, 6.22; Q^gamma = 0 on the ground
        tskf_predict_into(a_d[g], nz_a[g], b_d[g], g_d[g], q_d[g],
                          0.0 if on_ground else q_gamma, u, x_bar, p_x, gamma, p_gamma, v,
                          sc_predict)
    for i in range(W_PRIOR):  # the priors: x_bar, P^x, P^gamma, V
        work[W_PRIOR + i] = work[i]
    # screened against the prior x_hat = x_bar + V gamma (eq. 6.25) and its covariance
    # V P^gamma V' + P^x (eq. 6.26); on the ground the accelerometer feels the ground
    prior = scratch[_SC_X_HAT:_SC_X_HAT + 2 * N]  # x_hat, then the diagonal (overwritten)
    tskf_output_into(prior, x_bar, p_x, gamma, p_gamma, v)
    p_hat = shaped(scratch[SC_P_HAT:SC_P_HAT + N * N], (N, N))
    # the state entries each channel reads (a column of its S with a non-zero entry):
    # screening reads P only in the block of a channel's entries (S P S'), so only those
    # blocks are formed
    used = scratch[_SC_USED:_SC_USED + N]
    for c in range(layout.shape[0]):
        n_used = 0
        for j in range(N):
            for r in range(layout[c, screening.ROW0], layout[c, screening.ROW1]):
                if sel_stack[r, j] != 0.0:
                    used[n_used] = j
                    n_used += 1
                    break
        for ti in range(n_used):
            i = int(used[ti])
            for g in range(G):
                acc = 0.0
                for h in range(G):
                    acc += v[i, h] * p_gamma[h, g]
                prior[N + g] = acc  # (V P^gamma)[i, :], kept in the diagonal's room
            # P[i, j] = P^x[i, j] + sum_g (V P^gamma)[i, g] V'[g, j]
            for tj in range(n_used):
                j = int(used[tj])
                acc = p_x[i, j]
                for g in range(G):
                    acc += prior[N + g] * v[j, g]
                p_hat[i, j] = acc
    screen = out[2 * N:]
    screening.screen_channels_into(screen, x_hat, p_hat, meas, sel_stack, layout, noise,
                                   excluded, on_ground, reject, sc_predict)
    n_ch = layout.shape[0]
    status = screen[2 * sel_stack.shape[0] + n_ch:]  # the channels' status codes
    m = 0
    for c in range(n_ch):
        if status[c] == screening.APPLIED:
            m += layout[c, screening.ROW1] - layout[c, screening.ROW0]
            if layout[c, screening.IS_ACCEL] != 0:
                # the accelerometer's innovation power nu^2: fast attack (2 s), slow decay
                # (20 s); what its measurement noise becomes when larger than the model's
                sq = screen[layout[c, screening.ROW0]] ** 2
                rate = dt_s / (2.0 if sq > accel_power else 20.0)
                accel_power += rate * (sq - accel_power)
    if m > 0:
        g = 1 if on_ground else 0
        c_mat = shaped(scratch[_SC_C:_SC_C + m * N], (m, N))
        y = scratch[_SC_Y:_SC_Y + m]
        r_diag = scratch[_SC_R_DIAG:_SC_R_DIAG + m]
        yaw_row = -1
        k = 0
        for c in range(n_ch):
            if status[c] != screening.APPLIED:
                continue
            i0, i1 = layout[c, screening.ROW0], layout[c, screening.ROW1]
            # C = S (I - delta A_c): the rows mapped back to the batch's mean sample time
            delta = time_s - meas[c, screening.TIME]
            # R = sigma^2 / n for the mean of n samples (+ model error)
            r_var = screening.noise_var(noise, c, meas[c, screening.COUNT])
            if layout[c, screening.IS_ACCEL] != 0 and accel_power > r_var:
                r_var = accel_power  # adaptive: the measured innovation power (class doc)
            for i in range(i1 - i0):
                for j in range(N):
                    c_mat[k, j] = sel_stack[i0 + i, j] - delta * sel_a[g, i0 + i, j]
                y[k] = meas[c, screening.VALUE + i]
                if layout[c, MAPPED] != 0:
                    # y = S x(t - delta) = C x - delta S (B_c u + g_c): move the known part over
                    acc = 0.0
                    for q in range(G):
                        acc += sel_b[g, i0 + i, q] * u[q]
                    y[k] += delta * (acc + sel_g[g, i0 + i])
                r_diag[k] = r_var
                if layout[c, screening.WRAP_YAW] != 0 and i == 2:
                    yaw_row = k
                k += 1
        # r_{k+1} = y_{k+1} - C_{k+1} x_bar_{k+1|k}   (yaw wrapped)
        res = work[W_RES:W_RES + m]
        sub_mul_vec_into(res, y, c_mat, x_bar)
        if yaw_row >= 0:
            res[yaw_row] = wrap_pi(res[yaw_row])
        # eq. 6.12-6.14, 6.17-6.20, 6.23, 6.24
        tskf_update_into(c_mat, res, r_diag, x_bar, p_x, gamma, p_gamma, v,
                         shaped(work[W_RES_COV:W_RES_COV + m * m], (m, m)), work[W_INN:W_INN + m],
                         shaped(work[W_INN_COV:W_INN_COV + m * m], (m, m)),
                         scratch[SC_UPDATE:SC_UPDATE + TSKF_UPDATE_SCRATCH])
        x_bar[YAW_INDEX] = wrap_pi(x_bar[YAW_INDEX])
    # x_hat = x_bar + V gamma_hat (eq. 6.25); P = V P^gamma V' + P^x (eq. 6.26), diagonal
    estimate = out[:2 * N]
    tskf_output_into(estimate, x_bar, p_x, gamma, p_gamma, v)
    # the estimate's yaw in [-pi, pi), as StateEstimate keeps it
    estimate[YAW_INDEX] = wrap_pi(estimate[YAW_INDEX])
    return on_ground, accel_power, m
