"""The fault engine of the simulated world: schedules faults and applies them (thesis ch. 4).

The engine sits inside the plant (docs/design.md). The autopilot never reads it: a fault
reaches the autopilot only through what the sensors report and how the vehicle moves. What
each fault kind does, and how several compose, is documented in :mod:`sim.world.fault_types`,
which defines the faults and the events this engine emits.

Here ``t0`` is the simulated time at which a fault starts acting: the first engine call with
``time_s >= start_s`` (the plant calls the engine every step, so ``t0`` is the first plant step
at or after ``start_s``; it equals ``start_s`` when that lies on the step grid). A fault acts
for ``t0 <= t < end_s``.

The rules, compiled
-------------------
:meth:`FaultEngine.actuator_inputs`, :meth:`FaultEngine.corrupt` and
:meth:`FaultEngine.true_loe` apply the rules with the compiled kernels of
:mod:`sim.world.fault_kernels`, the one implementation of each (used when the world steps in
Python and by anyone calling the engine directly); the world's compiled steps call the same
kernels inside their steps. The state of the active faults (a lock's held command, a freeze's
held reading, the random draws, the last reading of each sensor, the clock) is kept in the
engine's arrays, :attr:`FaultEngine.arrays` (:mod:`sim.world.fault_arrays`), so the world may
switch between the two at any step. Starts, ends, scheduling, clearing and the random draws
only happen here, in Python.

Cost
----
The methods compare the time with a cached next-change time, so a step without faults costs
one comparison (and no kernel call); the active set is rebuilt only when a fault starts, ends,
is scheduled or is cleared. Each kernel is called through a :class:`jitsupport.calls.KernelCall`
with arguments of fixed types (float64 arrays of the engine's own, a float time), the types
that the precompile flights compile (:mod:`sim.preparation`).

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
from jitsupport.calls import KernelCall
from sim.world.fault_arrays import FaultArrays, new_row
from sim.world.fault_kernels import (
    actuator_draws_ready,
    apply_actuator_faults,
    corrupt_reading,
    sensor_draws_ready,
    true_loe_into,
)
from sim.world.fault_types import (
    ADDITIVE_KINDS,
    MOTORS,
    OVERRIDE_KINDS,
    SENSOR_AXES,
    SENSOR_NAMES,
    ActuatorFault,
    EventKind,
    Fault,
    FaultEvent,
    FaultKind,
    ScheduledFault,
    SensorFault,
    StructuralFault,
)

_SENSOR_INDEX = {name: i for i, name in enumerate(SENSOR_NAMES)}
_FLOAT64 = np.dtype(np.float64)
# the kernels' calls from Python (module docstring: Cost)
_actuator_draws_ready = KernelCall(actuator_draws_ready)
_apply_actuator_faults = KernelCall(apply_actuator_faults)
_true_loe_into = KernelCall(true_loe_into)
_sensor_draws_ready = KernelCall(sensor_draws_ready)
_corrupt_reading = KernelCall(corrupt_reading)

PENDING, ACTIVE = 0, 1  # FaultRecord.state


class FaultRecord:
    """The engine's bookkeeping of one scheduled fault (what changes while it acts is in the
    arrays, at ``row``)."""

    __slots__ = ("fault_id", "fault", "kind", "rng", "state", "t0", "row")

    def __init__(self, fault_id: int, fault: Fault, rng: np.random.Generator) -> None:
        self.fault_id = fault_id
        self.fault = fault
        kind = getattr(fault, "kind", None)  # (a structural fault has none)
        self.kind: FaultKind | None = None if kind is None else FaultKind.of(kind)
        self.rng = rng  # the fault's own generator (random profile, noise, garbage)
        self.state = PENDING
        self.t0 = math.nan  # s, time at which it started acting
        self.row = -1  # its row in the arrays' table while active (actuator, sensor faults)


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
        if self._act_mode == 0:
            values = (0.0, 0.0, 0.0, 0.0)
        else:
            a = self._actuator_arrays(time_s)
            out = np.empty(4)
            _true_loe_into.call(a.state, a.table, a.pool, float(time_s), out)
            values = (out.item(0), out.item(1), out.item(2), out.item(3))
        if self._act_mode != 2:  # no fault, or only steps and total losses: constant
            self._true_loe_static = values
        return values

    # ------------------------------------------------------------------ the rules
    def actuator_inputs(self, time_s: float, pwm_cmd: np.ndarray) -> np.ndarray:
        """PWM the motors see at ``time_s`` given the commanded ``pwm_cmd``
        (:func:`sim.world.fault_kernels.apply_actuator_faults`).

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

        Raises
        ------
        ValueError
            ``pwm_cmd`` is not of shape (4,) (checked when an actuator fault is active).
        """
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        if self._act_mode == 0:
            return pwm_cmd
        cmd = np.array(pwm_cmd, dtype=_FLOAT64)  # (a new C array: the kernel's argument type)
        if cmd.shape != (4,):
            raise ValueError(f"pwm_cmd shape {cmd.shape}: want (4,), motors 1..4")
        a = self._actuator_arrays(time_s)
        out = np.empty(4)
        _apply_actuator_faults.call(a.state, a.table, a.pool, float(time_s), cmd, out)
        return out

    def corrupt(self, sensor: str, time_s: float, value: np.ndarray,
                nominal_sigma: float) -> np.ndarray:
        """Apply the active faults of ``sensor`` to a noisy reading
        (:func:`sim.world.fault_kernels.corrupt_reading`).

        Parameters
        ----------
        sensor : str
            Sensor name (``"gyro"``, ``"accel"``, ``"mocap_pos"``, ``"mocap_att"``, ``"baro"``).
        time_s : float
            Simulated time of the reading, s (non-decreasing).
        value : numpy.ndarray, shape (n,)
            Reading with its nominal noise already added (sensor unit). Not modified.
        nominal_sigma : float
            Standard deviation of the noise already in each element of ``value`` (sensor
            unit), the base of loss-of-accuracy faults.

        Returns
        -------
        numpy.ndarray, shape (n,)
            The reading the autopilot gets: ``value`` itself when no fault of ``sensor`` is
            active, else a new array. The engine remembers it for freeze faults.
        """
        self._clock_s = time_s
        if time_s >= self._next_change_s:
            self._advance(time_s)
        i = _SENSOR_INDEX[sensor]
        if not self._sensor_faulty[i]:
            self.arrays.remember(i, value)
            return value
        out = np.array(value, dtype=_FLOAT64)  # (a new C array: the kernel's argument type)
        n = out.shape[0]
        a = self.arrays
        while not _sensor_draws_ready.call(a.state, a.table, i, n):
            self.refill_draws()
        _corrupt_reading.call(a.state, a.table, a.pool, i, float(time_s), out,
                              float(nominal_sigma))  # (and remembers it)
        return out

    # ------------------------------------------------------------------ draws
    def refill_draws(self) -> None:
        """Draw what a kernel found missing (the arrays' refill request), from the fault's
        own generator: a run draws the same numbers whichever path asked, and whenever."""
        request = self.arrays.refill_request()
        if request is None:
            return
        r, count = request
        rec = self._row_records[r]
        f = rec.fault
        if isinstance(f, ActuatorFault):  # a random profile's gammas
            self.arrays.ensure_gammas(r, count, rec.rng, f)
        else:
            assert isinstance(f, SensorFault)
            self.arrays.ensure_unused(r, count, rec.rng, f)

    def _actuator_arrays(self, time_s: float) -> FaultArrays:
        """The arrays, with every random profile's gamma for ``time_s`` drawn."""
        a = self.arrays
        while not _actuator_draws_ready.call(a.state, a.table, float(time_s)):
            self.refill_draws()
        return a

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
        """Group the active faults by motor and sensor, cache the mass, and lay out the table
        in the order the rules apply them (fault_kernels docstring)."""
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

        static = True  # no override, every effectiveness fault a step or a total loss
        order: list[FaultRecord] = []
        act_start = []
        for idx in range(4):
            act_start.append(len(order))
            recs = by_motor.get(idx, [])
            overrides = sorted((r for r in recs if r.kind in OVERRIDE_KINDS), key=started)
            scalers = [r for r in recs if r.kind not in OVERRIDE_KINDS]
            order += [*overrides, *scalers]
            static = static and not overrides and all(
                r.kind == FaultKind.TOTAL_LOSS or getattr(r.fault, "profile", "") == "step"
                for r in scalers)
        # 0: no actuator fault (the command passes as it is), 1: true_loe constant, 2: varies
        self._act_mode = 0 if not order else (1 if static else 2)
        self._true_loe_static = None  # true_loe_values's, while it cannot change

        sens_start = []
        for name in SENSOR_NAMES:
            sens_start.append(len(order))
            recs = by_sensor.get(name, [])
            additive = [r for r in recs if r.kind in ADDITIVE_KINDS]
            replacing = sorted((r for r in recs if r.kind not in ADDITIVE_KINDS), key=started)
            order += [*additive, *replacing]
        sens_start.append(len(order))
        self._sensor_faulty = [sens_start[i] < sens_start[i + 1]
                               for i in range(len(SENSOR_NAMES))]
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
