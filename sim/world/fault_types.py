"""Fault definitions of the simulated world: actuator, sensor and structural (thesis ch. 4).

The engine sits inside the plant (docs/design.md). The autopilot never reads it: a fault
reaches the autopilot only through what the sensors report and how the vehicle moves.

Fault kinds
-----------
Actuator faults act on the PWM command of one motor (thesis motor numbering, eq. 3.2):

==============  ==========================================================================
``loe``         loss of effectiveness, eq. 4.10: ``u_f = (1 - gamma) u``, gamma in [0, 1],
                with a time profile (Table 6.1):

                - ``step``: gamma = ``loe`` from the start on;
                - ``sinusoid``: gamma(t) = loe (1 - cos(2 pi (t - t0) / period_s)) / 2, which
                  starts at 0, peaks at ``loe`` half a period later and never leaves [0, loe];
                - ``random``: gamma uniform in [``low``, ``loe``], a new value every
                  ``hold_s`` seconds (drawn from the fault's own seeded generator, so the
                  sequence does not depend on how often the engine is called);
                - ``pulse``: gamma = ``loe`` during the first ``pulse_width_s`` of every
                  ``period_s``, else 0.
``lock``        the command stays at the value it had at the step where the fault started.
``float``       the command is forced to 0: the motor freewheels and makes no thrust.
``hardover``    the command is forced to ``pwm_max``.
``total_loss``  gamma = 1 (no thrust whatever the command).
==============  ==========================================================================

Here ``t0`` is the simulated time at which the fault starts acting: the first engine call
with ``time_s >= start_s`` (the plant calls the engine every step, so ``t0`` is the first
plant step at or after ``start_s``; it equals ``start_s`` when that lies on the step grid).
A fault acts for ``t0 <= t < end_s``.

Several actuator faults on one motor compose as a motor would: the command is first replaced
by the *override* faults (lock, float, hardover; when several are active, the one that started
last wins, ties going to the later-scheduled fault), then every active effectiveness fault
(loe, total_loss) scales it, effectivenesses multiplying: ``u_f = prod_i (1 - gamma_i) *
u_override``. A locked or hard-over motor with a damaged propeller therefore gives the
damaged fraction of its stuck command. Saturation to [0, pwm_max] is the motor model's job
(the engine passes out-of-range commands through unchanged).

Profile defaults (the thesis gives none; Figure 6.2 shows slow variations over a 60 s run):
``period_s = 10`` s for the sinusoid and the pulse, ``pulse_width_s = 5`` s (half duty, as
Simulink's Pulse Generator), ``hold_s = 1`` s for the random profile, all fields of
:class:`ActuatorFault`. :meth:`FaultEngine.true_loe` reports the injected gamma per motor:
loe and total_loss as above, float as 1, lock and hardover as NaN (their output does not
scale with the command).

Sensor faults act on an already-noisy reading (thesis section 4.6), optionally on one axis:

====================  ====================================================================
``bias``              adds ``magnitude`` (sensor unit).
``loss_of_accuracy``  noise grows by ``magnitude`` percent of the nominal sigma: the reading's
                      standard deviation becomes sigma (1 + magnitude / 100) (200 -> 3 sigma),
                      by adding independent Gaussian noise of sigma sqrt((1 + m/100)^2 - 1).
``drift``             adds ``magnitude + rate (t - t0)`` (a ramp, sensor unit and unit/s).
``freeze``            holds the last reading reported before the fault started (the first
                      reading during the fault when none was reported before).
``calibration``       uncorrelated readings uniform in [``low``, ``high``] (default: a wide
                      range per sensor, :data:`DEFAULT_GARBAGE_RANGE`).
====================  ====================================================================

Several sensor faults compose in this order: the additive ones (bias, drift, loss of
accuracy) sum; then the replacing ones (calibration, freeze) apply in the order they started,
so the one that started last decides the reading (a freeze that starts during a calibration
error holds the last garbage value).

A structural fault removes ``mass_loss_kg`` from the airframe at ``start_s`` (thesis: a 300 g
battery at t = 22 s; mass only, inertia unchanged). It lasts until cleared.

Kinds and profiles by number
----------------------------
:class:`FaultKind` and :class:`FaultProfile` are the one table from a kind's or a profile's
name (the names above, those of scenarios, records and MAVLink: :mod:`flightdata.vocabulary`)
to the code the compiled rules read; :data:`OVERRIDE_KINDS`, :data:`ADDITIVE_KINDS` and
:data:`DRAWING_KINDS` say how a kind composes and whether it draws random numbers.

The engine that applies the faults is :class:`sim.world.faults.FaultEngine`; the rules
themselves, one implementation each, are the compiled kernels of :mod:`sim.world.fault_kernels`.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple, get_args

import numpy as np

from flightdata.config import ConfigError, finite, from_mapping, require
from flightdata.records import FaultRecord
from flightdata.vocabulary import ActuatorKind, LoeProfile, SensorKind, SensorName

EventKind = Literal["injected", "cleared", "started", "ended"]


class FaultKind(enum.IntEnum):
    """Actuator and sensor fault kinds by number: a member is the kind's name upper-cased
    (``FaultKind["LOSS_OF_ACCURACY"]``, :meth:`of`), its value the code in a compiled table
    row (``FAULT_ROW.kind``); the kernels compare with the members themselves."""

    LOE = 0  # actuator: scales the command
    TOTAL_LOSS = 1  # actuator: scales the command
    LOCK = 2  # actuator: replaces the command (OVERRIDE_KINDS)
    FLOAT = 3  # actuator: replaces the command
    HARDOVER = 4  # actuator: replaces the command
    BIAS = 5  # sensor: adds to the reading (ADDITIVE_KINDS)
    DRIFT = 6  # sensor: adds to the reading
    LOSS_OF_ACCURACY = 7  # sensor: adds to the reading, draws (DRAWING_KINDS)
    FREEZE = 8  # sensor: replaces the reading
    CALIBRATION = 9  # sensor: replaces the reading, draws

    @classmethod
    def of(cls, name: str) -> FaultKind:
        """The member of a kind's name (``"loe"`` -> ``FaultKind.LOE``)."""
        return cls[name.upper()]


class FaultProfile(enum.IntEnum):
    """Time profiles of a loss of effectiveness by number (``FAULT_ROW.profile``), as
    :class:`FaultKind`: ``FaultProfile.of("random")`` is ``FaultProfile.RANDOM``."""

    STEP = 0
    SINUSOID = 1
    RANDOM = 2
    PULSE = 3

    @classmethod
    def of(cls, name: str) -> FaultProfile:
        """The member of a profile's name."""
        return cls[name.upper()]


OVERRIDE_KINDS = frozenset({FaultKind.LOCK, FaultKind.FLOAT, FaultKind.HARDOVER})
"""Actuator kinds that replace the command (the last started wins); the others scale it."""
ADDITIVE_KINDS = frozenset({FaultKind.BIAS, FaultKind.DRIFT, FaultKind.LOSS_OF_ACCURACY})
"""Sensor kinds that add to the reading; the others replace it (in the order they started)."""
DRAWING_KINDS = frozenset({FaultKind.LOSS_OF_ACCURACY, FaultKind.CALIBRATION})
"""Sensor kinds that take one random draw per element they corrupt
(:meth:`SensorFault.draws`)."""

MOTORS = (1, 2, 3, 4)
"""Motor numbers of thesis eq. 3.2 (docs/design.md)."""

SENSOR_AXES: Mapping[str, int] = {
    "gyro": 3,
    "accel": 3,
    "mocap_pos": 3,
    "mocap_att": 3,
    "baro": 1,
}
"""Number of elements of each sensor's value (docs/design.md, fcu/hal.py)."""

DEFAULT_GARBAGE_RANGE: Mapping[str, tuple[float, float]] = {
    "gyro": (-34.9, 34.9),  # rad/s: +-2000 deg/s, a MEMS gyro's widest full scale
    "accel": (-156.9, 156.9),  # m/s^2: +-16 g, a MEMS accelerometer's widest full scale
    "mocap_pos": (-5.0, 5.0),  # m: an indoor motion-capture volume around home
    "mocap_att": (-math.pi, math.pi),  # rad: any angle
    "baro": (-10.0, 10.0),  # m: well beyond an indoor flight's altitude band
}
"""Default [low, high] of calibration-error readings, in each sensor's unit."""

SENSOR_NAMES: tuple[str, ...] = tuple(SENSOR_AXES)
"""Sensor names in their fixed order (a sensor's index in compiled tables and sample batches)."""


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _one_of(values: tuple[Any, ...]) -> str:
    return "must be one of " + ", ".join(map(repr, values))


def _check_window(start_s: float, end_s: float | None) -> None:
    require(finite(start_s) and start_s >= 0.0, "start_s", start_s,
            "must be a finite time >= 0 s")
    require(end_s is None or (finite(end_s) and end_s > start_s), "end_s", end_s,
            f"must be later than start_s = {start_s!r} s (or absent: the fault stays until "
            "cleared)")


def _require_defaults(obj: Any, names: tuple[str, ...], context: str) -> None:
    """Reject fields that ``context`` ignores unless they keep their default values."""
    for f in dataclasses.fields(obj):
        if f.name in names:
            value = getattr(obj, f.name)
            require(value == f.default, f.name, value, f"does not apply to {context}; leave it out")


@dataclass(frozen=True, kw_only=True)
class ActuatorFault:
    """A fault on one motor's command (see the module docstring for the semantics).

    Raises
    ------
    ConfigError
        A value is out of range, or a field that ``kind``/``profile`` ignores was set.
    """

    motor: int  # -, motor number 1..4 (thesis eq. 3.2)
    kind: ActuatorKind  # -, "loe" | "lock" | "float" | "hardover" | "total_loss"
    start_s: float = 0.0  # s, simulated time at which the fault starts
    end_s: float | None = None  # s, simulated time at which it ends; None = until cleared
    loe: float = 0.0  # -, gamma of eq. 4.10 in [0, 1]; the peak (upper bound) for profiles
    profile: LoeProfile = "step"  # -, time profile of gamma (kind "loe" only)
    period_s: float = 10.0  # s, period of the sinusoid and pulse profiles
    pulse_width_s: float = 5.0  # s, time at gamma = loe in each pulse period, in (0, period_s]
    hold_s: float = 1.0  # s, random profile: how long each drawn gamma is held
    low: float = 0.0  # -, random profile: lower bound of gamma, in [0, loe]

    def __post_init__(self) -> None:
        require(_is_int(self.motor) and self.motor in MOTORS, "motor", self.motor,
                "must be 1, 2, 3 or 4")
        kinds = get_args(ActuatorKind)
        require(self.kind in kinds, "kind", self.kind, _one_of(kinds))
        _check_window(self.start_s, self.end_s)
        require(finite(self.loe) and 0.0 <= self.loe <= 1.0, "loe", self.loe,
                "must be within [0, 1]")
        profiles = get_args(LoeProfile)
        require(self.profile in profiles, "profile", self.profile, _one_of(profiles))
        require(finite(self.period_s) and self.period_s > 0.0, "period_s", self.period_s,
                "must be > 0 s")
        require(finite(self.pulse_width_s) and self.pulse_width_s > 0.0, "pulse_width_s",
                self.pulse_width_s, "must be > 0 s")
        if self.profile == "pulse":
            require(self.pulse_width_s <= self.period_s, "pulse_width_s", self.pulse_width_s,
                    f"must be within (0, period_s = {self.period_s!r}] s")
        require(finite(self.hold_s) and self.hold_s > 0.0, "hold_s", self.hold_s,
                "must be > 0 s")
        require(finite(self.low) and 0.0 <= self.low <= self.loe, "low", self.low,
                f"must be within [0, loe = {self.loe!r}]")
        profile_fields = ("period_s", "pulse_width_s", "hold_s", "low")
        if self.kind != "loe":
            _require_defaults(self, ("loe", "profile", *profile_fields), f"kind {self.kind!r}")
            return
        used = {"step": (), "sinusoid": ("period_s",), "random": ("hold_s", "low"),
                "pulse": ("period_s", "pulse_width_s")}[self.profile]
        _require_defaults(self, tuple(n for n in profile_fields if n not in used),
                          f"profile {self.profile!r}")

    def describe(self) -> str:
        """One line for logs and events, e.g. ``"motor 1: loe 30 % (step)"``."""
        if self.kind == "loe":
            if self.profile == "random":
                what = f"loe {100 * self.low:g}-{100 * self.loe:g} % (random, {self.hold_s:g} s)"
            else:
                what = f"loe {100 * self.loe:g} % ({self.profile})"
        else:
            what = self.kind.replace("_", " ")
        return f"motor {self.motor}: {what}"


@dataclass(frozen=True, kw_only=True)
class SensorFault:
    """A fault on one sensor, on one axis or all (see the module docstring).

    Raises
    ------
    ConfigError
        A value is out of range, or a field that ``kind`` ignores was set.
    """

    sensor: SensorName  # -, "gyro" | "accel" | "mocap_pos" | "mocap_att" | "baro"
    kind: SensorKind  # -, "bias" | "loss_of_accuracy" | "drift" | "freeze" | "calibration"
    axis: int | None = None  # -, 0-based index into the sensor's value; None = all axes
    start_s: float = 0.0  # s, simulated time at which the fault starts
    end_s: float | None = None  # s, simulated time at which it ends; None = until cleared
    magnitude: float = 0.0  # sensor unit (bias, drift offset) or % of sigma (loss_of_accuracy)
    rate: float = 0.0  # sensor unit per s, drift slope
    low: float | None = None  # sensor unit, calibration readings' lower bound; None = default
    high: float | None = None  # sensor unit, calibration readings' upper bound; None = default

    def __post_init__(self) -> None:
        require(self.sensor in SENSOR_AXES, "sensor", self.sensor, _one_of(tuple(SENSOR_AXES)))
        kinds = get_args(SensorKind)
        require(self.kind in kinds, "kind", self.kind, _one_of(kinds))
        n = SENSOR_AXES[self.sensor]
        allowed_axes = "must be 0" if n == 1 else f"must be 0 to {n - 1}"
        require(self.axis is None or (_is_int(self.axis) and 0 <= self.axis < n), "axis",
                self.axis, f"{allowed_axes} for sensor {self.sensor!r} (or absent: all axes)")
        _check_window(self.start_s, self.end_s)
        require(finite(self.magnitude), "magnitude", self.magnitude, "must be a finite number")
        require(finite(self.rate), "rate", self.rate, "must be a finite number (unit/s)")
        if self.kind == "loss_of_accuracy":
            require(self.magnitude >= 0.0, "magnitude", self.magnitude,
                    "must be >= 0 (percent of the nominal sigma added)")
        if self.kind == "calibration":
            given = "low" if self.high is None else "high"
            require((self.low is None) == (self.high is None), given, getattr(self, given),
                    "give both low and high, or neither (the sensor's default range)")
            low, high = self.low, self.high
            if low is not None and high is not None:
                require(finite(low), "low", low, "must be a finite number")
                require(finite(high) and high > low, "high", high,
                        f"must be a finite number > low = {low!r}")
        ignored = {"bias": ("rate", "low", "high"), "drift": ("low", "high"),
                   "loss_of_accuracy": ("rate", "low", "high"),
                   "freeze": ("magnitude", "rate", "low", "high"),
                   "calibration": ("magnitude", "rate")}[self.kind]
        _require_defaults(self, ignored, f"kind {self.kind!r}")

    def draws(self, rng: np.random.Generator, size: int) -> np.ndarray:
        """``size`` random numbers of a kind of :data:`DRAWING_KINDS`, from its ``rng``:
        standard normals (loss of accuracy) or readings uniform in :attr:`garbage_range`
        (calibration)."""
        if self.kind == "loss_of_accuracy":
            return rng.standard_normal(size)
        low, high = self.garbage_range
        return rng.uniform(low, high, size=size)

    @property
    def garbage_range(self) -> tuple[float, float]:
        """[low, high] of calibration-error readings (sensor unit), defaults filled in."""
        if self.low is None or self.high is None:
            return DEFAULT_GARBAGE_RANGE[self.sensor]
        return (self.low, self.high)

    def describe(self) -> str:
        """One line for logs and events, e.g. ``"baro: bias 0.1"``."""
        where = self.sensor if self.axis is None else f"{self.sensor}[{self.axis}]"
        what = {"bias": f"bias {self.magnitude:g}",
                "loss_of_accuracy": f"loss of accuracy +{self.magnitude:g} % sigma",
                "drift": f"drift {self.magnitude:g} + {self.rate:g}/s",
                "freeze": "freeze",
                "calibration": "calibration error in [{:g}, {:g}]".format(*self.garbage_range),
                }[self.kind]
        return f"{where}: {what}"


@dataclass(frozen=True, kw_only=True)
class StructuralFault:
    """A mass leaves the airframe at ``start_s`` (mass only, inertia unchanged)."""

    mass_loss_kg: float  # kg, mass that leaves (> 0); thesis: a 0.3 kg battery
    start_s: float = 0.0  # s, simulated time at which it leaves

    def __post_init__(self) -> None:
        require(finite(self.mass_loss_kg) and self.mass_loss_kg > 0.0, "mass_loss_kg",
                self.mass_loss_kg, "must be > 0 kg")
        require(finite(self.start_s) and self.start_s >= 0.0, "start_s", self.start_s,
                "must be a finite time >= 0 s")

    @property
    def end_s(self) -> None:
        """Always None: a lost part stays lost until the fault is cleared."""
        return None

    def describe(self) -> str:
        """One line for logs and events."""
        return f"airframe: loses {self.mass_loss_kg:g} kg"


Fault = ActuatorFault | SensorFault | StructuralFault


def fault_from_mapping(table: Mapping[str, Any]) -> Fault:
    """Build a fault from a TOML table, choosing the type by its keys.

    A table with ``motor`` is an :class:`ActuatorFault`, one with ``sensor`` a
    :class:`SensorFault`, one with ``mass_loss_kg`` a :class:`StructuralFault`; e.g. a scenario
    lists ``[[faults]] motor = 1, kind = "loe", loe = 0.3, start_s = 38.0``.

    Raises
    ------
    ConfigError
        The table matches no fault type, or a value is wrong.
    """
    if not isinstance(table, Mapping):
        raise ConfigError(f"fault: expected a table, got {table!r}")
    if "motor" in table:
        return from_mapping(ActuatorFault, table)
    if "sensor" in table:
        return from_mapping(SensorFault, table)
    if "mass_loss_kg" in table:
        return from_mapping(StructuralFault, table)
    raise ConfigError(f"fault {dict(table)!r}: needs a 'motor' (actuator fault), a 'sensor' "
                      "(sensor fault) or a 'mass_loss_kg' (structural fault) key")


_RECORD_ACTIONS = {"injected": "scheduled", "started": "started", "ended": "ended",
                   "cleared": "cleared"}


def fault_record(time_s: float, kind: EventKind, fault_id: int, fault: Fault) -> FaultRecord:
    """The :class:`flightdata.records.FaultRecord` of an event of ``fault``.

    Magnitude: the loss of effectiveness (a profile's peak; 1 for a total loss; NaN for lock,
    float and hard-over), the bias or loss of accuracy (sensor unit, % of sigma), a drift's
    rate (sensor unit per s), the mass lost (kg); NaN for freeze and calibration.
    """
    action = _RECORD_ACTIONS[kind]
    if isinstance(fault, ActuatorFault):
        magnitude = {"loe": fault.loe, "total_loss": 1.0}.get(fault.kind, math.nan)
        return FaultRecord(time_s=time_s, action=action, kind=fault.kind,  # type: ignore[arg-type]
                           motor=fault.motor, magnitude=magnitude, fault_id=fault_id,
                           profile=fault.profile if fault.kind == "loe" else None)
    if isinstance(fault, SensorFault):
        magnitude = {"bias": fault.magnitude, "loss_of_accuracy": fault.magnitude,
                     "drift": fault.rate}.get(fault.kind, math.nan)
        return FaultRecord(time_s=time_s, action=action, kind=fault.kind,  # type: ignore[arg-type]
                           sensor=fault.sensor, magnitude=magnitude, fault_id=fault_id)
    return FaultRecord(time_s=time_s, action=action, kind="mass_loss",  # type: ignore[arg-type]
                       magnitude=fault.mass_loss_kg, fault_id=fault_id)


@dataclass(frozen=True, slots=True)
class FaultEvent:
    """Something that happened to a fault, at a simulated time."""

    time_s: float  # s, simulated time
    kind: EventKind  # -, "injected" | "cleared" | "started" | "ended"
    fault_id: int  # -, id returned by FaultEngine.schedule
    description: str  # -, human-readable summary of the fault
    fault: Fault  # the fault itself

    @property
    def record(self) -> FaultRecord:
        """The event as data (:func:`fault_record`)."""
        return fault_record(self.time_s, self.kind, self.fault_id, self.fault)


class ScheduledFault(NamedTuple):
    """A fault known to the engine and its id."""

    fault_id: int
    fault: Fault
