"""Fault engine of the simulated world: actuator, sensor and structural faults (thesis ch. 4).

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

Cost
----
:meth:`FaultEngine.actuator_inputs`, :meth:`FaultEngine.corrupt` and
:meth:`FaultEngine.mass_kg` compare the time with a cached next-change time and return cached
results, so a step without faults costs one comparison; the active set is rebuilt only when a
fault starts, ends, is scheduled or is cleared.

The engine is not thread-safe: a MAVLink endpoint on another thread should queue injections
for the simulation loop, which applies them between steps (:meth:`FaultEngine.apply_now`,
:meth:`FaultEngine.clear_matching`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple, get_args

import numpy as np

from flightdata.config import ConfigError, finite, from_mapping, require

ActuatorKind = Literal["loe", "lock", "float", "hardover", "total_loss"]
LoeProfile = Literal["step", "sinusoid", "random", "pulse"]
SensorName = Literal["gyro", "accel", "mocap_pos", "mocap_att", "baro"]
SensorKind = Literal["bias", "loss_of_accuracy", "drift", "freeze", "calibration"]
EventKind = Literal["injected", "cleared", "started", "ended"]

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

_OVERRIDE_KINDS = ("lock", "float", "hardover")
_PENDING, _ACTIVE = 0, 1
_RANDOM_BLOCK = 64  # random-profile values drawn at a time


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


@dataclass(frozen=True, slots=True)
class FaultEvent:
    """Something that happened to a fault, at a simulated time."""

    time_s: float  # s, simulated time
    kind: EventKind  # -, "injected" | "cleared" | "started" | "ended"
    fault_id: int  # -, id returned by FaultEngine.schedule
    description: str  # -, human-readable summary of the fault


class ScheduledFault(NamedTuple):
    """A fault known to the engine and its id."""

    fault_id: int
    fault: Fault


class _Record:
    """Mutable bookkeeping of one scheduled fault."""

    __slots__ = ("fault_id", "fault", "kind", "rng", "state", "t0", "held", "draws")

    def __init__(self, fault_id: int, fault: Fault, rng: np.random.Generator) -> None:
        self.fault_id = fault_id
        self.fault = fault
        self.kind: str = getattr(fault, "kind", "structural")
        self.rng = rng  # the fault's own generator (random profile, noise, garbage)
        self.state = _PENDING
        self.t0 = math.nan  # s, time at which it started acting
        self.held: Any = None  # lock: float command; freeze: frozen reading (ndarray)
        self.draws: np.ndarray | None = None  # random profile: gamma per hold interval


class FaultEngine:
    """Schedules faults and applies them to motor commands, sensor readings and mass.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of every random draw; each scheduled fault takes a seed from it and gets its
        own generator, so one fault's draws never depend on another's or on the call pattern.
    pwm_max : float
        PWM command of a hard-over motor (unit PWM; thesis 0.05).
    base_mass_kg : float
        Airframe mass before any structural fault, kg.

    Notes
    -----
    Time given to the engine must not go backwards; call :meth:`reset` to start a new run.
    Methods that take no time (:meth:`schedule`, :meth:`clear` without ``time_s``) stamp their
    events with :attr:`clock_s`, the latest simulated time the engine was given.
    """

    def __init__(self, rng: np.random.Generator, pwm_max: float, base_mass_kg: float) -> None:
        require(finite(pwm_max) and pwm_max > 0.0, "pwm_max", pwm_max, "must be > 0")
        require(finite(base_mass_kg) and base_mass_kg > 0.0, "base_mass_kg", base_mass_kg,
                "must be > 0 kg")
        self._rng = rng
        self._pwm_max = float(pwm_max)
        self._base_mass_kg = float(base_mass_kg)
        self.events: list[FaultEvent] = []
        """Every event since construction or :meth:`reset`, oldest first."""
        self._records: dict[int, _Record] = {}
        self.reset()

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        """Forget every fault and event and restart the clock at 0 (the rng is not rewound)."""
        self._records.clear()
        self.events.clear()
        self._drained = 0
        self._next_id = 1
        self._clock_s = 0.0
        self._last_reading: dict[str, np.ndarray] = {}
        self._next_change_s = math.inf
        self._rebuild()

    @property
    def clock_s(self) -> float:
        """Latest simulated time given to the engine, s."""
        return self._clock_s

    @property
    def pwm_max(self) -> float:
        """Hard-over PWM command."""
        return self._pwm_max

    @property
    def base_mass_kg(self) -> float:
        """Airframe mass before structural faults, kg."""
        return self._base_mass_kg

    # ------------------------------------------------------------------ scheduling
    def schedule(self, fault: Fault) -> int:
        """Add a fault; it acts from ``fault.start_s`` (a past start acts at the next call).

        Returns
        -------
        int
            The fault id (1, 2, ... in scheduling order).

        Raises
        ------
        TypeError
            ``fault`` is not a fault.
        ConfigError
            Structural faults would remove the whole airframe mass.
        """
        if not isinstance(fault, (ActuatorFault, SensorFault, StructuralFault)):
            raise TypeError(f"expected ActuatorFault, SensorFault or StructuralFault, "
                            f"got {type(fault).__name__}")
        if isinstance(fault, StructuralFault):
            lost = sum(r.fault.mass_loss_kg for r in self._records.values()
                       if isinstance(r.fault, StructuralFault))
            remaining = self._base_mass_kg - lost
            require(fault.mass_loss_kg < remaining, "mass_loss_kg", fault.mass_loss_kg,
                    f"must be less than the remaining airframe mass {remaining:g} kg")
        fault_id = self._next_id
        self._next_id += 1
        seed = int(self._rng.integers(0, 2**63 - 1))
        self._records[fault_id] = _Record(fault_id, fault, np.random.default_rng(seed))
        self._emit(self._clock_s, "injected", fault_id, fault)
        self._next_change_s = min(self._next_change_s, fault.start_s)
        return fault_id

    def apply_now(self, fault: Fault, time_s: float) -> int:
        """Schedule ``fault`` to start at ``time_s``, keeping its duration ``end_s - start_s``.

        Returns
        -------
        int
            The fault id.
        """
        require(finite(time_s) and time_s >= 0.0, "time_s", time_s, "must be a time >= 0 s")
        self._clock_s = max(self._clock_s, float(time_s))
        if isinstance(fault, StructuralFault):
            return self.schedule(dataclasses.replace(fault, start_s=float(time_s)))
        end_s = fault.end_s
        if end_s is not None:
            end_s = float(time_s) + (end_s - fault.start_s)
        return self.schedule(dataclasses.replace(fault, start_s=float(time_s), end_s=end_s))

    def clear(self, fault_id: int, time_s: float | None = None) -> None:
        """Remove a pending or active fault; its effect stops at once.

        Parameters
        ----------
        fault_id : int
            Id returned by :meth:`schedule`.
        time_s : float, optional
            Simulated time of the "cleared" event; default :attr:`clock_s`.

        Raises
        ------
        KeyError
            No pending or active fault has this id (unknown, ended or cleared already).
        """
        rec = self._records.pop(fault_id, None)
        if rec is None:
            raise KeyError(f"fault {fault_id} is not scheduled (unknown, ended or cleared)")
        self._emit(self._clock_s if time_s is None else time_s, "cleared", fault_id, rec.fault)
        self._refresh()

    def clear_all(self, time_s: float | None = None) -> list[int]:
        """Remove every pending or active fault; returns their ids."""
        return self._clear_where(lambda f: True, time_s)

    def clear_matching(self, target: int | str, time_s: float | None = None) -> list[int]:
        """Remove the pending or active faults of one part (a MAVLink "OK" injection).

        Parameters
        ----------
        target : int or str
            A motor number 1..4 (its actuator faults), a sensor name (its sensor faults, every
            axis), ``"motors"`` (all actuator faults), ``"sensors"`` (all sensor faults) or
            ``"structural"`` (all structural faults).
        time_s : float, optional
            Simulated time of the "cleared" events; default :attr:`clock_s`.

        Returns
        -------
        list of int
            Ids of the faults removed.

        Raises
        ------
        ConfigError
            ``target`` names no part.
        """
        if _is_int(target) and target in MOTORS:
            return self._clear_where(
                lambda f: isinstance(f, ActuatorFault) and f.motor == target, time_s)
        if target in SENSOR_AXES:
            return self._clear_where(
                lambda f: isinstance(f, SensorFault) and f.sensor == target, time_s)
        kinds = {"motors": ActuatorFault, "sensors": SensorFault, "structural": StructuralFault}
        require(isinstance(target, str) and target in kinds, "target", target,
                "must be a motor 1..4, a sensor name (" + ", ".join(SENSOR_AXES)
                + "), 'motors', 'sensors' or 'structural'")
        cls = kinds[target]  # type: ignore[index]
        return self._clear_where(lambda f: isinstance(f, cls), time_s)

    def _clear_where(self, match: Any, time_s: float | None) -> list[int]:
        ids = [i for i, r in self._records.items() if match(r.fault)]
        when = self._clock_s if time_s is None else time_s
        for i in ids:
            self._emit(when, "cleared", i, self._records.pop(i).fault)
        if ids:
            self._refresh()
        return ids

    # ------------------------------------------------------------------ queries
    def active(self, time_s: float) -> list[ScheduledFault]:
        """Faults acting at ``time_s``, in scheduling order."""
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        return [ScheduledFault(r.fault_id, r.fault) for r in self._records.values()
                if r.state == _ACTIVE]

    def scheduled(self) -> list[ScheduledFault]:
        """Faults pending or acting (not ended, not cleared), in scheduling order."""
        return [ScheduledFault(r.fault_id, r.fault) for r in self._records.values()]

    def drain_events(self) -> list[FaultEvent]:
        """Events appended since the previous call (they stay in :attr:`events`)."""
        new = self.events[self._drained:]
        self._drained = len(self.events)
        return new

    def mass_kg(self, time_s: float) -> float:
        """Airframe mass at ``time_s`` after structural faults, kg."""
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        return self._mass_kg

    def true_loe(self, time_s: float) -> np.ndarray:
        """Injected loss of effectiveness per motor at ``time_s`` (for reports, never the FCU).

        Returns
        -------
        numpy.ndarray, shape (4,)
            gamma of motors 1..4: ``1 - prod(1 - gamma_i)`` over the active loe and total_loss
            faults (total_loss counts as 1). ``float`` reports 1 (no thrust at any command).
            ``lock`` and ``hardover`` report NaN: their output does not scale with the
            command, so no gamma describes them. The override that decides the command
            (see the module docstring) decides between 1 and NaN.
        """
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        out = np.zeros(4)
        for idx, overrides, scalers in self._act_groups:
            if overrides and overrides[-1].kind != "float":
                out[idx] = math.nan
            elif overrides:
                out[idx] = 1.0
            elif len(scalers) == 1:
                out[idx] = self._gamma(scalers[0], time_s)  # exactly the injected gamma
            else:
                eff = 1.0
                for rec in scalers:
                    eff *= 1.0 - self._gamma(rec, time_s)
                out[idx] = 1.0 - eff
        return out

    # ------------------------------------------------------------------ the hot paths
    def _stepping_state(self) -> tuple[int, np.ndarray, float, float]:
        """What :class:`sim.world.World`'s compiled stepping needs to stand in for
        :meth:`actuator_inputs` and :meth:`mass_kg` on steps that start before the next
        change: ``(mode, gains, mass_kg, next_change_s)``. Until ``next_change_s`` the
        effective PWM is the command itself (mode 0) or the command times ``gains`` (mode 1),
        and the mass is constant; mode 2 (time-varying or overriding faults) needs
        :meth:`actuator_inputs` at every step."""
        return self._act_mode, self._act_gain, self._mass_kg, self._next_change_s

    def _set_clock(self, time_s: float) -> None:
        """Set the clock as the calls :meth:`_stepping_state` stood in for would have."""
        self._clock_s = time_s

    def actuator_inputs(self, time_s: float, pwm_cmd: np.ndarray) -> np.ndarray:
        """PWM the motors see at ``time_s`` given the commanded ``pwm_cmd``.

        Parameters
        ----------
        time_s : float
            Simulated time of the plant step, s (non-decreasing).
        pwm_cmd : numpy.ndarray, shape (4,)
            Commanded PWM of motors 1..4 (unit PWM).

        Returns
        -------
        numpy.ndarray, shape (4,)
            Effective PWM. Without an active actuator fault this is ``pwm_cmd`` itself (not a
            copy); otherwise a new array. Not saturated.
        """
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        mode = self._act_mode
        if mode == 0:
            return pwm_cmd
        if mode == 1:
            return pwm_cmd * self._act_gain
        return self._actuators_general(time_s, pwm_cmd)

    def corrupt(self, sensor: str, time_s: float, value: np.ndarray,
                nominal_sigma: np.ndarray) -> np.ndarray:
        """Apply the active faults of ``sensor`` to a noisy reading.

        Parameters
        ----------
        sensor : str
            Sensor name (``"gyro"``, ``"accel"``, ``"mocap_pos"``, ``"mocap_att"``, ``"baro"``).
        time_s : float
            Simulated time of the reading, s (non-decreasing).
        value : numpy.ndarray, shape (n,)
            Reading with its nominal noise already added (sensor unit). Not modified.
        nominal_sigma : numpy.ndarray, shape (n,) or scalar
            Standard deviation of the noise already in ``value`` (sensor unit), the base of
            loss-of-accuracy faults.

        Returns
        -------
        numpy.ndarray, shape (n,)
            The reading the autopilot gets: ``value`` itself when no fault of ``sensor`` is
            active, else a new array. The engine remembers it for freeze faults.
        """
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        faults = self._sensor_groups.get(sensor)
        if faults is None:
            self._last_reading[sensor] = value
            return value
        out = self._corrupt_general(sensor, time_s, value, nominal_sigma, *faults)
        self._last_reading[sensor] = out
        return out

    # ------------------------------------------------------------------ internals
    def _emit(self, time_s: float, kind: EventKind, fault_id: int, fault: Fault) -> None:
        self.events.append(FaultEvent(time_s=float(time_s), kind=kind, fault_id=fault_id,
                                      description=fault.describe()))

    def _advance(self, time_s: float) -> None:
        """Start and end faults whose times have come, then rebuild the caches."""
        for fault_id, rec in list(self._records.items()):
            f = rec.fault
            if rec.state == _PENDING and time_s >= f.start_s:
                rec.state = _ACTIVE
                rec.t0 = float(time_s)
                self._emit(time_s, "started", fault_id, f)
            if rec.state == _ACTIVE and f.end_s is not None and time_s >= f.end_s:
                del self._records[fault_id]
                self._emit(time_s, "ended", fault_id, f)
        self._refresh()

    def _refresh(self) -> None:
        """Recompute the next change time and the caches from the records."""
        nxt = math.inf
        for rec in self._records.values():
            f = rec.fault
            if rec.state == _PENDING:
                nxt = min(nxt, f.start_s)
            elif f.end_s is not None:
                nxt = min(nxt, f.end_s)
        self._next_change_s = nxt
        self._rebuild()

    def _rebuild(self) -> None:
        """Group the active faults by motor and sensor; cache the mass and static gains."""
        by_motor: dict[int, list[_Record]] = {}
        by_sensor: dict[str, list[_Record]] = {}
        mass = self._base_mass_kg
        for rec in self._records.values():
            if rec.state != _ACTIVE:
                continue
            f = rec.fault
            if isinstance(f, ActuatorFault):
                by_motor.setdefault(f.motor - 1, []).append(rec)
            elif isinstance(f, SensorFault):
                by_sensor.setdefault(f.sensor, []).append(rec)
            else:
                mass -= f.mass_loss_kg
        self._mass_kg = mass

        def started(r: _Record) -> tuple[float, int]:
            return (r.t0, r.fault_id)

        groups = []
        gain = np.ones(4)
        static = True
        for idx in sorted(by_motor):
            recs = by_motor[idx]
            overrides = tuple(sorted((r for r in recs if r.kind in _OVERRIDE_KINDS),
                                     key=started))
            scalers = tuple(r for r in recs if r.kind not in _OVERRIDE_KINDS)
            groups.append((idx, overrides, scalers))
            for r in scalers:
                f = r.fault
                assert isinstance(f, ActuatorFault)
                if f.kind == "total_loss":
                    gain[idx] *= 0.0
                elif f.profile == "step":
                    gain[idx] *= 1.0 - f.loe
                else:
                    static = False
            if overrides:
                static = False
        self._act_groups: list[tuple[int, tuple[_Record, ...], tuple[_Record, ...]]] = groups
        self._act_gain = gain
        self._act_mode = 0 if not groups else (1 if static else 2)

        self._sensor_groups: dict[str, tuple[tuple[_Record, ...], tuple[_Record, ...]]] = {}
        for name, recs in by_sensor.items():
            additive = tuple(r for r in recs
                             if r.kind in ("bias", "drift", "loss_of_accuracy"))
            replacing = tuple(sorted((r for r in recs
                                      if r.kind in ("freeze", "calibration")),
                                     key=started))
            self._sensor_groups[name] = (additive, replacing)

    def _gamma(self, rec: _Record, time_s: float) -> float:
        """gamma of an effectiveness fault (loe or total_loss) at ``time_s``."""
        f = rec.fault
        assert isinstance(f, ActuatorFault)
        if f.kind != "loe":
            return 1.0
        profile = f.profile
        if profile == "step":
            return f.loe
        tau = time_s - rec.t0
        if profile == "sinusoid":
            # gamma = loe (1 - cos(2 pi tau / T)) / 2, in [0, loe], 0 at the start
            return f.loe * 0.5 * (1.0 - math.cos(2.0 * math.pi * tau / f.period_s))
        if profile == "pulse":
            return f.loe if tau % f.period_s < f.pulse_width_s else 0.0
        k = int(tau // f.hold_s)
        draws = rec.draws
        if draws is None or k >= draws.shape[0]:
            have = 0 if draws is None else draws.shape[0]
            blocks = (k + 1 - have + _RANDOM_BLOCK - 1) // _RANDOM_BLOCK
            new = [rec.rng.uniform(f.low, f.loe, size=_RANDOM_BLOCK) for _ in range(blocks)]
            draws = np.concatenate(new if draws is None else [draws, *new])
            rec.draws = draws
        return float(draws[k])

    def _actuators_general(self, time_s: float, pwm_cmd: np.ndarray) -> np.ndarray:
        out = np.array(pwm_cmd, dtype=float)
        for idx, overrides, scalers in self._act_groups:
            if overrides:
                for rec in overrides:
                    if rec.kind == "lock" and rec.held is None:
                        rec.held = float(pwm_cmd[idx])  # the command at onset
                kind = overrides[-1].kind  # the override that started last wins
                if kind == "lock":
                    base = overrides[-1].held
                elif kind == "float":
                    base = 0.0
                else:
                    base = self._pwm_max
            else:
                base = float(out[idx])
            eff = 1.0
            for rec in scalers:
                eff *= 1.0 - self._gamma(rec, time_s)  # eq. 4.10, effectivenesses multiply
            out[idx] = base * eff
        return out

    def _corrupt_general(self, sensor: str, time_s: float, value: np.ndarray,
                         nominal_sigma: np.ndarray, additive: tuple[_Record, ...],
                         replacing: tuple[_Record, ...]) -> np.ndarray:
        out = np.array(value, dtype=float)
        for rec in additive:
            f = rec.fault
            assert isinstance(f, SensorFault)
            sel: Any = slice(None) if f.axis is None else f.axis
            if f.kind == "bias":
                out[sel] += f.magnitude
            elif f.kind == "drift":
                out[sel] += f.magnitude + f.rate * (time_s - rec.t0)
            else:
                # total sigma s (1 + m/100) = sqrt(s^2 + s_extra^2)
                extra = math.sqrt((1.0 + f.magnitude / 100.0) ** 2 - 1.0)
                s = np.broadcast_to(np.asarray(nominal_sigma, dtype=float), out.shape)[sel]
                out[sel] += extra * s * rec.rng.standard_normal(np.shape(s))
        for rec in replacing:
            f = rec.fault
            assert isinstance(f, SensorFault)
            sel = slice(None) if f.axis is None else f.axis
            if f.kind == "calibration":
                low, high = f.garbage_range
                out[sel] = rec.rng.uniform(low, high, size=np.shape(out[sel]))
            else:
                if rec.held is None:
                    last = self._last_reading.get(sensor)
                    rec.held = np.array(out if last is None else last, dtype=float)
                out[sel] = rec.held[sel]
        return out
