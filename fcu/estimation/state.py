"""What the state estimators share: the estimate they publish, the state layout, sensor noise,
the height-source switch and the grouping of one tick's sensor samples.

Both estimators (:mod:`fcu.estimation.ekf`, :mod:`fcu.estimation.tskf`) carry the same
16-entry state, in this order:

=======  ===========================  =======
index    name                         unit
=======  ===========================  =======
0:3      pos_ned (x, y, z)            m
3:6      vel_ned                      m/s
6:9      euler_rad (roll, pitch, yaw) rad
9:12     rate_frd (p, q, r)           rad/s
12:16    thrust_n (T1..T4)            N
=======  ===========================  =======

(The TSKF's linear hover model carries Euler-angle rates in 9:12; at hover they equal the body
rates to first order, see :mod:`fcu.estimation.tskf`.)

The autopilot loop calls an estimator once per control tick with the samples produced since
the previous tick. Samples of one kind are averaged (:func:`group_samples`) and the average is
treated as one measurement taken at the samples' mean time; the estimators map their state at
the tick back to that time to first order (``h(x) = S (x - delta f(x))``, ``delta`` = tick
time minus mean sample time), so a 250 Hz gyro averaged over a 10 ms tick carries no lag bias.

Height source (like ArduPilot's ``EK3_SRC1_POSZ``): ``"mocap"`` (default) takes height from
the motion-capture z; ``"baro"`` takes it from the barometer and uses motion capture for the
horizontal position only.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import TypeVar, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

import fcu.floats
from fcu.floats import wrap_pi
from fcu.hal import SensorSampleArrays, SensorSampleLike
from flightdata.vocabulary import HEIGHT_SOURCES, SENSORS
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.views import shaped

# group_sample_arrays compiles in kernel_views' shaped
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)

FloatArray = NDArray[np.float64]
ArrayLikeFloat = FloatArray | list[float] | tuple[float, ...]

_FLOAT64 = np.dtype(np.float64)

# ---- state layout shared by the EKF and the TSKF --------------------------------------------
STATE_DIM = 16  # entries of the estimator state
POS = slice(0, 3)  # pos_ned, m
VEL = slice(3, 6)  # vel_ned, m/s
EULER = slice(6, 9)  # roll, pitch, yaw, rad
RATE = slice(9, 12)  # p, q, r (FRD), rad/s
THRUST = slice(12, 16)  # T1..T4, N
YAW_INDEX = 8  # index of yaw in the state
Z_INDEX = 2  # index of z_ned in the state
STATE_NAMES: tuple[str, ...] = (
    "x_ned", "y_ned", "z_ned", "vx_ned", "vy_ned", "vz_ned", "roll", "pitch", "yaw",
    "p", "q", "r", "thrust1", "thrust2", "thrust3", "thrust4",
)


def check_height_source(height_source: str) -> str:
    """Return ``height_source`` if it is one of :data:`flightdata.vocabulary.HEIGHT_SOURCES`
    (``"mocap"``, ``"baro"``), else raise ValueError."""
    if height_source not in HEIGHT_SOURCES:
        raise ValueError(f"height_source = {height_source!r}: must be one of "
                         f"{', '.join(map(repr, HEIGHT_SOURCES))}")
    return height_source


@dataclass(frozen=True, kw_only=True)
class SensorNoise:
    """Measurement noise the estimators assume (1 sigma per sample, per axis).

    Defaults are the simulator's documented sensor noise (docs/design.md).
    """

    gyro: float = 0.003  # rad/s
    accel: float = 0.03  # m/s^2 (not used by the estimators, kept for completeness)
    mocap_pos: float = 0.0005  # m
    mocap_att: float = 0.002  # rad
    baro: float = 0.02  # m

    def __post_init__(self) -> None:
        for name in SENSORS:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} = {value!r}: noise sigma must be a finite number > 0")


@dataclass(frozen=True, kw_only=True)
class InitialUncertainty:
    """One-sigma uncertainty of the initial state when an estimator is reset without one.

    Wide enough for a vehicle anywhere near home: the first mocap updates pin position and
    attitude (yaw too), the motion the rest.
    """

    pos: float = 0.5  # m
    vel: float = 0.5  # m/s
    euler: float = 0.3  # rad
    rate: float = 0.2  # rad/s
    thrust: float = 1.0  # N

    def diagonal(self) -> FloatArray:
        """Covariance diagonal in the state order, shape (16,)."""
        return np.array([self.pos] * 3 + [self.vel] * 3 + [self.euler] * 3
                        + [self.rate] * 3 + [self.thrust] * 4) ** 2


@dataclass(frozen=True, slots=True)
class StateEstimate:
    """An estimator's output at one control tick.

    Attributes
    ----------
    time_s : float
        Simulated time of the estimate, s.
    pos_ned : ndarray, shape (3,)
        Position, NED, m (home origin on the ground; z down).
    vel_ned : ndarray, shape (3,)
        Velocity, NED, m/s.
    euler_rad : ndarray, shape (3,)
        Roll, pitch, yaw (ZYX), rad; yaw wrapped to [-pi, pi).
    rate_frd : ndarray, shape (3,)
        Body rates p, q, r (FRD), rad/s.
    thrust_n : ndarray, shape (4,)
        Motor thrusts T1..T4 (motor numbering of eq. 3.2), N.
    covariance_diag : ndarray, shape (16,)
        Diagonal of the estimate's covariance in the state order of this module (units
        squared).
    """

    time_s: float
    pos_ned: FloatArray
    vel_ned: FloatArray
    euler_rad: FloatArray
    rate_frd: FloatArray
    thrust_n: FloatArray
    covariance_diag: FloatArray

    @property
    def alt_m(self) -> float:
        """Altitude above home, up positive, m."""
        return -float(self.pos_ned[2])

    @property
    def std(self) -> FloatArray:
        """One-sigma uncertainty of each state, shape (16,), units of the state."""
        return np.sqrt(np.maximum(self.covariance_diag, 0.0))

    def to_vector(self) -> FloatArray:
        """The state as one vector, shape (16,), in the order of this module."""
        return np.concatenate((self.pos_ned, self.vel_ned, self.euler_rad, self.rate_frd,
                               self.thrust_n))

    @classmethod
    def _from_owned(cls, time_s: float, x: FloatArray, covariance_diag: FloatArray
                    ) -> StateEstimate:
        """:meth:`from_vector` for float64 arrays of shape (16,) that the caller hands over
        (fresh, held by no one else): the fields are slices of ``x``, no copies."""
        euler = x[EULER]
        euler[2] = wrap_pi(float(euler[2]))
        return cls(float(time_s), x[POS], x[VEL], euler, x[RATE], x[THRUST], covariance_diag)

    @classmethod
    def _from_tick(cls, time_s: float, estimate: FloatArray) -> StateEstimate:
        """The estimate of a filter's tick kernel: ``estimate`` (float64, fresh, held by no
        one else) holds the state, yaw already wrapped to [-pi, pi), then the covariance
        diagonal (first 32 entries; the tick's screening may follow, which the estimate
        keeps alive but does not show); the fields are slices of it, set without the
        dataclass's checks (the constructor of a frozen dataclass sets each field through
        ``object.__setattr__``)."""
        est = _NEW_OBJECT(cls)
        _SET_TIME(est, time_s)
        _SET_POS(est, estimate[0:3])
        _SET_VEL(est, estimate[3:6])
        _SET_EULER(est, estimate[6:9])
        _SET_RATE(est, estimate[9:12])
        _SET_THRUST(est, estimate[12:16])
        _SET_COV(est, estimate[16:32])
        return est

    @classmethod
    def from_vector(cls, time_s: float, x: ArrayLikeFloat,
                    covariance_diag: ArrayLikeFloat) -> StateEstimate:
        """Build an estimate from a state vector ``x`` (16,) and a covariance diagonal (16,)."""
        # one private copy; the fields are disjoint slices of it (cheaper than five copies)
        xv = np.array(x, dtype=float).reshape(STATE_DIM)
        pv = np.array(covariance_diag, dtype=float).reshape(STATE_DIM)
        euler = xv[EULER]
        euler[2] = wrap_pi(float(euler[2]))
        return cls(time_s=float(time_s), pos_ned=xv[POS], vel_ned=xv[VEL], euler_rad=euler,
                   rate_frd=xv[RATE], thrust_n=xv[THRUST], covariance_diag=pv)


# the slots of StateEstimate, set directly by StateEstimate._from_tick
_NEW_OBJECT = object.__new__
(_SET_TIME, _SET_POS, _SET_VEL, _SET_EULER, _SET_RATE, _SET_THRUST, _SET_COV) = (
    getattr(StateEstimate, name).__set__
    for name in ("time_s", "pos_ned", "vel_ned", "euler_rad", "rate_frd", "thrust_n",
                 "covariance_diag"))


@dataclass(frozen=True, slots=True)
class Innovation:
    """One measurement update's innovation, kept for fault detection and consistency checks.

    Attributes
    ----------
    sensor : str
        Sensor kind (``"mocap_pos"``, ``"mocap_att"``, ``"gyro"``, ``"baro"``).
    time_s : float
        Tick time of the update, s.
    residual : ndarray, shape (m,)
        Innovation ``y - h(x_prior)`` (yaw wrapped), sensor units.
    covariance : ndarray, shape (m, m)
        Its covariance ``S = H P H' + R``, sensor units squared.
    nis : float
        Normalised innovation squared ``y' S^-1 y`` (chi-square with m degrees of freedom for a
        consistent filter).
    """

    sensor: str
    time_s: float
    residual: FloatArray
    covariance: FloatArray
    nis: float


class SampleBatch:
    """The samples of one sensor kind within one tick, reduced to one measurement.

    A plain record (one is made per kind and tick: a frozen dataclass costs three times as
    much to build); treat it as read-only.

    Attributes
    ----------
    value : ndarray, shape (n,)
        Mean of the sample values (angles averaged without wrap-around jumps), sensor units;
        from :func:`group_samples`, a view of :attr:`GroupedSamples.flat`.
    time_s : float
        Mean sample time, s.
    count : int
        Number of samples averaged.
    """

    __slots__ = ("count", "time_s", "value")

    def __init__(self, value: FloatArray, time_s: float, count: int) -> None:
        self.value = value
        self.time_s = time_s
        self.count = count

    def __repr__(self) -> str:
        return (f"SampleBatch(value={self.value.tolist()!r}, time_s={self.time_s!r}, "
                f"count={self.count!r})")


_V = TypeVar("_V")


class BuiltOnRead(Mapping[str, _V]):
    """A read-only mapping by sensor whose dict a subclass builds on first read
    (:meth:`_built`, once): per-tick results that most ticks never read as records."""

    __slots__ = ()

    def _built(self) -> dict[str, _V]:
        raise NotImplementedError

    def __getitem__(self, sensor: str) -> _V:
        return self._built()[sensor]

    def __iter__(self) -> Iterator[str]:
        return iter(self._built())

    def __len__(self) -> int:
        return len(self._built())


class GroupedSamples(BuiltOnRead[SampleBatch]):
    """One tick's samples averaged per kind (:func:`group_samples`): a mapping of
    :class:`SampleBatch` by sensor kind, in the order of their first samples, over the array
    of :func:`group_sample_arrays`, for readers that want no object per kind.

    The batches are built when the mapping is first read as a whole (iterated, indexed, ...);
    :meth:`pop` of one kind and the arrays build no other.

    Attributes
    ----------
    flat : ndarray, shape (n_slots * width + 1,)
        What :func:`group_sample_arrays` wrote: :attr:`table` row by row, then a spare zero.
    width : int
        Entries of a slot (row of :attr:`table`): ``w + 3``.
    slot_names : tuple of str
        The sensor kind of each slot.
    slot_axes : tuple of int
        The value entries of each slot.
    popped : tuple of str
        The kinds :meth:`pop` removed (their slots stay in :attr:`flat`).
    """

    __slots__ = ("_batches", "flat", "popped", "slot_axes", "slot_names", "width")

    def __init__(self, flat: FloatArray, width: int, slot_names: tuple[str, ...],
                 slot_axes: tuple[int, ...]) -> None:
        self.flat = flat
        self.width = width
        self.slot_names = slot_names
        self.slot_axes = slot_axes
        self._batches: dict[str, SampleBatch] | None = None  # built on first read
        self.popped: tuple[str, ...] = ()

    @property
    def table(self) -> FloatArray:
        """Shape (n_slots, w + 3): per slot the mean value (first ``slot_axes[slot]``
        entries), the mean time (column ``w``), the count (``w + 1``, 0: no batch) and the
        index of its first sample (``w + 2``) (a view of :attr:`flat`)."""
        n = len(self.slot_names)
        return self.flat[:n * self.width].reshape(n, self.width)

    def _built(self) -> dict[str, SampleBatch]:
        """The batches by kind, in the order of their first samples (built once)."""
        batches = self._batches
        if batches is None:
            flat, width, axes = self.flat, self.width, self.slot_axes
            rows = flat.tolist()
            # the kinds present, in the order of their first samples
            order = [(rows[s * width + width - 1], s) for s in range(len(self.slot_names))
                     if rows[s * width + width - 2] > 0]
            order.sort()
            batches = self._batches = {}
            for _, s in order:
                name = self.slot_names[s]
                if name not in self.popped:
                    at = s * width
                    batches[name] = SampleBatch(flat[at:at + axes[s]], rows[at + width - 3],
                                                int(rows[at + width - 2]))
        return batches

    def peek_value(self, sensor: str) -> list[float] | None:
        """``sensor``'s mean value as a list, the batch left in place (None when there is
        none, or it was popped)."""
        if sensor in self.popped or sensor not in self.slot_names:
            return None
        if self._batches is not None:
            batch = self._batches.get(sensor)
            return None if batch is None else batch.value.tolist()
        s = self.slot_names.index(sensor)
        at = s * self.width
        if self.flat.item(at + self.width - 2) <= 0:  # no sample: no batch
            return None
        return self.flat[at:at + self.slot_axes[s]].tolist()

    def pop_value(self, sensor: str) -> list[float] | None:
        """:meth:`pop` of ``sensor``'s batch returning its mean value only, as a list (None
        when there is no batch)."""
        if self._batches is not None or sensor in self.popped or sensor not in self.slot_names:
            batch = self.pop(sensor)
            return None if batch is None else batch.value.tolist()
        s = self.slot_names.index(sensor)
        at = s * self.width
        if self.flat.item(at + self.width - 2) <= 0:  # no sample: no batch
            return None
        self.popped += (sensor,)
        return self.flat[at:at + self.slot_axes[s]].tolist()

    def pop(self, sensor: str, default: SampleBatch | None = None) -> SampleBatch | None:
        """Remove ``sensor``'s batch and return it (``default`` when there is none)."""
        if self._batches is not None:
            batch = self._batches.pop(sensor, None)
        elif sensor not in self.slot_names or sensor in self.popped:
            batch = None
        else:
            s = self.slot_names.index(sensor)
            at = s * self.width
            time_s, count = self.flat[at + self.width - 3:at + self.width - 1].tolist()
            batch = (SampleBatch(self.flat[at:at + self.slot_axes[s]], time_s, int(count))
                     if count > 0 else None)
        if batch is None:
            return default
        self.popped += (sensor,)
        return batch

@njit(cache=True, error_model="numpy")
def group_sample_arrays(flat: FloatArray, sensor_index: np.ndarray, time_s: FloatArray,
                        values: FloatArray, slots: np.ndarray) -> None:
    """Average a tick's samples per kind (:func:`group_samples`), compiled.

    Parameters
    ----------
    flat : ndarray, shape (n_slots * (w + 3) + 1,)
        Zeros; written: per slot (row of a table of w + 3 columns, flattened) the mean value
        (yaw averaged as offsets from the first reading, wrapped to [-pi, pi)), the mean
        time (s), the samples averaged (samples with a non-finite value are dropped) and
        the index of its first sample (-1: none); the spare zero after them stays (what the
        estimators' measurement tables read for an absent batch,
        :meth:`fcu.estimation.channels.ChannelSet.measurements`).
    sensor_index : ndarray of int, shape (n,)
        Each sample's sensor, an index into ``slot_of``.
    time_s : ndarray, shape (n,)
        Sample times, s.
    values : ndarray, shape (n, w)
        Sample values; the first ``axes[slot]`` entries of a row count.
    slots : ndarray of int
        ``[yaw_slot, n_slots, axes..., slot_of...]`` (:func:`pack_slots`): the slot whose
        third entry is a yaw (``mocap_att``) or -1, the number of slots, the entries of each
        slot's value, and the slot (output row) of each sensor index (-1: not kept).
    """
    yaw_slot = slots[0]
    n_slots = slots[1]
    axes = slots[2:2 + n_slots]
    slot_of = slots[2 + n_slots:]
    w = values.shape[1]
    # (shaped, not numba's reshape, whose size check formats its error message with the
    # shapes: 3 s more of compile for a check shaped makes with a constant message)
    out = shaped(flat[:n_slots * (w + 3)], (n_slots, w + 3))
    mean = out[:, :w]
    time_sum = out[:, w]
    count = np.zeros(n_slots, dtype=np.int64)
    first = np.full(n_slots, -1, dtype=np.int64)
    yaw0 = 0.0
    for j in range(sensor_index.shape[0]):
        s = slot_of[sensor_index[j]]
        if s < 0:
            continue
        finite = True
        for i in range(axes[s]):
            finite = finite and math.isfinite(values[j, i])
        if not finite:
            continue
        if count[s] == 0:
            first[s] = j
            for i in range(axes[s]):
                mean[s, i] = values[j, i]
            if s == yaw_slot:
                yaw0 = values[j, 2]
        elif s == yaw_slot:
            mean[s, 0] += values[j, 0]
            mean[s, 1] += values[j, 1]
            # yaw offset from the first reading, wrapped to [-pi, pi)
            mean[s, 2] += yaw0 + wrap_pi(values[j, 2] - yaw0)
        else:
            for i in range(axes[s]):
                mean[s, i] += values[j, i]
        time_sum[s] += time_s[j]
        count[s] += 1
    for s in range(n_slots):
        if count[s] > 1:
            for i in range(axes[s]):
                mean[s, i] /= count[s]
        if s == yaw_slot:
            mean[s, 2] = wrap_pi(mean[s, 2])
        if count[s] > 0:
            time_sum[s] /= count[s]
    out[:, w + 1] = count
    out[:, w + 2] = first


def pack_slots(slot_of: np.ndarray, axes: np.ndarray, yaw_slot: int) -> np.ndarray:
    """:func:`group_sample_arrays`' ``slots``: ``[yaw_slot, n_slots, axes..., slot_of...]``."""
    return np.concatenate(([yaw_slot, axes.shape[0]], axes, slot_of)).astype(np.int64)


@functools.lru_cache(maxsize=64)
def _slots(sensor_names: tuple[str, ...], sensor_axes: tuple[int, ...],
           kinds: frozenset[str] | tuple[str, ...]
           ) -> tuple[np.ndarray, tuple[str, ...], tuple[int, ...]]:
    """:func:`group_sample_arrays`' ``slots`` for samples of ``sensor_names`` (with
    ``sensor_axes`` entries) keeping ``kinds``, the slots' names and their axes."""
    names = tuple(n for n in sensor_names if n in kinds)
    slot_of = np.array([names.index(n) if n in names else -1 for n in sensor_names],
                       dtype=np.int64)
    axes = np.array([sensor_axes[sensor_names.index(n)] for n in names], dtype=np.int64)
    yaw_slot = names.index("mocap_att") if "mocap_att" in names else -1
    return pack_slots(slot_of, axes, yaw_slot), names, tuple(axes.tolist())


def group_samples(samples: Iterable[SensorSampleLike],
                  kinds: Collection[str] = SENSORS) -> GroupedSamples:
    """Average one tick's samples per sensor kind.

    Parameters
    ----------
    samples : iterable of SensorSampleLike
        Samples produced since the previous tick, any order, any mix of kinds. Samples of
        kinds not in ``kinds`` are ignored; samples holding a non-finite value are dropped.
        Samples that come as arrays (:class:`fcu.hal.SensorSampleArrays`) are read as such.
    kinds : collection of str
        Sensor kinds to keep.

    Returns
    -------
    GroupedSamples
        A mapping of one :class:`SampleBatch` per kept sensor kind that delivered at least one
        usable sample, in the order of their first samples, with the arrays behind them. The
        ``mocap_att`` yaw is averaged as offsets from the first reading, so readings on both
        sides of +-pi average correctly (result wrapped to [-pi, pi)).
    """
    if hasattr(samples, "sensor_axes"):  # SensorSampleArrays (the protocol's test is slow)
        arrays = cast(SensorSampleArrays, samples)
        slots, names, axes_t = _slots(
            arrays.sensor_names, arrays.sensor_axes,
            kinds if isinstance(kinds, (frozenset, tuple)) else frozenset(kinds))
        index, times, values = arrays.sensor_index, arrays.time_s, arrays.values
    else:
        index, times, values, slot_of, axes, yaw_slot, names = _sample_arrays(samples, kinds)
        if not names:  # nothing kept (the boot tick's empty list): no slot to fill
            return GroupedSamples(np.zeros(1), values.shape[1] + 3, (), ())
        slots, axes_t = pack_slots(slot_of, axes, yaw_slot), tuple(axes.tolist())
    width = values.shape[1] + 3
    flat = np.zeros(len(names) * width + 1)
    group_sample_arrays(flat, index, times, values, slots)
    return GroupedSamples(flat, width, names, axes_t)


def _sample_arrays(samples: Iterable[SensorSampleLike], kinds: Collection[str]
                   ) -> tuple[np.ndarray, FloatArray, FloatArray, np.ndarray, np.ndarray, int,
                              tuple[str, ...]]:
    """Samples given one object each, as :func:`group_sample_arrays` takes them: each kept
    kind a slot, in the order of its first sample (raises ValueError when a kind's samples
    differ in length)."""
    slot: dict[str, int] = {}
    axes: list[int] = []
    index: list[int] = []
    times: list[float] = []
    rows: list[list[float]] = []
    for sample in samples:
        name = sample.sensor
        if name not in kinds:
            continue
        value = sample.value
        if type(value) is np.ndarray and value.dtype == _FLOAT64 and value.ndim == 1:
            vals = value.tolist()
        else:
            vals = np.asarray(value, dtype=float).reshape(-1).tolist()
        if not all(map(math.isfinite, vals)):
            continue  # dropped (the arrays' kernel drops such samples too)
        s = slot.get(name)
        if s is None:
            s = slot[name] = len(axes)
            axes.append(len(vals))
        elif len(vals) != axes[s]:
            raise ValueError(f"{name} sample at {sample.time_s!r} s has {len(vals)} "
                             f"values, earlier ones {axes[s]}")
        index.append(s)
        times.append(float(sample.time_s))
        rows.append(vals)
    width = max(axes, default=0)
    padded = [r + [0.0] * (width - len(r)) for r in rows]
    values = np.array(padded, dtype=float).reshape(len(rows), width)
    names = tuple(slot)
    return (np.array(index, dtype=np.int64), np.array(times, dtype=float), values,
            np.arange(len(names), dtype=np.int64), np.array(axes, dtype=np.int64),
            slot.get("mocap_att", -1), names)
