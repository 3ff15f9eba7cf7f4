"""The fault engine of the simulated world: schedules faults and applies them (thesis ch. 4).

The engine sits inside the plant (docs/design.md). The autopilot never reads it: a fault
reaches the autopilot only through what the sensors report and how the vehicle moves. What
each fault kind does, and how several compose, is documented in :mod:`sim.world.fault_types`,
which defines the faults and the events this engine emits.

Here ``t0`` is the simulated time at which a fault starts acting: the first engine call with
``time_s >= start_s`` (the plant calls the engine every step, so ``t0`` is the first plant step
at or after ``start_s``; it equals ``start_s`` when that lies on the step grid). A fault acts
for ``t0 <= t < end_s``.

Two implementations, one state
-------------------------------
:meth:`FaultEngine.actuator_inputs`, :meth:`FaultEngine.corrupt` and
:meth:`FaultEngine.mass_kg` apply the rules in Python: the reference, used when the world
steps in Python and by anyone calling the engine directly. :mod:`sim.world.fault_kernels`
applies the same rules compiled, inside the world's compiled steps. Both keep the state of
the active faults (a lock's held command, a freeze's held reading, the random draws, the
last reading of each sensor, the clock) in the engine's arrays, :attr:`FaultEngine.arrays`
(:mod:`sim.world.fault_arrays`), so the world may switch between them at any step. Starts,
ends, scheduling and clearing only happen here, in Python.

Cost
----
The Python methods compare the time with a cached next-change time and return cached
results, so a step without faults costs one comparison; the active set is rebuilt only when a
fault starts, ends, is scheduled or is cleared.

The engine is not thread-safe: a MAVLink endpoint on another thread should queue injections
for the simulation loop, which applies them between steps (:meth:`FaultEngine.apply_now`,
:meth:`FaultEngine.clear_matching`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from flightdata.config import finite, require
from sim.world import fault_rules
from sim.world.fault_arrays import FaultArrays, keeps_all_draws, new_row
from sim.world.fault_rules import ACTIVE, PENDING, FaultRecord, MotorGroup, SensorGroup
from sim.world.fault_types import (
    MOTORS,
    SENSOR_AXES,
    SENSOR_NAMES,
    ActuatorFault,
    EventKind,
    Fault,
    FaultEvent,
    ScheduledFault,
    SensorFault,
    StructuralFault,
)

_OVERRIDE_KINDS = ("lock", "float", "hardover")
_ADDITIVE_KINDS = ("bias", "drift", "loss_of_accuracy")
_SENSOR_INDEX = {name: i for i, name in enumerate(SENSOR_NAMES)}


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

    Attributes
    ----------
    events : list of FaultEvent
        Every event since construction or :meth:`reset`, oldest first.
    arrays : FaultArrays
        The state of the active faults as arrays (``state``, ``table``, ``pool``): what the
        world's compiled steps read and change with :mod:`sim.world.fault_kernels`.

    Notes
    -----
    Time given to the engine must not go backwards; call :meth:`reset` to start a new run.
    Methods that take no time (:meth:`schedule`, :meth:`clear` without ``time_s``) stamp their
    events with :attr:`clock_s`, the latest simulated time the engine was given. The arrays
    belong to the engine: the world's compiled steps change them in place through
    :mod:`sim.world.fault_kernels`, nothing else should.
    """

    def __init__(self, rng: np.random.Generator, pwm_max: float, base_mass_kg: float) -> None:
        require(finite(pwm_max) and pwm_max > 0.0, "pwm_max", pwm_max, "must be > 0")
        require(finite(base_mass_kg) and base_mass_kg > 0.0, "base_mass_kg", base_mass_kg,
                "must be > 0 kg")
        self._rng = rng
        self._pwm_max = float(pwm_max)
        self._base_mass_kg = float(base_mass_kg)
        self.events: list[FaultEvent] = []
        self._records: dict[int, FaultRecord] = {}
        self.arrays = FaultArrays(self._pwm_max)
        self._true_loe_static: tuple[float, float, float, float] | None = None
        self.reset()

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        """Forget every fault and event and restart the clock at 0 (the rng is not rewound)."""
        self._records.clear()
        self.events.clear()
        self._drained = 0
        self._next_id = 1
        self.arrays.reset()
        self._row_records: list[FaultRecord] = []
        self._next_change_s = math.inf
        self._rebuild()

    @property
    def _clock_s(self) -> float:
        return self.arrays.clock_s

    @_clock_s.setter
    def _clock_s(self, time_s: float) -> None:
        self.arrays.clock_s = time_s

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

    @property
    def next_change_s(self) -> float:
        """Next time a scheduled fault starts or ends, s (inf when none will)."""
        return self._next_change_s

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
        self._records[fault_id] = FaultRecord(fault_id, fault, np.random.default_rng(seed))
        self._emit(self._clock_s, "injected", fault_id, fault)
        self._set_next_change(min(self._next_change_s, fault.start_s))
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
        if isinstance(target, int) and not isinstance(target, bool) and target in MOTORS:
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
                if r.state == ACTIVE]

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
            (see :mod:`sim.world.fault_types`) decides between 1 and NaN.
        """
        return np.array(self.true_loe_values(time_s))

    def true_loe_values(self, time_s: float) -> tuple[float, float, float, float]:
        """:meth:`true_loe` as four floats (a per-tick log's row). Between two changes of the
        active faults it is worked out once when every effectiveness fault is a step (or
        there is none): it cannot change with time then."""
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        values = self._true_loe_static
        if values is not None:
            return values
        out = [0.0, 0.0, 0.0, 0.0]
        for idx, overrides, scalers in self._act_groups:
            if overrides and overrides[-1].kind != "float":
                out[idx] = math.nan
            elif overrides:
                out[idx] = 1.0
            elif len(scalers) == 1:
                out[idx] = fault_rules.gamma(scalers[0], time_s, self.arrays)  # exactly
            else:
                eff = 1.0
                for rec in scalers:
                    eff *= 1.0 - fault_rules.gamma(rec, time_s, self.arrays)
                out[idx] = 1.0 - eff
        values = (out[0], out[1], out[2], out[3])
        if self._act_mode != 2:  # no fault, or only steps and total losses: constant
            self._true_loe_static = values
        return values

    # ------------------------------------------------------------------ the Python rules
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
        return fault_rules.actuators(self._act_groups, time_s, pwm_cmd, self._pwm_max,
                                     self.arrays)

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
        out = value if faults is None else fault_rules.corrupt(
            faults, _SENSOR_INDEX[sensor], time_s, value, nominal_sigma, self.arrays)
        self.arrays.remember(_SENSOR_INDEX[sensor], out)
        return out

    # ------------------------------------------------------------------ draws
    def refill_draws(self) -> None:
        """Draw what a compiled kernel found missing (the arrays' refill request).

        The draws come from the fault's own generator in the order the Python rules take
        them, so a run draws the same numbers whichever path asked first.
        """
        request = self.arrays.refill_request()
        if request is None:
            return
        r, count = request
        rec = self._row_records[r]
        if keeps_all_draws(self.arrays.table[r]):
            fault_rules.ensure_gammas(rec, count, self.arrays)
        else:
            fault_rules.ensure_unused(rec, count, self.arrays)

    # ------------------------------------------------------------------ internals
    def _emit(self, time_s: float, kind: EventKind, fault_id: int, fault: Fault) -> None:
        self.events.append(FaultEvent(time_s=float(time_s), kind=kind, fault_id=fault_id,
                                      description=fault.describe(), fault=fault))

    def _set_next_change(self, time_s: float) -> None:
        self._next_change_s = time_s
        self.arrays.set_next_change(time_s)

    def _advance(self, time_s: float) -> None:
        """Start and end faults whose times have come, then rebuild the caches."""
        for fault_id, rec in list(self._records.items()):
            f = rec.fault
            if rec.state == PENDING and time_s >= f.start_s:
                rec.state = ACTIVE
                rec.t0 = float(time_s)
                self._emit(time_s, "started", fault_id, f)
            if rec.state == ACTIVE and f.end_s is not None and time_s >= f.end_s:
                del self._records[fault_id]
                self._emit(time_s, "ended", fault_id, f)
        self._refresh()

    def _refresh(self) -> None:
        """Recompute the next change time and the caches from the records."""
        nxt = math.inf
        for rec in self._records.values():
            f = rec.fault
            if rec.state == PENDING:
                nxt = min(nxt, f.start_s)
            elif f.end_s is not None:
                nxt = min(nxt, f.end_s)
        self._set_next_change(nxt)
        self._rebuild()

    def _rebuild(self) -> None:
        """Group the active faults by motor and sensor, cache the mass and static gains, and
        lay out the table in the order the rules apply them (fault_kernels docstring)."""
        by_motor: dict[int, list[FaultRecord]] = {}
        by_sensor: dict[str, list[FaultRecord]] = {}
        mass = self._base_mass_kg
        for rec in self._records.values():
            if rec.state != ACTIVE:
                continue
            f = rec.fault
            if isinstance(f, ActuatorFault):
                by_motor.setdefault(f.motor - 1, []).append(rec)
            elif isinstance(f, SensorFault):
                by_sensor.setdefault(f.sensor, []).append(rec)
            else:
                mass -= f.mass_loss_kg
        self._mass_kg = mass

        def started(r: FaultRecord) -> tuple[float, int]:
            return (r.t0, r.fault_id)

        groups = []
        gain = np.ones(4)
        static = True
        order: list[FaultRecord] = []
        act_start = []
        for idx in range(4):
            act_start.append(len(order))
            recs = by_motor.get(idx, [])
            if not recs:
                continue
            overrides = tuple(sorted((r for r in recs if r.kind in _OVERRIDE_KINDS),
                                     key=started))
            scalers = tuple(r for r in recs if r.kind not in _OVERRIDE_KINDS)
            groups.append((idx, overrides, scalers))
            order += [*overrides, *scalers]
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
        self._act_groups: list[MotorGroup] = groups
        self._act_gain = gain
        self._act_mode = 0 if not groups else (1 if static else 2)
        self._true_loe_static = None  # true_loe_values's, while it cannot change

        self._sensor_groups: dict[str, SensorGroup] = {}
        sens_start = []
        for name in SENSOR_NAMES:
            sens_start.append(len(order))
            recs = by_sensor.get(name, [])
            if not recs:
                continue
            additive = tuple(r for r in recs if r.kind in _ADDITIVE_KINDS)
            replacing = tuple(sorted((r for r in recs if r.kind not in _ADDITIVE_KINDS),
                                     key=started))
            self._sensor_groups[name] = (additive, replacing)
            order += [*additive, *replacing]
        sens_start.append(len(order))
        self._lay_out(order, act_start + [sens_start[0]], sens_start)

    def _lay_out(self, order: list[FaultRecord], act_start: list[int],
                 sens_start: list[int]) -> None:
        """Give the arrays a table in ``order``, keeping the rows of faults already active."""
        rows = [rec.row if rec.row >= 0 else new_row(rec.fault_id, rec.fault, rec.t0)
                for rec in order]
        for rec in self._row_records:
            rec.row = -1
        for r, rec in enumerate(order):
            rec.row = r
        self._row_records = order
        self.arrays.lay_out(rows, act_start, sens_start, self._mass_kg)


__all__ = ["FaultEngine"]
