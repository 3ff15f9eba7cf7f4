"""The estimators' update and the sensor watch on its screening, in one compiled call.

An autopilot flying the EKF steps it and the TSKF together
(:func:`fcu.estimation.pair.step_pair`), then watches its sensors on the EKF's screening of
the same samples (:meth:`fcu.monitoring.sensor_health.SensorHealth.step`). Both are compiled;
:func:`step_pair_watched` runs them in one call (:func:`pair_watch_tick`), the same arithmetic
in the same order, which ``tests/fcu/monitoring/test_watched_pair.py`` pins to the two calls
made one after the other.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

import fcu.floats
from fcu.estimation import pair
from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.pair import pair_arguments, pair_kept, pair_tick
from fcu.estimation.state import STATE_DIM, FloatArray, GroupedSamples, StateEstimate
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.monitoring import sensor_health as sensor_health_module
from fcu.monitoring.sensor_health import SensorHealth, watch_sensors
from flightdata.records import DetectionRecord
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.calls import KernelCall
from jitsupport.views import refcount_free_kernel

# pair_watch_tick compiles in pair_tick and every estimation kernel it calls, and
# watch_sensors
drop_stale_kernels(__file__, *map(str, Path(pair.__file__).parent.glob("*.py")),
                   sensor_health_module.__file__, kernel_views.__file__, fcu.floats.__file__)

__all__ = ["pair_watch_tick", "step_pair_watched"]


@refcount_free_kernel
def pair_watch_tick(flat: FloatArray, u: FloatArray, time_s: float, reject: bool,
                    out: FloatArray, t_buf: FloatArray, t_ints: np.ndarray, t_excluded: int,
                    t_gamma: FloatArray, n_steps: int, t_on_ground: bool, accel_power: float,
                    e_buf: FloatArray, e_ints: np.ndarray, e_excluded: int, dt: float,
                    e_on_ground: bool, screen_end: int, par: FloatArray, state: FloatArray,
                    events: FloatArray, index: FloatArray, cross: np.ndarray,
                    window: FloatArray, window_at: np.ndarray
                    ) -> tuple[tuple[bool, float, int, bool, int], int, bool]:
    """:func:`~fcu.estimation.pair.pair_tick` (its seventeen arguments first), then
    :func:`~fcu.monitoring.sensor_health.watch_sensors` (its seven tables last) on the same
    grouped samples and the EKF's screening: ``out[2 * STATE_DIM:screen_end]``
    (``screen_end``: the EKF's tick size), the lone-outlier flag ``reject`` as its
    ``airborne``. Returns ``pair_tick``'s result, then ``watch_sensors``'.
    """
    result = pair_tick(flat, u, time_s, reject, out, t_buf, t_ints, t_excluded, t_gamma,
                       n_steps, t_on_ground, accel_power, e_buf, e_ints, e_excluded, dt,
                       e_on_ground)
    n_events, rejected = watch_sensors(par, state, events, index, cross, window, window_at,
                                       flat, out[2 * STATE_DIM:screen_end], time_s, reject)
    return result, n_events, rejected


# (its arguments: the filters' and the watch's buffers, the tick's fresh arrays, scalars
# converted by pair_arguments)
_pair_watch_tick = KernelCall(pair_watch_tick)


def step_pair_watched(ekf: ExtendedKalmanEstimator, tskf: TwoStageKalmanFilter,
                      health: SensorHealth, time_s: float, pwm_applied: ArrayLike,
                      grouped: GroupedSamples, *, excluded: Collection[str] = (),
                      reject: bool = True, noise: Mapping[str, float]
                      ) -> tuple[StateEstimate, list[DetectionRecord]]:
    """``step_pair(ekf, tskf, ...)`` then ``health.step(time_s, grouped, ekf.screening,
    reject, noise)`` in one compiled call; returns the EKF's estimate and the watch's
    records."""
    time_s = float(time_s)
    arguments = pair_arguments(ekf, tskf, time_s, pwm_applied, grouped, excluded, reject)
    result, n_events, rejected = _pair_watch_tick.call(
        *(*arguments, ekf.channel_set.tick_size,
          *health.kernel_arguments(grouped, ekf.channel_set, noise)))
    estimate = pair_kept(ekf, tskf, time_s, arguments[4], result)
    return estimate, health.watched(time_s, n_events, rejected)
