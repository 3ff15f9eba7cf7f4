"""Parameter table and the MAVLink parameter protocol (PARAM_REQUEST_LIST/READ, PARAM_SET).

Encoding, as ArduPilot's: PARAM_VALUE.param_type is the parameter's type (:func:`wire_type`:
REAL32 for a float parameter; for a whole-number one, ``ParamSpec.integer``, the smallest of
INT8, INT16 and INT32 that holds its range, as ArduPilot declares each parameter AP_Int8,
AP_Int16 or AP_Int32) and param_value carries the value cast to float (C_CAST: the float
*is* the value, also for integers; AUTOPILOT_VERSION advertises PARAM_ENCODE_C_CAST, and
MAVSDK decodes an ArduPilot vehicle's parameters this way, so ``get_param_int`` works on the
integer ones). Values are stored rounded to float32 so that what a ground station reads back
is exactly what the vehicle holds.

PARAM_SET's param_type is ignored, as ArduPilot ignores it: the float value is taken as the
value whatever type the sender named (pymavlink tools send REAL32 for everything, MAVSDK the
type it read), then validated; the echo carries the parameter's own type. A sender that
insists on a type (MAVSDK's ``set_param_float`` on an integer parameter) sees its own type
mismatch and gives up, as it does against ArduPilot.

Indices are the position in the name-sorted table: contiguous 0..count-1 and stable for the
lifetime of the endpoint. A PARAM_SET is validated (known name, finite, whole number where
required, inclusive range, allowed set, then the owner's own check) and always answered with
a PARAM_VALUE carrying the value now in force; a refusal also sends a STATUSTEXT saying why.
A PARAM_SET or PARAM_REQUEST_READ naming an unknown parameter (or an index out of range) gets
no PARAM_VALUE, as from ArduPilot, so the client times out with its own error. The
STATUSTEXTs of the parameter protocol (an unknown name, a refused value) are said once: the
same text again within :data:`REPEAT_QUIET_S` of wall time is not repeated (a client retrying,
as MAVSDK does six times, must not flood the pilot's messages; a refused PARAM_SET is still
echoed each time with the value in force).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from fcu.mavlink.enums import Severity
from fcu.mavlink.port import ParamProvider
from fcu.mavlink.port_records import CommandResult, ParamSpec
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2
from fcu.mavlink.transport.link import Address, Outbox

__all__ = ["REPEAT_QUIET_S", "ParamEntry", "ParamService", "ParamSetOutcome", "ParamTable",
           "entries_from", "wire_type"]

OnChange = Callable[[float], CommandResult]
REPEAT_QUIET_S = 30.0  # s wall, least time between two identical parameter STATUSTEXTs
_SAID_MEMORY = 64  # texts remembered for the rate limit (oldest forgotten first)
_INT_TYPES = ((mavlink2.MAV_PARAM_TYPE_INT8, -2**7, 2**7 - 1),
              (mavlink2.MAV_PARAM_TYPE_INT16, -2**15, 2**15 - 1),
              (mavlink2.MAV_PARAM_TYPE_INT32, -2**31, 2**31 - 1))


def to_float32(value: float) -> float:
    """``value`` rounded to the nearest float32 (what REAL32 can carry)."""
    return float(np.float32(value))


def _int_bounds(spec: ParamSpec) -> tuple[float, float]:
    """Smallest and largest value an integer parameter can take."""
    if spec.allowed is not None:
        return min(spec.allowed), max(spec.allowed)
    return spec.min_value, spec.max_value


def wire_type(spec: ParamSpec) -> int:
    """MAV_PARAM_TYPE of ``spec`` on the wire (module docstring): REAL32 for a float
    parameter, the smallest of INT8/INT16/INT32 holding an integer parameter's range."""
    if not spec.integer:
        return int(mavlink2.MAV_PARAM_TYPE_REAL32)
    lo, hi = _int_bounds(spec)
    for param_type, type_lo, type_hi in _INT_TYPES:
        if type_lo <= lo and hi <= type_hi:
            return int(param_type)
    return int(mavlink2.MAV_PARAM_TYPE_INT32)  # the range is clipped to INT32 by check()


@dataclass(frozen=True, slots=True)
class ParamEntry:
    """A parameter definition plus who to tell when it changes.

    Attributes
    ----------
    spec : ParamSpec
        Name, initial value, limits, description.
    on_change : callable or None
        Called with an already validated new value; a refused CommandResult keeps the old
        value and its reason goes to the ground station.
    """

    spec: ParamSpec
    on_change: OnChange | None = None


@dataclass(frozen=True, slots=True)
class ParamSetOutcome:
    """Result of :meth:`ParamTable.set`: the value now in force, and why a change was refused."""

    accepted: bool
    value: float
    reason: str = ""


def entries_from(provider: ParamProvider) -> list[ParamEntry]:
    """Entries for every parameter of ``provider``, each applying changes through it."""

    def apply(name: str) -> OnChange:
        return lambda value: provider.set_param(name, value)

    return [ParamEntry(spec, apply(spec.name)) for spec in provider.param_specs()]


class ParamTable:
    """Name-sorted parameters with validated changes.

    Parameters
    ----------
    entries : iterable of ParamEntry
        Unique names.

    Raises
    ------
    ValueError
        On a duplicate name.
    """

    def __init__(self, entries: Iterable[ParamEntry]) -> None:
        by_name: dict[str, ParamEntry] = {}
        for entry in entries:
            if entry.spec.name in by_name:
                raise ValueError(f"parameter {entry.spec.name!r} defined twice")
            by_name[entry.spec.name] = entry
        self._entries = [by_name[name] for name in sorted(by_name)]
        self._index = {e.spec.name: i for i, e in enumerate(self._entries)}
        self._values = [to_float32(e.spec.value) for e in self._entries]

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    @property
    def names(self) -> list[str]:
        """Names in index order."""
        return [e.spec.name for e in self._entries]

    def index_of(self, name: str) -> int | None:
        """Index of ``name``, or None when unknown."""
        return self._index.get(name)

    def spec_at(self, index: int) -> ParamSpec:
        """Definition of the parameter at ``index``."""
        return self._entries[index].spec

    def value_at(self, index: int) -> float:
        """Current value of the parameter at ``index``."""
        return self._values[index]

    def get(self, name: str) -> float:
        """Current value of ``name``.

        Raises
        ------
        KeyError
            When ``name`` is unknown.
        """
        return self._values[self._index[name]]

    def check(self, name: str, value: float) -> str:
        """Why ``value`` is not acceptable for ``name`` ("" when it is)."""
        index = self._index.get(name)
        if index is None:
            return f"unknown parameter {name}"
        spec = self._entries[index].spec
        if not math.isfinite(value):
            return f"{name}: {value} is not a finite number"
        value = to_float32(value)
        if spec.integer and value != round(value):
            return f"{name}: {value:g} is not a whole number"
        if spec.integer and not _INT_TYPES[-1][1] <= value <= _INT_TYPES[-1][2]:
            return f"{name}: {value:g} outside the INT32 range"
        if not spec.min_value <= value <= spec.max_value:
            return f"{name}: {value:g} outside {spec.min_value:g}..{spec.max_value:g}"
        if spec.allowed is not None and value not in {to_float32(a) for a in spec.allowed}:
            allowed = ", ".join(f"{a:g}" for a in spec.allowed)
            return f"{name}: {value:g} not one of {allowed}"
        return ""

    def set(self, name: str, value: float) -> ParamSetOutcome:
        """Validate and apply a change requested by a ground station.

        Returns
        -------
        ParamSetOutcome
            ``value`` is the value in force afterwards (the old one when refused).

        Raises
        ------
        KeyError
            When ``name`` is unknown.
        """
        index = self._index[name]
        current = self._values[index]
        reason = self.check(name, value)
        if reason:
            return ParamSetOutcome(False, current, reason)
        new = to_float32(value)
        if new == current:
            return ParamSetOutcome(True, current)
        on_change = self._entries[index].on_change
        if on_change is not None:
            result = on_change(new)
            if not result.accepted:
                return ParamSetOutcome(False, current,
                                       f"{name}: {result.reason or 'refused by the vehicle'}")
        self._values[index] = new
        return ParamSetOutcome(True, new)


def _decode_name(raw: object) -> str:
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", errors="replace")
    return str(raw).split("\x00", 1)[0]


class ParamService:
    """Answers the parameter messages of the MAVLink parameter protocol.

    Parameters
    ----------
    table : ParamTable
    outbox : Outbox
    wall_clock : callable, optional
        Monotonic wall-clock time, s (the rate limit of repeated STATUSTEXTs); without one,
        each text is said once.
    """

    def __init__(self, table: ParamTable, outbox: Outbox,
                 wall_clock: Callable[[], float] | None = None) -> None:
        self._table = table
        self._outbox = outbox
        self._wall_clock = wall_clock if wall_clock is not None else (lambda: 0.0)
        self._said: dict[str, float] = {}  # STATUSTEXT -> wall time it was last said

    @property
    def table(self) -> ParamTable:
        """The underlying table."""
        return self._table

    def value_message(self, index: int) -> MAVLinkMessage:
        """PARAM_VALUE for the parameter at ``index``."""
        name = self._table.spec_at(index).name
        return mavlink2.MAVLink_param_value_message(
            name.encode("ascii"), self._table.value_at(index),
            wire_type(self._table.spec_at(index)), len(self._table), index)

    def _say(self, text: str) -> None:
        """STATUSTEXT ``text``, unless the same text was said less than REPEAT_QUIET_S ago."""
        now = self._wall_clock()
        said = self._said.get(text)
        if said is not None and now - said < REPEAT_QUIET_S:
            return
        self._said.pop(text, None)
        self._said[text] = now
        while len(self._said) > _SAID_MEMORY:
            del self._said[next(iter(self._said))]
        self._outbox.status(Severity.WARNING, text)

    def handle_request_list(self, to: Address) -> None:
        """PARAM_REQUEST_LIST: every parameter, indices 0..count-1, to the requester."""
        for index in range(len(self._table)):
            self._outbox.send(self.value_message(index), to)

    def handle_request_read(self, msg: MAVLinkMessage, to: Address) -> None:
        """PARAM_REQUEST_READ: by index when param_index >= 0, else by name."""
        index_req = int(msg.param_index)
        name = _decode_name(msg.param_id)
        count = len(self._table)
        if index_req >= 0:
            if index_req >= count:
                self._say(f"Param index {index_req} out of range 0..{count - 1}")
                return
            self._outbox.send(self.value_message(index_req), to)
            return
        index = self._table.index_of(name)
        if index is None:
            self._say(f"Unknown parameter {name}")
            return
        self._outbox.send(self.value_message(index), to)

    def handle_set(self, msg: MAVLinkMessage) -> None:
        """PARAM_SET: validate, apply, and always echo the value in force to every peer.

        ``param_type`` is ignored (module docstring): ``param_value`` is the value."""
        name = _decode_name(msg.param_id)
        index = self._table.index_of(name)
        if index is None:
            self._say(f"Unknown parameter {name}")
            return
        outcome = self._table.set(name, float(msg.param_value))
        if not outcome.accepted:
            self._say(outcome.reason)
        self._outbox.send(self.value_message(index))

    def all_specs(self) -> Sequence[ParamSpec]:
        """Definitions in index order."""
        return [self._table.spec_at(i) for i in range(len(self._table))]
