"""The fault rules in plain Python: the reference that the compiled kernels are pinned to.

The product has one implementation of each rule, the kernels of :mod:`sim.world.fault_kernels`
(:class:`sim.world.faults.FaultEngine` calls them from Python too). This module writes the
rules of :mod:`sim.world.fault_types` again, independently, from the faults' own fields (not
the compiled table's copies of them), grouping an engine's active faults itself, so that a
wrong kernel, a wrong table row or a wrong layout shows as a difference
(``test_world_stepping.py``). It shares the engine's bookkeeping: its records (start times,
generators, rows) and the arrays holding what changes while a fault acts (a lock's held
command, a freeze's held reading, the draws, the last reading of each sensor), read and
written here as the kernels do.

:func:`use_reference_rules` makes an engine apply these instead of its kernels.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

import numpy as np

from sim.world.fault_types import SENSOR_NAMES, ActuatorFault, SensorFault
from sim.world.faults import ACTIVE, FaultEngine, FaultRecord

_OVERRIDES = ("lock", "float", "hardover")
_ADDITIVE = ("bias", "drift", "loss_of_accuracy")


def _started(rec: FaultRecord) -> tuple[float, int]:
    return (rec.t0, rec.fault_id)


def _active(engine: FaultEngine, time_s: float) -> list[FaultRecord]:
    """The engine's active records at ``time_s`` (starting and ending faults as it does)."""
    engine.mass_kg(time_s)  # sets the clock, starts and ends faults
    return [r for r in engine._records.values() if r.state == ACTIVE]  # (its bookkeeping)


def _motor_groups(engine: FaultEngine, time_s: float) -> dict[int, tuple[list[FaultRecord],
                                                                         list[FaultRecord]]]:
    """Motor index -> (overrides by start, effectiveness faults by id)."""
    groups: dict[int, tuple[list[FaultRecord], list[FaultRecord]]] = {}
    for rec in _active(engine, time_s):
        f = rec.fault
        if isinstance(f, ActuatorFault):
            overrides, scalers = groups.setdefault(f.motor - 1, ([], []))
            (overrides if f.kind in _OVERRIDES else scalers).append(rec)
    for overrides, _ in groups.values():
        overrides.sort(key=_started)
    return groups


# ---- draws ---------------------------------------------------------------------------------
def _gamma_draw(engine: FaultEngine, rec: FaultRecord, k: int) -> float:
    """The ``k``-th gamma of a random profile (drawn if need be)."""
    assert isinstance(rec.fault, ActuatorFault)
    arrays = engine.arrays
    arrays.ensure_gammas(rec.row, k + 1, rec.rng, rec.fault)
    return float(arrays.pool[int(arrays.table[rec.row]["draw_start"]) + k])


def _take(engine: FaultEngine, rec: FaultRecord, count: int) -> np.ndarray:
    """The next ``count`` draws of a loss-of-accuracy or calibration fault, consumed."""
    assert isinstance(rec.fault, SensorFault)
    arrays = engine.arrays
    arrays.ensure_unused(rec.row, count, rec.rng, rec.fault)
    row = arrays.table[rec.row]
    i = int(row["draw_next"])
    row["draw_next"] = i + count
    return arrays.pool[i:i + count]


# ---- actuator faults -----------------------------------------------------------------------
def gamma(engine: FaultEngine, rec: FaultRecord, time_s: float) -> float:
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
    # random: the k-th gamma drawn, k = floor(tau / hold_s)
    return _gamma_draw(engine, rec, int(tau // f.hold_s))


def actuator_inputs(engine: FaultEngine, time_s: float, pwm_cmd: np.ndarray) -> np.ndarray:
    """PWM the motors see at ``time_s``: per motor, the override that started last replaces
    the command (a lock holds the command of its first step), then
    ``u_f = prod_i (1 - gamma_i) u`` over the effectiveness faults (eq. 4.10); ``pwm_cmd``
    itself without an actuator fault, else a new array."""
    groups = _motor_groups(engine, time_s)
    if not groups:
        return pwm_cmd
    out = np.array(pwm_cmd, dtype=float)
    table = engine.arrays.table
    for idx, (overrides, scalers) in groups.items():
        if overrides:
            for rec in overrides:
                row = table[rec.row]
                if rec.fault.kind == "lock" and not row["has_held"]:  # type: ignore[union-attr]
                    row["held"][0] = float(pwm_cmd[idx])  # the command at onset
                    row["has_held"] = True
            last = overrides[-1].fault  # the override that started last wins
            assert isinstance(last, ActuatorFault)
            if last.kind == "lock":
                base = float(table[overrides[-1].row]["held"][0])
            elif last.kind == "float":
                base = 0.0
            else:
                base = engine.pwm_max
        else:
            base = float(out[idx])
        eff = 1.0
        for rec in scalers:
            eff *= 1.0 - gamma(engine, rec, time_s)  # eq. 4.10, effectivenesses multiply
        out[idx] = base * eff
    return out


def true_loe_values(engine: FaultEngine, time_s: float) -> tuple[float, float, float, float]:
    """Injected gamma per motor: NaN under a lock or hardover that decides, 1 under a float,
    else ``1 - prod(1 - gamma_i)`` (one fault's gamma exactly), 0 without a fault."""
    out = [0.0, 0.0, 0.0, 0.0]
    for idx, (overrides, scalers) in _motor_groups(engine, time_s).items():
        if overrides:
            out[idx] = 1.0 if overrides[-1].fault.kind == "float" else math.nan  # type: ignore[union-attr]
        elif len(scalers) == 1:
            out[idx] = gamma(engine, scalers[0], time_s)
        else:
            eff = 1.0
            for rec in scalers:
                eff *= 1.0 - gamma(engine, rec, time_s)
            out[idx] = 1.0 - eff
    return (out[0], out[1], out[2], out[3])


# ---- sensor faults -------------------------------------------------------------------------
def corrupt(engine: FaultEngine, sensor: str, time_s: float, value: np.ndarray,
            nominal_sigma: float) -> np.ndarray:
    """The reading after the active faults of ``sensor`` (``value`` itself without one, else a
    new array), remembered for freeze faults.

    Additive faults first, by id: bias ``+ magnitude``, drift ``+ magnitude + rate (t - t0)``,
    loss of accuracy ``+ sigma sqrt((1 + m/100)^2 - 1) z``; then replacing faults by start:
    calibration error (uniform readings), freeze (the reading reported before it started, or
    this one).
    """
    recs = [r for r in _active(engine, time_s)
            if isinstance(r.fault, SensorFault) and r.fault.sensor == sensor]
    i = SENSOR_NAMES.index(sensor)
    state = engine.arrays.state[0]
    if not recs:
        out = value
    else:
        additive = [r for r in recs if r.fault.kind in _ADDITIVE]  # type: ignore[union-attr]
        replacing = sorted((r for r in recs if r.fault.kind not in _ADDITIVE),  # type: ignore[union-attr]
                           key=_started)
        out = np.array(value, dtype=float)
        n = out.shape[0]
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
                z = _take(engine, rec, n if f.axis is None else 1)
                out[sel] += extra * nominal_sigma * (z if f.axis is None else z[0])
        for rec in replacing:
            f = rec.fault
            assert isinstance(f, SensorFault)
            sel = slice(None) if f.axis is None else f.axis
            if f.kind == "calibration":  # draws uniform in f.garbage_range
                z = _take(engine, rec, n if f.axis is None else 1)
                out[sel] = z if f.axis is None else z[0]
            else:
                row = engine.arrays.table[rec.row]
                if not row["has_held"]:  # the last reading reported, else this one
                    row["held"][:n] = state["last_reading"][i, :n] if state["has_last"][i] \
                        else out
                    row["has_held"] = True
                out[sel] = row["held"][:n][sel]
    state["last_reading"][i, :out.shape[0]] = out
    state["has_last"][i] = 1
    return out


def use_reference_rules(engine: FaultEngine) -> FaultEngine:
    """``engine``, its actuator_inputs, corrupt, true_loe and true_loe_values replaced by
    this module's (on the instance); returns it."""
    engine.actuator_inputs = partial(actuator_inputs, engine)  # type: ignore[method-assign]
    engine.corrupt = partial(corrupt, engine)  # type: ignore[method-assign]
    engine.true_loe_values = partial(true_loe_values, engine)  # type: ignore[method-assign]
    engine.true_loe = lambda t: np.array(true_loe_values(engine, t))  # type: ignore[method-assign]
    return engine
