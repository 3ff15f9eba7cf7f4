"""Extended Kalman filter on the full nonlinear quadrotor model (thesis section 6.1.2).

The model (eq. 3.18 in NED/FRD), its Jacobian and its discretisation are in
:mod:`fcu.estimation.ekf_model`; this module holds the filter: its compiled tick (the prediction of
:mod:`fcu.estimation.ekf_predict`, the screening and the updates), the process noise, and the
estimator the autopilot runs.

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
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation import screening
from fcu.estimation.channels import Channel, ChannelSet
from fcu.estimation.ekf_model import (
    TRANSITION_SCRATCH,
    model_derivative_into,
    model_jacobian_into,
    pack_params,
)
from fcu.estimation.ekf_predict import predict_covariance_into
from fcu.estimation.estimator import (
    InitialUncertainty,
    Innovation,
    ProcessNoiseDensities,
    SensorNoise,
    StateEstimate,
    TickEstimator,
)
from fcu.estimation.kalman_update import UPDATE_SCRATCH, kalman_update_into
from fcu.estimation.state import STATE_DIM, YAW_INDEX, FloatArray, GroupedSamples
from fcu.floats import wrap_pi
from fcu.model import VehicleModel
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import Layout
from jitsupport.views import refcount_free_kernel, shaped

# ekf_tick compiles in the kernels of ekf_predict, ekf_model, screening, kalman_update,
# small_matrix and kernel_views
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)

if TYPE_CHECKING:  # filterpy (and the scipy.stats it loads) only when the view is asked for
    from fcu.estimation.ekf_filterpy import QuadrotorEKF


# ---- the estimator's state: one float array, these layouts (jitsupport.layout) -----------
N = STATE_DIM
NN = N * N
MAX_ROWS = 3  # rows of one channel at the most
MAX_CHANNELS = screening.MAX_CHANNELS  # channels of a height source
WORK = Layout("EKF work (ekf_tick's state)")
_X = WORK.field("x", N)  # posterior x
_P = WORK.field("P", NN)  # posterior P (N x N, row-major)
_X_PRIOR = WORK.field("x_prior", N)  # prior x
_P_PRIOR = WORK.field("P_prior", NN)  # prior P
_F = WORK.field("F", NN)  # the latest prediction's F
_Q = WORK.field("Q", NN)  # and Q
_Y = WORK.field("y_stack", N)  # innovations (N rows at the most)
_Z = WORK.field("z_stack", N)  # measurements
_NIS = WORK.field("nis", MAX_CHANNELS)  # per channel: NIS of its update
_COUNTS = WORK.field("counts", MAX_CHANNELS)  # samples applied (0: not updated)
# the last update's S^-1 (m x m, stride MAX_ROWS)
_S_INV = WORK.field("S_inv", MAX_ROWS * MAX_ROWS)
_K = WORK.field("K", N * MAX_ROWS)  # and K (N x m, stride MAX_ROWS)
WORK_SIZE = WORK.size
SCRATCH = Layout("EKF scratch (within one ekf_tick)")
# discrete_transition_into's
_SC_TRANSITION = SCRATCH.field("transition", TRANSITION_SCRATCH[0] * NN)
_SC_UPDATE = SCRATCH.field("update", UPDATE_SCRATCH)  # kalman_update_into's
_SC_JAC = SCRATCH.field("A", NN)  # A at the update's x (N x N)
_SC_XD = SCRATCH.field("f", N)  # f at the update's x (N)
_SC_H = SCRATCH.field("H", MAX_ROWS * N)  # H (MAX_ROWS x N)
_SC_HX = SCRATCH.field("h", MAX_ROWS)  # h(x)
_SC_Y = SCRATCH.field("y", MAX_ROWS)  # y
_SC_R = SCRATCH.field("R", MAX_ROWS * MAX_ROWS)  # R (MAX_ROWS x MAX_ROWS)
_SC_S = SCRATCH.field("S", MAX_ROWS * MAX_ROWS)  # S
_SC_S_INV = SCRATCH.field("S_inv", MAX_ROWS * MAX_ROWS)  # S^-1
_SC_K = SCRATCH.field("K_t", N * MAX_ROWS)  # K' (MAX_ROWS x N)
_SC_NZ_F = SCRATCH.field("F_nonzero", N * (N + 1))  # F's non-zero columns (N x (N + 1))
# the tick's measurement table, when gathered here (pair_tick)
SC_MEAS = SCRATCH.field("measurements", MAX_CHANNELS * screening.MEAS_WIDTH)
SCRATCH_SIZE = SCRATCH.size
N_PARAMS = 9  # entries of pack_params' model
CONSTANTS = Layout("EKF constants")
_C_PARAMS = CONSTANTS.field("model", N_PARAMS)  # the packed model (pack_params)
_C_QC = CONSTANTS.field("Qc", N)  # Qc diagonal (N)
_C_GROUND = CONSTANTS.field("ground", 3)  # the ground plane (on_ground_at)
_C_DT_MAX = CONSTANTS.field("dt_max", 1)  # the longest prediction step, s
CONSTANTS_SIZE = CONSTANTS.size
# the estimator's float arrays, kept in one (ExtendedKalmanEstimator._buf), so that a
# compiled call takes them as one argument (fcu.estimation.pair); then every height source's
# channel tables (ChannelSet.tables_at)
BUFFER = Layout("EKF buffer (ExtendedKalmanEstimator._buf)")
B_WORK = BUFFER.field("work", WORK_SIZE)
# (MAX_CHANNELS x MAX_ROWS x MAX_ROWS)
B_S_STACK = BUFFER.field("s_stack", MAX_CHANNELS * MAX_ROWS * MAX_ROWS)
B_SCRATCH = BUFFER.field("scratch", SCRATCH_SIZE)
B_CONSTANTS = BUFFER.field("constants", CONSTANTS_SIZE)
B_TABLES = BUFFER.size


@njit(cache=True, error_model="numpy", inline="always")
def buffer_views(buf: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`ekf_tick`'s ``work``, ``s_stack``, ``scratch`` and ``constants``: views of the
    estimator's buffer ``buf`` (offsets ``B_*``), holding no reference (:func:`shaped`)."""
    return (buf[B_WORK:B_WORK + WORK_SIZE],
            shaped(buf[B_S_STACK:B_SCRATCH], (MAX_CHANNELS, MAX_ROWS, MAX_ROWS)),
            buf[B_SCRATCH:B_SCRATCH + SCRATCH_SIZE],
            buf[B_CONSTANTS:B_CONSTANTS + CONSTANTS_SIZE])


@njit(cache=True, error_model="numpy")
def _entries_read(sel: np.ndarray) -> tuple[int, int]:
    """``first, end``: the state entries ``first <= k < end`` a channel's selection ``sel``
    (m, N) reads. (A function of its own so that the bounds reach the model kernels typed as
    integers, not as the constants they start from: numba would compile those kernels once
    more for the constants.)"""
    first, end = N, 0
    for r in range(sel.shape[0]):
        for k in range(N):
            if sel[r, k] != 0.0:
                first, end = min(first, k), max(end, k + 1)
    return first, end


@refcount_free_kernel
def ekf_tick(work: FloatArray, s_stack: FloatArray, scratch: FloatArray, out: FloatArray,
             constants: FloatArray, tables: FloatArray, layout: np.ndarray, u: FloatArray,
             meas: FloatArray, excluded: np.ndarray, dt: float, time_s: float, reject: bool,
             on_ground: bool) -> tuple[bool, int]:
    """One tick of the estimator in one compiled call: predict, screen, update.

    Parameters
    ----------
    work : ndarray, shape (WORK_SIZE,)
        The estimator's workspace (:data:`WORK`), updated in place: read are the previous
        posterior ``x``, ``P``; written are the posterior, the prior, ``F`` and ``Q`` (when
        there is a prediction), and, when a channel was updated, the updates' innovations
        (``y_stack``), NIS, sample counts (0: not updated), measurements (``z_stack``) and
        the last update's ``S^-1`` and ``K`` (top-left blocks).
    s_stack : ndarray, shape (MAX_CHANNELS, MAX_ROWS, MAX_ROWS)
        Written with the updates: each channel's innovation covariance ``S`` (top-left
        block).
    scratch : ndarray, shape (SCRATCH_SIZE,)
        Room for the tick's intermediate results (nothing kept from tick to tick).
    out : ndarray, shape (32 + 2 rows_total + 2 n_ch,)
        Written: the posterior state (yaw wrapped to [-pi, pi)) and its covariance
        diagonal, then the screening (:func:`~fcu.estimation.screening.screen_channels`'
        table).
    constants : ndarray, shape (CONSTANTS_SIZE,)
        The packed model (:func:`~fcu.estimation.ekf_model.pack_params`), the ``Qc``
        diagonal, the ground plane (:func:`~fcu.estimation.estimator.on_ground_at`) and the
        longest prediction step (s), packed (offsets ``_C_*``).
    tables, layout : ndarrays
        The channels (:class:`~fcu.estimation.channels.ChannelSet`).
    u : ndarray, shape (4,)
        PWM held since the previous tick.
    meas, excluded, reject
        The tick's measurements, exclusions and whether a lone outlier may be rejected
        (:func:`~fcu.estimation.screening.screen_channels`).
    dt : float
        Time since the previous tick, s.
    time_s : float
        Tick time, s.
    on_ground : bool
        Whether the previous prediction held the vehicle on the ground (kept when there is
        nothing to predict).

    Returns
    -------
    on_ground, last
        The ground flag used; the last channel updated (-1: none).
    """
    p = constants[_C_PARAMS:_C_PARAMS + N_PARAMS]
    qc_diag = constants[_C_QC:_C_QC + N]
    ground = constants[_C_GROUND:_C_GROUND + 3]
    dt_max = constants[_C_DT_MAX]
    sel_stack, noise, _ = screening.channel_tables(tables, layout)
    x = work[_X:_X + N]
    p_mat = shaped(work[_P:_P + NN], (N, N))
    if dt > 1e-9:
        # a longer gap than dt_max: several equal RK4 steps
        n_sub = max(1, math.ceil(dt / dt_max - 1e-6))
        on_ground = screening.on_ground_at(x, ground)
        f_mat = shaped(work[_F:_F + NN], (N, N))
        q_mat = shaped(work[_Q:_Q + NN], (N, N))
        sc_tr = shaped(scratch[_SC_TRANSITION:_SC_UPDATE], TRANSITION_SCRATCH)
        nz_f = shaped(scratch[_SC_NZ_F:_SC_NZ_F + N * (N + 1)], (N, N + 1))
        for _ in range(n_sub):
            # x = RK4(f, x, u, dt); P = F P F' + Q   (filterpy predict)
            predict_covariance_into(x, p_mat, u, dt / n_sub, p, on_ground, qc_diag, f_mat,
                                    q_mat, sc_tr, nz_f)
    for i in range(N + NN):  # the prior: x, P
        work[_X_PRIOR + i] = work[_X + i]
    # screened against the prior; on the ground the accelerometer is skipped
    screen = out[2 * N:]
    screening.screen_channels_into(
        screen, x, p_mat, meas, sel_stack, layout, noise, excluded, on_ground, reject,
        scratch[_SC_TRANSITION:_SC_TRANSITION + screening.SCREEN_SCRATCH])
    n_ch = layout.shape[0]
    n_rows = sel_stack.shape[0]
    status = screen[2 * n_rows + n_ch:]  # the channels' status codes
    last = -1
    for c in range(n_ch):
        if status[c] == screening.APPLIED:
            last = c
    if last >= 0:  # this tick's updates replace the latest tick's that had some
        for i in range(n_rows):
            work[_Y + i] = 0.0
            work[_Z + i] = 0.0
        for c in range(n_ch):
            work[_NIS + c] = 0.0
            work[_COUNTS + c] = 0.0
        s_stack[:, :, :] = 0.0
    sc_update = scratch[_SC_UPDATE:_SC_UPDATE + UPDATE_SCRATCH]
    jac = shaped(scratch[_SC_JAC:_SC_JAC + NN], (N, N))
    xd = scratch[_SC_XD:_SC_XD + N]
    # per channel: h(x) = S (x - delta f(x, u)), H = S (I - delta A(x));  y = z - h(x);
    # S = H P H' + R;  K = P H' S^-1;  x = x + K y;  P = (I - K H) P (I - K H)' + K R K'
    for c in range(n_ch):
        if status[c] != screening.APPLIED:
            continue
        i0, i1 = layout[c, screening.ROW0], layout[c, screening.ROW1]
        m = i1 - i0
        count = meas[c, screening.COUNT]
        # s, how long before the tick the batch was taken
        delta = time_s - meas[c, screening.TIME]
        sel = sel_stack[i0:i1]
        h_mat = shaped(scratch[_SC_H:_SC_H + m * N], (m, N))
        hx = scratch[_SC_HX:_SC_HX + m]
        y = scratch[_SC_Y:_SC_Y + m]
        r_mat = shaped(scratch[_SC_R:_SC_R + m * m], (m, m))
        s_mat = shaped(scratch[_SC_S:_SC_S + m * m], (m, m))
        s_inv = shaped(scratch[_SC_S_INV:_SC_S_INV + m * m], (m, m))
        k_gain_t = shaped(scratch[_SC_K:_SC_K + m * N], (m, N))  # K'
        mapped = abs(delta) >= 1e-9
        if mapped:
            # A and f only in the rows of the state entries the channel reads
            first, end = _entries_read(sel)
            model_jacobian_into(jac, x, p, on_ground, first, end)
            model_derivative_into(xd, x, u, p, on_ground, first, end)
        for r in range(m):
            # H = S (I - delta A(x)) (S when delta = 0);  h(x) = S (x - delta f(x, u))
            acc = 0.0
            for j in range(N):
                h_mat[r, j] = sel[r, j]
            for k in range(N):
                s_rk = sel[r, k]
                if s_rk == 0.0:
                    continue
                if mapped:
                    acc += s_rk * (x[k] - delta * xd[k])
                    for j in range(N):
                        h_mat[r, j] -= delta * (s_rk * jac[k, j])
                else:
                    acc += s_rk * x[k]
            hx[r] = acc
            # y = z - h(x)
            y[r] = meas[c, screening.VALUE + r] - acc
            # R = sigma^2 / n for the mean of n samples (+ model error, not reduced)
            for q in range(m):
                r_mat[r, q] = 0.0
            r_mat[r, r] = screening.noise_var(noise, c, count)
        if layout[c, screening.WRAP_YAW] != 0:  # attitude: yaw difference wrapped
            y[2] = wrap_pi(y[2])
        # K = P H' (H P H' + R)^-1;  x = x + K y;  P = (I-KH) P (I-KH)' + K R K'
        kalman_update_into(x, p_mat, y, h_mat, r_mat, s_mat, s_inv, k_gain_t, sc_update)
        x[YAW_INDEX] = wrap_pi(x[YAW_INDEX])
        # NIS = y' S^-1 y
        nis = 0.0
        for r in range(m):
            for q in range(m):
                nis += y[r] * s_inv[r, q] * y[q]
        work[_NIS + c] = nis
        work[_COUNTS + c] = count
        for r in range(m):
            work[_Y + i0 + r] = y[r]
            work[_Z + i0 + r] = meas[c, screening.VALUE + r]
            for q in range(m):
                s_stack[c, r, q] = s_mat[r, q]
        if c == last:  # the last update's S^-1 and K
            for r in range(m):
                for q in range(m):
                    work[_S_INV + MAX_ROWS * r + q] = s_inv[r, q]
            for i in range(N):
                for r in range(m):
                    work[_K + MAX_ROWS * i + r] = k_gain_t[r, i]
    for i in range(N):
        out[i] = x[i]
        out[N + i] = p_mat[i, i]
    # the estimate's yaw in [-pi, pi), as StateEstimate keeps it
    out[YAW_INDEX] = wrap_pi(out[YAW_INDEX])
    return on_ground, last


@dataclass(frozen=True, kw_only=True)
class EkfProcessNoise(ProcessNoiseDensities):
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


class ExtendedKalmanEstimator(TickEstimator):
    """EKF state estimator of the autopilot (thesis section 6.1.2), built on filterpy.

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe (Table 7.1).
    dt_s : float
        Nominal control-tick period, s (100 Hz: 0.01). A longer gap between two ticks is
        covered by several RK4 steps of at most ``dt_s``.
    height_source : str
        Where height comes from, "mocap" or "baro" (module :mod:`fcu.estimation.state`).
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
                 height_source: str = "mocap", *,
                 noise: SensorNoise | None = None,
                 process_noise: EkfProcessNoise | None = None,
                 initial_uncertainty: InitialUncertainty | None = None,
                 ground_z_ned: float | None = 0.0,
                 ground_margin_m: float = 0.02,
                 accel_z_model_sigma: float | None = 0.1) -> None:
        super().__init__(model, dt_s, height_source, noise, initial_uncertainty, ground_z_ned,
                         ground_margin_m, accel_z_model_sigma)
        self.process_noise = process_noise if process_noise is not None else EkfProcessNoise()
        self._params = pack_params(model)
        self._qc_diag = self.process_noise.diagonal()
        self._build_channel_sets()
        # the float arrays of ekf_tick in one (offsets B_*), then the channel tables
        self._buf = self._packed_buffer(B_TABLES)
        self._work = self._buf[B_WORK:B_WORK + WORK_SIZE]
        self._s_stack = self._buf[B_S_STACK:B_SCRATCH].reshape(MAX_CHANNELS, MAX_ROWS,
                                                                MAX_ROWS)
        self._scratch = self._buf[B_SCRATCH:B_SCRATCH + SCRATCH_SIZE]
        # packed for ekf_tick (offsets _C_*)
        self._constants = self._buf[B_CONSTANTS:B_CONSTANTS + CONSTANTS_SIZE]
        self._constants[:] = np.concatenate((self._params, self._qc_diag, self._ground,
                                             [self.dt_s]))
        self.reset()

    def _make_channels(self, height_source: str) -> ChannelSet:
        n = self.noise
        return ChannelSet(tuple(Channel(sensor, sel, value_index, getattr(n, sensor), model_sigma)
                                for sensor, sel, value_index, model_sigma
                                in self._common_channels(height_source)))

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
        x0, p0 = self._initial_state(initial)
        # x, P, priors, F, Q and the latest updates, as ekf_tick keeps them
        self._work[:] = 0.0
        self._s_stack[:] = 0.0
        self._scratch[:] = 0.0
        w = self._work
        w[_X:_X + N] = w[_X_PRIOR:_X_PRIOR + N] = x0
        w[_P:_P + NN] = w[_P_PRIOR:_P_PRIOR + NN] = np.diag(p0).ravel()
        w[_F:_F + NN] = w[_Q:_Q + NN] = np.eye(N).ravel()  # filterpy's start
        self._on_ground = False
        # the channels, the last channel updated and the time of the latest tick with updates
        self._updated: tuple[ChannelSet, int, float] | None = None
        self._innovations: dict[str, Innovation] | None = {}
        self._time_s = float(time_s)
        self._estimate = StateEstimate._from_owned(self._time_s, x0.astype(float),
                                                   p0.astype(float))

    def _tick(self, time_s: float, u: FloatArray, channel_set: ChannelSet, meas: FloatArray,
              excluded: np.ndarray, reject: bool, out: FloatArray) -> None:
        """Predict to ``time_s`` (s), screen the tick's measurements and update with those
        that pass, in one compiled call (:func:`ekf_tick`), writing the estimate and the
        screening into ``out`` (:meth:`TickEstimator._tick`)."""
        cs = channel_set
        on_ground, last = ekf_tick(
            self._work, self._s_stack, self._scratch, out, self._constants, cs.tables,
            cs.layout, u, meas, excluded, self._dt_to(time_s), time_s, reject,
            self._on_ground)
        self._kept(time_s, cs, out, on_ground, last)

    def pair_inputs(self, time_s: float, grouped: GroupedSamples, excluded: Collection[str]
                    ) -> tuple[FloatArray, np.ndarray, int, float, bool]:
        """The EKF's part of :func:`fcu.estimation.pair.pair_tick`'s arguments for a tick at
        ``time_s`` (s): its buffer, the channels' integer tables for ``grouped``, the
        ``excluded`` sensors as channel bits, the prediction step (s; ValueError when
        ``time_s`` is earlier than the latest tick) and the ground flag."""
        cs = self._set
        return (self._buf, cs.kernel_ints(grouped),
                cs.exclusion_bits(excluded) if excluded else 0, self._dt_to(time_s),
                self._on_ground)

    def keep_pair_tick(self, time_s: float, out: FloatArray, on_ground: bool,
                       last: int) -> None:
        """What the pair's compiled tick at ``time_s`` returned for the EKF and wrote into
        ``out`` (its estimate, then its screening), kept as :meth:`step_grouped` keeps it."""
        self._kept(time_s, self._set, out, on_ground, last)

    def _dt_to(self, time_s: float) -> float:
        """Time from the latest tick to ``time_s``, s (ValueError when ``time_s`` is
        earlier)."""
        dt = time_s - self._time_s
        if dt < -1e-9:
            raise ValueError(f"time_s = {time_s!r}: earlier than the previous tick "
                             f"({self._time_s!r})")
        return dt

    def _kept(self, time_s: float, cs: ChannelSet, out: FloatArray, on_ground: bool,
              last: int) -> None:
        """What :func:`ekf_tick` at ``time_s`` (s) with the channels ``cs`` returned (the
        ground flag, the last channel updated) and wrote into ``out`` (the estimate, then
        the screening), kept."""
        self._on_ground = on_ground
        self._ticked(time_s, cs, out)
        # the Innovation records and the filterpy view are built on request from the
        # workspace, which holds the updates of the latest tick that had some
        self._innovations = None if last >= 0 else {}
        if last >= 0:
            self._updated = (cs, last, time_s)

    def _update_parts(self, cs: ChannelSet, c: int) -> tuple[FloatArray, ...]:
        """(y, S, S^-1, K, z) of channel ``c``'s update at the latest tick (copies)."""
        w = self._work
        i0, i1 = cs.rows_list[c]
        m = i1 - i0
        return (w[_Y + i0:_Y + i1].copy(), self._s_stack[c, :m, :m].copy(),
                w[_S_INV:_S_INV + MAX_ROWS * m].reshape(m, MAX_ROWS)[:, :m].copy(),
                w[_K:_K + MAX_ROWS * N].reshape(N, MAX_ROWS)[:, :m].copy(),
                w[_Z + i0:_Z + i1].copy())

    # ---- inspection ------------------------------------------------------------------------
    @property
    def x(self) -> FloatArray:
        """Posterior state ``x_{k|k}``, shape (16,) (a copy)."""
        return self._work[_X:_X + N].copy()

    @property
    def P(self) -> FloatArray:  # noqa: N802 (filter notation)
        """Posterior covariance ``P_{k|k}``, shape (16, 16) (a copy)."""
        return self._work[_P:_P + NN].reshape(N, N).copy()

    @property
    def x_prior(self) -> FloatArray:
        """Prior state ``x_{k|k-1}`` of the latest tick, shape (16,) (a copy)."""
        return self._work[_X_PRIOR:_X_PRIOR + N].copy()

    @property
    def P_prior(self) -> FloatArray:  # noqa: N802 (filter notation)
        """Prior covariance ``P_{k|k-1}`` of the latest tick, shape (16, 16) (a copy)."""
        return self._work[_P_PRIOR:_P_PRIOR + NN].reshape(N, N).copy()

    @property
    def on_ground(self) -> bool:
        """Whether the latest prediction held the vehicle on the ground."""
        return bool(self._on_ground)

    @property
    def filter(self) -> QuadrotorEKF:
        """The latest tick as filterpy's EKF holds it (built on request, copies): ``x``,
        ``P``, the priors, the latest prediction's ``F`` and ``Q``, and the latest update's
        ``y``, ``S``, ``SI``, ``K``, ``z``."""
        from fcu.estimation.ekf_filterpy import QuadrotorEKF

        f = QuadrotorEKF(self._params, self._qc_diag)
        f.x, f.P, f.x_prior, f.P_prior = self.x, self.P, self.x_prior, self.P_prior
        f.x_post, f.P_post = self.x, self.P
        f.F = self._work[_F:_F + NN].reshape(N, N).copy()
        f.Q = self._work[_Q:_Q + NN].reshape(N, N).copy()
        f.step_dt_s, f.on_ground = self.dt_s, self._on_ground
        if self._updated is not None:
            cs, last, _ = self._updated
            f.y, f.S, f.SI, f.K, f.z = self._update_parts(cs, last)
        return f

    @property
    def last_innovation(self) -> Mapping[str, Innovation]:
        """Innovation, its covariance and NIS of each sensor updated at the latest tick."""
        if self._innovations is None:
            assert self._updated is not None
            cs, _, time_s = self._updated
            n_ch = len(cs.channels)
            counts = self._work[_COUNTS:_COUNTS + n_ch].tolist()
            nis = self._work[_NIS:_NIS + n_ch].tolist()
            self._innovations = {}
            for c, sensor in enumerate(cs.sensors):
                if counts[c] > 0:
                    y, s_mat, _, _, _ = self._update_parts(cs, c)
                    self._innovations[sensor] = Innovation(sensor, time_s, y, s_mat, nis[c])
        return dict(self._innovations)


__all__ = [
    "EkfProcessNoise",
    "ExtendedKalmanEstimator",
]
