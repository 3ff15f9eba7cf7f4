"""The fault rules in Python: the reference that :mod:`sim.world.fault_kernels` compiles.

:class:`sim.world.faults.FaultEngine` groups its active faults by motor and by sensor and
calls these functions when the world steps in Python (or when anyone calls the engine
directly). The rules are those of :mod:`sim.world.fault_types`; what changes while a fault
acts (a lock's held command, a freeze's held reading, the random draws, the last reading of
each sensor) is read and written in the engine's :class:`sim.world.fault_arrays.FaultArrays`,
the same arrays the compiled rules use, so the world may switch between them at any step.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sim.world.fault_arrays import FaultArrays
from sim.world.fault_types import ActuatorFault, Fault, SensorFault

PENDING, ACTIVE = 0, 1  # FaultRecord.state


class FaultRecord:
    """The engine's bookkeeping of one scheduled fault (what changes while it acts is in the
    arrays, at ``row``)."""

    __slots__ = ("fault_id", "fault", "kind", "rng", "state", "t0", "row")

    def __init__(self, fault_id: int, fault: Fault, rng: np.random.Generator) -> None:
        self.fault_id = fault_id
        self.fault = fault
        self.kind: str = getattr(fault, "kind", "structural")
        self.rng = rng  # the fault's own generator (random profile, noise, garbage)
        self.state = PENDING
        self.t0 = math.nan  # s, time at which it started acting
        self.row = -1  # its row in the arrays' table while active (actuator, sensor faults)


MotorGroup = tuple[int, tuple[FaultRecord, ...], tuple[FaultRecord, ...]]
"""(motor index 0..3, overrides by start, effectiveness faults by id)."""
SensorGroup = tuple[tuple[FaultRecord, ...], tuple[FaultRecord, ...]]
"""(additive faults by id, replacing faults by start) of one sensor."""


# ---- draws -------------------------------------------------------------------------------
def ensure_gammas(rec: FaultRecord, count: int, arrays: FaultArrays) -> None:
    """Give a random-profile fault at least ``count`` gammas (from its generator)."""
    assert isinstance(rec.fault, ActuatorFault)
    arrays.ensure_gammas(rec.row, count, rec.rng, rec.fault)


def ensure_unused(rec: FaultRecord, count: int, arrays: FaultArrays) -> None:
    """Give a loss-of-accuracy or calibration fault at least ``count`` unused draws."""
    assert isinstance(rec.fault, SensorFault)
    arrays.ensure_unused(rec.row, count, rec.rng, rec.fault)


def _take(rec: FaultRecord, count: int, arrays: FaultArrays) -> np.ndarray:
    """The next ``count`` draws of a loss-of-accuracy or calibration fault."""
    ensure_unused(rec, count, arrays)
    return arrays.take(rec.row, count)


# ---- actuator faults ---------------------------------------------------------------------
def gamma(rec: FaultRecord, time_s: float, arrays: FaultArrays) -> float:
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
    k = int(tau // f.hold_s)
    ensure_gammas(rec, k + 1, arrays)
    return arrays.draw(rec.row, k)


def actuators(groups: list[MotorGroup], time_s: float, pwm_cmd: np.ndarray, pwm_max: float,
              arrays: FaultArrays) -> np.ndarray:
    """PWM the motors see at ``time_s`` (a new array): per motor, the override that started
    last replaces the command (a lock holds the command of its first step), then
    ``u_f = prod_i (1 - gamma_i) u`` over the effectiveness faults (eq. 4.10)."""
    out = np.array(pwm_cmd, dtype=float)
    table = arrays.table
    for idx, overrides, scalers in groups:
        if overrides:
            for rec in overrides:
                row = table[rec.row]
                if rec.kind == "lock" and not row["has_held"]:
                    row["held"][0] = float(pwm_cmd[idx])  # the command at onset
                    row["has_held"] = True
            last = overrides[-1]  # the override that started last wins
            if last.kind == "lock":
                base = float(table[last.row]["held"][0])
            elif last.kind == "float":
                base = 0.0
            else:
                base = pwm_max
        else:
            base = float(out[idx])
        eff = 1.0
        for rec in scalers:
            eff *= 1.0 - gamma(rec, time_s, arrays)  # eq. 4.10, effectivenesses multiply
        out[idx] = base * eff
    return out


# ---- sensor faults -----------------------------------------------------------------------
def corrupt(group: SensorGroup, sensor: int, time_s: float, value: np.ndarray,
            nominal_sigma: np.ndarray, arrays: FaultArrays) -> np.ndarray:
    """The reading of sensor index ``sensor`` after its active faults (a new array).

    Additive faults first, by id: bias ``+ magnitude``, drift ``+ magnitude + rate (t - t0)``,
    loss of accuracy ``+ sigma sqrt((1 + m/100)^2 - 1) z``; then replacing faults by start:
    calibration error (uniform readings), freeze (the reading reported before it started, or
    this one).
    """
    additive, replacing = group
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
            z = _take(rec, out.shape[0] if f.axis is None else 1, arrays)
            out[sel] += extra * s * (z if f.axis is None else z[0])
    for rec in replacing:
        f = rec.fault
        assert isinstance(f, SensorFault)
        sel = slice(None) if f.axis is None else f.axis
        if f.kind == "calibration":  # draws uniform in f.garbage_range
            z = _take(rec, out.shape[0] if f.axis is None else 1, arrays)
            out[sel] = z if f.axis is None else z[0]
        else:
            row = arrays.table[rec.row]
            n = out.shape[0]
            if not row["has_held"]:  # the last reading reported, else this one
                last = arrays.last_reading(sensor, n)
                row["held"][:n] = out if last is None else last
                row["has_held"] = True
            out[sel] = row["held"][:n][sel]
    return out


__all__ = ["ACTIVE", "PENDING", "FaultRecord", "MotorGroup", "SensorGroup", "actuators",
           "corrupt", "ensure_gammas", "ensure_unused", "gamma"]
