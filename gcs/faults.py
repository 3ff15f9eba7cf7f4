"""Fault schedules: what to inject, and when, in the vehicle's simulated time.

A schedule is a list of :class:`FaultSpec`, each at ``at_s`` seconds of simulated time after
the mission start (the MISSION_START the ground station sent; the thesis's fault times are
measured from the start of the flight). Two kinds:

- motor loss of effectiveness (thesis eq. 4.10, ``u_f = (1 - loe) u``, motors numbered as
  in docs/design.md: 1 front, 2 back, 3 left, 4 right);
- any simulator parameter set to a value (``SIM_BARO_GLITCH``, ``SIM_BARO_DRIFT``,
  ``SIM_MASS_DROP``, ``SIM_WIND_SPD``...), for the faults the vehicle exposes that way.

Sources
-------
- :data:`TABLE_7_3`: the thesis's chapter-7 actuator faults (motor 3 20 % at 22 s, motor 1
  30 % at 38 s, motor 4 15 % at 48 s).
- TOML files (:func:`load_schedule`)::

      [[faults]]
      motor = 3          # 1..4
      loe = 0.20         # 0..1
      at_s = 22.0        # s after the mission start

      [[faults]]
      param = "SIM_BARO_GLITCH"
      value = 0.1
      at_s = 30.0

  The scenario files of ``sim/scenarios`` also load: their actuator faults ``{motor, kind =
  "loe", start_s, loe}`` are read as motor faults (``start_s`` for ``at_s``); other kinds are
  refused with a message naming the key.
- Flags (:func:`parse_fault_flag`): ``MOTOR:LOE@AT_S`` (``3:0.20@22``) and
  ``PARAM=VALUE@AT_S`` (``SIM_BARO_GLITCH=0.1@30``).
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flightdata import thesis

__all__ = [
    "TABLE_7_3",
    "FaultScheduleError",
    "FaultSpec",
    "load_schedule",
    "parse_fault_flag",
    "sorted_schedule",
]


class FaultScheduleError(ValueError):
    """A fault schedule that cannot be used; the message names the source and the key."""


@dataclass(frozen=True, kw_only=True)
class FaultSpec:
    """One injection.

    Attributes
    ----------
    at_s : float
        When, s of simulated time after the mission start (>= 0).
    motor : int or None
        Motor 1..4 for a loss of effectiveness; None for a parameter fault.
    loe : float
        Loss of effectiveness of ``motor``, 0 (healthy) .. 1 (no thrust).
    param : str or None
        Simulator parameter to set (parameter faults).
    value : float
        Value of ``param``.
    """

    at_s: float
    motor: int | None = None
    loe: float = 0.0
    param: str | None = None
    value: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.at_s) and self.at_s >= 0.0):
            raise FaultScheduleError(f"at_s = {self.at_s!r}: must be a finite time >= 0 s")
        if (self.motor is None) == (self.param is None):
            raise FaultScheduleError("a fault names either a motor (1..4) or a param")
        if self.motor is not None:
            if self.motor not in (1, 2, 3, 4):
                raise FaultScheduleError(f"motor = {self.motor!r}: must be 1, 2, 3 or 4")
            if not (math.isfinite(self.loe) and 0.0 <= self.loe <= 1.0):
                raise FaultScheduleError(f"loe = {self.loe!r}: must be within [0, 1]")
        if self.param is not None:
            if not (1 <= len(self.param) <= 16 and self.param.isascii()):
                raise FaultScheduleError(f"param = {self.param!r}: must be 1..16 ASCII "
                                         "characters")
            if not math.isfinite(self.value):
                raise FaultScheduleError(f"value = {self.value!r}: must be finite")

    def describe(self) -> str:
        """E.g. ``motor 3 loss of effectiveness 0.20`` or ``SIM_BARO_GLITCH = 0.1``."""
        if self.motor is not None:
            return f"motor {self.motor} loss of effectiveness {self.loe:.2f}"
        return f"{self.param} = {self.value:g}"


TABLE_7_3: tuple[FaultSpec, ...] = tuple(
    FaultSpec(motor=f.motor, loe=f.loe, at_s=f.start_s) for f in thesis.TABLE_7_3)
"""Thesis Table 7.3 (:data:`flightdata.thesis.TABLE_7_3`) as a schedule, in time order."""


def sorted_schedule(faults: list[FaultSpec] | tuple[FaultSpec, ...]) -> list[FaultSpec]:
    """The schedule in time order (stable for equal times)."""
    return sorted(faults, key=lambda f: f.at_s)


_MOTOR_FLAG = re.compile(r"^\s*([1-4])\s*:\s*([0-9.eE+-]+)\s*@\s*([0-9.eE+-]+)\s*$")
_PARAM_FLAG = re.compile(r"^\s*([A-Za-z0-9_]{1,16})\s*=\s*([0-9.eE+-]+)\s*@\s*([0-9.eE+-]+)\s*$")


def parse_fault_flag(text: str) -> FaultSpec:
    """A fault from a command-line flag: ``MOTOR:LOE@AT_S`` or ``PARAM=VALUE@AT_S``.

    Raises
    ------
    FaultScheduleError
        When the text matches neither form or a value is out of range.
    """
    try:
        m = _MOTOR_FLAG.match(text)
        if m:
            return FaultSpec(motor=int(m.group(1)), loe=float(m.group(2)),
                             at_s=float(m.group(3)))
        m = _PARAM_FLAG.match(text)
        if m:
            return FaultSpec(param=m.group(1).upper(), value=float(m.group(2)),
                             at_s=float(m.group(3)))
    except ValueError as err:
        raise FaultScheduleError(f"--fault {text!r}: {err}") from None
    raise FaultScheduleError(f"--fault {text!r}: expected MOTOR:LOE@AT_S (e.g. 3:0.20@22) or "
                             "PARAM=VALUE@AT_S (e.g. SIM_BARO_GLITCH=0.1@30)")


def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FaultScheduleError(f"{where} = {value!r}: must be a number")
    return float(value)


def _fault_from_table(source: str, index: int, table: Mapping[str, Any]) -> FaultSpec:
    where = f"{source}: faults[{index}]"
    if not isinstance(table, Mapping):
        raise FaultScheduleError(f"{where}: must be a table")
    data = dict(table)
    if data.get("type", "actuator") == "actuator":
        data.pop("type", None)
    else:
        raise FaultScheduleError(f"{where}.type = {data['type']!r}: only actuator faults "
                                 "(motor, loe) and param faults can be sent; set a sensor or "
                                 "structural fault through its SIM_* parameter (param, value)")
    if "start_s" in data and "at_s" not in data:
        data["at_s"] = data.pop("start_s")
    kind = data.pop("kind", "loe")
    if kind != "loe":
        raise FaultScheduleError(f"{where}.kind = {kind!r}: only 'loe' can be injected as a "
                                 "motor fault")
    allowed = {"at_s", "motor", "loe", "param", "value"}
    extra = sorted(set(data) - allowed)
    if extra:
        raise FaultScheduleError(f"{where}: unknown key {extra[0]} (allowed: "
                                 f"{', '.join(sorted(allowed))})")
    if "at_s" not in data:
        raise FaultScheduleError(f"{where}: needs at_s (s after the mission start)")
    try:
        if "param" in data:
            param = data["param"]
            if not isinstance(param, str):
                raise FaultScheduleError(f"{where}.param = {param!r}: must be a string")
            return FaultSpec(param=param.upper(), value=_number(f"{where}.value",
                                                                data.get("value")),
                             at_s=_number(f"{where}.at_s", data["at_s"]))
        motor = data.get("motor")
        if isinstance(motor, bool) or not isinstance(motor, int):
            raise FaultScheduleError(f"{where}.motor = {motor!r}: must be 1, 2, 3 or 4")
        return FaultSpec(motor=motor, loe=_number(f"{where}.loe", data.get("loe")),
                         at_s=_number(f"{where}.at_s", data["at_s"]))
    except FaultScheduleError as err:
        if str(err).startswith(source):
            raise
        raise FaultScheduleError(f"{where}: {err}") from None


def load_schedule(path: str | Path) -> list[FaultSpec]:
    """The ``[[faults]]`` of a TOML file (see the module docstring), in time order.

    Raises
    ------
    FaultScheduleError
        Missing file, bad TOML, unknown key, value out of range.
    """
    p = Path(path)
    if not p.is_file():
        raise FaultScheduleError(f"{p}: no such fault schedule file")
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise FaultScheduleError(f"{p}: not valid TOML: {err}") from None
    faults = data.get("faults", [])
    if not isinstance(faults, list):
        raise FaultScheduleError(f"{p}: faults must be an array of tables [[faults]]")
    return sorted_schedule([_fault_from_table(str(p), i, t) for i, t in enumerate(faults)])
