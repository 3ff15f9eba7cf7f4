"""The EKF and the TSKF stepped together, in one compiled call per tick.

The autopilot flying the EKF runs a TSKF beside it for the per-motor effectiveness
(:mod:`fcu.autopilot`). Both take the same tick's averaged samples
(:func:`fcu.estimation.state.group_samples`), PWM, exclusions and rejection flag; :func:`step_pair`
gives each its measurement table from the grouped samples and runs both tick kernels
(:func:`fcu.estimation.tskf.tskf_tick`, then :func:`fcu.estimation.ekf.ekf_tick`) in one call,
the same arithmetic as :meth:`TwoStageKalmanFilter.advance_grouped` followed by
:meth:`ExtendedKalmanEstimator.step_grouped`, which ``tests/fcu/estimation/test_pair.py`` pins
bit for bit.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from fcu.estimation.ekf import SC_MEAS as E_MEAS
from fcu.estimation.ekf import ExtendedKalmanEstimator, ekf_tick
from fcu.estimation.estimator import pwm_array
from fcu.estimation.screening import MEAS_WIDTH
from fcu.estimation.state import FloatArray, GroupedSamples, StateEstimate
from fcu.estimation.tskf import SC_MEAS as T_MEAS
from fcu.estimation.tskf import TwoStageKalmanFilter, tskf_tick
from fcu.estimation.tskf_model import N_MOTORS
from flightdata import kernel_views
from flightdata.kernel_cache import drop_stale_kernels
from flightdata.kernel_views import borrowed, shaped

# pair_tick compiles in the kernels of ekf, tskf and the modules they call
drop_stale_kernels(__file__, kernel_views.__file__)


@njit(cache=True, error_model="numpy")
def gathered(flat: FloatArray, gather: np.ndarray) -> FloatArray:
    """A filter's measurement table from grouped samples: ``flat[gather]``
    (:meth:`fcu.estimation.estimator.ChannelSet.gather`), shape (n_ch, MEAS_WIDTH), in a
    fresh array (:func:`gather_into`)."""
    meas = np.empty((gather.shape[0], MEAS_WIDTH))
    gather_into(meas, flat, gather)
    return meas


@njit(cache=True, error_model="numpy")
def gather_into(meas: FloatArray, flat: FloatArray, gather: np.ndarray) -> None:
    """:func:`gathered` written into ``meas`` (n_ch, MEAS_WIDTH)."""
    for c in range(gather.shape[0]):
        for k in range(MEAS_WIDTH):
            meas[c, k] = flat[gather[c, k]]


@njit(cache=True, error_model="numpy")
def pair_tick(flat: FloatArray, u: FloatArray, time_s: float, reject: bool, out: FloatArray,
              e_size: int, t_size: int, t_work: FloatArray, t_scratch: FloatArray,
              t_gamma: FloatArray, t_model: FloatArray, t_tables: FloatArray, t_layout: np.ndarray,
              t_gather: np.ndarray, t_excluded: np.ndarray, n_steps: int, t_on_ground: bool,
              accel_power: float, e_work: FloatArray, e_s_stack: FloatArray,
              e_scratch: FloatArray, e_constants: FloatArray, e_tables: FloatArray,
              e_layout: np.ndarray, e_gather: np.ndarray, e_excluded: np.ndarray, dt: float,
              e_on_ground: bool) -> tuple[bool, float, int, bool, int]:
    """:func:`~fcu.estimation.tskf.tskf_tick` and :func:`~fcu.estimation.ekf.ekf_tick` of one
    tick, on the grouped samples ``flat`` (:attr:`~fcu.estimation.state.GroupedSamples.flat`).

    Parameters
    ----------
    flat : ndarray
        The tick's grouped samples.
    u, time_s, reject
        PWM held since the previous tick (4,), tick time (s), whether a lone outlier may be
        rejected: both filters'.
    out : ndarray, shape (e_size + t_size + 4,)
        Written: the EKF's tick output (its estimate and screening, ``e_size`` entries), the
        TSKF's (``t_size``), then the TSKF's new ``gamma_hat``.
    e_size, t_size : int
        Each filter's :attr:`~fcu.estimation.estimator.ChannelSet.tick_size`.
    t_work, t_scratch, t_model, t_tables, t_layout, n_steps, t_on_ground, accel_power
        :func:`~fcu.estimation.tskf.tskf_tick`'s, ``t_gamma`` its ``gamma_hat`` before the
        tick (read only).
    e_work, e_s_stack, e_scratch, e_constants, e_tables, e_layout, dt, e_on_ground
        :func:`~fcu.estimation.ekf.ekf_tick`'s.
    t_gather, e_gather : ndarrays of int
        Each filter's measurement table in ``flat`` (:func:`gathered`).
    t_excluded, e_excluded : ndarrays of bool
        Each filter's excluded channels.

    Returns
    -------
    tuple
        :func:`~fcu.estimation.tskf.tskf_tick`'s result (ground flag, accelerometer
        power, update rows), then :func:`~fcu.estimation.ekf.ekf_tick`'s (ground flag, last
        channel updated).
    """
    # the arguments as views that hold no references: no reference counting in the tick
    flat, u, out, t_gamma = borrowed(flat), borrowed(u), borrowed(out), borrowed(t_gamma)
    t_work, t_scratch, t_model = borrowed(t_work), borrowed(t_scratch), borrowed(t_model)
    t_tables, t_layout, t_gather = borrowed(t_tables), borrowed(t_layout), borrowed(t_gather)
    t_excluded, e_work, e_s_stack = borrowed(t_excluded), borrowed(e_work), borrowed(e_s_stack)
    e_scratch, e_constants, e_tables = (borrowed(e_scratch), borrowed(e_constants),
                                        borrowed(e_tables))
    e_layout, e_gather, e_excluded = borrowed(e_layout), borrowed(e_gather), borrowed(e_excluded)
    gamma = out[e_size + t_size:]
    gamma[:] = t_gamma
    # each filter's measurement table, gathered into its scratch (which the tick leaves alone
    # there)
    n_t, n_e = t_gather.shape[0], e_gather.shape[0]
    t_meas = shaped(t_scratch[T_MEAS:T_MEAS + n_t * MEAS_WIDTH], (n_t, MEAS_WIDTH))
    e_meas = shaped(e_scratch[E_MEAS:E_MEAS + n_e * MEAS_WIDTH], (n_e, MEAS_WIDTH))
    gather_into(t_meas, flat, t_gather)
    gather_into(e_meas, flat, e_gather)
    t_on_ground, accel_power, m = tskf_tick(
        t_work, t_scratch, gamma, out[e_size:e_size + t_size], t_model, t_tables, t_layout,
        u, t_meas, t_excluded, n_steps, time_s, reject, t_on_ground, accel_power)
    e_on_ground, last = ekf_tick(
        e_work, e_s_stack, e_scratch, out[:e_size], e_constants, e_tables, e_layout, u,
        e_meas, e_excluded, dt, time_s, reject, e_on_ground)
    return t_on_ground, accel_power, m, e_on_ground, last


def step_pair(ekf: ExtendedKalmanEstimator, tskf: TwoStageKalmanFilter, time_s: float,
              pwm_applied: ArrayLike, grouped: GroupedSamples, *,
              excluded: Collection[str] = (), reject: bool = True) -> StateEstimate:
    """``tskf.advance_grouped(...)`` then ``ekf.step_grouped(...)`` with the same arguments
    (:meth:`fcu.estimation.estimator.TickEstimator.step_grouped`), in one compiled call
    (:func:`pair_tick`); returns the EKF's estimate. The samples must come grouped by
    :func:`fcu.estimation.state.group_samples`."""
    time_s = float(time_s)
    u = pwm_array(pwm_applied)
    # both checked before either filter moves
    n_steps = tskf._steps_to(time_s)
    dt = ekf._dt_to(time_s)
    e_cs, t_cs = ekf._set, tskf._set
    e_size, t_size = e_cs.tick_size, t_cs.tick_size
    # the estimates' own array (each a part), the screenings' and the new gamma_hat's
    out = np.empty(e_size + t_size + N_MOTORS)
    t_on_ground, accel_power, m, e_on_ground, last = pair_tick(
        grouped.flat, u, time_s, bool(reject), out, e_size, t_size,
        tskf._work, tskf._scratch, tskf.gamma_raw, tskf._model, t_cs.tables, t_cs.layout,
        t_cs.gather(grouped), t_cs.exclusion(excluded), n_steps, tskf.on_ground,
        tskf._accel_power,
        ekf._work, ekf._s_stack, ekf._scratch, ekf._constants, e_cs.tables, e_cs.layout,
        e_cs.gather(grouped), e_cs.exclusion(excluded), dt, ekf._on_ground)
    tskf_out = out[e_size:]
    tskf._kept(t_cs, tskf_out, out[-N_MOTORS:], t_on_ground, accel_power, m)
    tskf._ticked(time_s, tskf_out)
    ekf._kept(time_s, e_cs, out, e_on_ground, last)
    ekf._ticked(time_s, out)
    return ekf.estimate


__all__ = ["pair_tick", "step_pair"]
