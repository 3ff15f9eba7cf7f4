"""The autopilot builds the parts its configuration names through the registries."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fcu.autopilot import Autopilot
from fcu.config import AutopilotConfig
from fcu.control.attitude_lqr import AttitudeLQR
from fcu.control.attitude_pd import AttitudePD
from fcu.control.dob import AccelerationDob, NoDob, VelocityDob
from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.hal import SensorSample
from flightdata.vocabulary import ALLOCATORS, ATTITUDE_LAWS, DISTURBANCE_OBSERVERS, ESTIMATORS

ATTITUDE_TYPES = {"pd": AttitudePD, "lqg": AttitudeLQR}
DOB_TYPES = {"none": NoDob, "vbdob": VelocityDob, "abdob": AccelerationDob}


@pytest.mark.parametrize(("estimator", "attitude", "dob", "allocator"), list(
    itertools.product(ESTIMATORS, ATTITUDE_LAWS, DISTURBANCE_OBSERVERS, ALLOCATORS)))
def test_every_configuration_builds_its_parts_and_ticks(estimator: str, attitude: str,
                                                        dob: str, allocator: str) -> None:
    ap = Autopilot(AutopilotConfig(estimator=estimator, attitude=attitude, dob=dob,
                                   allocator=allocator))
    assert isinstance(ap.attitude, ATTITUDE_TYPES[attitude])
    assert isinstance(ap.dob, DOB_TYPES[dob])
    # the effectiveness estimates always come from a TSKF, the selected one when it is one
    assert isinstance(ap.tskf, TwoStageKalmanFilter)
    assert (ap.estimator is ap.tskf) == (estimator == "tskf")
    assert isinstance(ap.ekf, ExtendedKalmanEstimator) == (estimator == "ekf")
    samples = [SensorSample("mocap_pos", 0.01, np.zeros(3)),
               SensorSample("mocap_att", 0.01, np.zeros(3)),
               SensorSample("gyro", 0.01, np.zeros(3))]
    pwm = ap.step(0.01, samples)
    np.testing.assert_array_equal(pwm, 0.0)  # disarmed: motors off
    assert ap.status is not None and ap.status.estimate.time_s == pytest.approx(0.01)
    ap.reset_estimators(2.0)
    assert ap.estimator.estimate.time_s == 2.0 and ap.tskf.estimate.time_s == 2.0
