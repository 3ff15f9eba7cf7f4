"""Every estimator the registry names builds from the autopilot's configuration and
estimates a vehicle standing still on the ground."""

from __future__ import annotations

import numpy as np
import pytest

from fcu.config import AutopilotConfig
from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.registry import ESTIMATOR_REGISTRY
from fcu.estimation.state import group_samples
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.hal import SensorSample
from flightdata.vocabulary import ESTIMATORS, HEIGHT_SOURCES

DT = 0.01  # s, the 100 Hz tick
ON_THE_GROUND = {  # at home, level, at rest, motors off: what perfect sensors read
    "gyro": np.zeros(3), "accel": np.array([0.0, 0.0, -9.81]), "mocap_pos": np.zeros(3),
    "mocap_att": np.zeros(3), "baro": np.zeros(1),
}


@pytest.mark.parametrize("height_source", HEIGHT_SOURCES)
@pytest.mark.parametrize("name", ESTIMATORS)
def test_each_estimator_builds_and_steps(name: str, height_source: str) -> None:
    config = AutopilotConfig(estimator=name, height_source=height_source)
    estimator = ESTIMATOR_REGISTRY.factory(name)(config, DT)
    assert isinstance(estimator, {"ekf": ExtendedKalmanEstimator,
                                  "tskf": TwoStageKalmanFilter}[name])
    # every height source's sensors (the source can be switched in flight)
    assert {"mocap_pos", "mocap_att", "gyro", "accel", "baro"} <= estimator.sensor_kinds
    for k in range(1, 51):
        t = k * DT
        samples = [SensorSample(s, t, v) for s, v in ON_THE_GROUND.items()]
        estimate = estimator.step_grouped(t, np.zeros(4),
                                          group_samples(samples, estimator.sensor_kinds))
    assert estimate.time_s == pytest.approx(0.5)  # s, the last tick
    # only the configured height source is screened and used
    assert ("baro" in estimator.screening) == (height_source == "baro")
    assert estimator.screening["mocap_pos"].residual.shape == (
        (3,) if height_source == "mocap" else (2,))
    assert estimator.screening["accel"].status == "skipped"  # on the ground
    # the ground holds the vehicle and every reading agrees: the estimate stays put
    # (m, m/s, rad; only rounding of the updates)
    np.testing.assert_allclose(estimate.pos_ned, 0.0, atol=1e-12)
    np.testing.assert_allclose(estimate.vel_ned, 0.0, atol=1e-12)
    np.testing.assert_allclose(estimate.euler_rad, 0.0, atol=1e-12)
    # 50 mocap updates of 0.5 mm each pin the horizontal position far below its 0.5 m prior
    assert np.all(estimate.std[:2] < 1e-3)
    assert estimator.last_innovation["mocap_pos"].nis >= 0.0
    estimator.reset(1.0)
    assert estimator.estimate.time_s == 1.0


@pytest.mark.parametrize("name", ESTIMATORS)
def test_an_estimate_built_when_read_equals_the_one_stepped(name: str) -> None:
    config = AutopilotConfig(estimator=name)
    stepped = ESTIMATOR_REGISTRY.factory(name)(config, DT)
    advanced = ESTIMATOR_REGISTRY.factory(name)(config, DT)
    rng = np.random.default_rng(4)
    for k in range(1, 31):
        t = k * DT
        samples = [SensorSample(s, t, v + 0.001 * rng.normal(size=v.shape))
                   for s, v in ON_THE_GROUND.items()]
        grouped = group_samples(samples, stepped.sensor_kinds)
        estimate = stepped.step_grouped(t, np.full(4, 0.1), grouped)
        advanced.advance_grouped(t, np.full(4, 0.1), grouped)
        if k % 3:  # read every third tick only: the rest are never built
            continue
        late = advanced.estimate
        assert late.time_s == estimate.time_s == t
        # the same filter on the same samples: the same numbers, to the bit
        np.testing.assert_array_equal(late.to_vector(), estimate.to_vector())
        np.testing.assert_array_equal(late.covariance_diag, estimate.covariance_diag)
        assert advanced.estimate is late  # built once
