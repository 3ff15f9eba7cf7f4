"""The autopilot's hardware layer: what it receives from sensors and sends to motors.

The autopilot sees the world only through sensor samples. Any object with the three
attributes of :class:`SensorSample` is accepted (the simulator's own sample type is one), so
the autopilot never imports the simulator.

Sensor names (:data:`flightdata.vocabulary.SENSORS`) and value layouts (docs/design.md):

=============  ====================================  =======
sensor         value                                 unit
=============  ====================================  =======
``gyro``       body rates p, q, r (FRD)              rad/s
``accel``      specific force (FRD)                  m/s^2
``mocap_pos``  position (NED, home origin)           m
``mocap_att``  roll, pitch, yaw (ZYX Euler)          rad
``baro``       altitude above home (up positive)     m
``battery``    terminal voltage, current drawn       V, A
=============  ====================================  =======

(``battery`` is the power module's, read by the battery monitor only; it is not among
:data:`flightdata.vocabulary.SENSORS`, the sensors the estimators and faults know.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class SensorSampleLike(Protocol):
    """Structural type of one sensor sample (read-only attributes)."""

    @property
    def sensor(self) -> str: ...

    @property
    def time_s(self) -> float: ...

    @property
    def value(self) -> np.ndarray: ...


class SensorSampleArrays(Protocol):
    """Structural type of a tick's samples held as arrays rather than one object each (the
    simulator's sample batch is one, the power module's ``battery`` readings among them);
    :func:`fcu.estimation.state.group_samples` reads them without an object per sample and
    averages them per kind into one table
    (:class:`fcu.estimation.state.GroupedSamples`)."""

    sensor_names: tuple[str, ...]  # the sensor names sensor_index indexes
    sensor_axes: tuple[int, ...]  # entries of each of those sensors' values

    @property
    def sensor_index(self) -> np.ndarray:
        """Index into ``sensor_names`` of each sample, int, shape (n,)."""
        ...

    @property
    def time_s(self) -> np.ndarray:
        """Simulated time of each sample, s, shape (n,)."""
        ...

    @property
    def values(self) -> np.ndarray:
        """Sample values, shape (n, w); the first ``sensor_axes[sensor_index[j]]`` entries of
        row j count."""
        ...


@dataclass(frozen=True, slots=True)
class SensorSample:
    """One timestamped sensor reading (simulated time, seconds)."""

    sensor: str
    time_s: float
    value: np.ndarray
