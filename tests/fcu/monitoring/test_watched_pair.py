"""The estimators' update and the sensor watch in one compiled call
(fcu.monitoring.watched_pair) against the two calls made one after the other."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from fcu.config import AutopilotConfig
from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.pair import step_pair
from fcu.estimation.state import group_samples
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.monitoring.sensor_health import SensorHealth
from fcu.monitoring.watched_pair import step_pair_watched
from flightdata.vocabulary import BATTERY_SENSOR, SENSORS
from sim.world.fault_types import SensorFault

# a barometer frozen in the climb (it disagrees with motion capture), motion-capture position
# biased by 2 m (rejected), the attitude frozen: each excluded, then re-admitted
_FAULTS = (SensorFault(sensor="baro", kind="freeze", start_s=2.0, end_s=3.5),
           SensorFault(sensor="mocap_pos", kind="bias", axis=0, magnitude=2.0, start_s=4.0,
                       end_s=4.3),
           SensorFault(sensor="mocap_att", kind="freeze", start_s=5.0, end_s=5.5))


def test_the_watched_pair_is_the_pair_then_the_watch_to_the_bit(
        takeoff_ticks: Callable[..., list[tuple[float, np.ndarray, Any]]]) -> None:
    ticks = takeoff_ticks(700, seed=11, faults=_FAULTS)
    config = AutopilotConfig()
    model, dt_s = config.model, 1.0 / config.loop_rate_hz

    def parts() -> tuple[ExtendedKalmanEstimator, TwoStageKalmanFilter, SensorHealth]:
        return (ExtendedKalmanEstimator(model, dt_s), TwoStageKalmanFilter(model, dt_s),
                SensorHealth(config.sensors, "mocap"))

    apart, together = parts(), parts()
    noise = {name: float(getattr(apart[0].noise, name)) for name in SENSORS}
    kinds = apart[0].sensor_kinds | apart[1].sensor_kinds | {BATTERY_SENSOR}
    kinds_seen: set[tuple[str, str]] = set()
    for time_s, pwm, samples in ticks:
        reject = time_s > 1.0  # (in flight)
        records = []
        for ekf, tskf, health in (apart, together):
            grouped = group_samples(samples, kinds)
            grouped.pop_value(BATTERY_SENSOR)
            excluded = health.excluded
            if health is apart[2]:
                estimate = step_pair(ekf, tskf, time_s, pwm, grouped, excluded=excluded,
                                     reject=reject)
                records.append(health.step(time_s, grouped, ekf.screening, reject, noise))
            else:
                estimate, found = step_pair_watched(ekf, tskf, health, time_s, pwm, grouped,
                                                    excluded=excluded, reject=reject,
                                                    noise=noise)
                records.append(found)
            assert estimate is ekf.estimate
        assert records[0] == records[1]
        kinds_seen |= {(r.kind, r.action) for r in records[1]}
        assert np.array_equal(apart[0].estimate.to_vector(), together[0].estimate.to_vector())
        assert np.array_equal(apart[1].gamma_raw, together[1].gamma_raw)
        assert np.array_equal(apart[0].P, together[0].P)
        assert apart[2].excluded == together[2].excluded
        assert apart[2].suspect(time_s) == together[2].suspect(time_s)
        assert np.array_equal(apart[2]._state, together[2]._state, equal_nan=True)
    # the watch had something to do: each check excluded a sensor, and each came back
    assert {(kind, action) for kind in ("sensor_inconsistent", "sensor_rejected",
                                        "sensor_frozen")
            for action in ("detected", "cleared")} <= kinds_seen, kinds_seen
