"""Extended Kalman filter on the full nonlinear quadrotor model (thesis section 6.1.2).

The model (eq. 3.18 in NED/FRD), its Jacobian and its discretisation are in
:mod:`fcu.estimation.ekf_model`; this module holds the filter: the compiled prediction and
updates, the process noise, and the estimator the autopilot runs.

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
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from fcu.estimation import screening
from fcu.estimation.ekf_model import (
    discrete_transition,
    model_derivative,
    model_jacobian,
    pack_params,
)
from fcu.estimation.estimator import (
    Channel,
    ChannelSet,
    InitialUncertainty,
    Innovation,
    ProcessNoiseDensities,
    SensorNoise,
    StateEstimate,
    TickEstimator,
)
from fcu.estimation.state import STATE_DIM, YAW_INDEX, FloatArray
from fcu.model import VehicleModel
from flightdata.kernel_cache import drop_stale_kernels

drop_stale_kernels(__file__)  # ekf_tick compiles in the kernels of ekf_model and screening

if TYPE_CHECKING:  # filterpy (and the scipy.stats it loads) only when the view is asked for
    from fcu.estimation.ekf_filterpy import QuadrotorEKF


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
                   r_mat: FloatArray, wrap_yaw: bool, picks: bool = False
                   ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
                              FloatArray, float]:
    """One sequential measurement update of a channel ``h(x) = S (x - delta f(x, u))``.

    One of the estimator's sequential updates in one compiled call (module docstring,
    "Measurements"): ``H = S (I - delta A(x))`` (``S`` when ``|delta| < 1e-9``),
    ``y = z - h(x)`` (yaw wrapped when ``wrap_yaw``), :func:`kalman_update`, posterior yaw
    wrapped, and the NIS (``picks``: as for :func:`~fcu.estimation.estimator.select`).

    Returns
    -------
    x_post, p_post, y, s_mat, s_inv, k_gain, nis
        Shapes (16,), (16, 16), (m,), (m, m), (m, m), (16, m); ``nis = y' S^-1 y``.
    """
    if abs(delta) < 1e-9:
        h_mat = sel
        hx = screening.select(sel, x, picks)
    else:
        # H = S (I - delta A(x))
        h_mat = sel - delta * screening.select(sel, model_jacobian(x, p, on_ground), picks)
        # h(x) = S (x - delta f(x, u))
        hx = screening.select(sel, x - delta * model_derivative(x, u, p, on_ground), picks)
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
                       on_ground: bool, sel_stack: FloatArray, layout: np.ndarray,
                       noise: FloatArray, counts: np.ndarray, deltas: FloatArray,
                       z_stack: FloatArray
                       ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
                                  FloatArray, FloatArray, int]:
    """A tick's sequential updates, channel after channel, each by :func:`channel_update`.

    Parameters
    ----------
    x, p_mat : ndarrays, shapes (16,), (16, 16)
        Prior state and covariance.
    u, p, on_ground
        As for :func:`channel_update`.
    sel_stack, layout, noise : ndarrays
        The channels (:class:`~fcu.estimation.estimator.ChannelSet`): selections ``S``
        stacked in update order, each channel's rows and yaw flag, its noise variance of one
        sample (divided by the count) and model error (not), so
        ``R = (sample_var / count + model_var) I``.
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
    n_ch = layout.shape[0]
    m_max = 1
    for c in range(n_ch):
        m_max = max(m_max, layout[c, screening.ROW1] - layout[c, screening.ROW0])
    y_stack = np.zeros(z_stack.shape[0])
    s_stack = np.zeros((n_ch, m_max, m_max))
    nis = np.zeros(n_ch)
    s_inv = np.zeros((0, 0))
    k_gain = np.zeros((x.shape[0], 0))
    last = -1
    for c in range(n_ch):
        if counts[c] <= 0:
            continue
        i0, i1 = layout[c, screening.ROW0], layout[c, screening.ROW1]
        m = i1 - i0
        # R = sigma^2 / n for the mean of n samples (+ model error, not reduced)
        r_mat = np.zeros((m, m))
        for i in range(m):
            r_mat[i, i] = screening.noise_var(noise, c, counts[c])
        x, p_mat, y, s_mat, s_inv, k_gain, nis[c] = channel_update(
            x, p_mat, z_stack[i0:i1].copy(), np.ascontiguousarray(sel_stack[i0:i1]),
            deltas[c], u, p, on_ground, r_mat, layout[c, screening.WRAP_YAW] != 0,
            layout[c, screening.PICKS] != 0)
        y_stack[i0:i1] = y
        s_stack[c, :m, :m] = s_mat
        last = c
    return x, p_mat, y_stack, s_stack, nis, s_inv, k_gain, last


# ---- the estimator's workspace (ekf_tick): one float array, these offsets ----------------
N = STATE_DIM
NN = N * N
MAX_CHANNELS, MAX_ROWS = 5, 3  # channels of a height source, rows of one channel
_X = 0  # posterior x (N)
_P = _X + N  # posterior P (N x N, row-major)
_X_PRIOR = _P + NN  # prior x
_P_PRIOR = _X_PRIOR + N  # prior P
_F = _P_PRIOR + NN  # the latest prediction's F
_Q = _F + NN  # and Q
_Y = _Q + NN  # y_stack (N rows at the most)
_Z = _Y + N  # z_stack
_NIS = _Z + N  # per channel: NIS of its update
_COUNTS = _NIS + MAX_CHANNELS  # samples applied (0: not updated)
_S_INV = _COUNTS + MAX_CHANNELS  # the last update's S^-1 (m x m, row-major, stride MAX_ROWS)
_K = _S_INV + MAX_ROWS * MAX_ROWS  # and K (N x m, stride MAX_ROWS)
WORK_SIZE = _K + N * MAX_ROWS


@njit(cache=True, error_model="numpy")
def ekf_tick(work: FloatArray, s_stack: FloatArray, on_ground: bool, u: FloatArray, dt: float,
             dt_max: float, p: FloatArray, qc_diag: FloatArray, ground: FloatArray,
             meas: FloatArray, time_s: float, excluded: np.ndarray, reject: bool,
             sel_stack: FloatArray, layout: np.ndarray, noise: FloatArray
             ) -> tuple[FloatArray, FloatArray, bool, bool, int]:
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
    on_ground : bool
        Whether the previous prediction held the vehicle on the ground (kept when there is
        nothing to predict).
    u : ndarray, shape (4,)
        PWM held since the previous tick.
    dt, dt_max : float
        Time since the previous tick and the longest prediction step, s.
    p, qc_diag : ndarrays, shapes (9,), (16,)
        Packed model (:func:`~fcu.estimation.ekf_model.pack_params`) and ``Qc`` diagonal.
    ground : ndarray, shape (3,)
        The ground plane (:func:`~fcu.estimation.estimator.on_ground_at`).
    meas, excluded, reject
        The tick's measurements, exclusions and whether a lone outlier may be rejected
        (:func:`~fcu.estimation.screening.screen_channels`).
    time_s : float
        Tick time, s.
    sel_stack, layout, noise : ndarrays
        The channels (:class:`~fcu.estimation.estimator.ChannelSet`).

    Returns
    -------
    estimate, screen, on_ground, predicted, last
        The posterior state and its covariance diagonal, shape (32,) (fresh: the estimate's
        own); the screening (:func:`~fcu.estimation.screening.screen_channels`); the
        ground flag used; whether there was a prediction; the last channel updated (-1:
        none).
    """
    x = work[_X:_X + N].copy()
    p_mat = work[_P:_P + NN].reshape(N, N).copy()
    predicted = dt > 1e-9
    if predicted:
        # a longer gap than dt_max: several equal RK4 steps
        n_sub = max(1, math.ceil(dt / dt_max - 1e-6))
        on_ground = screening.on_ground_at(x, ground)
        for _ in range(n_sub):
            # x = RK4(f, x, u, dt); P = F P F' + Q   (filterpy predict)
            x, f_mat, q_mat, p_mat = predict_covariance(x, p_mat, u, dt / n_sub, p, on_ground,
                                                        qc_diag)
            work[_F:_F + NN] = f_mat.ravel()
            work[_Q:_Q + NN] = q_mat.ravel()
    work[_X_PRIOR:_X_PRIOR + N] = x
    work[_P_PRIOR:_P_PRIOR + NN] = p_mat.ravel()
    # screened against the prior; on the ground the accelerometer is skipped
    screen, status = screening.screen_channels(x, p_mat, meas, sel_stack, layout, noise, excluded,
                                     on_ground, reject)
    n_ch = layout.shape[0]
    counts = np.zeros(n_ch, dtype=np.int64)
    deltas = np.zeros(n_ch)
    z_stack = np.zeros(sel_stack.shape[0])
    for c in range(n_ch):
        if status[c] == screening.APPLIED:
            counts[c] = int(meas[c, screening.COUNT])
            # s, how long before the tick the batch was taken
            deltas[c] = time_s - meas[c, screening.TIME]
            i0, i1 = layout[c, screening.ROW0], layout[c, screening.ROW1]
            z_stack[i0:i1] = meas[c, screening.VALUE:screening.VALUE + i1 - i0]
    # per channel: h(x) = S (x - delta f(x, u)), H = S (I - delta A(x));  y = z - h(x);
    # S = H P H' + R;  K = P H' S^-1;  x = x + K y;  P = (I - K H) P (I - K H)' + K R K'
    x, p_mat, y_stack, s_all, nis, s_inv, k_gain, last = sequential_updates(
        x, p_mat, u, p, on_ground, sel_stack, layout, noise, counts, deltas, z_stack)
    work[_X:_X + N] = x
    work[_P:_P + NN] = p_mat.ravel()
    if last >= 0:  # the updates (a tick without any keeps the latest tick's that had some)
        n_rows = sel_stack.shape[0]
        work[_Y:_Y + n_rows] = y_stack
        work[_Z:_Z + n_rows] = z_stack
        work[_NIS:_NIS + n_ch] = nis
        work[_COUNTS:_COUNTS + n_ch] = counts
        m = s_inv.shape[0]
        for i in range(m):
            for j in range(m):
                work[_S_INV + MAX_ROWS * i + j] = s_inv[i, j]
        for i in range(N):
            for j in range(m):
                work[_K + MAX_ROWS * i + j] = k_gain[i, j]
        s_stack[:] = 0.0
        s_stack[:n_ch, :s_all.shape[1], :s_all.shape[2]] = s_all
    estimate = np.empty(2 * N)
    estimate[:N] = x
    estimate[N:] = np.diag(p_mat)
    return estimate, screen, on_ground, predicted, last


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
        self._work = np.zeros(WORK_SIZE)
        self._s_stack = np.zeros((MAX_CHANNELS, MAX_ROWS, MAX_ROWS))
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
              excluded: np.ndarray, reject: bool) -> tuple[FloatArray, FloatArray]:
        """Predict to ``time_s`` (s), screen the tick's measurements and update with those
        that pass, in one compiled call (:func:`ekf_tick`)."""
        dt = time_s - self._time_s
        if dt < -1e-9:
            raise ValueError(f"time_s = {time_s!r}: earlier than the previous tick "
                             f"({self._time_s!r})")
        cs = channel_set
        estimate, screen, self._on_ground, _, last = ekf_tick(
            self._work, self._s_stack, self._on_ground, u, dt, self.dt_s, self._params,
            self._qc_diag, self._ground, meas, time_s, excluded, reject, cs.sel_stack,
            cs.layout, cs.noise)
        self._keep_screening(cs, screen)
        # the Innovation records and the filterpy view are built on request from the
        # workspace, which holds the updates of the latest tick that had some
        self._innovations = None if last >= 0 else {}
        if last >= 0:
            self._updated = (cs, last, time_s)
        return estimate[:N], estimate[N:]

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
    "kalman_update",
]
