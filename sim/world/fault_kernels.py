"""The fault rules, compiled: actuator effects and sensor corruption on the engine's arrays.

These kernels are the one implementation of the rules of :mod:`sim.world.fault_types`.
:class:`sim.world.faults.FaultEngine` keeps the state of its active faults in the three arrays
below (:class:`sim.world.fault_arrays.FaultArrays`) and calls these kernels on them from
Python (when the world steps in Python, or anyone calls the engine directly); the world's
compiled stepping (:mod:`sim.world.stepping`) calls them inside its steps. Both read and write
the same arrays, so the world can take one step in Python and the next compiled. Kinds and
profiles are compared with the members of :class:`~sim.world.fault_types.FaultKind` and
:class:`~sim.world.fault_types.FaultProfile` (constants once compiled).
``tests/sim/world/test_world_stepping.py`` pins these kernels bit for bit to an independent
Python reference of the rules kept with the tests.

Arrays
------
``state``: one :data:`ENGINE_STATE` record: the engine's clock, the next time a fault starts
or ends, the mass, where each motor's and sensor's rows start in ``table``, the last reading
reported per sensor (what a freeze holds) and a refill request.

``table``: one :data:`FAULT_ROW` per *active* actuator or sensor fault, in the order the rules
apply them (rebuilt whenever a fault starts, ends or is cleared)::

    motor 1: overrides (lock, float, hardover) by start, then effectiveness faults by id
    ...
    motor 4
    gyro:    additive faults (bias, drift, loss of accuracy) by id, then replacing faults
    ...      (freeze, calibration) by start
    baro

    rows of motor m:  state.act_start[m] <= row < state.act_start[m + 1]   (m = 0..3)
    rows of sensor i: state.sens_start[i] <= row < state.sens_start[i + 1]  (i = 0..4)

``pool``: pre-drawn random numbers. A row that draws (random LOE profile, loss of accuracy,
calibration error) owns ``pool[draw_start:draw_end]``, drawn from the fault's own generator:
gamma per hold interval (``draw_start + k``) for the random profile, one value per corrupted
element (consumed from ``draw_next``) for the others. When a kernel finds a segment too short
it takes no step and records the row and the count it needs in ``state``
(:func:`request_draws`); :meth:`FaultEngine.refill_draws` draws more from the same generator,
so the numbers do not depend on when, or by which path, they were asked for.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from jitsupport.cache import drop_stale_kernels
from sim.world.fault_types import FaultKind, FaultProfile

drop_stale_kernels(__file__)  # the kernels compile in fault_types' kind and profile codes

N_SENSORS = 5  # gyro, accel, mocap_pos, mocap_att, baro (fault_types.SENSOR_NAMES)

ENGINE_STATE = np.dtype([
    ("clock_s", np.float64),  # s, latest simulated time given to the engine
    ("next_change_s", np.float64),  # s, next start or end of a scheduled fault (inf: none)
    ("mass_kg", np.float64),  # kg, airframe mass after the active structural faults
    ("pwm_max", np.float64),  # PWM duty of a hard-over motor
    ("act_start", np.int64, (5,)),  # first table row of motor m; [4]: first sensor row
    ("sens_start", np.int64, (N_SENSORS + 1,)),  # first row of sensor i; [5]: rows in table
    ("last_reading", np.float64, (N_SENSORS, 3)),  # sensor unit, last reading reported
    ("has_last", np.int8, (N_SENSORS,)),  # 1 once a reading was reported since reset
    ("refill_row", np.int64),  # row whose draws ran short in a kernel, -1 when none
    ("refill_count", np.int64),  # draws it needs: from draw_start (random) or draw_next
], align=True)
"""The engine's scalars and per-sensor memory (one record, module docstring)."""

FAULT_ROW = np.dtype([
    ("fault_id", np.int64),  # -, id given by FaultEngine.schedule
    ("kind", np.int64),  # -, FaultKind
    ("target", np.int64),  # -, motor index 0..3 or sensor index 0..4
    ("axis", np.int64),  # -, sensor axis 0..2, -1 for all axes
    ("profile", np.int64),  # -, FaultProfile (kind loe)
    ("loe", np.float64),  # -, gamma (eq. 4.10) or the profile's peak
    ("period_s", np.float64),  # s, sinusoid and pulse period
    ("pulse_width_s", np.float64),  # s, pulse width
    ("hold_s", np.float64),  # s, random profile hold
    ("magnitude", np.float64),  # sensor unit: bias, drift offset
    ("rate", np.float64),  # sensor unit per s: drift slope
    ("noise_gain", np.float64),  # -, loss of accuracy: sqrt((1 + magnitude/100)^2 - 1)
    ("t0_s", np.float64),  # s, time the fault started acting
    ("has_held", np.bool_),  # lock/freeze: the held value was captured
    ("held", np.float64, (3,)),  # lock: [0] the command at onset; freeze: the held reading
    ("draw_start", np.int64),  # first pool index of the row's draws
    ("draw_next", np.int64),  # next unused pool index (loss of accuracy, calibration)
    ("draw_end", np.int64),  # one past the last pool index drawn so far
], align=True)
"""One active actuator or sensor fault (module docstring)."""


# ---- draws -------------------------------------------------------------------------------
@njit(cache=True)
def request_draws(state: np.ndarray, row: int, count: int) -> None:
    """Ask Python to give ``row`` at least ``count`` draws (module docstring)."""
    s = state[0]
    s.refill_row = row
    s.refill_count = count


@njit(cache=True)
def _random_index(table: np.ndarray, r: int, time_s: float) -> int:
    """Hold interval of row ``r``'s random profile at ``time_s``: k = floor((t - t0) / hold)."""
    row = table[r]
    return int((time_s - row.t0_s) // row.hold_s)


@njit(cache=True)
def actuator_draws_ready(state: np.ndarray, table: np.ndarray, time_s: float) -> bool:
    """True when every random-profile row has its gamma for ``time_s`` in the pool; else
    request the draws and return False."""
    s = state[0]
    for r in range(s.act_start[0], s.act_start[4]):
        row = table[r]
        if row.kind == FaultKind.LOE and row.profile == FaultProfile.RANDOM:
            k = _random_index(table, r, time_s)
            if row.draw_start + k >= row.draw_end:
                request_draws(state, r, k + 1)
                return False
    return True


@njit(cache=True)
def sensor_draws_ready(state: np.ndarray, table: np.ndarray, sensor: int, n_axes: int) -> bool:
    """True when the rows of ``sensor`` that draw have enough for one more reading; else
    request the draws and return False."""
    s = state[0]
    for r in range(s.sens_start[sensor], s.sens_start[sensor + 1]):
        row = table[r]
        if row.kind == FaultKind.LOSS_OF_ACCURACY or row.kind == FaultKind.CALIBRATION:
            need = n_axes if row.axis < 0 else 1
            if row.draw_next + need > row.draw_end:
                request_draws(state, r, need)
                return False
    return True


# ---- actuator faults ---------------------------------------------------------------------
@njit(cache=True)
def _gamma(table: np.ndarray, r: int, pool: np.ndarray, time_s: float) -> float:
    """gamma of the effectiveness fault in row ``r`` at ``time_s`` (its draws must be in the
    pool)."""
    row = table[r]
    if row.kind != FaultKind.LOE:
        return 1.0  # total_loss
    profile = row.profile
    if profile == FaultProfile.STEP:
        return row.loe
    tau = time_s - row.t0_s
    if profile == FaultProfile.SINUSOID:
        # gamma = loe (1 - cos(2 pi tau / T)) / 2, in [0, loe], 0 at the start
        return row.loe * 0.5 * (1.0 - math.cos(2.0 * math.pi * tau / row.period_s))
    if profile == FaultProfile.PULSE:
        # gamma = loe during the first pulse_width_s of every period_s
        return row.loe if tau % row.period_s < row.pulse_width_s else 0.0
    # random: the k-th drawn gamma, k = floor(tau / hold_s)
    gamma: float = pool[row.draw_start + int(tau // row.hold_s)]
    return gamma


@njit(cache=True)
def apply_actuator_faults(state: np.ndarray, table: np.ndarray, pool: np.ndarray,
                          time_s: float, pwm_cmd: np.ndarray, out: np.ndarray) -> None:
    """PWM the motors see at ``time_s`` (:meth:`FaultEngine.actuator_inputs`) into ``out``.

    Per motor: the override that started last replaces the command (a lock holds the command
    of its first step), then ``u_f = prod_i (1 - gamma_i) u`` over the effectiveness faults
    (eq. 4.10). Random-profile draws must be in the pool (:func:`actuator_draws_ready`).
    """
    s = state[0]
    for m in range(4):
        out[m] = pwm_cmd[m]
    for m in range(4):
        first, stop = s.act_start[m], s.act_start[m + 1]
        if first == stop:
            continue
        base = out[m]
        eff = 1.0
        for r in range(first, stop):
            row = table[r]
            kind = row.kind
            if kind == FaultKind.LOCK:
                if not row.has_held:  # the command at onset
                    row.held[0] = pwm_cmd[m]
                    row.has_held = True
                base = row.held[0]  # overrides come by start: the last one wins
            elif kind == FaultKind.FLOAT:
                base = 0.0
            elif kind == FaultKind.HARDOVER:
                base = s.pwm_max
            else:
                eff *= 1.0 - _gamma(table, r, pool, time_s)  # eq. 4.10, effectivenesses multiply
        out[m] = base * eff


@njit(cache=True)
def true_loe_into(state: np.ndarray, table: np.ndarray, pool: np.ndarray, time_s: float,
                  out: np.ndarray) -> None:
    """Injected loss of effectiveness of each motor at ``time_s`` into ``out``
    (:meth:`FaultEngine.true_loe`): with an override, 1 when the one that decides is a float
    (no thrust at any command), else NaN (lock, hardover: no gamma describes them); without,
    the gamma of a single effectiveness fault, ``1 - prod_i (1 - gamma_i)`` of several, 0 of
    none. Random-profile draws must be in the pool (:func:`actuator_draws_ready`)."""
    s = state[0]
    for m in range(4):
        last = -1  # kind of the override that started last (they come first, by start)
        n = 0
        gamma = 0.0
        eff = 1.0
        for r in range(s.act_start[m], s.act_start[m + 1]):
            kind = table[r].kind
            if kind == FaultKind.LOCK or kind == FaultKind.FLOAT or kind == FaultKind.HARDOVER:
                last = kind
            elif last < 0:
                gamma = _gamma(table, r, pool, time_s)
                eff *= 1.0 - gamma
                n += 1
        if last >= 0:
            out[m] = 1.0 if last == FaultKind.FLOAT else math.nan
        elif n > 1:
            out[m] = 1.0 - eff
        else:
            out[m] = gamma  # one fault's gamma exactly (0.0 without any)


# ---- sensor faults -----------------------------------------------------------------------
@njit(cache=True)
def corrupt_reading(state: np.ndarray, table: np.ndarray, pool: np.ndarray, sensor: int,
                    time_s: float, value: np.ndarray, sigma: float) -> None:
    """Apply the active faults of ``sensor`` to its noisy reading ``value`` in place
    (:meth:`FaultEngine.corrupt`) and remember the result for freeze faults.

    ``value`` holds the sensor's elements (3, or 1 for the barometer), ``sigma`` the nominal
    noise sigma already in it. Additive faults first, by id: bias ``+ magnitude``, drift
    ``+ magnitude + rate (t - t0)``, loss of accuracy ``+ g sigma z`` (z ~ N(0, 1) from the
    pool, ``g = noise_gain``); then replacing faults by start: calibration error (uniform
    draws from the pool), freeze (the reading reported before it started, or this one).
    Draws must be in the pool (:func:`sensor_draws_ready`).
    """
    s = state[0]
    n = value.shape[0]
    for r in range(s.sens_start[sensor], s.sens_start[sensor + 1]):
        row = table[r]
        kind = row.kind
        lo = 0 if row.axis < 0 else row.axis
        hi = n if row.axis < 0 else row.axis + 1
        if kind == FaultKind.BIAS:
            for a in range(lo, hi):
                value[a] += row.magnitude
        elif kind == FaultKind.DRIFT:
            for a in range(lo, hi):
                value[a] += row.magnitude + row.rate * (time_s - row.t0_s)
        elif kind == FaultKind.LOSS_OF_ACCURACY:
            # total sigma s (1 + m/100) = sqrt(s^2 + (g s)^2)
            for a in range(lo, hi):
                value[a] += row.noise_gain * sigma * pool[row.draw_next]
                row.draw_next += 1
        elif kind == FaultKind.CALIBRATION:
            for a in range(lo, hi):  # uniform in [low, high], drawn as such
                value[a] = pool[row.draw_next]
                row.draw_next += 1
        else:  # freeze
            if not row.has_held:
                for a in range(n):
                    row.held[a] = s.last_reading[sensor, a] if s.has_last[sensor] else value[a]
                row.has_held = True
            for a in range(lo, hi):
                value[a] = row.held[a]
    for a in range(n):
        s.last_reading[sensor, a] = value[a]
    s.has_last[sensor] = 1
