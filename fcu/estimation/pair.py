"""The EKF and the TSKF stepped together, in one compiled call per tick.

The autopilot flying the EKF runs a TSKF beside it for the per-motor effectiveness
(:mod:`fcu.autopilot`). Both take the same tick's averaged samples
(:func:`fcu.estimation.state.group_samples`), PWM, exclusions and rejection flag; :func:`step_pair`
gives each its measurement table from the grouped samples and runs both tick kernels
(:func:`fcu.estimation.tskf_kernel.tskf_tick`, then :func:`fcu.estimation.ekf.ekf_tick`) in one
call, the same arithmetic as :meth:`TwoStageKalmanFilter.advance_grouped` followed by
:meth:`ExtendedKalmanEstimator.step_grouped`, which ``tests/fcu/estimation/test_pair.py`` pins
bit for bit.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

import fcu.floats
from fcu.estimation.channels import I_LAYOUT, I_LAYOUT_COLS, I_N_CH, I_TABLES_AT, I_TABLES_SIZE
from fcu.estimation.ekf import SC_MEAS as E_MEAS
from fcu.estimation.ekf import ExtendedKalmanEstimator, ekf_tick
from fcu.estimation.ekf import buffer_views as ekf_buffer_views
from fcu.estimation.estimator import pwm_array
from fcu.estimation.screening import MEAS_WIDTH, ROW1
from fcu.estimation.state import STATE_DIM, FloatArray, GroupedSamples, StateEstimate
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.estimation.tskf_kernel import SC_MEAS as T_MEAS
from fcu.estimation.tskf_kernel import buffer_views as tskf_buffer_views
from fcu.estimation.tskf_kernel import tskf_tick
from fcu.estimation.tskf_model import N_MOTORS
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.views import borrowed, carve, refcount_free_kernel, shaped

# pair_tick compiles in the kernels of ekf, tskf and the modules they call
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)


@refcount_free_kernel
def gather_into(meas: FloatArray, flat: FloatArray, gather: np.ndarray) -> None:
    """A filter's measurement table from grouped samples, ``flat[gather]``
    (:meth:`fcu.estimation.channels.ChannelSet.gather`), written into ``meas``
    (n_ch, MEAS_WIDTH)."""
    for c in range(gather.shape[0]):
        for k in range(MEAS_WIDTH):
            meas[c, k] = flat[gather[c, k]]


@njit(cache=True, error_model="numpy", inline="always")
def channel_views(buf: FloatArray, ints: np.ndarray, excluded_bits: int
                  ) -> tuple[FloatArray, np.ndarray, np.ndarray, np.ndarray, int]:
    """A filter's channel tables for a tick: ``tables`` (a view of its float buffer ``buf``),
    ``layout``, the gather index and the exclusions (views of ``ints``,
    :meth:`~fcu.estimation.channels.ChannelSet.kernel_ints`, offsets ``I_*``), the last
    written from ``excluded_bits`` (channel ``c`` excluded: bit ``1 << c``), and the tick
    output's size (:attr:`~fcu.estimation.channels.ChannelSet.tick_size`)."""
    n_ch, cols = ints[I_N_CH], ints[I_LAYOUT_COLS]
    at = ints[I_TABLES_AT]
    tables = buf[at:at + ints[I_TABLES_SIZE]]
    layout, o = carve(ints, I_LAYOUT, (n_ch, cols))
    gather, o = carve(ints, o, (n_ch, MEAS_WIDTH))
    excluded = ints[o:o + n_ch]
    for c in range(n_ch):
        excluded[c] = (excluded_bits >> c) & 1
    # the estimate's state and covariance diagonal, then the screening (2 rows + 2 n_ch)
    tick_size = 2 * STATE_DIM + 2 * layout[n_ch - 1, ROW1] + 2 * n_ch
    return tables, layout, gather, excluded, tick_size


# inlined into its one compiled caller (fcu.monitoring.watched_pair.pair_watch_tick): a
# library of its own made LLVM optimise both filters' ticks once more (3.7 s of LLVM time in
# a cold build by numba's llvm_lock events); called from Python (step_pair), it compiles as
# a kernel of its own
@njit(cache=True, error_model="numpy", inline="always",  # type: ignore[call-overload]
      _nrt=False)
def pair_tick(flat: FloatArray, u: FloatArray, time_s: float, reject: bool, out: FloatArray,
              t_buf: FloatArray, t_ints: np.ndarray, t_excluded: int, t_gamma: FloatArray,
              n_steps: int, t_on_ground: bool, accel_power: float, e_buf: FloatArray,
              e_ints: np.ndarray, e_excluded: int, dt: float, e_on_ground: bool
              ) -> tuple[bool, float, int, bool, int]:
    """:func:`~fcu.estimation.tskf_kernel.tskf_tick` and :func:`~fcu.estimation.ekf.ekf_tick` of one
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
        TSKF's (``t_size``), then the TSKF's new ``gamma_hat`` (each filter's size:
        :attr:`~fcu.estimation.channels.ChannelSet.tick_size`).
    t_buf, e_buf : ndarrays
        Each filter's float buffer: its workspace, scratch, model or constants (and the
        EKF's ``s_stack``) at the offsets ``B_*`` of :mod:`~fcu.estimation.tskf` and
        :mod:`~fcu.estimation.ekf`, then the channel tables.
    t_ints, e_ints : ndarrays of int
        The current channels' integer tables for this slot layout
        (:meth:`~fcu.estimation.channels.ChannelSet.kernel_ints`).
    t_excluded, e_excluded : int
        Each filter's excluded channels, as bits (:func:`channel_views`).
    t_gamma : ndarray, shape (4,)
        The TSKF's ``gamma_hat`` before the tick (read only).
    n_steps, t_on_ground, accel_power
        :func:`~fcu.estimation.tskf_kernel.tskf_tick`'s.
    dt, e_on_ground
        :func:`~fcu.estimation.ekf.ekf_tick`'s.

    Returns
    -------
    tuple
        :func:`~fcu.estimation.tskf_kernel.tskf_tick`'s result (ground flag, accelerometer
        power, update rows), then :func:`~fcu.estimation.ekf.ekf_tick`'s (ground flag, last
        channel updated).
    """
    # the arguments as views that hold no references: no reference counting in the tick
    flat, u, out, t_gamma = borrowed(flat), borrowed(u), borrowed(out), borrowed(t_gamma)
    t_buf, t_ints, e_buf, e_ints = borrowed(t_buf), borrowed(t_ints), borrowed(e_buf), \
        borrowed(e_ints)
    t_work, t_scratch, t_model = tskf_buffer_views(t_buf)
    t_tables, t_layout, t_gather, t_excl, t_size = channel_views(t_buf, t_ints, t_excluded)
    e_work, e_s_stack, e_scratch, e_constants = ekf_buffer_views(e_buf)
    e_tables, e_layout, e_gather, e_excl, e_size = channel_views(e_buf, e_ints, e_excluded)
    gamma = out[e_size + t_size:]
    for g in range(N_MOTORS):
        gamma[g] = t_gamma[g]
    # each filter's measurement table, gathered into its scratch (which the tick leaves alone
    # there)
    n_t, n_e = t_gather.shape[0], e_gather.shape[0]
    t_meas = shaped(t_scratch[T_MEAS:T_MEAS + n_t * MEAS_WIDTH], (n_t, MEAS_WIDTH))
    e_meas = shaped(e_scratch[E_MEAS:E_MEAS + n_e * MEAS_WIDTH], (n_e, MEAS_WIDTH))
    gather_into(t_meas, flat, t_gather)
    gather_into(e_meas, flat, e_gather)
    t_on_ground, accel_power, m = tskf_tick(
        t_work, t_scratch, gamma, out[e_size:e_size + t_size], t_model, t_tables, t_layout,
        u, t_meas, t_excl, n_steps, time_s, reject, t_on_ground, accel_power)
    e_on_ground, last = ekf_tick(
        e_work, e_s_stack, e_scratch, out[:e_size], e_constants, e_tables, e_layout, u,
        e_meas, e_excl, dt, time_s, reject, e_on_ground)
    return t_on_ground, accel_power, m, e_on_ground, last


def step_pair(ekf: ExtendedKalmanEstimator, tskf: TwoStageKalmanFilter, time_s: float,
              pwm_applied: ArrayLike, grouped: GroupedSamples, *,
              excluded: Collection[str] = (), reject: bool = True) -> StateEstimate:
    """``tskf.advance_grouped(...)`` then ``ekf.step_grouped(...)`` with the same arguments
    (:meth:`fcu.estimation.estimator.TickEstimator.step_grouped`), in one compiled call
    (:func:`pair_tick`); returns the EKF's estimate. The samples must come grouped by
    :func:`fcu.estimation.state.group_samples`."""
    time_s = float(time_s)
    arguments = pair_arguments(ekf, tskf, time_s, pwm_applied, grouped, excluded, reject)
    return pair_kept(ekf, tskf, time_s, arguments[4], pair_tick(*arguments))


def pair_arguments(ekf: ExtendedKalmanEstimator, tskf: TwoStageKalmanFilter, time_s: float,
                   pwm_applied: ArrayLike, grouped: GroupedSamples,
                   excluded: Collection[str], reject: bool) -> tuple[Any, ...]:
    """:func:`pair_tick`'s arguments for :func:`step_pair`'s (``time_s`` a float); both
    filters are checked (ValueError) before either moves. The fifth is the tick's output
    array, fresh."""
    u = pwm_array(pwm_applied)
    t_inputs = tskf.pair_inputs(time_s, grouped, excluded)  # checks the time first
    e_inputs = ekf.pair_inputs(time_s, grouped, excluded)
    # the estimates' own array (each a part), the screenings' and the new gamma_hat's
    out = np.empty(ekf.channel_set.tick_size + tskf.channel_set.tick_size + N_MOTORS)
    return (grouped.flat, u, time_s, bool(reject), out, *t_inputs, *e_inputs)


def pair_kept(ekf: ExtendedKalmanEstimator, tskf: TwoStageKalmanFilter, time_s: float,
              out: FloatArray, result: tuple[bool, float, int, bool, int]) -> StateEstimate:
    """What :func:`pair_tick` at ``time_s`` (s) returned (``result``) and wrote into ``out``,
    kept by each filter; returns the EKF's estimate."""
    t_on_ground, accel_power, m, e_on_ground, last = result
    e_size = ekf.channel_set.tick_size
    tskf.keep_pair_tick(time_s, out[e_size:], out[-N_MOTORS:], t_on_ground, accel_power, m)
    ekf.keep_pair_tick(time_s, out, e_on_ground, last)
    return ekf.estimate


__all__ = ["pair_arguments", "pair_kept", "pair_tick", "step_pair"]
