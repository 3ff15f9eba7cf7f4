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

Rejections count, and sensors are frozen, only in flight: on the ground a touchdown or a
disarm moves the vehicle in ways no estimator model follows.

Gusts: the estimators' model has no horizontal force but the thrust's, while the
accelerometer's in-plane axes read the drag alone (the thrust has no in-plane part). Above
``gust_accel_m_s2`` of in-plane specific force the model is known not to hold, and the
autopilot lets no lone outlier be rejected (:mod:`fcu.autopilot`): in 8 m/s of severe
turbulence a 20 m/s gust put motion capture outside the gate alone for five ticks, it was
excluded, the estimate coasted away from the truth and never let it back, and the position
failsafe's landing drifted downwind out of the mission area (3 of 128 fault-free flights).

Fallback (:attr:`SensorHealth.height_source`): height comes from the configured source while
it is trusted, else from the other one if trusted. :attr:`SensorHealth.position_fix` is False
while motion-capture position is excluded: the autopilot then holds attitude and height and
lands after its position failsafe timeout (:mod:`fcu.autopilot`). :attr:`SensorHealth.suspect`
is True while any sensor is excluded, or was rejected within ``quiet_s``: motor fault
evidence is not taken then (a sensor fault would otherwise raise motor alarms).

The three checks and the re-admission run in one compiled call a tick (:func:`watch_sensors`)
over a table of each sensor's state and the cross-check's window, reading the tick's grouped
batches and the screening's table as arrays.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation.channels import ChannelSet
from fcu.estimation.estimator import ChannelCheck, Screening
from fcu.estimation.screening import ABSENT, REJECTED, STATUS_NAMES
from fcu.estimation.state import GroupedSamples, SampleBatch
from fcu.floats import wrap_pi
from flightdata.config import finite, require
from flightdata.records import DetectionRecord
from flightdata.vocabulary import SENSORS
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import Layout

drop_stale_kernels(__file__, fcu.floats.__file__)  # watch_sensors compiles in fcu.floats' wrap_pi


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
    # m/s^2, in-plane specific force above which a lone outlier is the model's, not the
    # sensor's (module docstring, "Gusts"): 0.15 at most in the thesis mission's air, 2.0 in
    # 4 m/s of moderate turbulence, up to 7 in 8 m/s of severe turbulence
    gust_accel_m_s2: float = 3.0

    def __post_init__(self) -> None:
        for name in ("reject_ticks", "frozen_ticks"):
            value = getattr(self, name)
            require(isinstance(value, int) and value >= 1, name, value,
                    "must be an integer >= 1")
        for name in ("recover_s", "cross_window_s", "cross_limit_m",
                     "jump_sigma", "max_speed", "gust_accel_m_s2"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a number > 0")
        require(finite(self.quiet_s) and self.quiet_s >= 0, "quiet_s", self.quiet_s,
                "must be >= 0 s")


# SensorHealth's state table: one row per sensor of SENSORS, these columns (times in s;
# NaN: not running)
ROW = Layout("sensor health row")
# the kind it is excluded as, a code of _KINDS (0: trusted)
_EXCLUDED_AS = ROW.field("excluded_as", 1)
_EXCLUDED_S = ROW.field("excluded_s", 1)  # s, when it was excluded
_REJECTIONS = ROW.field("rejections", 1)  # consecutive batches the estimator rejected
_LAST_N = ROW.field("last_n", 1)  # entries of the latest batch value (0: none yet)
_LAST_TIME_S = ROW.field("last_time_s", 1)  # s, time of the latest batch
_SAME = ROW.field("same", 1)  # consecutive batches with the same value
_JUMPED = ROW.field("jumped", 1)  # 1 after a jump beyond the physical bounds
_FROZEN_SINCE_S = ROW.field("frozen_since_s", 1)  # s, start of the run of equal values
_GOOD_SINCE_S = ROW.field("good_since_s", 1)  # s, start of the run of good batches
_SIGMA = ROW.field("sigma", 1)  # the sensor's noise, its unit
_LAST_VALUE = ROW.field("last_value", 3)  # the latest batch value, _LAST_N entries
_STATE_WIDTH = ROW.size
_KINDS: tuple[str, ...] = ("", "sensor_frozen", "sensor_rejected", "sensor_inconsistent")
_TRUSTED, _FROZEN, _REJECTED, _INCONSISTENT = range(4)
# its parameter vector (SensorHealthConfig)
(_P_REJECT_TICKS, _P_FROZEN_TICKS, _P_RECOVER_S, _P_JUMP_SIGMA, _P_MAX_SPEED,
 _P_CROSS_WINDOW_S, _P_CROSS_LIMIT_M) = range(7)
# the rows of the state table the cross-check reads
_BARO_ROW, _MOCAP_POS_ROW = SENSORS.index("baro"), SENSORS.index("mocap_pos")
# where the cross-check finds the tick's heights in the grouped samples' flat array: the
# barometer's value and count, the motion-capture position's (-1: no cross-check)
_X_BARO_AT, _X_BARO_COUNT_AT, _X_MOCAP_AT, _X_MOCAP_COUNT_AT = range(4)
# the cross-check's window, a ring of (tick time, baro alt - mocap alt) rows: the index of
# its oldest row and its rows, in an int array
_W_FIRST, _W_ROWS = range(2)
# the tick's index: one row per channel screened (floats): the sensor's row in the state
# table, where its batch value and count are in the grouped samples' flat array (value -1:
# no slot), its entries, the third a yaw, its NIS gate, where its NIS and status code are
# in the screening table
(_I_ROW, _I_VALUE_AT, _I_COUNT_AT, _I_AXES, _I_YAW, _I_GATE, _I_NIS_AT,
 _I_STATUS_AT) = range(8)
_INDEX_WIDTH = 8
# an event of watch_sensors: detected (0) or cleared (1), kind code, sensor row, magnitude
_E_ACTION, _E_KIND, _E_ROW, _E_MAGNITUDE = range(4)


@njit(cache=True, error_model="numpy", inline="always")
def _exclude(state: np.ndarray, events: np.ndarray, n_events: int, row: int, kind: int,
             time_s: float, magnitude: float) -> int:
    """Exclude sensor ``row`` as ``kind`` (unless it is excluded already), writing the event;
    returns the events written."""
    if state[row, _EXCLUDED_AS] != _TRUSTED:
        return n_events
    state[row, _EXCLUDED_AS] = kind
    state[row, _EXCLUDED_S] = time_s
    state[row, _GOOD_SINCE_S] = np.nan
    events[n_events, _E_ACTION] = 0.0
    events[n_events, _E_KIND] = kind
    events[n_events, _E_ROW] = row
    events[n_events, _E_MAGNITUDE] = magnitude
    return n_events + 1


@njit(cache=True, error_model="numpy", inline="always")
def _good_for(state: np.ndarray, row: int, time_s: float, recover_s: float) -> bool:
    """Sensor ``row`` found good at ``time_s``: whether it has been since ``recover_s`` (its
    good spell starts now unless one runs)."""
    if math.isnan(state[row, _GOOD_SINCE_S]):
        state[row, _GOOD_SINCE_S] = time_s
    return time_s - state[row, _GOOD_SINCE_S] >= recover_s - 1e-9


@njit(cache=True, error_model="numpy", inline="always")
def _readmit(state: np.ndarray, events: np.ndarray, n_events: int, row: int,
             magnitude: float) -> int:
    """Trust sensor ``row`` again, writing the event (the kind it was excluded as); returns
    the events written."""
    events[n_events, _E_ACTION] = 1.0
    events[n_events, _E_KIND] = state[row, _EXCLUDED_AS]
    events[n_events, _E_ROW] = row
    events[n_events, _E_MAGNITUDE] = magnitude
    state[row, _EXCLUDED_AS] = _TRUSTED
    state[row, _GOOD_SINCE_S] = np.nan
    return n_events + 1


@njit(cache=True, error_model="numpy")
def cross_check(par: np.ndarray, state: np.ndarray, events: np.ndarray, n_events: int,
                cross: np.ndarray, window: np.ndarray, window_at: np.ndarray,
                flat: np.ndarray, time_s: float) -> int:
    """The barometer against the motion-capture height (module docstring), on the tick's
    batches ``flat`` (``cross``: where the heights are in it, ``_X_*``), with the window
    ``window`` (a ring of (tick time s, baro alt - mocap alt m) rows, ``window_at``: its
    oldest row and its rows, advanced; it has room for one more row); writes an exclusion
    or re-admission of the barometer after the ``n_events`` events; returns the events."""
    if (flat[cross[_X_BARO_COUNT_AT]] <= 0 or flat[cross[_X_MOCAP_COUNT_AT]] <= 0
            or state[_MOCAP_POS_ROW, _EXCLUDED_AS] != _TRUSTED):
        return n_events
    cap = window.shape[0]
    first = window_at[_W_FIRST]
    rows = window_at[_W_ROWS]
    # alt = -z (NED); both averaged over the tick
    last = (first + rows) % cap
    window[last, 0] = time_s
    window[last, 1] = flat[cross[_X_BARO_AT]] + flat[cross[_X_MOCAP_AT] + 2]
    rows += 1
    while rows > 0 and window[first, 0] <= time_s - par[_P_CROSS_WINDOW_S]:
        first = (first + 1) % cap
        rows -= 1
    window_at[_W_FIRST] = first
    window_at[_W_ROWS] = rows
    if rows < 2 or window[last, 0] - window[first, 0] < 0.5 * par[_P_CROSS_WINDOW_S]:
        return n_events
    # the mean difference, summed oldest first
    total = 0.0
    for k in range(rows):
        total += window[(first + k) % cap, 1]
    mean = total / rows
    limit = par[_P_CROSS_LIMIT_M]
    baro = state[_BARO_ROW]
    kind = baro[_EXCLUDED_AS]
    if kind == _TRUSTED and abs(mean) > limit:
        return _exclude(state, events, n_events, _BARO_ROW, _INCONSISTENT, time_s, mean)
    if kind == _INCONSISTENT and abs(mean) < 0.5 * limit:
        if _good_for(state, _BARO_ROW, time_s, par[_P_RECOVER_S]):
            n_events = _readmit(state, events, n_events, _BARO_ROW, mean)
    elif kind == _INCONSISTENT:
        baro[_GOOD_SINCE_S] = np.nan
    return n_events


@njit(cache=True, error_model="numpy")
def watch_sensors(par: np.ndarray, state: np.ndarray, events: np.ndarray, index: np.ndarray,
                  cross: np.ndarray, window: np.ndarray, window_at: np.ndarray,
                  flat: np.ndarray, screen: np.ndarray, time_s: float,
                  airborne: bool) -> tuple[int, bool]:
    """The innovation and frozen-signal checks of one tick, and the re-admission of sensors
    they excluded (module docstring), for each channel of ``index`` screened this tick; then
    the cross-check (:func:`cross_check`, unless ``cross`` is -1).

    ``par``: the settings (``_P_*``); ``state``: the state table, advanced; ``events``: the
    exclusions and re-admissions, written in order; ``flat``: the tick's batches
    (:attr:`fcu.estimation.state.GroupedSamples.flat`); ``screen``: the screening's table
    (:class:`fcu.estimation.estimator.Screening`). Returns the events written and whether
    any sensor was rejected.
    """
    # typed as an integer, not as the constant 0 (numba types a literal by its value, and
    # cross_check below would be compiled once more for it)
    n_events = int(np.int64(0))
    rejected = False
    for c in range(index.shape[0]):
        status = screen[int(index[c, _I_STATUS_AT])]
        if status == ABSENT:
            continue
        r = int(index[c, _I_ROW])
        nis = screen[int(index[c, _I_NIS_AT])]
        at = int(index[c, _I_VALUE_AT])
        if at >= 0 and flat[int(index[c, _I_COUNT_AT])] > 0:
            # repeats (frozen) and jumps (garbage) of the batch values
            n = int(index[c, _I_AXES])
            if state[r, _LAST_N] != 0 and state[r, _LAST_N] != n:
                raise ValueError("a sensor's batch values changed length")
            same = state[r, _LAST_N] != 0
            for i in range(n):
                same = same and flat[at + i] == state[r, _LAST_VALUE + i]
            if same:
                if state[r, _SAME] == 0:
                    state[r, _FROZEN_SINCE_S] = time_s
                state[r, _SAME] += 1
                state[r, _JUMPED] = 0.0
            else:
                state[r, _SAME] = 0.0
                if state[r, _LAST_N] != 0:
                    limit = par[_P_JUMP_SIGMA] * state[r, _SIGMA] + par[_P_MAX_SPEED] * (
                        time_s - state[r, _LAST_TIME_S])
                    # some |change| > limit (a yaw's change wrapped to [-pi, pi))
                    jumped = False
                    for i in range(n):
                        change = flat[at + i] - state[r, _LAST_VALUE + i]
                        if i == 2 and index[c, _I_YAW] != 0:
                            change = wrap_pi(change)
                        jumped = jumped or change > limit or change < -limit
                    state[r, _JUMPED] = 1.0 if jumped else 0.0
            for i in range(n):
                state[r, _LAST_VALUE + i] = flat[at + i]
            state[r, _LAST_N] = n
            state[r, _LAST_TIME_S] = time_s
        if airborne:
            if state[r, _SAME] >= par[_P_FROZEN_TICKS]:
                n_events = _exclude(state, events, n_events, r, _FROZEN, time_s,
                                    time_s - state[r, _FROZEN_SINCE_S])
            if status != REJECTED:
                state[r, _REJECTIONS] = 0.0
            else:
                # the flying estimator rejected the sensor at this tick (innovation check)
                state[r, _REJECTIONS] += 1
                rejected = True
                if state[r, _REJECTIONS] >= par[_P_REJECT_TICKS]:
                    n_events = _exclude(state, events, n_events, r, _REJECTED, time_s, nis)
        else:
            state[r, _REJECTIONS] = 0.0
        kind = state[r, _EXCLUDED_AS]
        if kind == _TRUSTED or kind == _INCONSISTENT:
            continue  # (the cross-check re-admits an inconsistent barometer)
        # re-admitted once consistent for recover_s
        if not (nis <= index[c, _I_GATE] and state[r, _SAME] == 0
                and state[r, _JUMPED] == 0):
            state[r, _GOOD_SINCE_S] = np.nan
            continue
        if _good_for(state, r, time_s, par[_P_RECOVER_S]):
            n_events = _readmit(state, events, n_events, r, time_s - state[r, _EXCLUDED_S])
            state[r, _REJECTIONS] = 0.0
    if cross[0] >= 0:
        n_events = cross_check(par, state, events, n_events, cross, window, window_at, flat,
                               time_s)
    return n_events, rejected


# the sensor each height source reads
_HEIGHT_SENSOR = {"mocap": "mocap_pos", "baro": "baro"}
_ROW = {sensor: r for r, sensor in enumerate(SENSORS)}  # rows of the state table
# watch_sensors' index of a tick's channels, and where cross_check reads the tick's heights
_Index = tuple[np.ndarray, np.ndarray]
_NO_CROSS = np.full(4, -1, dtype=np.int64)  # no height to cross-check
_STATUS_CODES = {name: code for code, name in enumerate(STATUS_NAMES)}
_WINDOW_ROWS = 256  # the cross-check window's first room (grown when full)


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
        self._par = np.array([config.reject_ticks, config.frozen_ticks, config.recover_s,
                              config.jump_sigma, config.max_speed, config.cross_window_s,
                              config.cross_limit_m], dtype=float)
        self._events = np.zeros((2 * len(SENSORS) + 1, 4))
        # watch_sensors' index, by (channels screened, grouped slots, slots popped)
        self._indexes: dict[tuple[object, ...], _Index] = {}
        self._last_key: tuple[object, ...] = (None,) * 5  # kernel_arguments' latest
        self._last_index: _Index = (np.zeros((0, _INDEX_WIDTH)), _NO_CROSS)
        self.reset()

    def reset(self) -> None:
        """Every sensor trusted, every check restarted."""
        self._state = np.zeros((len(SENSORS), _STATE_WIDTH))
        self._state[:, _GOOD_SINCE_S] = np.nan
        self._noise: dict[str, float] | None = None  # the noise the _SIGMA column holds
        self._noise_given: Mapping[str, float] | None = None  # the mapping it was read from
        # the cross-check's window (cross_check): a ring of (tick time s, baro alt - mocap
        # alt m) rows, its oldest row and its rows
        self._window = np.zeros((_WINDOW_ROWS, 2))
        self._window_at = np.zeros(2, dtype=np.int64)
        self._last_rejected_s = -math.inf  # the latest rejection of any sensor
        self._exclusions_changed()

    def _exclusions_changed(self) -> None:
        """Refresh what follows from the excluded sensors (read every tick)."""
        kinds = self._state[:, _EXCLUDED_AS].tolist()
        self._excluded = frozenset(s for s, k in zip(SENSORS, kinds, strict=True) if k)

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
            Each sensor's noise, one sample, 1 sigma, sensor units (the jump test); read
            when a mapping other than the previous tick's is given (not watched for changes
            made in place).
        """
        grouped = (batches if isinstance(batches, GroupedSamples)
                   else _grouped(batches))
        if isinstance(screening, Screening):
            screen = screening.screen
            par, state, events, index, cross, window, window_at = self.kernel_arguments(
                grouped, screening.channel_set, noise)
        else:
            checks = [(sensor, check.gate) for sensor, check in screening.items()]
            key = (tuple(checks), grouped.slot_names, grouped.slot_axes, grouped.width,
                   grouped.popped)
            screen = np.array([check.nis for check in screening.values()]
                              + [_STATUS_CODES[check.status] for check in screening.values()],
                              dtype=float)
            index, cross = self._indexes.get(key) or self._index(
                key, [(sensor, gate, 0, 0) for sensor, gate in checks], 0, grouped)
            self._take_noise(noise)
            par, state, events, window, window_at = (self._par, self._state, self._events,
                                                     self._window, self._window_at)
        n_events, rejected = watch_sensors(par, state, events, index, cross, window,
                                           window_at, grouped.flat, screen, time_s,
                                           bool(airborne))
        return self.watched(time_s, n_events, rejected)

    def kernel_arguments(self, grouped: GroupedSamples, channel_set: ChannelSet,
                         noise: Mapping[str, float]) -> tuple[Any, ...]:
        """:func:`watch_sensors`' first seven arguments for a tick of ``grouped`` samples
        screened by ``channel_set`` (its :class:`Screening` table), :meth:`step`'s
        ``noise`` taken; for a compiled call that runs the watch after the estimators'
        update (:mod:`fcu.monitoring.watched_pair`), then :meth:`watched`."""
        last = self._last_key
        if (channel_set is last[0] and grouped.slot_names is last[1]
                and grouped.slot_axes is last[2] and grouped.width == last[3]
                and grouped.popped == last[4]):  # (a flight's ticks: the same layout)
            index, cross = self._last_index
        else:
            key: tuple[object, ...] = (channel_set, grouped.slot_names, grouped.slot_axes,
                                       grouped.width, grouped.popped)
            index, cross = self._indexes.get(key) or self._index(
                key, channel_set.checks, 2 * channel_set.n_rows, grouped)
            self._last_key, self._last_index = key, (index, cross)
        if noise is not self._noise_given:
            self._take_noise(noise)
        return (self._par, self._state, self._events, index, cross, self._window,
                self._window_at)

    def _take_noise(self, noise: Mapping[str, float]) -> None:
        """Each sensor's noise for the jump test, when ``noise`` is another mapping."""
        if noise is not self._noise_given:
            self._noise_given = noise
            if noise != self._noise:
                self._noise = dict(noise)
                self._state[:, _SIGMA] = [noise.get(sensor, 0.0) for sensor in SENSORS]

    def watched(self, time_s: float, n_events: int, rejected: bool) -> list[DetectionRecord]:
        """After :func:`watch_sensors` at ``time_s`` (s) wrote ``n_events`` events and found
        a rejection or not: the window grown when full, the records of the events."""
        if self._window_at.item(_W_ROWS) == self._window.shape[0]:  # full: room for a row
            self._grow_window()
        if rejected:
            self._last_rejected_s = max(self._last_rejected_s, time_s)
        if not n_events:
            return []
        records = []
        for action, kind, row, magnitude in self._events[:n_events].tolist():
            records.append(DetectionRecord(
                time_s=time_s, action="cleared" if action else "detected",
                kind=_KINDS[int(kind)], sensor=SENSORS[int(row)], magnitude=magnitude))
        self._exclusions_changed()
        return records

    def _grow_window(self) -> None:
        """Twice the room in the cross-check's window, its rows kept (oldest first)."""
        window, (first, rows) = self._window, self._window_at.tolist()
        order = (first + np.arange(rows)) % window.shape[0]
        self._window = np.zeros((2 * window.shape[0], 2))
        self._window[:rows] = window[order]
        self._window_at[:] = (0, rows)

    def _index(self, key: tuple[object, ...], checks: Sequence[tuple[str, float, int, int]],
               nis_at: int, grouped: GroupedSamples) -> _Index:
        """:func:`watch_sensors`' index of the channels ``checks`` (sensor, gate, rows) whose
        NIS and status codes are in the screening table from ``nis_at``, over the slots of
        ``grouped``; and where the barometer's value and count, and the motion-capture
        position's, are in its flat array (:meth:`_cross_check`; None without both)."""
        width = grouped.width
        slots = {name: s for s, name in enumerate(grouped.slot_names)
                 if name not in grouped.popped}
        index = np.zeros((len(checks), _INDEX_WIDTH))
        for c, (sensor, gate, _, _) in enumerate(checks):
            if sensor not in _ROW:
                raise ValueError(f"sensor = {sensor!r}: must be one of {', '.join(SENSORS)}")
            s = slots.get(sensor, -1)
            index[c] = (_ROW[sensor], s * width if s >= 0 else -1, s * width + width - 2,
                        grouped.slot_axes[s] if s >= 0 else 0, sensor == "mocap_att", gate,
                        nis_at + c, nis_at + len(checks) + c)
        baro, mocap = slots.get("baro", -1), slots.get("mocap_pos", -1)
        cross = _NO_CROSS
        if baro >= 0 and mocap >= 0 and grouped.slot_axes[mocap] >= 3:  # a height to compare
            cross = np.array([baro * width, baro * width + width - 2, mocap * width,
                              mocap * width + width - 2], dtype=np.int64)
        self._indexes[key] = index, cross
        return index, cross

    # ------------------------------------------------------------------ observation
    def excluded_as(self, sensor: str) -> str | None:
        """Why ``sensor`` is excluded (its detection kind), or None when trusted."""
        row = _ROW.get(sensor)
        return None if row is None else _KINDS[int(self._state[row, _EXCLUDED_AS])] or None

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


def _grouped(batches: Mapping[str, SampleBatch]) -> GroupedSamples:
    """Batches of any mapping as :func:`~fcu.estimation.state.group_samples` returns them
    (one slot each, in the mapping's order)."""
    names = tuple(batches)
    width = 3 + 3  # up to three value entries, then mean time, count, first sample
    flat = np.zeros(len(names) * width + 1)
    axes = []
    for s, batch in enumerate(batches.values()):
        value = np.asarray(batch.value, dtype=float).reshape(-1)
        if value.shape[0] > 3:
            raise ValueError(f"{names[s]} batch has {value.shape[0]} values: at most 3")
        flat[s * width:s * width + value.shape[0]] = value
        flat[s * width + width - 3:s * width + width] = (batch.time_s, batch.count, s)
        axes.append(value.shape[0])
    return GroupedSamples(flat, width, names, tuple(axes))
