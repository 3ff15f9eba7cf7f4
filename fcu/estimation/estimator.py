"""The frame both state estimators share: checked construction, the measurement channels,
reset to an initial estimate, one call per tick, the ground test and inspection.

:class:`TickEstimator` is the base of :class:`~fcu.estimation.ekf.ExtendedKalmanEstimator`
and :class:`~fcu.estimation.tskf.TwoStageKalmanFilter`; each filter adds its own
maths in :meth:`TickEstimator.step_grouped` and its own per-channel data.

Measurements common to both (state layout of :mod:`fcu.estimation.state`), linear in the
state at their sample time, ``y = S x``: mocap position (x, y only when
``height_source="baro"``), barometric altitude ``-z`` (baro source only), mocap attitude
(its yaw innovation wrapped to [-pi, pi)), the gyro, and the accelerometer's body-z axis
(``f_z = -(T1 + T2 + T3 + T4)/m``, thrust along -z_body; skipped on the ground, where the
accelerometer feels the ground reaction).

Screening (beyond the thesis, which assumes healthy sensors)
-----------------------------------------------------------
Before its update, each tick, an estimator screens every sensor that delivered a batch
against its prior (:meth:`TickEstimator._screen`): the innovation ``nu = z - S x_prior``, its
variance ``diag(S P_prior S' + R)`` and ``NIS = nu' (S P S' + R)^-1 nu`` (chi-square with m
degrees of freedom for a consistent filter). A measurement is *rejected* for this tick when its
NIS exceeds the gate (the chi-square quantile at probability :data:`GATE_PROBABILITY`, about
6 sigma) **and it is the only one to do so**: one sensor far from what the others and the
model agree on is that sensor's fault, while several at once (a motor failing, a gust the
model does not know) is the model's, and then every measurement is needed. Sensors the
autopilot's health monitor has *excluded* are screened too (so it can see them recover) but
never applied. :attr:`TickEstimator.screening` keeps the tick's :class:`ChannelCheck` per
sensor. The height source can be switched at run time (:attr:`TickEstimator.height_source`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike
from scipy.stats import chi2

from fcu.estimation.state import (
    STATE_DIM,
    THRUST,
    Z_INDEX,
    FloatArray,
    InitialUncertainty,
    SampleBatch,
    SensorNoise,
    StateEstimate,
    check_height_source,
    group_samples,
)
from fcu.hal import SensorSampleLike
from fcu.model import VehicleModel

GATE_PROBABILITY = 1e-9
"""Probability that a consistent measurement exceeds its NIS gate (about 6 sigma)."""

ChannelStatus = str  # "applied" | "rejected" | "excluded" | "skipped"


@dataclass(frozen=True, slots=True)
class ChannelCheck:
    """One sensor's measurement at one tick, screened against the prior (module docstring).

    Attributes
    ----------
    sensor : str
    residual : ndarray, shape (m,)
        ``nu = z - S x_prior`` (yaw wrapped), sensor units.
    variance : ndarray, shape (m,)
        ``diag(S P_prior S' + R)``, sensor units squared.
    nis : float
        ``nu' (S P_prior S' + R)^-1 nu``.
    gate : float
        The NIS above which it is an outlier.
    status : {"applied", "rejected", "excluded", "skipped"}
        Used in the update; a lone outlier this tick; excluded by the health monitor; not
        usable now (the accelerometer on the ground).
    """

    sensor: str
    residual: FloatArray
    variance: FloatArray
    nis: float
    gate: float
    status: ChannelStatus

    @property
    def outlier(self) -> bool:
        """NIS above the gate."""
        return self.nis > self.gate


@njit(cache=True, error_model="numpy")
def screen_channel(sel: FloatArray, z: FloatArray, x: FloatArray, p_mat: FloatArray,
                   r_var: float, wrap_yaw: bool) -> tuple[FloatArray, FloatArray, float]:
    """One channel's screening against the prior (module docstring), compiled.

    Returns ``nu = z - S x`` (third entry wrapped to [-pi, pi) when ``wrap_yaw``), the
    diagonal of ``S P S' + R`` (``R = r_var I``) and ``NIS = nu' (S P S' + R)^-1 nu``.
    """
    nu = z - sel @ x
    if wrap_yaw:
        nu[2] = (nu[2] + math.pi) % (2.0 * math.pi) - math.pi
    s_mat = sel @ p_mat @ sel.T
    for i in range(s_mat.shape[0]):
        s_mat[i, i] += r_var
    nis = float(nu @ np.linalg.solve(s_mat, nu))
    return nu, np.diag(s_mat).copy(), nis


_DENSITY_NAMES = ("pos", "accel", "euler", "ang_accel", "thrust")


class ProcessNoiseDensities:
    """Validation and state-order diagonal of a frozen dataclass of continuous process-noise
    spectral densities with the fields ``pos``, ``accel``, ``euler``, ``ang_accel`` and
    ``thrust`` (:class:`~fcu.estimation.ekf.EkfProcessNoise`,
    :class:`~fcu.estimation.tskf.TskfProcessNoise`)."""

    pos: float  # m^2/s
    accel: float  # (m/s^2)^2/Hz, each NED axis
    euler: float  # rad^2/s
    ang_accel: float  # (rad/s^2)^2/Hz, each axis
    thrust: float  # N^2/s, each motor

    def __post_init__(self) -> None:
        for name in _DENSITY_NAMES:
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} = {value!r}: spectral density must be finite, >= 0")

    def diagonal(self) -> FloatArray:
        """``Qc`` diagonal in the state order, shape (16,)."""
        return np.array([self.pos] * 3 + [self.accel] * 3 + [self.euler] * 3
                        + [self.ang_accel] * 3 + [self.thrust] * 4)


def selection(columns: tuple[int, ...], sign: float = 1.0) -> FloatArray:
    """Selection matrix ``S`` picking ``columns`` of the state (times ``sign``), (m, 16)."""
    sel = np.zeros((len(columns), STATE_DIM))
    sel[np.arange(len(columns)), list(columns)] = sign
    return sel


class Channel:
    """One measurement kind: ``y = S x`` at its sample time, from entries of a sample value.

    Parameters
    ----------
    sensor : str
        Sensor name (:data:`flightdata.vocabulary.SENSORS`).
    selection : ndarray, shape (m, 16)
        ``S``.
    value_index : tuple of int
        The (consecutive) entries of the sample value measured.
    sigma : float
        Noise of one sample, sensor units (``R = sigma^2 / n`` for a mean of n).
    model_sigma : float
        Model error of the measurement, sensor units (added to ``R``, not reduced by
        averaging).
    """

    def __init__(self, sensor: str, selection: FloatArray, value_index: tuple[int, ...],
                 sigma: float, model_sigma: float = 0.0) -> None:
        self.sensor = sensor
        self.sample_var = float(sigma) ** 2  # per sample, divided by n for a mean of n
        self.model_var = float(model_sigma) ** 2  # not reduced by averaging
        self.selection = np.ascontiguousarray(selection, dtype=float)  # S, shape (m, 16)
        self.value_index = np.array(value_index)  # entries of the sample value used
        if list(value_index) != list(range(value_index[0], value_index[-1] + 1)):
            raise ValueError(f"value_index = {value_index!r}: must be consecutive")
        self.value_slice = slice(value_index[0], value_index[-1] + 1)  # the same, as a slice
        self.rows = self.selection.shape[0]  # m
        self.wrap_yaw = sensor == "mocap_att"  # innovation's third entry is a yaw difference
        # NIS gate: chi-square quantile of m degrees of freedom at GATE_PROBABILITY
        self.gate = float(chi2.isf(GATE_PROBABILITY, self.rows))

    def noise_var(self, count: int) -> float:
        """``R`` (per axis) of a mean of ``count`` samples."""
        return self.sample_var / count + self.model_var


def common_channels(height_source: str, model: VehicleModel, accel_model_sigma: float | None
                    ) -> list[tuple[str, FloatArray, tuple[int, ...], float]]:
    """(sensor, ``S``, value entries, model error) of the measurements both estimators use,
    in update order (module docstring); the accelerometer with its model error
    ``accel_model_sigma`` (m/s^2), or not at all when None."""
    channels: list[tuple[str, FloatArray, tuple[int, ...], float]] = []
    if height_source == "baro":
        channels.append(("mocap_pos", selection((0, 1)), (0, 1), 0.0))
        channels.append(("baro", selection((Z_INDEX,), -1.0), (0,), 0.0))  # alt = -z
    else:
        channels.append(("mocap_pos", selection((0, 1, 2)), (0, 1, 2), 0.0))
    channels.append(("mocap_att", selection((6, 7, 8)), (0, 1, 2), 0.0))
    channels.append(("gyro", selection((9, 10, 11)), (0, 1, 2), 0.0))
    if accel_model_sigma is not None:
        # body-z specific force f_z = -(T1 + T2 + T3 + T4)/m (thrust along -z_body)
        accel = np.zeros((1, STATE_DIM))
        accel[0, THRUST] = -1.0 / model.mass
        channels.append(("accel", accel, (2,), accel_model_sigma))
    return channels


class TickEstimator:
    """What an estimator of the autopilot is, apart from its filter maths.

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe (Table 7.1).
    dt_s : float
        Nominal control-tick period, s.
    height_source : str
        Where height comes from (:data:`flightdata.vocabulary.HEIGHT_SOURCES`).
    noise : SensorNoise or None
        Assumed measurement noise (default :class:`SensorNoise`).
    initial_uncertainty : InitialUncertainty or None
        Covariance used by ``reset`` when the initial estimate carries none.
    ground_z_ned : float or None
        z (NED, m) of the ground plane, or None for no ground contact.
    ground_margin_m : float
        Distance above the ground plane within which the vehicle counts as on the ground, m.
    """

    def __init__(self, model: VehicleModel, dt_s: float, height_source: str,
                 noise: SensorNoise | None, initial_uncertainty: InitialUncertainty | None,
                 ground_z_ned: float | None, ground_margin_m: float) -> None:
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be a finite number > 0 s")
        if not (math.isfinite(ground_margin_m) and ground_margin_m >= 0):
            raise ValueError(f"ground_margin_m = {ground_margin_m!r}: must be >= 0 m")
        self.model = model
        self.dt_s = float(dt_s)
        self._height_source = check_height_source(height_source)
        self.noise = noise if noise is not None else SensorNoise()
        self.initial_uncertainty = (initial_uncertainty if initial_uncertainty is not None
                                    else InitialUncertainty())
        self.ground_z_ned = ground_z_ned
        self.ground_margin_m = float(ground_margin_m)
        self._weight_n = model.mass * model.gravity
        self._time_s = 0.0
        self._kinds: frozenset[str] = frozenset()
        self._estimate: StateEstimate | None = None
        self.screening: dict[str, ChannelCheck] = {}
        """Each sensor's :class:`ChannelCheck` at the latest tick (module docstring)."""

    # ---- the measurement channels ------------------------------------------------------------
    @property
    def height_source(self) -> str:
        """Where height comes from now ("mocap" or "baro"); settable between ticks (the
        autopilot's health monitor falls back to the other source when one fails)."""
        return self._height_source

    @height_source.setter
    def height_source(self, source: str) -> None:
        source = check_height_source(source)
        if source != self._height_source:
            self._height_source = source
            self._select_channels(source)

    def _select_channels(self, height_source: str) -> None:
        """Make the channel set of ``height_source`` the one updated (built at construction
        for every source, :data:`flightdata.vocabulary.HEIGHT_SOURCES`)."""
        raise NotImplementedError

    def _screen(self, channels: Iterable[Channel], batches: Mapping[str, SampleBatch],
                x: FloatArray, p_mat: FloatArray, excluded: Collection[str],
                usable: Callable[[Channel], bool], reject: bool) -> dict[str, SampleBatch]:
        """Screen the tick's measurements against the prior ``x``, ``p_mat`` (module
        docstring); returns the batches to update with and sets :attr:`screening`.

        ``usable(channel)`` says whether a delivered channel can be used at all now (the
        accelerometer not on the ground); ``reject`` whether a lone outlier may be rejected
        (the caller knows when the model is too uncertain for that: on the ground, in a
        tumble).
        """
        checks: dict[str, ChannelCheck] = {}
        outliers: list[str] = []
        for ch in channels:
            batch = batches.get(ch.sensor)
            if batch is None:
                continue
            nu, variance, nis = screen_channel(
                ch.selection, np.asarray(batch.value, dtype=float)[ch.value_slice], x, p_mat,
                ch.noise_var(batch.count), ch.wrap_yaw)
            if ch.sensor in excluded:
                status = "excluded"
            elif not usable(ch):
                status = "skipped"
            else:
                status = "applied"
                if nis > ch.gate:
                    outliers.append(ch.sensor)
            checks[ch.sensor] = ChannelCheck(ch.sensor, nu, variance, nis, ch.gate, status)
        if reject and len(outliers) == 1:  # a lone outlier is that sensor's fault
            c = checks[outliers[0]]
            checks[c.sensor] = ChannelCheck(c.sensor, c.residual, c.variance, c.nis, c.gate,
                                            "rejected")
        self.screening = checks
        return {name: batches[name] for name, c in checks.items() if c.status == "applied"}

    def _initial_state(self, initial: StateEstimate | None) -> tuple[FloatArray, FloatArray]:
        """State and covariance diagonal to restart from, shapes (16,), (16,): ``initial``'s,
        or at rest at the origin, level, motors off, with ``initial_uncertainty``."""
        if initial is None:
            return np.zeros(STATE_DIM), self.initial_uncertainty.diagonal()
        x0 = initial.to_vector()
        p0 = np.array(initial.covariance_diag, dtype=float)
        if p0.shape != (STATE_DIM,) or not np.all(p0 > 0):
            raise ValueError(f"initial.covariance_diag = {p0.tolist()}: must be 16 "
                             "numbers > 0")
        return x0, p0

    def _on_ground_at(self, x: FloatArray) -> bool:
        """The ground holds a vehicle in state ``x``: within ``ground_margin_m`` of the
        ground plane with its thrust below its weight."""
        return bool(self.ground_z_ned is not None
                    and x[Z_INDEX] >= self.ground_z_ned - self.ground_margin_m
                    and float(np.sum(x[THRUST])) < self._weight_n)

    def step(self, time_s: float, pwm_applied: ArrayLike,
             samples: Iterable[SensorSampleLike], *,
             excluded: Collection[str] = (), reject: bool = True) -> StateEstimate:
        """Advance to ``time_s`` and update with the tick's samples.

        Parameters
        ----------
        time_s : float
            Tick time, s (>= the previous tick's).
        pwm_applied : array_like, shape (4,)
            PWM held over (previous tick, time_s], motors 1..4.
        samples : iterable of SensorSampleLike
            Samples produced since the previous tick.
        excluded : collection of str
            Sensors screened but not used (the health monitor's exclusions).
        reject : bool
            A lone outlier may be rejected for this tick (module docstring).

        Returns
        -------
        StateEstimate
            Posterior at ``time_s``.
        """
        return self.step_grouped(time_s, pwm_applied, group_samples(samples, self._kinds),
                                 excluded=excluded, reject=reject)

    def step_grouped(self, time_s: float, pwm_applied: ArrayLike,
                     batches: Mapping[str, SampleBatch], *,
                     excluded: Collection[str] = (), reject: bool = True) -> StateEstimate:
        """:meth:`step` with the tick's samples already averaged by
        :func:`fcu.estimation.state.group_samples` (batches of kinds this filter does not use
        are ignored), so that several estimators can share one grouping."""
        raise NotImplementedError

    @property
    def estimate(self) -> StateEstimate:
        """The latest estimate."""
        assert self._estimate is not None
        return self._estimate

    @property
    def time_s(self) -> float:
        """Time of the latest estimate, s."""
        return self._time_s

    @property
    def sensor_kinds(self) -> frozenset[str]:
        """The sensor kinds this estimator uses (samples of other kinds are ignored)."""
        return self._kinds
