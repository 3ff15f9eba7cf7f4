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


@dataclass(frozen=True, slots=True)
class SensorSample:
    """One timestamped sensor reading (simulated time, seconds)."""

    sensor: str
    time_s: float
    value: np.ndarray
