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
averaged and mapped back to the tick (:mod:`fcu.estimation.tskf_channels`).
``R = sigma^2 / n + sigma_model^2`` for a mean of n.

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
from collections.abc import Collection, Mapping

import numpy as np
from numpy.typing import ArrayLike

import fcu.floats
from fcu.estimation import screening
from fcu.estimation.channels import Channel, ChannelSet
from fcu.estimation.estimator import (
    InitialUncertainty,
    Innovation,
    SensorNoise,
    StateEstimate,
    TickEstimator,
)
from fcu.estimation.small_matrix import nonzero_columns
from fcu.estimation.state import FloatArray, GroupedSamples
from fcu.estimation.tskf_algebra import (
    tskf_output,
)
from fcu.estimation.tskf_channels import TskfChannelSet
from fcu.estimation.tskf_kernel import (
    B_MODEL,
    B_SCRATCH,
    B_TABLES,
    B_WORK,
    MODEL_SIZE,
    SCRATCH_SIZE,
    W_INN,
    W_INN_COV,
    W_P_GAMMA,
    W_P_X,
    W_PRIOR,
    W_RES,
    W_RES_COV,
    W_V,
    W_X_BAR,
    WORK_SIZE,
    G,
    N,
    tskf_tick,
)
from fcu.estimation.tskf_model import (
    N_MOTORS,
    TskfProcessNoise,
    shared_hover_model,
)
from fcu.floats import clip
from fcu.model import VehicleModel
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels

# tskf_tick compiles in the kernels of tskf_algebra, screening and what they call
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)


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

    _sets: Mapping[str, TskfChannelSet]  # every height source's channels (_build_channel_sets)

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

    def _make_channels(self, height_source: str) -> TskfChannelSet:
        n = self.noise
        return TskfChannelSet(tuple(Channel(sensor, sel, value_index, getattr(n, sensor),
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
        for at in (0, W_PRIOR):
            self._work[at + W_X_BAR:at + W_X_BAR + N] = x0
            self._work[at + W_P_X:at + W_P_X + N * N] = np.diag(p0).ravel()
            self._work[at + W_P_GAMMA:at + W_P_GAMMA + G * G] = (
                np.eye(G) * self.gamma_std0 ** 2).ravel()
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

    def pair_inputs(self, time_s: float, grouped: GroupedSamples, excluded: Collection[str]
                    ) -> tuple[FloatArray, np.ndarray, int, FloatArray, int, bool, float]:
        """The TSKF's part of :func:`fcu.estimation.pair.pair_tick`'s arguments for a tick
        at ``time_s`` (s): its buffer, the channels' integer tables for ``grouped``, the
        ``excluded`` sensors as channel bits, gamma_hat, the time updates to ``time_s``
        (ValueError off the filter's period), the ground flag and the accelerometer's
        innovation power."""
        cs = self._set
        n_steps = self._steps_to(time_s)
        return (self._buf, cs.kernel_ints(grouped),
                cs.exclusion_bits(excluded) if excluded else 0, self.gamma_raw, n_steps,
                self.on_ground, self._accel_power)

    def keep_pair_tick(self, time_s: float, out: FloatArray, gamma: FloatArray,
                       on_ground: bool, accel_power: float, m: int) -> None:
        """What the pair's compiled tick at ``time_s`` returned for the TSKF and wrote
        (``gamma``, fresh; into ``out`` its estimate, then its screening), kept as
        :meth:`step_grouped` keeps it."""
        self._kept(time_s, self._set, out, gamma, on_ground, accel_power, m)

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

    x_bar = _workspace_array(W_X_BAR, (N,), "Bias-free filter's ``x_bar_{k|k}`` (eq. 6.18).")
    P_x = _workspace_array(W_P_X, (N, N), "Bias-free filter's ``P^x_{k|k}`` (eq. 6.19).")
    P_gamma = _workspace_array(W_P_GAMMA, (G, G), "Bias filter's ``P^gamma_{k|k}`` (eq. 6.14).")
    V = _workspace_array(W_V, (N, G), "Coupling ``V_{k|k}`` (eq. 6.24).")
    x_bar_prior = _workspace_array(W_PRIOR + W_X_BAR, (N,), "``x_bar_{k+1|k}`` (eq. 6.15).")
    P_x_prior = _workspace_array(W_PRIOR + W_P_X, (N, N), "``P^x_{k+1|k}`` (eq. 6.16).")
    P_gamma_prior = _workspace_array(W_PRIOR + W_P_GAMMA, (G, G), "``P^gamma_{k+1|k}`` (eq. 6.11).")
    V_prior = _workspace_array(W_PRIOR + W_V, (N, G), "``V_{k+1|k}`` (eq. 6.22).")
    residual = _workspace_array(W_RES, ("m",), "``r_{k+1} = y - C x_bar_{k+1|k}``.")
    residual_cov = _workspace_array(W_RES_COV, ("m", "m"), "``S_bar_{k+1}`` (eq. 6.20).")
    innovation = _workspace_array(W_INN, ("m",), "``r - H gamma_hat_{k+1|k}``.")
    innovation_cov = _workspace_array(W_INN_COV, ("m", "m"), "``H P^gamma H' + S_bar``.")

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
