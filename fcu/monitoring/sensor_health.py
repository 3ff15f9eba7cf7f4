"""Sensor fault detection and containment: which sensors the estimators may trust.

The thesis assumes healthy sensors. Here every sensor is watched by three checks, and one that
fails is announced, excluded from the estimators, and re-admitted only once it has been
consistent again for ``recover_s``:

- **innovation**: the flying estimator screens each measurement against its prior
  (:mod:`fcu.estimation.estimator`: NIS above a 6-sigma chi-square gate while every other
  sensor agrees with the model). ``reject_ticks`` consecutive rejections exclude the sensor
  (``sensor_rejected``, magnitude: the NIS). Garbage is caught this way in a few ticks.
- **frozen signal**: a reading repeated bit for bit for ``frozen_ticks`` batches in flight
  (``sensor_frozen``, magnitude: seconds frozen). Real sensors are noisy, and a flying
  vehicle moves: a reading that no longer changes is a dead driver. (On the ground a
  noise-free simulation repeats itself legitimately: the check waits for flight.) The
  estimate cannot be the judge here: it follows a frozen position as long as that is
  applied, so the repeat itself is the evidence.
- **cross-check** of the two height sources: the barometer against the motion-capture
  height, as the mean difference over ``cross_window_s``; beyond ``cross_limit_m`` the
  barometer is excluded (``sensor_inconsistent``, magnitude: the difference, m). Motion
  capture is the reference: it is absolute and drift-free, while a barometer drifts with
  the weather and the rotor wash; a motion-capture fault is caught by its own checks.

While excluded, a sensor is still screened (its NIS is computed against the coasting estimate,
whose covariance grows), so a sensor that comes back is seen to agree. Agreement with a
coasting estimate is a weak test (its covariance has grown), so the sensor must also be
*self-consistent* for ``recover_s``: each batch within ``jump_sigma`` noise standard
deviations plus ``max_speed`` times the tick of the previous one (garbage jumps), and not
repeated (a frozen one must change again). An inconsistent barometer must come back within
half the limit.

The repeat and jump tests of the tick's batches run as one compiled call
(:func:`watch_values`) over the averaged table the autopilot's grouping produced
(:class:`fcu.estimation.state.GroupedSamples`), with each sensor's bookkeeping in one array.

Rejections count, and sensors are frozen, only in flight: on the ground a touchdown or a
disarm moves the vehicle in ways no estimator model follows.

Fallback (:attr:`SensorHealth.height_source`): height comes from the configured source while
it is trusted, else from the other one if trusted. :attr:`SensorHealth.position_fix` is False
while motion-capture position is excluded: the autopilot then holds attitude and height and
lands after its position failsafe timeout (:mod:`fcu.autopilot`). :attr:`SensorHealth.suspect`
is True while any sensor is excluded, or was rejected within ``quiet_s``: motor fault
evidence is not taken then (a sensor fault would otherwise raise motor alarms).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numba import njit

from fcu.estimation.estimator import ChannelCheck
from fcu.estimation.state import GroupedSamples, SampleBatch
from flightdata.config import finite, require
from flightdata.records import DetectionRecord
from flightdata.vocabulary import SENSORS


@dataclass(frozen=True, kw_only=True)
class SensorHealthConfig:
    """Settings of the sensor checks (module docstring)."""

    reject_ticks: int = 5  # consecutive screening rejections that exclude a sensor
    frozen_ticks: int = 5  # identical consecutive batches (with motion) that exclude it
    recover_s: float = 0.5  # s of consistency before an excluded sensor is re-admitted
    cross_window_s: float = 1.0  # s, averaging of the barometer / motion-capture height
    cross_limit_m: float = 0.06  # m, |mean difference| beyond which the barometer is out
    quiet_s: float = 1.0  # s after a rejection during which sensors count as suspect
    jump_sigma: float = 6.0  # noise sigmas of a batch-to-batch change that is a jump
    max_speed: float = 5.0  # sensor units per s a real signal may move (m/s, rad/s, ...)

    def __post_init__(self) -> None:
        for name in ("reject_ticks", "frozen_ticks"):
            value = getattr(self, name)
            require(isinstance(value, int) and value >= 1, name, value,
                    "must be an integer >= 1")
        for name in ("recover_s", "cross_window_s", "cross_limit_m",
                     "jump_sigma", "max_speed"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a number > 0")
        require(finite(self.quiet_s) and self.quiet_s >= 0, "quiet_s", self.quiet_s,
                "must be >= 0 s")


@dataclass(slots=True)
class _Watch:
    """Bookkeeping of one sensor (its repeat and jump state: row ``index`` of the watch
    table, :data:`WATCH_COLUMNS`)."""

    index: int  # row of the sensor in the watch table
    excluded_as: str | None = None  # detection kind while excluded
    excluded_s: float = 0.0
    rejections: int = 0
    last_rejected_s: float = -math.inf
    good_since_s: float | None = None


# the watch table: one row per sensor, these columns (counts and flags as exact floats)
LAST_VALUE = 0  # 0:3, the latest batch value (its first entries)
HAS_LAST = 3  # 1: a batch was seen
LAST_TIME = 4  # s, tick of the latest batch
SAME = 5  # -, consecutive batches equal to the one before
JUMPED = 6  # 1: the latest batch jumped from the one before
FROZEN_SINCE = 7  # s, tick at which the repeats began
SIGMA = 8  # sensor unit, one sample's noise, 1 sigma
WATCH_COLUMNS = 9
_MAX_SENSORS = 8  # rows of the watch table (the SENSORS first)


@njit(cache=True, error_model="numpy")
def watch_values(time_s: float, table: np.ndarray, plan: np.ndarray, watch: np.ndarray,
                 limits: np.ndarray) -> None:
    """Repeats (frozen) and jumps (garbage) of one tick's batch values, every sensor at once.

    Parameters
    ----------
    time_s : float
        Tick time, s.
    table : ndarray, shape (n_slots, w + 3)
        The tick's averaged samples (:class:`fcu.estimation.state.GroupedSamples`
        ``table``): value entries, then mean time, count (0: no batch) and first index.
    plan : ndarray of int, shape (3, n_watch)
        Per sensor (watch-table row): its slot in ``table`` (-1: none), the entries of its
        value (at most 3 are compared), and 1 when it is checked this tick (the estimator
        screened it), else 0.
    watch : ndarray, shape (n_watch, WATCH_COLUMNS)
        The watch table (module constants), updated in place.
    limits : ndarray, shape (3,)
        ``jump_sigma``, ``max_speed`` (a change beyond ``jump_sigma sigma + max_speed
        (t - t_last)`` is a jump) and the row of the sensor whose third entry is an angle
        (its change wrapped to [-pi, pi)), -1 for none.
    """
    jump_sigma, max_speed, yaw_row = limits[0], limits[1], int(limits[2])
    rows, axes, watched = plan[0], plan[1], plan[2]
    w = table.shape[1] - 3
    for i in range(rows.shape[0]):
        r = rows[i]
        if watched[i] == 0 or r < 0 or table[r, w + 1] <= 0.0:
            continue  # not screened, or no batch this tick
        n = min(axes[i], 3)
        had = watch[i, HAS_LAST] != 0.0
        equal = had
        for a in range(n):
            equal = equal and table[r, a] == watch[i, LAST_VALUE + a]
        if equal:
            if watch[i, SAME] == 0.0:
                watch[i, FROZEN_SINCE] = time_s
            watch[i, SAME] += 1.0
            watch[i, JUMPED] = 0.0
        else:
            watch[i, SAME] = 0.0
            if had:
                # limit = jump_sigma sigma + max_speed (t - t_last); a jump: some |change| > limit
                limit = jump_sigma * watch[i, SIGMA] + max_speed * (time_s - watch[i, LAST_TIME])
                hi = -math.inf
                lo = math.inf
                for a in range(n):
                    change = table[r, a] - watch[i, LAST_VALUE + a]
                    if i == yaw_row and a == 2:
                        change = (change + math.pi) % (2.0 * math.pi) - math.pi
                    hi = max(hi, change)
                    lo = min(lo, change)
                watch[i, JUMPED] = 1.0 if (hi > limit or lo < -limit) else 0.0
        for a in range(n):
            watch[i, LAST_VALUE + a] = table[r, a]
        watch[i, HAS_LAST] = 1.0
        watch[i, LAST_TIME] = time_s


# the sensor each height source reads
_HEIGHT_SENSOR = {"mocap": "mocap_pos", "baro": "baro"}


class SensorHealth:
    """The three sensor checks and the fallbacks (module docstring).

    Parameters
    ----------
    config : SensorHealthConfig
    height_source : str
        The configured height source ("mocap" or "baro").
    """

    def __init__(self, config: SensorHealthConfig, height_source: str) -> None:
        self.config = config
        self.configured_height_source = height_source
        self.reset()

    def reset(self) -> None:
        """Every sensor trusted, every check restarted."""
        self._watch: dict[str, _Watch] = {}
        self._rows_of: dict[str, int] = {name: i for i, name in enumerate(SENSORS)}
        self._table = np.zeros((_MAX_SENSORS, WATCH_COLUMNS))
        cfg = self.config
        self._limits = np.array([cfg.jump_sigma, cfg.max_speed, self._rows_of["mocap_att"]])
        self._noise: Mapping[str, float] | None = None  # the noise the SIGMA column holds
        # watch_values' plan by (table slots, screened sensors)
        self._plans: dict[tuple[tuple[str, ...], tuple[str, ...]], np.ndarray] = {}
        # the cross-check's window: tick times and baro alt - mocap alt, m
        self._cross_t: deque[float] = deque()
        self._cross_v: deque[float] = deque()
        self._last_rejected_s = -math.inf  # the latest rejection of any sensor
        self._exclusions_changed()

    def _w(self, sensor: str) -> _Watch:
        w = self._watch.get(sensor)
        if w is None:
            w = self._watch[sensor] = _Watch(self._row(sensor))
        return w

    def _row(self, sensor: str) -> int:
        """The watch-table row of ``sensor`` (sensors outside SENSORS get the next free)."""
        i = self._rows_of.get(sensor)
        if i is None:
            i = len(self._rows_of)
            if i >= _MAX_SENSORS:
                raise ValueError(f"sensor {sensor!r}: at most {_MAX_SENSORS} sensors watched")
            self._rows_of[sensor] = i
            self._noise = None
        return i

    def _exclusions_changed(self) -> None:
        """Refresh what follows from the excluded sensors (read every tick)."""
        self._excluded = frozenset(s for s, w in self._watch.items()
                                   if w.excluded_as is not None)

    # ------------------------------------------------------------------ the tick
    def step(self, time_s: float, batches: Mapping[str, SampleBatch],
             screening: Mapping[str, ChannelCheck], airborne: bool,
             noise: Mapping[str, float]) -> list[DetectionRecord]:
        """One tick, after the estimators' update.

        Parameters
        ----------
        time_s : float
            Tick time, s.
        batches : mapping of str to SampleBatch
            The tick's averaged samples.
        screening : mapping of str to ChannelCheck
            The flying estimator's screening of them.
        airborne : bool
            The vehicle is in flight (the checks count only then).
        noise : mapping of str to float
            Each sensor's noise, one sample, 1 sigma, sensor units (the jump test).
        """
        records: list[DetectionRecord] = []
        watch = self._watch
        cfg = self.config
        table, plan = self._plan(batches, tuple(screening))
        if noise is not self._noise:  # (a sensor new to the table clears _noise)
            for sensor, i in self._rows_of.items():
                self._table[i, SIGMA] = noise.get(sensor, 0.0)
            self._noise = noise
        watch_values(time_s, table, plan, self._table, self._limits)
        state = self._table[:, SAME:FROZEN_SINCE + 1].tolist()  # SAME, JUMPED, FROZEN_SINCE
        for sensor, check in screening.items():
            w = watch.get(sensor) or self._w(sensor)
            row = state[w.index]
            same = row[0]
            if airborne:
                if same >= cfg.frozen_ticks:
                    self._exclude(records, time_s, sensor, w, "sensor_frozen",
                                  time_s - row[2])
                if check.status != "rejected":
                    w.rejections = 0
                else:
                    self._rejected(records, time_s, sensor, w, check)
            else:
                w.rejections = 0
            kind = w.excluded_as
            if kind is not None and kind != "sensor_inconsistent":
                # (the cross-check re-admits an inconsistent barometer)
                self._recovery(records, time_s, sensor, w, kind, check,
                               same == 0.0 and row[1] == 0.0)
        self._cross_check(records, time_s, batches)
        return records

    def _plan(self, batches: Mapping[str, SampleBatch], screened: tuple[str, ...]
              ) -> tuple[np.ndarray, np.ndarray]:
        """The tick's batch values and :func:`watch_values`' plan for them: the grouping's
        own table when ``batches`` carries one, else one built from the batches."""
        if isinstance(batches, GroupedSamples):
            key = (batches.slot_names, screened)
            plan = self._plans.get(key)
            if plan is None:
                plan = self._plans[key] = self._new_plan(screened)
                for slot, sensor in enumerate(batches.slot_names):
                    i = self._row(sensor)
                    plan[0, i] = slot
                    plan[1, i] = batches.slot_axes[slot]
            return batches.table, plan
        plan = self._new_plan(screened)
        table = np.zeros((_MAX_SENSORS, 6))
        for sensor, batch in batches.items():
            i = self._row(sensor)
            value = np.asarray(batch.value, dtype=float).reshape(-1)[:3]
            plan[0, i] = i
            plan[1, i] = value.shape[0]
            table[i, :value.shape[0]] = value
            table[i, 4] = 1.0  # count: a batch
        return table, plan

    def _new_plan(self, screened: tuple[str, ...]) -> np.ndarray:
        """A plan (:func:`watch_values`) with no slots, checking the ``screened`` sensors."""
        plan = np.zeros((3, _MAX_SENSORS), dtype=np.int64)
        plan[0] = -1
        for sensor in screened:
            plan[2, self._row(sensor)] = 1
        return plan

    def _exclude(self, records: list[DetectionRecord], time_s: float, sensor: str, w: _Watch,
                 kind: str, magnitude: float) -> None:
        if w.excluded_as is not None:
            return
        w.excluded_as, w.excluded_s, w.good_since_s = kind, time_s, None
        self._exclusions_changed()
        records.append(DetectionRecord(time_s=time_s, action="detected", kind=kind,
                                       sensor=sensor, magnitude=magnitude))

    def _rejected(self, records: list[DetectionRecord], time_s: float, sensor: str,
                  w: _Watch, check: ChannelCheck) -> None:
        """The flying estimator rejected ``sensor`` at this tick (innovation check)."""
        w.rejections += 1
        w.last_rejected_s = time_s
        self._last_rejected_s = max(self._last_rejected_s, time_s)
        if w.rejections >= self.config.reject_ticks:
            self._exclude(records, time_s, sensor, w, "sensor_rejected", check.nis)

    def _recovery(self, records: list[DetectionRecord], time_s: float, sensor: str,
                  w: _Watch, kind: str, check: ChannelCheck, self_consistent: bool) -> None:
        """Re-admit ``sensor``, excluded as ``kind``, once consistent for ``recover_s``
        (``self_consistent``: its latest batch neither repeated nor jumped)."""
        consistent = check.nis <= check.gate and self_consistent
        if not consistent:
            w.good_since_s = None
            return
        if w.good_since_s is None:
            w.good_since_s = time_s
        if time_s - w.good_since_s < self.config.recover_s - 1e-9:
            return
        w.excluded_as, w.good_since_s, w.rejections = None, None, 0
        self._exclusions_changed()
        records.append(DetectionRecord(time_s=time_s, action="cleared", kind=kind,
                                       sensor=sensor, magnitude=time_s - w.excluded_s))

    def _cross_check(self, records: list[DetectionRecord], time_s: float,
                     batches: Mapping[str, SampleBatch]) -> None:
        """Barometer against motion-capture height (module docstring)."""
        baro, mocap = batches.get("baro"), batches.get("mocap_pos")
        cfg = self.config
        if mocap is not None and "mocap_pos" in self._excluded:
            mocap = None
        if baro is None or mocap is None or len(mocap.value) < 3:
            return
        times, values = self._cross_t, self._cross_v
        # alt = -z (NED); both averaged over the tick
        times.append(time_s)
        values.append(float(baro.value[0]) + float(mocap.value[2]))
        while times and times[0] <= time_s - cfg.cross_window_s:
            times.popleft()
            values.popleft()
        if len(times) < 2 or times[-1] - times[0] < 0.5 * cfg.cross_window_s:
            return
        mean = sum(values) / len(values)
        w = self._w("baro")
        if w.excluded_as is None and abs(mean) > cfg.cross_limit_m:
            self._exclude(records, time_s, "baro", w, "sensor_inconsistent", mean)
            return
        if w.excluded_as == "sensor_inconsistent" and abs(mean) < 0.5 * cfg.cross_limit_m:
            if w.good_since_s is None:
                w.good_since_s = time_s
            if time_s - w.good_since_s >= cfg.recover_s - 1e-9:
                w.excluded_as, w.good_since_s = None, None
                self._exclusions_changed()
                records.append(DetectionRecord(time_s=time_s, action="cleared",
                                               kind="sensor_inconsistent", sensor="baro",
                                               magnitude=mean))
        elif w.excluded_as == "sensor_inconsistent":
            w.good_since_s = None

    # ------------------------------------------------------------------ observation
    def excluded_as(self, sensor: str) -> str | None:
        """Why ``sensor`` is excluded (its detection kind), or None when trusted."""
        w = self._watch.get(sensor)
        return None if w is None else w.excluded_as

    @property
    def excluded(self) -> frozenset[str]:
        """Sensors the estimators must not use."""
        return self._excluded

    def suspect(self, time_s: float) -> bool:
        """A sensor is excluded, or was rejected within ``quiet_s`` of ``time_s``."""
        return bool(self._excluded) or time_s - self._last_rejected_s < self.config.quiet_s

    @property
    def position_fix(self) -> bool:
        """Motion-capture position is trusted."""
        return "mocap_pos" not in self._excluded

    @property
    def height_source(self) -> str:
        """Where height should come from now (module docstring)."""
        source = self.configured_height_source
        if not self._excluded:
            return source
        other = "baro" if source == "mocap" else "mocap"
        if _HEIGHT_SENSOR[source] in self._excluded and \
                _HEIGHT_SENSOR[other] not in self._excluded:
            return other
        return source
