"""The axes a campaign sweeps: their names in campaign files, result columns and values.

Each line: the axis's key in a campaign file -> its result column (type): its values.

- ``seed`` -> ``seed`` (int): >= 0, seeds every random stream of the run;
- ``fault.kind`` -> ``fault_kind`` (str): ``"none"`` (no swept fault: a healthy run) or a
  kind of :data:`flightdata.vocabulary.FAULT_KINDS`;
- ``fault.motor`` -> ``fault_motor`` (int): 1..4, for actuator faults;
- ``fault.sensor`` -> ``fault_sensor`` (str): a sensor name, for sensor faults;
- ``fault.magnitude`` -> ``fault_magnitude`` (float): the loss of effectiveness 0..1
  (``loe``), the bias or the loss of accuracy (``bias``, ``loss_of_accuracy``, sensor unit
  and % of sigma), the drift rate (``drift``, sensor unit per s), the mass lost
  (``mass_loss``, kg); the other kinds have none;
- ``fault.start_s`` -> ``fault_start_s`` (float): s >= 0, when the swept fault starts;
- ``fault.profile`` -> ``fault_profile`` (str): the time profile of a loss of effectiveness;
- ``fault.opposite_after_s`` -> ``fault_opposite_after_s`` (float): s >= 0, the campaign's
  actuator fault again on the opposite motor that much later (0: both at once; the second
  of two rotors lost);
- ``wind`` -> ``wind`` (str): ``"indoor"`` (the scenarios' default air,
  :data:`sim.scenario.DEFAULT_WIND`) or a MIL-F-8785C intensity ``"none"``, ``"light"``,
  ``"moderate"``, ``"severe"`` (with the base scenario's mean wind); a base scenario's own
  ``[wind]`` with ``w20_m_s`` reads ``"custom"`` in the column;
- ``mean_wind_m_s`` -> ``mean_wind_m_s`` (float): m/s >= 0, the mean wind's speed
  (applied after ``wind``; on indoor air it adds a mean wind from the default direction
  with no turbulence);
- ``autopilot.attitude``, ``.estimator``, ``.dob``, ``.ftc``, ``.height_source`` ->
  ``attitude``, ``estimator``, ``dob``, ``ftc``, ``height_source`` (str): the names of
  :data:`flightdata.vocabulary.CONFIG_CHOICES`.

Every run's row carries every column above: the value flown, from the base scenario when the
campaign does not sweep it, None where it does not apply (the motor of a sensor fault).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from flightdata.config import finite
from flightdata.vocabulary import (
    ATTITUDE_LAWS,
    DISTURBANCE_OBSERVERS,
    ESTIMATORS,
    FAULT_KINDS,
    FTC_MODES,
    HEIGHT_SOURCES,
    LOE_PROFILES,
    MOTORS,
    SENSORS,
)
from sim.world.wind import W20_KT

NO_FAULT = "none"
"""``fault.kind`` of a run without the swept fault (a healthy reference run)."""

INDOOR_WIND = "indoor"
"""``wind`` of the scenarios' default air (:data:`sim.scenario.DEFAULT_WIND`)."""

WIND_LEVELS: tuple[str, ...] = (INDOOR_WIND, *W20_KT)
"""Values of the ``wind`` axis: the indoor default, then the MIL-F-8785C intensities."""


@dataclass(frozen=True)
class Axis:
    """One sweepable axis.

    Attributes
    ----------
    name : str
        Its key in a campaign file (``"fault.magnitude"``).
    column : str
        Its column in the results.
    kind : type
        ``int``, ``float`` or ``str``.
    choices : tuple or None
        The allowed values, None when any value of the type in ``low`` .. is allowed.
    low : float or None
        Least allowed value of a number axis (None: any).
    unit : str
        Unit of a number axis, for messages and figure labels ("" when none).
    """

    name: str
    column: str
    kind: type
    choices: tuple[Any, ...] | None = None
    low: float | None = None
    unit: str = ""

    def check(self, value: Any) -> str | None:
        """None when ``value`` is allowed on this axis, else what is allowed."""
        if self.kind is int:
            ok = isinstance(value, int) and not isinstance(value, bool)
            what = "an integer"
        elif self.kind is float:
            ok = finite(value)
            what = "a finite number"
        else:
            ok = isinstance(value, str)
            what = "a string"
        if ok and self.choices is not None and value not in self.choices:
            return "must be one of " + ", ".join(map(repr, self.choices))
        if ok and self.low is not None and value < self.low:
            return f"must be {what} >= {self.low:g}{' ' + self.unit if self.unit else ''}"
        if not ok:
            if self.choices is not None:
                return "must be one of " + ", ".join(map(repr, self.choices))
            bound = "" if self.low is None else f" >= {self.low:g}"
            return f"must be {what}{bound}{' ' + self.unit if self.unit else ''}"
        return None

    def coerce(self, value: Any) -> Any:
        """``value`` (already checked) in the axis's type: floats as float."""
        return float(value) if self.kind is float else value


_AXES = (
    Axis("seed", "seed", int, low=0),
    Axis("fault.kind", "fault_kind", str, (NO_FAULT, *FAULT_KINDS)),
    Axis("fault.motor", "fault_motor", int, MOTORS),
    Axis("fault.sensor", "fault_sensor", str, SENSORS),
    Axis("fault.magnitude", "fault_magnitude", float),
    Axis("fault.start_s", "fault_start_s", float, low=0.0, unit="s"),
    Axis("fault.profile", "fault_profile", str, LOE_PROFILES),
    Axis("fault.opposite_after_s", "fault_opposite_after_s", float, low=0.0, unit="s"),
    Axis("wind", "wind", str, WIND_LEVELS),
    Axis("mean_wind_m_s", "mean_wind_m_s", float, low=0.0, unit="m/s"),
    Axis("autopilot.attitude", "attitude", str, ATTITUDE_LAWS),
    Axis("autopilot.estimator", "estimator", str, ESTIMATORS),
    Axis("autopilot.dob", "dob", str, DISTURBANCE_OBSERVERS),
    Axis("autopilot.ftc", "ftc", str, FTC_MODES),
    Axis("autopilot.height_source", "height_source", str, HEIGHT_SOURCES),
)

AXES: Mapping[str, Axis] = MappingProxyType({a.name: a for a in _AXES})
"""Every axis by its campaign-file name, in column order."""

AXIS_COLUMNS: tuple[str, ...] = tuple(a.column for a in _AXES)
"""The result columns of the axes, in order."""

COLUMN_AXES: Mapping[str, Axis] = MappingProxyType({a.column: a for a in _AXES})
"""Every axis by its result column."""

AUTOPILOT_AXES: tuple[str, ...] = tuple(a.name for a in _AXES if a.name.startswith("autopilot."))
"""The axes of the autopilot's configuration (``autopilot.<key>``)."""

FAULT_AXES: tuple[str, ...] = tuple(a.name for a in _AXES if a.name.startswith("fault."))
"""The axes of the swept fault (``fault.<what>``)."""
