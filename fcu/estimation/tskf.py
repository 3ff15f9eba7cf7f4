"""Two-Stage Kalman Filter: state estimate and per-motor loss of effectiveness (eq. 6.1-6.26).

The augmented linear hover model it runs on (eq. 6.1-6.9) is built and discretised in
:mod:`fcu.estimation.tskf_model`, the filter's algebra (eq. 6.10-6.26) is compiled in
:mod:`fcu.estimation.tskf_algebra`; the measurement channels, reset and inspection it shares
with the EKF are in :mod:`fcu.estimation.estimator`.

Measurements ``y = C x``: mocap position (x, y only when ``height_source="baro"``), barometric
altitude ``-z`` (baro source only), mocap attitude (yaw innovation wrapped to [-pi, pi)), the
gyro and the accelerometer's body z (``f_z = -sum(T)/m``: the thesis's TSKF uses no
accelerometer; here it makes the collective thrust, hence a mass change, observable at once
rather than through the second derivative of the height), stacked into one update per tick
after screening (:mod:`fcu.estimation.estimator`). Samples of one kind within a tick are
averaged; their mean time lies ``delta`` before the tick, and the row is mapped back to that
time to first order, ``y = S x(t - delta) = S (x - delta (A_c x + B_c u + g_c))``, i.e.
``C = S (I - delta A_c)`` with the known input part ``delta S (B_c u + g_c)`` moved to the
measurement side (non-zero only for the accelerometer: the thrusts it reads respond to the
PWM within the tick). ``R = sigma^2 / n + sigma_model^2`` for a mean of n.

Ground contact as in :mod:`fcu.estimation.ekf`: while the estimate sits on the ground plane
with thrust below the weight, a ground model is used (no translational or angular acceleration, no
gravity input) and ``Q^gamma`` is set to zero for that tick: the motion then says nothing
about the motors, and gamma should not wander before take-off.

Filter
------
Bias filter eq. 6.10-6.14, bias-free filter eq. 6.15-6.19, residual covariance eq. 6.20,
coupling eq. 6.21-6.24 (eq. 6.16's last term is ``V P^gamma V'``), outputs eq. 6.25-6.26. It is
algebraically the Kalman filter on the 20-state model [x; gamma] (Hsieh and Chen, 1999), which
``tests/fcu/estimation/test_tskf.py`` verifies. Tuning (defaults of :class:`TskfProcessNoise` and
``q_gamma``) is documented there and in the class docstrings.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from fcu.estimation import screening
from fcu.estimation.channels import Channel, ChannelSet
from fcu.estimation.estimator import (
    InitialUncertainty,
    Innovation,
    SensorNoise,
    StateEstimate,
    TickEstimator,
)
from fcu.estimation.small_matrix import nonzero_columns, sub_mul_vec_into
from fcu.estimation.state import STATE_DIM, YAW_INDEX, FloatArray
from fcu.estimation.tskf_algebra import (
    PREDICT_SCRATCH,
    TSKF_UPDATE_SCRATCH,
    tskf_output,
    tskf_output_into,
    tskf_predict_into,
    tskf_update_into,
)
from fcu.estimation.tskf_model import (
    N_MOTORS,
    LinearHoverModel,
    TskfProcessNoise,
    shared_hover_model,
)
from fcu.floats import clip
from fcu.model import VehicleModel
from flightdata import kernel_views
from flightdata.kernel_cache import drop_stale_kernels
from flightdata.kernel_views import refcount_free_kernel, shaped

# tskf_tick compiles in the kernels of tskf_algebra, screening and what they call
drop_stale_kernels(__file__, kernel_views.__file__)


class _ChannelSet(ChannelSet):
    """One height source's channels, stacked, with ``S A_c``, ``S B_c`` and ``S g_c`` of the
    flight model (index 0) and the ground model (index 1): ``sel_a`` (2, rows, 16), ``sel_b``
    (2, rows, 4), ``sel_g`` (2, rows), and ``mapped`` (n_ch,), whether the input's share
    of a channel's back-mapping is non-zero. For :func:`tskf_tick`, ``tables`` carries
    ``sel_a``, ``sel_b`` and ``sel_g`` after the common tables, and ``layout`` ``mapped``
    in its column ``MAPPED``."""

    def __init__(self, channels: tuple[Channel, ...], flight: LinearHoverModel,
                 ground: LinearHoverModel) -> None:
        super().__init__(channels)
        models = (flight, ground)
        # S A_c of the flight and ground models, for C = S (I - delta A_c)
        self.sel_a = np.ascontiguousarray([self.sel_stack @ lm.a_c for lm in models])
        # S B_c and S g_c: the input's share of the back-mapping, x(t - delta) = x - delta
        # (A_c x + B_c u + g_c); non-zero only for the accelerometer, which reads the thrusts
        self.sel_b = np.ascontiguousarray([self.sel_stack @ lm.b_c for lm in models])
        self.sel_g = np.ascontiguousarray([self.sel_stack @ lm.g_c for lm in models])
        self.mapped = np.array([bool(np.any(self.sel_b[0, i0:i1]) or np.any(self.sel_g[0, i0:i1]))
                                for i0, i1 in self.rows_list])
        self.tables = np.concatenate((self.tables, self.sel_a.ravel(), self.sel_b.ravel(),
                                      self.sel_g.ravel()))
        self.layout = np.ascontiguousarray(np.column_stack((self.layout, self.mapped)),
                                           dtype=np.int64)


MAPPED = screening.PICKS + 1  # column of a _ChannelSet's layout: the input is back-mapped


# ---- the filter's workspace (tskf_tick): one float array, these offsets --------------------
N, G = STATE_DIM, N_MOTORS
MAX_M = STATE_DIM  # measurement rows of one update at the most
_XB = 0  # x_bar (N)
_PX = _XB + N  # P^x (N x N, row-major)
_PG = _PX + N * N  # P^gamma (G x G)
_V = _PG + G * G  # V (N x G)
_PRIOR = _V + N * G  # the same four, priors
_RES = 2 * _PRIOR  # residual r (m)
_RES_COV = _RES + MAX_M  # S_bar (m x m)
_INN = _RES_COV + MAX_M * MAX_M  # innovation r - H gamma (m)
_INN_COV = _INN + MAX_M  # its covariance (m x m)
WORK_SIZE = _INN_COV + MAX_M * MAX_M
# scratch of tskf_tick (no state: only within a tick)
_SC_PREDICT = 0  # tskf_predict_into's
_SC_UPDATE = _SC_PREDICT + PREDICT_SCRATCH  # tskf_update_into's
_SC_X_HAT = _SC_UPDATE + TSKF_UPDATE_SCRATCH  # x_hat and its covariance's diagonal (2 N)
_SC_P_HAT = _SC_X_HAT + 2 * N  # its covariance (N x N)
_SC_C = _SC_P_HAT + N * N  # C (MAX_M x N)
_SC_Y = _SC_C + MAX_M * N  # y, then r (MAX_M)
_SC_R_DIAG = _SC_Y + MAX_M  # diagonal of R (MAX_M)
_SC_ROW_DELTA = _SC_R_DIAG + MAX_M  # delta of each row (MAX_M)
_SC_USED = _SC_ROW_DELTA + MAX_M  # the state entries the channels read (N at the most)
SC_MEAS = _SC_USED + N  # the tick's measurement table, when gathered here (pair_tick)
SCRATCH_SIZE = SC_MEAS + screening.MAX_CHANNELS * screening.MEAS_WIDTH
# ---- the filter's constants (tskf_tick): one float array, these offsets --------------------
_M_A = 0  # A_d of the flight and ground models (2 x N x N)
_M_B = _M_A + 2 * N * N  # B_d (2 x N x G)
_M_G = _M_B + 2 * N * G  # g_d (2 x N)
_M_Q = _M_G + 2 * N  # Q_d (2 x N x N)
_M_Q_GAMMA = _M_Q + 2 * N * N  # Q^gamma per step in flight
_M_DT = _M_Q_GAMMA + 1  # filter period, s
_M_GROUND = _M_DT + 1  # the ground plane (3, on_ground_at)
_M_NZ_A = _M_GROUND + 3  # A_d's non-zero columns, both models (2 x N x (N + 1))
MODEL_SIZE = _M_NZ_A + 2 * N * (N + 1)
# the filter's float arrays, kept in one (TwoStageKalmanFilter._buf) at these offsets, so that
# a compiled call takes them as one argument (fcu.estimation.pair); then every height
# source's channel tables (ChannelSet.tables_at)
B_WORK = 0  # work (WORK_SIZE)
B_SCRATCH = B_WORK + WORK_SIZE  # scratch (SCRATCH_SIZE)
B_MODEL = B_SCRATCH + SCRATCH_SIZE  # model (MODEL_SIZE)
B_TABLES = B_MODEL + MODEL_SIZE


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
        The channels (:class:`_ChannelSet`).
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
    x_bar = work[_XB:_XB + N]
    p_x = shaped(work[_PX:_PX + N * N], (N, N))
    p_gamma = shaped(work[_PG:_PG + G * G], (G, G))
    v = shaped(work[_V:_V + N * G], (N, G))
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
    for i in range(_PRIOR):  # the priors: x_bar, P^x, P^gamma, V
        work[_PRIOR + i] = work[i]
    # screened against the prior x_hat = x_bar + V gamma (eq. 6.25) and its covariance
    # V P^gamma V' + P^x (eq. 6.26); on the ground the accelerometer feels the ground
    prior = scratch[_SC_X_HAT:_SC_X_HAT + 2 * N]  # x_hat, then the diagonal (overwritten)
    tskf_output_into(prior, x_bar, p_x, gamma, p_gamma, v)
    p_hat = shaped(scratch[_SC_P_HAT:_SC_P_HAT + N * N], (N, N))
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
    status = screening.screen_channels_into(screen, x_hat, p_hat, meas, sel_stack, layout,
                                            noise, excluded, on_ground, reject, sc_predict)
    n_ch = layout.shape[0]
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
        res = work[_RES:_RES + m]
        sub_mul_vec_into(res, y, c_mat, x_bar)
        if yaw_row >= 0:
            res[yaw_row] = (res[yaw_row] + math.pi) % (2.0 * math.pi) - math.pi
        # eq. 6.12-6.14, 6.17-6.20, 6.23, 6.24
        tskf_update_into(c_mat, res, r_diag, x_bar, p_x, gamma, p_gamma, v,
                         shaped(work[_RES_COV:_RES_COV + m * m], (m, m)), work[_INN:_INN + m],
                         shaped(work[_INN_COV:_INN_COV + m * m], (m, m)),
                         scratch[_SC_UPDATE:_SC_UPDATE + TSKF_UPDATE_SCRATCH])
        x_bar[YAW_INDEX] = (x_bar[YAW_INDEX] + math.pi) % (2.0 * math.pi) - math.pi
    # x_hat = x_bar + V gamma_hat (eq. 6.25); P = V P^gamma V' + P^x (eq. 6.26), diagonal
    estimate = out[:2 * N]
    tskf_output_into(estimate, x_bar, p_x, gamma, p_gamma, v)
    # the estimate's yaw in [-pi, pi), as StateEstimate keeps it
    estimate[YAW_INDEX] = (estimate[YAW_INDEX] + math.pi) % (2.0 * math.pi) - math.pi
    return on_ground, accel_power, m


def _workspace_array(at: int, shape: tuple[int | str, ...], doc: str) -> property:
    """A read-only attribute of :class:`TwoStageKalmanFilter`: the array of ``shape`` kept in
    its workspace from ``at`` (a copy; ``"m"`` in ``shape``: the latest update's rows)."""
    def read(self: TwoStageKalmanFilter) -> FloatArray:
        return self._read(at, shape)
    return property(read, doc=doc)


FLYING_ACCEL_MODEL_SIGMA = 0.4  # m/s^2, accelerometer model error of the TSKF that flies
# Default random-walk variance of gamma per 10 ms step (eq. 6.9): see TwoStageKalmanFilter.
DEFAULT_Q_GAMMA = 1e-4


class TwoStageKalmanFilter(TickEstimator):
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
    height_source : str
        Where height comes from, "mocap" or "baro".
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
    accel_z_model_sigma : float or None
        Model error of the accelerometer's thrust measurement, m/s^2; None (the default, the
        thesis's TSKF) leaves the accelerometer out. The TSKF that flies uses 0.4
        (:data:`FLYING_ACCEL_MODEL_SIGMA`), four times the EKF's: the linear hover model also
        neglects the thrust's tilt and the drag in this row, and with 0.1 the accelerometer's model
        error spread onto the per-motor estimates at fault onsets (Table 6.1 harness: a
        failed motor's estimate left its 0.05 band when the next motor failed); with 0.4
        every estimate stays in band and the collective (a mass change) still settles
        within a second. In turbulence the vertical drag is larger still: the accelerometer's
        noise becomes its measured innovation power when that is larger (adaptive
        measurement noise in the manner of Mehra 1970: fast attack 2 s, slow decay 20 s), so
        that gusts are not read as collective thrust changes.

    Attributes
    ----------
    (Read-only; the arrays are copies of the filter's workspace.)
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

    _sets: Mapping[str, _ChannelSet]  # every height source's channels (_build_channel_sets)

    def __init__(self, model: VehicleModel, dt_s: float = 0.01,
                 q_gamma: float = DEFAULT_Q_GAMMA, *,
                 height_source: str = "mocap",
                 noise: SensorNoise | None = None,
                 process_noise: TskfProcessNoise | None = None,
                 gamma_std0: float = 0.1,
                 initial_uncertainty: InitialUncertainty | None = None,
                 ground_z_ned: float | None = 0.0,
                 ground_margin_m: float = 0.02,
                 accel_z_model_sigma: float | None = None) -> None:
        if not (math.isfinite(q_gamma) and q_gamma >= 0):
            raise ValueError(f"q_gamma = {q_gamma!r}: must be a finite number >= 0")
        if not (math.isfinite(gamma_std0) and gamma_std0 > 0):
            raise ValueError(f"gamma_std0 = {gamma_std0!r}: must be a finite number > 0 "
                             "(P^gamma must stay invertible, eq. 6.22)")
        super().__init__(model, dt_s, height_source, noise, initial_uncertainty, ground_z_ned,
                         ground_margin_m, accel_z_model_sigma)
        self.q_gamma = float(q_gamma)
        self.process_noise = process_noise if process_noise is not None else TskfProcessNoise()
        self.gamma_std0 = float(gamma_std0)
        qc = tuple(self.process_noise.diagonal().tolist())
        # designed once per configuration and shared (read-only): shared_hover_model
        self.flight_model = shared_hover_model(model, self.dt_s, qc, False)
        self.ground_model = shared_hover_model(model, self.dt_s, qc, True)
        # both models stacked for tskf_tick: index 0 flight, 1 ground
        models = (self.flight_model, self.ground_model)
        self._a_d, self._b_d, self._g_d, self._q_d = (
            np.ascontiguousarray([getattr(lm, name) for lm in models])
            for name in ("a_d", "b_d", "g_d", "q_d"))
        self._build_channel_sets()
        # the float arrays of tskf_tick in one (offsets B_*), then the channel tables
        self._buf = self._packed_buffer(B_TABLES)
        self._work = self._buf[B_WORK:B_WORK + WORK_SIZE]
        self._scratch = self._buf[B_SCRATCH:B_SCRATCH + SCRATCH_SIZE]
        # packed for tskf_tick (offsets _M_*)
        self._model = self._buf[B_MODEL:B_MODEL + MODEL_SIZE]
        nz_a = np.empty((2, N, N + 1))  # A_d's non-zero columns, listed once
        for g, a_d in enumerate(self._a_d):
            nonzero_columns(nz_a[g], a_d)
        self._model[:] = np.concatenate((self._a_d.ravel(), self._b_d.ravel(),
                                         self._g_d.ravel(), self._q_d.ravel(),
                                         [self.q_gamma, self.dt_s], self._ground,
                                         nz_a.ravel()))
        self.reset()

    def _make_channels(self, height_source: str) -> _ChannelSet:
        n = self.noise
        return _ChannelSet(tuple(Channel(sensor, sel, value_index, getattr(n, sensor),
                                         model_sigma)
                                 for sensor, sel, value_index, model_sigma
                                 in self._common_channels(height_source)),
                           self.flight_model, self.ground_model)

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
        x0, p0 = self._initial_state(initial)
        self._time_s = float(time_s)
        self._accel_power = 0.0  # (m/s^2)^2, measured innovation power of the accelerometer
        # bias-free filter x_bar, P^x (eq. 6.15-6.19), bias filter P^gamma (eq. 6.10-6.14),
        # coupling V_{k|k} (eq. 6.24), their priors and the update's residual and innovation,
        # as tskf_tick keeps them (read through the properties below)
        self._work[:] = 0.0
        self._scratch[:] = 0.0
        for at in (0, _PRIOR):
            self._work[at + _XB:at + _XB + N] = x0
            self._work[at + _PX:at + _PX + N * N] = np.diag(p0).ravel()
            self._work[at + _PG:at + _PG + G * G] = (np.eye(G) * self.gamma_std0 ** 2).ravel()
            # V = 0: the initial state and gamma are uncorrelated
        self._m = 0  # rows of the latest update
        # gamma_hat (eq. 6.13), unclipped
        self.gamma_raw = (np.zeros(N_MOTORS) if gamma0 is None
                          else np.array(gamma0, dtype=float).reshape(N_MOTORS))
        self.on_ground = False
        x_hat, p_diag = tskf_output(self.x_bar, self.P_x, self.gamma_raw, self.P_gamma, self.V)
        self._estimate = StateEstimate._from_owned(self._time_s, x_hat, p_diag)

    def _tick(self, time_s: float, u: FloatArray, channel_set: ChannelSet, meas: FloatArray,
              excluded: np.ndarray, reject: bool, out: FloatArray) -> None:
        """Advance to ``time_s`` and update with the tick's measurements, in one compiled call
        (:func:`tskf_tick`); writes ``x_hat_{k|k}`` (eq. 6.25, yaw wrapped) and the diagonal
        of eq. 6.26, then the screening, into ``out`` (:meth:`TickEstimator._tick`).

        ``time_s`` is the previous tick's plus a whole number of ``dt_s`` (within 25 % of
        ``dt_s``); zero steps (same time) update only.
        """
        cs = channel_set
        gamma = self.gamma_raw.copy()  # updated in place: gamma_raw is a fresh array each tick
        on_ground, accel_power, m = tskf_tick(
            self._work, self._scratch, gamma, out, self._model, cs.tables, cs.layout, u, meas,
            excluded, self._steps_to(time_s), time_s, reject, self.on_ground,
            self._accel_power)
        self._kept(time_s, cs, out, gamma, on_ground, accel_power, m)

    def _steps_to(self, time_s: float) -> int:
        """Time updates from the latest tick to ``time_s`` (s): a whole number of ``dt_s``
        (within 25 %), else ValueError."""
        n_steps_f = (time_s - self._time_s) / self.dt_s
        n_steps = round(n_steps_f)
        if n_steps < 0 or abs(n_steps_f - n_steps) > 0.25:
            raise ValueError(f"time_s = {time_s!r}: the TSKF is discretised at dt_s = "
                             f"{self.dt_s} s and was last stepped at {self._time_s!r} s; "
                             "call it at whole multiples of dt_s")
        return n_steps

    def _kept(self, time_s: float, cs: ChannelSet, out: FloatArray, gamma: FloatArray,
              on_ground: bool, accel_power: float, m: int) -> None:
        """What :func:`tskf_tick` at ``time_s`` (s) with the channels ``cs`` returned (the
        ground flag, the accelerometer's innovation power, the update's rows) and wrote
        (``gamma``, fresh; into ``out`` the estimate, then the screening), kept."""
        self.on_ground, self._accel_power, self._m = on_ground, accel_power, m
        self.gamma_raw = gamma
        self._ticked(time_s, cs, out)

    # ---- the workspace, read (copies) ------------------------------------------------------
    def _read(self, at: int, shape: tuple[int | str, ...]) -> FloatArray:
        """The array of ``shape`` (``"m"``: the latest update's rows) stored in the workspace
        from ``at``, a copy."""
        dims = tuple(self._m if d == "m" else int(d) for d in shape)
        return self._work[at:at + int(np.prod(dims))].reshape(dims).copy()

    x_bar = _workspace_array(_XB, (N,), "Bias-free filter's ``x_bar_{k|k}`` (eq. 6.18).")
    P_x = _workspace_array(_PX, (N, N), "Bias-free filter's ``P^x_{k|k}`` (eq. 6.19).")
    P_gamma = _workspace_array(_PG, (G, G), "Bias filter's ``P^gamma_{k|k}`` (eq. 6.14).")
    V = _workspace_array(_V, (N, G), "Coupling ``V_{k|k}`` (eq. 6.24).")
    x_bar_prior = _workspace_array(_PRIOR + _XB, (N,), "``x_bar_{k+1|k}`` (eq. 6.15).")
    P_x_prior = _workspace_array(_PRIOR + _PX, (N, N), "``P^x_{k+1|k}`` (eq. 6.16).")
    P_gamma_prior = _workspace_array(_PRIOR + _PG, (G, G), "``P^gamma_{k+1|k}`` (eq. 6.11).")
    V_prior = _workspace_array(_PRIOR + _V, (N, G), "``V_{k+1|k}`` (eq. 6.22).")
    residual = _workspace_array(_RES, ("m",), "``r_{k+1} = y - C x_bar_{k+1|k}``.")
    residual_cov = _workspace_array(_RES_COV, ("m", "m"), "``S_bar_{k+1}`` (eq. 6.20).")
    innovation = _workspace_array(_INN, ("m",), "``r - H gamma_hat_{k+1|k}``.")
    innovation_cov = _workspace_array(_INN_COV, ("m", "m"), "``H P^gamma H' + S_bar``.")

    # ---- inspection ------------------------------------------------------------------------
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
        if self._m == 0 or self._screen_out is None:
            return out
        # the update stacks the applied channels' rows in update order
        cs = self._screen_out[0]
        blocks: list[tuple[str, int, int]] = []
        for c, code in enumerate(self._statuses()):
            if code == screening.APPLIED:
                i0 = blocks[-1][2] if blocks else 0
                blocks.append((cs.sensors[c], i0, i0 + cs.channels[c].rows))
        innovation, innovation_cov = self.innovation, self.innovation_cov
        for name, i0, i1 in blocks:
            blk = innovation_cov[i0:i1, i0:i1].copy()
            res = innovation[i0:i1].copy()
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
    "TwoStageKalmanFilter",
]
