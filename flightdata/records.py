"""Faults, detections and outcomes as data: one definition for logs, JSON and MAVLink.

Three records, each a frozen dataclass whose sentence for people (:meth:`text`) is derived
from its fields, never the other way round:

- :class:`FaultRecord`: the simulator changed a fault (scheduled, started, ended, cleared);
  simulator truth, which the autopilot never sees;
- :class:`DetectionRecord`: the autopilot concluded something about its motors, its mass,
  its sensors or a crash (``detected``), or stopped concluding it (``cleared``);
- :class:`OutcomeRecord`: how the flight really ended, judged from simulator truth.

JSON: :meth:`to_dict` / :func:`record_from_dict` (a ``"record"`` key names the type).

MAVLink: DEBUG_FLOAT_ARRAY (id 350, common.xml) named :data:`WIRE_NAME`, whose
``array_id`` is the record type (:data:`WIRE_ARRAY_IDS`) and whose ``data`` holds the fields
below as float32 (codes are indices into :mod:`flightdata.vocabulary`; -1 = none; the exact
time travels in ``time_usec``). :func:`to_wire` and :func:`from_wire` are the one encoder and
decoder; the first float of every record is its sequence number, which a receiver uses to drop
repeats (a vehicle may send each record more than once over a lossy link).

===========  ===========================================================================
record       data[0..]
===========  ===========================================================================
fault        seq, action, kind, motor (1..4 or -1), sensor, magnitude, fault_id, profile
detection    seq, action, kind, motor, sensor, magnitude
outcome      seq, kind, cause, impact_speed_m_s, tilt_deg, distance_m
===========  ===========================================================================
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np

from flightdata.vocabulary import (
    DETECTION_KINDS,
    FAULT_KINDS,
    LOE_PROFILES,
    MOTORS,
    OUTCOMES,
    SENSORS,
)

FaultAction = Literal["scheduled", "started", "ended", "cleared"]
DetectionAction = Literal["detected", "cleared"]
FAULT_ACTIONS: tuple[str, ...] = ("scheduled", "started", "ended", "cleared")
DETECTION_ACTIONS: tuple[str, ...] = ("detected", "cleared")
OUTCOME_CAUSES: tuple[str, ...] = ("touchdown", "impact_speed", "impact_tilt",
                                   "tilted_on_ground", "distance", "end_of_run", "no_flight")
"""Why an outcome was judged so (the wire code is the index)."""

WIRE_NAME = "FTC_REC"
"""DEBUG_FLOAT_ARRAY.name of every record."""
WIRE_ARRAY_IDS: Mapping[str, int] = {"fault": 1, "detection": 2, "outcome": 3}
"""DEBUG_FLOAT_ARRAY.array_id of each record type."""


def _check_subject(motor: int | None, sensor: str | None) -> None:
    if motor is not None and motor not in MOTORS:
        raise ValueError(f"motor = {motor!r}: must be one of {MOTORS} or None")
    if sensor is not None and sensor not in SENSORS:
        raise ValueError(f"sensor = {sensor!r}: must be one of {', '.join(SENSORS)} or None")


def _percent(fraction: float) -> str:
    return f"{round(100.0 * fraction)} %"


@dataclass(frozen=True, kw_only=True)
class FaultRecord:
    """A change of an injected fault (simulator truth).

    Attributes
    ----------
    time_s : float
        Simulated time of the change, s.
    action : {"scheduled", "started", "ended", "cleared"}
    kind : str
        One of :data:`flightdata.vocabulary.FAULT_KINDS`.
    motor : int or None
        Motor 1..4 of an actuator fault.
    sensor : str or None
        Sensor of a sensor fault.
    magnitude : float
        Loss of effectiveness 0..1 (``loe``: the peak of a profile; ``total_loss``: 1),
        bias or drift offset in the sensor's unit, drift rate per second for ``drift``, kg for
        ``mass_loss``; NaN when the kind has none.
    fault_id : int
        The simulator's id of the fault (the same on every record of one fault).
    profile : str or None
        Time profile of a loss of effectiveness.
    """

    time_s: float
    action: FaultAction
    kind: str
    motor: int | None = None
    sensor: str | None = None
    magnitude: float = math.nan
    fault_id: int = 0
    profile: str | None = None

    def __post_init__(self) -> None:
        if self.action not in FAULT_ACTIONS:
            raise ValueError(f"action = {self.action!r}: must be one of {FAULT_ACTIONS}")
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"kind = {self.kind!r}: must be one of {', '.join(FAULT_KINDS)}")
        if self.profile is not None and self.profile not in LOE_PROFILES:
            raise ValueError(f"profile = {self.profile!r}: must be one of {LOE_PROFILES}")
        _check_subject(self.motor, self.sensor)

    @property
    def subject(self) -> str:
        """``"motor 3"``, the sensor's name, or ``"airframe"``."""
        if self.motor is not None:
            return f"motor {self.motor}"
        return self.sensor if self.sensor is not None else "airframe"

    def describe(self) -> str:
        """What the fault is, e.g. ``"motor 3: loe 20 % (step)"``, ``"baro: drift"``."""
        kind = self.kind.replace("_", " ")
        if self.kind == "loe":
            what = f"loe {_percent(self.magnitude)}"
            if self.profile is not None:
                what += f" ({self.profile})"
        elif self.kind == "mass_loss":
            what = f"mass loss {self.magnitude:g} kg"
        elif math.isfinite(self.magnitude) and self.motor is None:
            what = f"{kind} {self.magnitude:g}"
        else:
            what = kind
        return f"{self.subject}: {what}"

    def text(self) -> str:
        """Operator sentence, e.g. ``"fault started: motor 3: loe 20 % (step)"``."""
        return f"fault {self.action}: {self.describe()}"

    @property
    def active(self) -> bool:
        """True when this change puts the fault in force."""
        return self.action == "started"

    def to_dict(self) -> dict[str, Any]:
        """JSON form (with ``"record": "fault"`` and the derived ``"text"``)."""
        return {"record": "fault", **_finite_or_none(asdict(self)), "text": self.text()}


@dataclass(frozen=True, kw_only=True)
class DetectionRecord:
    """What the autopilot concluded, or stopped concluding, at a simulated time.

    Attributes
    ----------
    time_s : float
        Simulated time of the decision, s.
    action : {"detected", "cleared"}
    kind : str
        One of :data:`flightdata.vocabulary.DETECTION_KINDS` (its docstring gives the unit
        of ``magnitude`` for each).
    motor : int or None
        The motor concerned (motor kinds).
    sensor : str or None
        The sensor concerned (sensor kinds).
    magnitude : float
        The estimated size of what was detected.
    """

    time_s: float
    action: DetectionAction
    kind: str
    motor: int | None = None
    sensor: str | None = None
    magnitude: float = math.nan

    def __post_init__(self) -> None:
        if self.action not in DETECTION_ACTIONS:
            raise ValueError(f"action = {self.action!r}: must be one of {DETECTION_ACTIONS}")
        if self.kind not in DETECTION_KINDS:
            raise ValueError(f"kind = {self.kind!r}: must be one of "
                             f"{', '.join(DETECTION_KINDS)}")
        _check_subject(self.motor, self.sensor)

    def text(self) -> str:
        """Operator sentence, e.g. ``"motor 3 lost about 19 % effectiveness"``."""
        m, s, v = self.motor, self.sensor, self.magnitude
        cleared = self.action == "cleared"
        if self.kind in ("loe", "motor_lost"):
            if cleared:
                return f"motor {m} recovered (loss of effectiveness about {_percent(v)})"
            if self.kind == "motor_lost":
                return f"motor {m} lost ({_percent(v)} of its effectiveness)"
            return f"motor {m} lost about {_percent(v)} effectiveness"
        if self.kind == "mass_change":
            if cleared:
                return "mass back to nominal"
            return f"mass changed by {v:+.2f} kg"
        if self.kind in ("sensor_rejected", "sensor_frozen", "sensor_inconsistent"):
            why = {"sensor_rejected": "fails its innovation test",
                   "sensor_frozen": "frozen", "sensor_inconsistent": "disagrees with the "
                   "other sources"}[self.kind]
            return f"{s} healthy again" if cleared else f"{s} {why}: excluded"
        if self.kind in ("motor_hard_over", "motor_stuck"):
            if self.kind == "motor_hard_over":
                return f"motor {m} hard-over: {_percent(v)} power whatever its command"
            return f"motor {m} stuck at {_percent(v)} power, not its command"
        if self.kind == "crash":
            return f"crash detected (attitude error {math.degrees(v):.0f} deg): disarming"
        return f"thrust loss (collective {_percent(v)}): check the motors"

    def to_dict(self) -> dict[str, Any]:
        """JSON form (with ``"record": "detection"`` and the derived ``"text"``)."""
        return {"record": "detection", **_finite_or_none(asdict(self)), "text": self.text()}


@dataclass(frozen=True, kw_only=True)
class OutcomeRecord:
    """How a flight ended, judged from simulator truth (:mod:`sim.outcome` documents the
    limits).

    Attributes
    ----------
    kind : {"landed", "crashed", "flyaway", "airborne"}
    time_s : float
        Simulated time at which the outcome was decided, s.
    cause : str
        One of :data:`OUTCOME_CAUSES`.
    impact_speed_m_s : float
        Speed at the last touchdown, m/s (NaN without one).
    tilt_deg : float
        Largest tilt while in ground contact, deg (NaN without contact).
    distance_m : float
        Largest horizontal distance from the mission's area, m.
    """

    kind: str
    time_s: float
    cause: str
    impact_speed_m_s: float = math.nan
    tilt_deg: float = math.nan
    distance_m: float = math.nan

    def __post_init__(self) -> None:
        if self.kind not in OUTCOMES:
            raise ValueError(f"kind = {self.kind!r}: must be one of {', '.join(OUTCOMES)}")
        if self.cause not in OUTCOME_CAUSES:
            raise ValueError(f"cause = {self.cause!r}: must be one of {OUTCOME_CAUSES}")

    @property
    def reason(self) -> str:
        """Why, in words, e.g. ``"touchdown at 2.60 m/s with 48 deg of tilt"``."""
        speed, tilt, dist = self.impact_speed_m_s, self.tilt_deg, self.distance_m
        contact = f"touchdown at {speed:.2f} m/s with {tilt:.0f} deg of tilt"
        return {
            "touchdown": contact,
            "impact_speed": contact + " (impact too fast)",
            "impact_tilt": contact + " (tilted too far)",
            "tilted_on_ground": f"on the ground at {tilt:.0f} deg of tilt",
            "distance": f"{dist:.1f} m from the mission area",
            "end_of_run": "still flying when the run ended",
            "no_flight": "never left the ground",
        }[self.cause]

    @property
    def safe(self) -> bool:
        """True for ``landed`` (the only outcome a flight can be called a success with)."""
        return self.kind == "landed"

    def text(self) -> str:
        """Operator sentence, e.g. ``"outcome: crashed at 38.62 s: touchdown at ..."``."""
        return f"outcome: {self.kind} at {self.time_s:.2f} s: {self.reason}"

    def to_dict(self) -> dict[str, Any]:
        """JSON form: kind, time_s, reason (the issue's contract), cause and the values."""
        out = _finite_or_none(asdict(self))
        return {"record": "outcome", "kind": self.kind, "time_s": self.time_s,
                "reason": self.reason, **{k: v for k, v in out.items()
                                          if k not in ("kind", "time_s")}}


Record = FaultRecord | DetectionRecord | OutcomeRecord


def _finite_or_none(values: Mapping[str, Any]) -> dict[str, Any]:
    """NaN floats as None (JSON has no NaN)."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in values.items()}


def _nan_if_none(value: Any) -> float:
    return math.nan if value is None else float(value)


def record_from_dict(data: Mapping[str, Any]) -> Record:
    """The record a :meth:`to_dict` produced (``"text"`` and ``"reason"`` are ignored).

    Raises
    ------
    ValueError
        Not a record, or a field out of its vocabulary.
    """
    kind = data.get("record")
    fields = {k: v for k, v in data.items() if k not in ("record", "text", "reason")}
    try:
        if kind == "fault":
            fields["magnitude"] = _nan_if_none(fields.get("magnitude"))
            return FaultRecord(**fields)
        if kind == "detection":
            fields["magnitude"] = _nan_if_none(fields.get("magnitude"))
            return DetectionRecord(**fields)
        if kind == "outcome":
            for name in ("impact_speed_m_s", "tilt_deg", "distance_m"):
                fields[name] = _nan_if_none(fields.get(name))
            return OutcomeRecord(**fields)
    except TypeError as err:
        raise ValueError(f"{kind} record: {err}") from None
    raise ValueError(f"record = {kind!r}: must be fault, detection or outcome")


# ---- MAVLink (DEBUG_FLOAT_ARRAY) ------------------------------------------------------------


def _code(value: str | None, vocabulary: Sequence[str]) -> float:
    return -1.0 if value is None else float(vocabulary.index(value))


def _word(code: float, vocabulary: Sequence[str], what: str) -> str | None:
    if code < 0:
        return None
    i = int(round(code))
    if not 0 <= i < len(vocabulary):
        raise ValueError(f"{what} code {code!r} outside 0..{len(vocabulary) - 1}")
    return vocabulary[i]


def _motor(code: float) -> int | None:
    return None if code < 0 else int(round(code))


def to_wire(record: Record, seq: int) -> tuple[int, list[float]]:
    """``(array_id, data)`` of DEBUG_FLOAT_ARRAY carrying ``record`` as number ``seq``."""
    if isinstance(record, FaultRecord):
        return WIRE_ARRAY_IDS["fault"], [
            float(seq), _code(record.action, FAULT_ACTIONS), _code(record.kind, FAULT_KINDS),
            -1.0 if record.motor is None else float(record.motor),
            _code(record.sensor, SENSORS), record.magnitude, float(record.fault_id),
            _code(record.profile, LOE_PROFILES)]
    if isinstance(record, DetectionRecord):
        return WIRE_ARRAY_IDS["detection"], [
            float(seq), _code(record.action, DETECTION_ACTIONS),
            _code(record.kind, DETECTION_KINDS),
            -1.0 if record.motor is None else float(record.motor),
            _code(record.sensor, SENSORS), record.magnitude]
    return WIRE_ARRAY_IDS["outcome"], [
        float(seq), _code(record.kind, OUTCOMES), _code(record.cause, OUTCOME_CAUSES),
        record.impact_speed_m_s, record.tilt_deg, record.distance_m]


def _decimal(value: float) -> float:
    """A float32 as the shortest decimal that rounds to it (0.2, not 0.2000000030)."""
    return float(str(np.float32(value)))


def from_wire(array_id: int, data: Sequence[float], time_s: float) -> tuple[int, Record]:
    """``(seq, record)`` from a DEBUG_FLOAT_ARRAY's ``array_id``, ``data`` and time (the
    float32 fields read back as the shortest decimals that round to them).

    Raises
    ------
    ValueError
        An unknown ``array_id`` or a code outside its vocabulary.
    """
    d = [_decimal(v) for v in data]
    seq = int(round(d[0]))
    if array_id == WIRE_ARRAY_IDS["fault"]:
        action = _word(d[1], FAULT_ACTIONS, "fault action")
        kind = _word(d[2], FAULT_KINDS, "fault kind")
        return seq, FaultRecord(time_s=time_s, action=action,  # type: ignore[arg-type]
                                kind=kind or "", motor=_motor(d[3]),
                                sensor=_word(d[4], SENSORS, "sensor"), magnitude=d[5],
                                fault_id=int(round(d[6])),
                                profile=_word(d[7], LOE_PROFILES, "profile"))
    if array_id == WIRE_ARRAY_IDS["detection"]:
        action = _word(d[1], DETECTION_ACTIONS, "detection action")
        kind = _word(d[2], DETECTION_KINDS, "detection kind")
        return seq, DetectionRecord(time_s=time_s, action=action,  # type: ignore[arg-type]
                                    kind=kind or "", motor=_motor(d[3]),
                                    sensor=_word(d[4], SENSORS, "sensor"), magnitude=d[5])
    if array_id == WIRE_ARRAY_IDS["outcome"]:
        return seq, OutcomeRecord(kind=_word(d[1], OUTCOMES, "outcome") or "", time_s=time_s,
                                  cause=_word(d[2], OUTCOME_CAUSES, "cause") or "",
                                  impact_speed_m_s=d[3], tilt_deg=d[4], distance_m=d[5])
    raise ValueError(f"array_id {array_id}: not a record type ({dict(WIRE_ARRAY_IDS)})")


__all__ = [
    "DETECTION_ACTIONS",
    "FAULT_ACTIONS",
    "OUTCOME_CAUSES",
    "WIRE_ARRAY_IDS",
    "WIRE_NAME",
    "DetectionRecord",
    "FaultRecord",
    "OutcomeRecord",
    "Record",
    "from_wire",
    "record_from_dict",
    "to_wire",
]
