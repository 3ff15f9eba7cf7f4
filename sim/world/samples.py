"""Sensor samples as the world hands them out: one object per reading, or one batch of arrays.

:meth:`sim.world.World.step` returns a :class:`SampleBatch`: the readings of the call in one
structured array (:data:`SAMPLE_RECORD`), in the order they were taken (by plant step, then in
:data:`sim.world.fault_types.SENSOR_NAMES` order), then the power module's readings of the call
(:mod:`sim.world.battery`). It is a sequence of :class:`SensorSample`
objects made on demand, so anything that iterates over samples and reads ``.sensor``,
``.time_s`` and ``.value`` (the autopilot's ``fcu.hal.SensorSampleLike``) works unchanged;
code that wants no object per sample reads :attr:`SampleBatch.sensor_index` (into
:attr:`SampleBatch.sensor_names`), :attr:`SampleBatch.time_s` and :attr:`SampleBatch.values`
(the first :attr:`SampleBatch.sensor_axes` entries of a row) instead, as the autopilot's
``fcu.hal.SensorSampleArrays`` does.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import overload

import numpy as np

from flightdata.vocabulary import BATTERY_SENSOR
from sim.world.fault_types import SENSOR_AXES, SENSOR_NAMES

SAMPLE_RECORD = np.dtype([
    ("sensor", np.int64),  # -, index into SAMPLE_NAMES
    ("time_s", np.float64),  # s, simulated time of the reading
    ("value", np.float64, (3,)),  # sensor unit; the first SENSOR_AXES[sensor] elements count
], align=True)
"""One reading in a :class:`SampleBatch`; a barometer reading leaves ``value[1:]`` at 0, a
power-module reading ``value[2]``."""

SAMPLE_NAMES: tuple[str, ...] = (*SENSOR_NAMES, BATTERY_SENSOR)
"""What a record's ``sensor`` indexes: the world's sensors in their fixed order, then the
power module (voltage V, current A) at index ``len(SENSOR_NAMES)``."""
_AXES = (*(SENSOR_AXES[name] for name in SENSOR_NAMES), 2)


@dataclass(frozen=True, slots=True)
class SensorSample:
    """One timestamped sensor reading (matches fcu.hal.SensorSampleLike)."""

    sensor: str  # -, one of SAMPLE_NAMES
    time_s: float  # s, simulated time of the reading
    value: np.ndarray  # sensor unit, layout in sim.world.sensors; treat as read-only


class SampleBatch(Sequence[SensorSample]):
    """The readings of one :meth:`sim.world.World.step` call (module docstring).

    Parameters
    ----------
    records : numpy.ndarray
        :data:`SAMPLE_RECORD` array, shape (n,); made read-only and kept (not copied).
    """

    __slots__ = ("records",)
    sensor_names: tuple[str, ...] = SAMPLE_NAMES
    """The names :attr:`sensor_index` indexes (for readers of the arrays)."""
    sensor_axes: tuple[int, ...] = _AXES
    """The entries of each of those sensors' values (the first of a row of :attr:`values`
    that count)."""

    def __init__(self, records: np.ndarray) -> None:
        if records.dtype != SAMPLE_RECORD or records.ndim != 1:
            raise ValueError(f"records: want a 1-D array of SAMPLE_RECORD, got "
                             f"{records.dtype} with shape {records.shape}")
        records.flags.writeable = False
        self.records = records

    @classmethod
    def wrap(cls, records: np.ndarray) -> SampleBatch:
        """A batch of ``records`` as they are (unchecked, not made read-only): for the world,
        which hands out read-only views of its sample buffer."""
        batch = cls.__new__(cls)
        batch.records = records
        return batch

    @classmethod
    def from_samples(cls, samples: Sequence[SensorSample]) -> SampleBatch:
        """A batch holding ``samples`` (objects with a known sensor name, any order)."""
        records = np.zeros(len(samples), dtype=SAMPLE_RECORD)
        for j, sample in enumerate(samples):
            value = np.asarray(sample.value, dtype=np.float64).reshape(-1)
            records[j]["sensor"] = SAMPLE_NAMES.index(sample.sensor)
            records[j]["time_s"] = sample.time_s
            records[j]["value"][:value.shape[0]] = value
        return cls(records)

    # ---- arrays, no objects --------------------------------------------------------------
    @property
    def sensor_index(self) -> np.ndarray:
        """Index into ``SAMPLE_NAMES`` of each reading, int64, shape (n,)."""
        return self.records["sensor"]

    @property
    def time_s(self) -> np.ndarray:
        """Simulated time of each reading, s, float64, shape (n,)."""
        return self.records["time_s"]

    @property
    def values(self) -> np.ndarray:
        """Readings, sensor unit, float64, shape (n, 3); a barometer uses column 0 only, the
        power module columns 0 and 1."""
        return self.records["value"]

    # ---- the sequence of SensorSample ----------------------------------------------------
    def __len__(self) -> int:
        return self.records.shape[0]

    @overload
    def __getitem__(self, index: int) -> SensorSample: ...

    @overload
    def __getitem__(self, index: slice) -> SampleBatch: ...

    def __getitem__(self, index: int | slice) -> SensorSample | SampleBatch:
        if isinstance(index, slice):
            return SampleBatch(self.records[index])
        rec = self.records[index]
        i = int(rec["sensor"])
        return SensorSample(SAMPLE_NAMES[i], float(rec["time_s"]), rec["value"][:_AXES[i]])

    def __iter__(self) -> Iterator[SensorSample]:
        values = self.records["value"]
        names, axes = SAMPLE_NAMES, _AXES
        times = self.records["time_s"].tolist()
        for j, i in enumerate(self.records["sensor"].tolist()):
            yield SensorSample(names[i], times[j], values[j, :axes[i]])

    def __repr__(self) -> str:
        return f"SampleBatch({len(self)} samples)"


__all__ = ["SAMPLE_NAMES", "SAMPLE_RECORD", "SampleBatch", "SensorSample"]
