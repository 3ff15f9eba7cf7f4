"""The frame both state estimators share: checked construction, the measurement channels,
reset to an initial estimate, one call per tick, the ground test and inspection.

:class:`TickEstimator` is the base of :class:`~fcu.estimation.ekf.ExtendedKalmanEstimator`
and :class:`~fcu.estimation.tskf.TwoStageKalmanFilter`; each filter adds its own
maths in :meth:`TickEstimator.step_grouped` and its own per-channel data.

Measurements common to both (state layout of :mod:`fcu.estimation.state`; the channels of
:mod:`fcu.estimation.channels`), linear in the state at their sample time, ``y = S x``: mocap
position (x, y only when ``height_source="baro"``), barometric altitude ``-z`` (baro source
only), mocap attitude (its yaw innovation wrapped to [-pi, pi)), the gyro, and the
accelerometer's body-z axis (``f_z = -(T1 + T2 + T3 + T4)/m``, thrust along -z_body; skipped
on the ground, where the accelerometer feels the ground reaction).

Screening (beyond the thesis, which assumes healthy sensors)
-----------------------------------------------------------
Before its update, each tick, an estimator screens every sensor that delivered a batch against
its prior (:func:`fcu.estimation.screening.screen_channels`, compiled): the innovation
``nu = z - S x_prior``, its variance ``diag(S P_prior S' + R)`` and ``NIS = nu' (S P S' + R)^-1 nu``
(chi-square with m degrees of freedom for a consistent filter). A measurement is *rejected* for
this tick when its NIS exceeds the gate (the chi-square quantile at probability
:data:`~fcu.estimation.channels.GATE_PROBABILITY`, about 6 sigma) **and it is the only one to
do so**: one sensor far from what the others and the model agree on is that sensor's fault,
while several at once (a motor failing, a gust the model does not know) is the model's, and
then every measurement is needed. Sensors the autopilot's health monitor has *excluded* are
screened too (so it can see them recover) but never applied. :attr:`TickEstimator.screening`
keeps the tick's :class:`ChannelCheck` per sensor. The height source can be switched at run
time (:attr:`TickEstimator.height_source`).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from fcu.estimation.channels import Channel, ChannelSet, common_channels
from fcu.estimation.screening import (
    ABSENT,
    STATUS_NAMES,
    ChannelStatus,
    noise_var,
    on_ground_at,
    screen_channel,
    screen_channels,
    select,
)
from fcu.estimation.state import (
    STATE_DIM,
    BuiltOnRead,
    FloatArray,
    InitialUncertainty,
    Innovation,
    SampleBatch,
    SensorNoise,
    StateEstimate,
    check_height_source,
    group_samples,
)
from fcu.hal import SensorSampleLike
from fcu.model import VehicleModel
from flightdata.vocabulary import HEIGHT_SOURCES
from jitsupport.layout import aligned_zeros

_FLOAT64 = np.dtype(np.float64)  # (the dtype of float64 arrays, compared by identity)
_NDARRAY = np.ndarray


def pwm_array(pwm_applied: ArrayLike) -> FloatArray:
    """``pwm_applied`` as a contiguous float64 array of shape (4,) (itself when it is one)."""
    u = pwm_applied
    if (type(u) is not _NDARRAY or u.dtype is not _FLOAT64 or u.shape != (4,)
            or not u.flags.c_contiguous):
        u = np.ascontiguousarray(pwm_applied, dtype=float).reshape(4)
    return u


class ChannelCheck(NamedTuple):
    """One sensor's measurement at one tick, screened against the prior (module docstring).

    Built every tick for every sensor that delivered a batch, so it is a light immutable
    record: the residual and its variance are views of the tick's screening table
    (:func:`~fcu.estimation.screening.screen_channels`), taken when read.

    Attributes
    ----------
    sensor : str
    nis : float
        ``nu' (S P_prior S' + R)^-1 nu``.
    gate : float
        The NIS above which it is an outlier.
    status : {"applied", "rejected", "excluded", "skipped"}
        Used in the update; a lone outlier this tick; excluded by the health monitor; not
        usable now (the accelerometer on the ground).
    screen : ndarray
        The tick's screening table (its layout in :func:`screen_channels`).
    row0, row1, n_rows : int
        The sensor's rows in it, and the rows of all channels.
    residual : ndarray, shape (m,)
        ``nu = z - S x_prior`` (yaw wrapped), sensor units.
    variance : ndarray, shape (m,)
        ``diag(S P_prior S' + R)``, sensor units squared.
    """

    sensor: str
    nis: float
    gate: float
    status: ChannelStatus
    screen: FloatArray
    row0: int
    row1: int
    n_rows: int

    @property
    def residual(self) -> FloatArray:
        """``nu = z - S x_prior`` (yaw wrapped), shape (m,), sensor units (a view)."""
        return self.screen[self.row0:self.row1]

    @property
    def variance(self) -> FloatArray:
        """``diag(S P_prior S' + R)``, shape (m,), sensor units squared (a view)."""
        return self.screen[self.n_rows + self.row0:self.n_rows + self.row1]

    @property
    def outlier(self) -> bool:
        """NIS above the gate."""
        return self.nis > self.gate


class Screening(BuiltOnRead[ChannelCheck]):
    """One tick's screening (module docstring): a mapping of each screened sensor's
    :class:`ChannelCheck`, built on first read, over the compiled screening's table.

    Parameters
    ----------
    channel_set : ChannelSet
        The channels screened.
    screen : ndarray
        :func:`~fcu.estimation.screening.screen_channels`' table.
    """

    __slots__ = ("_checks", "channel_set", "screen")

    def __init__(self, channel_set: ChannelSet, screen: FloatArray) -> None:
        self.channel_set = channel_set
        self.screen = screen
        self._checks: dict[str, ChannelCheck] | None = None

    def entries(self) -> list[tuple[str, ChannelStatus, float, float]]:
        """(sensor, status, NIS, gate) of each sensor screened, in update order, without
        building the :class:`ChannelCheck` records."""
        cs = self.channel_set
        n_ch = len(cs.checks)
        tail = self.screen[2 * cs.n_rows:].tolist()  # NIS, then status codes
        return [(sensor, STATUS_NAMES[int(code)], nis, gate)
                for (sensor, gate, _, _), nis, code in zip(cs.checks, tail[:n_ch],
                                                           tail[n_ch:], strict=True)
                if code != ABSENT]

    def _built(self) -> dict[str, ChannelCheck]:
        checks = self._checks
        if checks is None:
            cs, screen = self.channel_set, self.screen
            rows = {sensor: (i0, i1) for sensor, _, i0, i1 in cs.checks}
            checks = self._checks = {}
            for sensor, status, nis, gate in self.entries():
                i0, i1 = rows[sensor]
                checks[sensor] = ChannelCheck(sensor, nis, gate, status, screen, i0, i1,
                                              cs.n_rows)
        return checks


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
    accel_z_model_sigma : float or None
        Model error of the accelerometer's thrust measurement, m/s^2, or None to leave the
        accelerometer out.

    Subclasses build their channels by :meth:`_build_channel_sets` (after what their
    :meth:`_make_channels` needs) and keep each tick's estimate and screening by
    :meth:`_ticked`.
    """

    _sets: Mapping[str, ChannelSet]  # every height source's channels
    _set: ChannelSet  # the current height source's

    def __init__(self, model: VehicleModel, dt_s: float, height_source: str,
                 noise: SensorNoise | None, initial_uncertainty: InitialUncertainty | None,
                 ground_z_ned: float | None, ground_margin_m: float,
                 accel_z_model_sigma: float | None) -> None:
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be a finite number > 0 s")
        if not (math.isfinite(ground_margin_m) and ground_margin_m >= 0):
            raise ValueError(f"ground_margin_m = {ground_margin_m!r}: must be >= 0 m")
        if accel_z_model_sigma is not None and not (math.isfinite(accel_z_model_sigma)
                                                    and accel_z_model_sigma >= 0):
            raise ValueError(f"accel_z_model_sigma = {accel_z_model_sigma!r}: must be >= 0 "
                             "m/s^2, or None to leave the accelerometer out")
        self.model = model
        self.dt_s = float(dt_s)
        self._height_source = check_height_source(height_source)
        self.noise = noise if noise is not None else SensorNoise()
        self.initial_uncertainty = (initial_uncertainty if initial_uncertainty is not None
                                    else InitialUncertainty())
        self.ground_z_ned = ground_z_ned
        self.ground_margin_m = float(ground_margin_m)
        self.accel_z_model_sigma = accel_z_model_sigma
        # on_ground_at's view of the ground: [present, plane z - margin (m), weight (N)]
        self._ground = np.array([
            0.0 if ground_z_ned is None else 1.0,
            0.0 if ground_z_ned is None else ground_z_ned - self.ground_margin_m,
            model.mass * model.gravity])
        self._time_s = 0.0
        self._kinds: frozenset[str] = frozenset()
        self._estimate: StateEstimate | None = None
        self._tick_out: FloatArray | None = None  # the latest tick's, until read as estimate
        # the latest tick's screening, as computed (ChannelCheck records built on request)
        self._screen_out: tuple[ChannelSet, FloatArray] | None = None
        self._screening: Screening | None = None

    # ---- the measurement channels ------------------------------------------------------------
    @property
    def height_source(self) -> str:
        """Where height comes from now ("mocap" or "baro"); settable between ticks (the
        autopilot's health monitor falls back to the other source when one fails)."""
        return self._height_source

    @height_source.setter
    def height_source(self, source: str) -> None:
        if source != self._height_source:
            self._height_source = check_height_source(source)
            self._set = self._sets[self._height_source]

    @property
    def channel_set(self) -> ChannelSet:
        """The channels of the current height source, stacked (what a tick updates)."""
        return self._set

    @property
    def _channels(self) -> tuple[Channel, ...]:
        """The channels updated now, in update order."""
        return self._set.channels

    def _make_channels(self, height_source: str) -> ChannelSet:
        """The channels of ``height_source``, stacked."""
        raise NotImplementedError

    def _build_channel_sets(self) -> None:
        """Every height source's channels (:data:`flightdata.vocabulary.HEIGHT_SOURCES`),
        and the set of the current one."""
        self._sets = {source: self._make_channels(source) for source in HEIGHT_SOURCES}
        self._set = self._sets[self._height_source]
        self._kinds = frozenset(s for cs in self._sets.values() for s in cs.sensors)

    def _packed_buffer(self, at: int) -> FloatArray:
        """A float buffer of ``at`` entries (zeros, from a 64-byte boundary:
        :func:`~jitsupport.layout.aligned_zeros`) for the filter's own arrays, then
        the :attr:`ChannelSet.tables` of every height source, which become views of it
        (:attr:`ChannelSet.tables_at`): one argument of a compiled call
        (:mod:`fcu.estimation.pair`)."""
        sets = list(self._sets.values())
        # on a cache line: the kernels' 16-entry rows then stay on cache lines too
        buf = aligned_zeros(at + sum(cs.tables.size for cs in sets))
        for cs in sets:
            size = cs.tables.size
            buf[at:at + size] = cs.tables
            cs.tables, cs.tables_at = buf[at:at + size], at
            at += size
        return buf

    def _common_channels(self, height_source: str) -> list[tuple[str, FloatArray,
                                                                 tuple[int, ...], float]]:
        """:func:`common_channels` of this estimator."""
        return common_channels(height_source, self.model, self.accel_z_model_sigma)

    # ---- screening ---------------------------------------------------------------------------
    def _screen_table(self) -> tuple[ChannelSet, FloatArray] | None:
        """The latest tick's channels and screening table, or None before the first tick."""
        if self._screen_out is None:
            return None
        cs, out = self._screen_out
        return cs, out[2 * STATE_DIM:cs.tick_size]

    def _statuses(self) -> list[int]:
        """The latest tick's status code of each channel (:func:`screen_channels`)."""
        table = self._screen_table()
        if table is None:
            return []
        cs, screen = table
        return [int(code) for code in screen[-len(cs.channels):].tolist()]

    @property
    def screening(self) -> Mapping[str, ChannelCheck]:
        """Each sensor's :class:`ChannelCheck` at the latest tick (module docstring), a
        :class:`Screening`."""
        screening = self._screening
        if screening is None:
            table = self._screen_table()
            if table is None:
                return {}
            screening = self._screening = Screening(*table)
        return screening

    def _initial_state(self, initial: StateEstimate | None) -> tuple[FloatArray, FloatArray]:
        """State and covariance diagonal to restart from, shapes (16,), (16,): ``initial``'s,
        or at rest at the origin, level, motors off, with ``initial_uncertainty``."""
        self._screen_out = None
        self._screening = None
        self._tick_out = None
        if initial is None:
            return np.zeros(STATE_DIM), self.initial_uncertainty.diagonal()
        x0 = initial.to_vector()
        p0 = np.array(initial.covariance_diag, dtype=float)
        if p0.shape != (STATE_DIM,) or not np.all(p0 > 0):
            raise ValueError(f"initial.covariance_diag = {p0.tolist()}: must be 16 "
                             "numbers > 0")
        return x0, p0

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
        self.advance_grouped(time_s, pwm_applied, batches, excluded=excluded, reject=reject)
        return self.estimate

    def advance_grouped(self, time_s: float, pwm_applied: ArrayLike,
                        batches: Mapping[str, SampleBatch], *,
                        excluded: Collection[str] = (), reject: bool = True) -> None:
        """:meth:`step_grouped` for an estimator whose estimate is not needed at every tick:
        the :class:`StateEstimate` record is built when :attr:`estimate` is read."""
        time_s = float(time_s)
        cs = self._set
        u = pwm_array(pwm_applied)
        out = np.empty(cs.tick_size)  # the estimate's own array, and the screening's
        self._tick(time_s, u, cs, cs.measurements(batches), cs.exclusion(excluded),
                   bool(reject), out)

    def _ticked(self, time_s: float, channel_set: ChannelSet, out: FloatArray) -> None:
        """After a tick to ``time_s`` (s) with the channels ``channel_set`` whose output
        :meth:`_tick` wrote into ``out`` (fresh, held by no one else): the estimate at its
        start, then the :func:`screen_channels` table. Both are kept as ``out``: the
        :class:`StateEstimate` is built from it when :attr:`estimate` is read, the
        :attr:`screening` when that is."""
        self._time_s = time_s
        self._estimate = None
        self._tick_out = out
        self._screen_out = (channel_set, out)
        self._screening = None

    def _tick(self, time_s: float, u: FloatArray, channel_set: ChannelSet, meas: FloatArray,
              excluded: np.ndarray, reject: bool, out: FloatArray) -> None:
        """The filter's tick from its latest (at :attr:`time_s`) to ``time_s`` (s), with the
        PWM ``u`` (4,) held, the channels of the current height source, the tick's
        measurement table (:meth:`ChannelSet.measurements`), the channels excluded (bool per
        channel) and whether a lone outlier may be rejected. Writes into ``out`` (fresh,
        shape (``channel_set.tick_size``,)) the estimate's state (yaw wrapped to
        [-pi, pi)) and covariance diagonal (first 32 entries), then the screening
        (:func:`~fcu.estimation.screening.screen_channels`' table), and keeps them
        (:meth:`_ticked`)."""
        raise NotImplementedError

    @property
    def estimate(self) -> StateEstimate:
        """The latest estimate."""
        est = self._estimate
        if est is None:
            assert self._tick_out is not None
            est = self._estimate = StateEstimate._from_tick(self._time_s, self._tick_out)
            self._tick_out = None
        return est

    @property
    def time_s(self) -> float:
        """Time of the latest estimate, s."""
        return self._time_s

    @property
    def sensor_kinds(self) -> frozenset[str]:
        """The sensor kinds this estimator uses (samples of other kinds are ignored)."""
        return self._kinds


__all__ = [
    # the frame
    "ChannelCheck",
    "Screening",
    "ProcessNoiseDensities",
    "TickEstimator",
    "noise_var",
    "on_ground_at",
    "screen_channel",
    "screen_channels",
    "select",
    # what an estimator built on it takes and returns (from fcu.estimation.state)
    "InitialUncertainty",
    "Innovation",
    "SensorNoise",
    "StateEstimate",
]
