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

from fcu.estimation.estimator import ChannelCheck, Screening
from fcu.estimation.state import GroupedSamples, SampleBatch
from flightdata.config import finite, require
from flightdata.records import DetectionRecord


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
    """Bookkeeping of one sensor."""

    excluded_as: str | None = None  # detection kind while excluded
    excluded_s: float = 0.0
    rejections: int = 0
    last_rejected_s: float = -math.inf
    last_value: list[float] | None = None
    last_time_s: float = 0.0
    same: int = 0
    jumped: bool = False  # the latest batch jumped from the one before
    frozen_since_s: float = 0.0
    good_since_s: float | None = None


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
        # the cross-check's window: tick times and baro alt - mocap alt, m
        self._cross_t: deque[float] = deque()
        self._cross_v: deque[float] = deque()
        self._last_rejected_s = -math.inf  # the latest rejection of any sensor
        self._exclusions_changed()

    def _w(self, sensor: str) -> _Watch:
        w = self._watch.get(sensor)
        if w is None:
            w = self._watch[sensor] = _Watch()
        return w

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
        # the batch values as lists of floats, and (sensor, status, NIS, gate) per sensor
        # screened, from the arrays behind them when they come grouped and screened
        values = (batches.value_lists() if isinstance(batches, GroupedSamples)
                  else {sensor: batch.value.tolist() for sensor, batch in batches.items()})
        entries = (screening.entries() if isinstance(screening, Screening)
                   else [(sensor, check.status, check.nis, check.gate)
                         for sensor, check in screening.items()])
        frozen_ticks = self.config.frozen_ticks
        for sensor, status, nis, gate in entries:
            w = watch.get(sensor)
            if w is None:
                w = self._w(sensor)
            value = values.get(sensor)
            if value is not None:
                self._watch_value(time_s, w, value, noise.get(sensor, 0.0),
                                  sensor == "mocap_att")
            if airborne:
                if w.same >= frozen_ticks:
                    self._exclude(records, time_s, sensor, w, "sensor_frozen",
                                  time_s - w.frozen_since_s)
                if status != "rejected":
                    w.rejections = 0
                else:
                    self._rejected(records, time_s, sensor, w, nis)
            else:
                w.rejections = 0
            kind = w.excluded_as
            if kind is not None and kind != "sensor_inconsistent":
                # (the cross-check re-admits an inconsistent barometer)
                self._recovery(records, time_s, sensor, w, kind, nis <= gate)
        self._cross_check(records, time_s, values)
        return records

    def _exclude(self, records: list[DetectionRecord], time_s: float, sensor: str, w: _Watch,
                 kind: str, magnitude: float) -> None:
        if w.excluded_as is not None:
            return
        w.excluded_as, w.excluded_s, w.good_since_s = kind, time_s, None
        self._exclusions_changed()
        records.append(DetectionRecord(time_s=time_s, action="detected", kind=kind,
                                       sensor=sensor, magnitude=magnitude))

    def _watch_value(self, time_s: float, w: _Watch, value: list[float],
                     sigma: float, yaw_last: bool) -> None:
        """Repeats (frozen) and jumps (garbage) of the batch values (``yaw_last``: the third
        entry is an angle, its change wrapped to [-pi, pi))."""
        last = w.last_value
        if last is not None and value == last:
            if w.same == 0:
                w.frozen_since_s = time_s
            w.same += 1
            w.jumped = False
        else:
            w.same = 0
            if last is not None:
                cfg = self.config
                limit = cfg.jump_sigma * sigma + cfg.max_speed * (time_s - w.last_time_s)
                change = [a - b for a, b in zip(value, last, strict=True)]
                if yaw_last:
                    change[2] = (change[2] + math.pi) % (2.0 * math.pi) - math.pi
                # some |change| > limit
                w.jumped = max(change) > limit or min(change) < -limit
        w.last_value = value
        w.last_time_s = time_s

    def _rejected(self, records: list[DetectionRecord], time_s: float, sensor: str,
                  w: _Watch, nis: float) -> None:
        """The flying estimator rejected ``sensor`` (NIS ``nis``) at this tick (innovation
        check)."""
        w.rejections += 1
        w.last_rejected_s = time_s
        self._last_rejected_s = max(self._last_rejected_s, time_s)
        if w.rejections >= self.config.reject_ticks:
            self._exclude(records, time_s, sensor, w, "sensor_rejected", nis)

    def _recovery(self, records: list[DetectionRecord], time_s: float, sensor: str,
                  w: _Watch, kind: str, within_gate: bool) -> None:
        """Re-admit ``sensor``, excluded as ``kind``, once consistent for ``recover_s``
        (``within_gate``: its NIS at this tick is within the gate)."""
        consistent = within_gate and w.same == 0 and not w.jumped
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
                     batch_values: Mapping[str, list[float]]) -> None:
        """Barometer against motion-capture height (module docstring); ``batch_values``:
        the tick's batch values by kind."""
        baro, mocap = batch_values.get("baro"), batch_values.get("mocap_pos")
        cfg = self.config
        if mocap is not None and "mocap_pos" in self._excluded:
            mocap = None
        if baro is None or mocap is None or len(mocap) < 3:
            return
        times, values = self._cross_t, self._cross_v
        # alt = -z (NED); both averaged over the tick
        times.append(time_s)
        values.append(baro[0] + mocap[2])
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
