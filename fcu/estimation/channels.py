"""The measurement channels both state estimators share, and their tables for the compiled
tick.

A :class:`Channel` is one measurement kind, linear in the state at its sample time,
``y = S x`` (state layout of :mod:`fcu.estimation.state`), with its noise and its NIS gate
(the chi-square quantile at :data:`GATE_PROBABILITY`). :func:`common_channels` lists those
both estimators use (see :mod:`fcu.estimation.estimator`); a :class:`ChannelSet` stacks one
height source's channels into the arrays the compiled tick kernels take
(:mod:`fcu.estimation.screening`, :mod:`fcu.estimation.pair`: offsets ``I_*`` of
:meth:`ChannelSet.kernel_ints`) and gathers a tick's measurement table from the grouped
samples.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

import numpy as np

from fcu.estimation.chi_square import chi_square_isf
from fcu.estimation.screening import COUNT, MEAS_WIDTH, TIME, VALUE
from fcu.estimation.state import (
    STATE_DIM,
    THRUST,
    Z_INDEX,
    FloatArray,
    GroupedSamples,
    SampleBatch,
)
from fcu.model import VehicleModel

__all__ = [
    "GATE_PROBABILITY",
    "I_LAYOUT",
    "I_LAYOUT_COLS",
    "I_N_CH",
    "I_TABLES_AT",
    "I_TABLES_SIZE",
    "Channel",
    "ChannelSet",
    "common_channels",
    "selection",
]

GATE_PROBABILITY = 1e-9
"""Probability that a consistent measurement exceeds its NIS gate (about 6 sigma)."""


def selection(columns: tuple[int, ...], sign: float = 1.0) -> FloatArray:
    """Selection matrix ``S`` picking ``columns`` of the state (times ``sign``), (m, 16)."""
    sel = np.zeros((len(columns), STATE_DIM))
    sel[np.arange(len(columns)), list(columns)] = sign
    return sel


class Channel:
    """One measurement kind: ``y = S x`` at its sample time, from entries of a sample value.

    Parameters
    ----------
    sensor : str
        Sensor name (:data:`flightdata.vocabulary.SENSORS`).
    selection : ndarray, shape (m, 16)
        ``S``.
    value_index : tuple of int
        The (consecutive) entries of the sample value measured.
    sigma : float
        Noise of one sample, sensor units (``R = sigma^2 / n`` for a mean of n).
    model_sigma : float
        Model error of the measurement, sensor units (added to ``R``, not reduced by
        averaging).
    """

    def __init__(self, sensor: str, selection: FloatArray, value_index: tuple[int, ...],
                 sigma: float, model_sigma: float = 0.0) -> None:
        self.sensor = sensor
        self.sample_var = float(sigma) ** 2  # per sample, divided by n for a mean of n
        self.model_var = float(model_sigma) ** 2  # not reduced by averaging
        self.selection = np.ascontiguousarray(selection, dtype=float)  # S, shape (m, 16)
        self.value_index = np.array(value_index)  # entries of the sample value used
        if list(value_index) != list(range(value_index[0], value_index[-1] + 1)):
            raise ValueError(f"value_index = {value_index!r}: must be consecutive")
        self.value_slice = slice(value_index[0], value_index[-1] + 1)  # the same, as a slice
        self.rows = self.selection.shape[0]  # m
        self.wrap_yaw = sensor == "mocap_att"  # innovation's third entry is a yaw difference
        # each row of S picks one state entry (times +-1): S x and S A are those entries
        self.picks = bool(np.all(np.sum(self.selection != 0.0, axis=1) == 1)
                          and np.all(np.abs(self.selection[self.selection != 0.0]) == 1.0))
        # NIS gate: chi-square quantile of m degrees of freedom at GATE_PROBABILITY
        self.gate = chi_square_isf(GATE_PROBABILITY, self.rows)


def common_channels(height_source: str, model: VehicleModel, accel_model_sigma: float | None
                    ) -> list[tuple[str, FloatArray, tuple[int, ...], float]]:
    """(sensor, ``S``, value entries, model error) of the measurements both estimators use,
    in update order (:mod:`fcu.estimation.estimator`'s docstring); the accelerometer with its
    model error ``accel_model_sigma`` (m/s^2), or not at all when None."""
    channels: list[tuple[str, FloatArray, tuple[int, ...], float]] = []
    if height_source == "baro":
        channels.append(("mocap_pos", selection((0, 1)), (0, 1), 0.0))
        channels.append(("baro", selection((Z_INDEX,), -1.0), (0,), 0.0))  # alt = -z
    else:
        channels.append(("mocap_pos", selection((0, 1, 2)), (0, 1, 2), 0.0))
    channels.append(("mocap_att", selection((6, 7, 8)), (0, 1, 2), 0.0))
    channels.append(("gyro", selection((9, 10, 11)), (0, 1, 2), 0.0))
    if accel_model_sigma is not None:
        # body-z specific force f_z = -(T1 + T2 + T3 + T4)/m (thrust along -z_body)
        accel = np.zeros((1, STATE_DIM))
        accel[0, THRUST] = -1.0 / model.mass
        channels.append(("accel", accel, (2,), accel_model_sigma))
    return channels


# A channel set's integer tables for one slot layout of the grouped samples, packed into one
# int64 array (ChannelSet.kernel_ints) at these offsets, for a compiled call that takes the
# filter's floats as one array too (fcu.estimation.pair)
I_TABLES_AT = 0  # where tables starts in the filter's float buffer (ChannelSet.tables_at)
I_TABLES_SIZE = 1  # its entries
I_N_CH = 2  # channels
I_LAYOUT_COLS = 3  # columns of layout
I_LAYOUT = 4  # then layout (n_ch x cols), the gather index (n_ch x MEAS_WIDTH) and the
# exclusions (n_ch, written by the kernel each tick)


class ChannelSet:
    """One height source's channels, stacked for the compiled tick of an estimator.

    Attributes
    ----------
    channels : tuple of Channel
        In update order.
    sensors : tuple of str
        Their sensor names.
    sel_stack : ndarray, shape (rows_total, 16)
        Every channel's ``S``, stacked in update order.
    layout : ndarray of int, shape (n_ch, 5)
        Per channel: first and end row in ``sel_stack``, yaw in the third entry (its
        innovation is wrapped), the accelerometer, each row of ``S`` a single entry of +-1
        (:func:`select`) (columns ``ROW0``, ``ROW1``, ``WRAP_YAW``, ``IS_ACCEL``,
        ``PICKS``).
    noise : ndarray, shape (n_ch, 3)
        Per channel: noise variance of one sample (divided by the count), model error
        variance (not), NIS gate (columns ``SAMPLE_VAR``, ``MODEL_VAR``, ``GATE``).
    tables : ndarray
        ``sel_stack`` and ``noise`` packed into one array, as the tick kernels take them
        (:func:`~fcu.estimation.screening.channel_tables`).
    tick_size : int
        Entries of a tick's output (:meth:`TickEstimator._tick`).
    tables_at : int
        Where :attr:`tables` sits in its estimator's float buffer
        (:meth:`TickEstimator._packed_buffer`; -1 before).
    """

    def __init__(self, channels: tuple[Channel, ...]) -> None:
        self.channels = channels
        self.sensors = tuple(c.sensor for c in channels)
        self.sel_stack = np.ascontiguousarray(np.vstack([c.selection for c in channels]))
        ends = np.cumsum([c.rows for c in channels])
        self.layout = np.array([(end - c.rows, end, c.wrap_yaw, c.sensor == "accel",
                                 c.picks)
                                for c, end in zip(channels, ends.tolist(), strict=True)],
                               dtype=np.int64)
        self.noise = np.array([(c.sample_var, c.model_var, c.gate) for c in channels])
        # sel_stack and noise packed into one array for the tick kernels
        # (fcu.estimation.screening.channel_tables); a filter may append its own tables
        self.tables = np.concatenate((self.sel_stack.ravel(), self.noise.ravel()))
        # a tick's output (TickEstimator._tick): the estimate's state and covariance
        # diagonal, then the screening (screen_channels' table)
        self.tick_size = 2 * STATE_DIM + 2 * self.sel_stack.shape[0] + 2 * len(channels)
        self.rows_list: list[tuple[int, int]] = [(int(a), int(b)) for a, b in self.layout[:, :2]]
        self.n_rows = int(self.sel_stack.shape[0])
        # what a ChannelCheck takes of each channel: sensor, NIS gate, rows
        self.checks = [(c.sensor, c.gate, i0, i1)
                       for c, (i0, i1) in zip(channels, self.rows_list, strict=True)]
        # what _measurements reads of each sensor's batch value, and the padding after it
        self._reads = [(c.sensor, c.value_slice, [0.0] * (MEAS_WIDTH - VALUE - c.rows))
                       for c in channels]
        # (int64 as in the estimators' packed tables, fcu.estimation.pair: one specialisation
        # of the tick kernels serves both paths)
        self.no_exclusion = np.zeros(len(channels), dtype=np.int64)
        self._absent = [0.0] * MEAS_WIDTH
        self._gathers: dict[tuple[tuple[str, ...], int], np.ndarray] = {}
        self.tables_at = -1
        # kernel_ints' arrays by slot layout, and the latest one asked for
        self._ints: dict[tuple[tuple[str, ...], int], np.ndarray] = {}
        self._last_ints: tuple[tuple[str, ...], int, np.ndarray] = ((), -1, self.layout)

    def measurements(self, batches: Mapping[str, SampleBatch]) -> FloatArray:
        """The tick's measurement table, shape (n_ch, MEAS_WIDTH): per channel the count
        and mean time of its batch and the entries it measures (zeros without a batch).

        Batches grouped by :func:`~fcu.estimation.state.group_samples` are read straight
        from their table (one gather); other mappings batch by batch."""
        if isinstance(batches, GroupedSamples):
            return batches.flat[self.gather(batches)]
        flat: list[float] = []
        get = batches.get
        for sensor, value_slice, pad in self._reads:
            batch = get(sensor)
            if batch is None:
                flat += self._absent
                continue
            value = batch.value
            vals = (value.tolist() if type(value) is np.ndarray
                    else np.asarray(value, dtype=float).tolist())
            flat.append(batch.count)
            flat.append(batch.time_s)
            flat += vals[value_slice]
            flat += pad
        return np.array(flat, dtype=np.float64).reshape(len(self._reads), MEAS_WIDTH)

    def gather(self, grouped: GroupedSamples) -> np.ndarray:
        """Indices into ``grouped.flat`` giving :meth:`measurements`' table, int, shape
        (n_ch, MEAS_WIDTH) (made once per slot layout).

        The table's slots: mean value, mean time (w), count (w + 1); a slot without samples
        is all zeros there, as an absent batch reads; the spare zero after the table pads
        and stands for kinds without a slot."""
        key = (grouped.slot_names, grouped.width)
        gather = self._gathers.get(key)
        if gather is None:
            gather = self._gathers[key] = self._gather_index(*key)
        return gather

    def kernel_ints(self, grouped: GroupedSamples) -> np.ndarray:
        """The integer tables for a compiled tick on ``grouped`` (offsets ``I_*``): where
        :attr:`tables` sits in the estimator's float buffer, :attr:`layout`, :meth:`gather`'s
        index and room for the tick's exclusions (made once per slot layout; the slot names
        of a flight's ticks are one tuple, compared by identity first)."""
        names, width, ints = self._last_ints
        if grouped.slot_names is not names or grouped.width != width:
            key = (grouped.slot_names, grouped.width)
            made = self._ints.get(key)
            if made is None:
                assert self.tables_at >= 0, "the tables are not in a buffer"
                n_ch, cols = self.layout.shape
                made = self._ints[key] = np.concatenate((
                    [self.tables_at, self.tables.size, n_ch, cols], self.layout.ravel(),
                    self.gather(grouped).ravel(), np.zeros(n_ch))).astype(np.int64)
            ints = made
            self._last_ints = (grouped.slot_names, grouped.width, ints)
        return ints

    def exclusion_bits(self, excluded: Collection[str]) -> int:
        """:meth:`exclusion` as bits, channel ``c`` the bit ``1 << c``."""
        bits = 0
        for c, sensor in enumerate(self.sensors):
            if sensor in excluded:
                bits |= 1 << c
        return bits

    def _gather_index(self, slot_names: tuple[str, ...], width: int) -> np.ndarray:
        """Indices into :attr:`GroupedSamples.flat` (a flattened table and one spare zero,
        which the padding and absent batches read) giving :meth:`measurements`' table."""
        zero = len(slot_names) * width
        w = width - 3
        index = np.full((len(self._reads), MEAS_WIDTH), zero, dtype=np.int64)
        for c, (sensor, value_slice, _) in enumerate(self._reads):
            if sensor not in slot_names:
                continue
            row = slot_names.index(sensor) * width
            index[c, COUNT] = row + w + 1
            index[c, TIME] = row + w
            entries = range(value_slice.start, value_slice.stop)
            index[c, VALUE:VALUE + len(entries)] = [row + i for i in entries]
        return index

    def exclusion(self, excluded: Collection[str]) -> np.ndarray:
        """Which channels are ``excluded``: 1 (excluded) or 0, int64, shape (n_ch,)."""
        if not excluded:
            return self.no_exclusion
        return np.array([s in excluded for s in self.sensors], dtype=np.int64)
