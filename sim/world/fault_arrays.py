"""The fault engine's three arrays and the Python operations that reshape them.

:class:`FaultArrays` owns the ``state``, ``table`` and ``pool`` arrays laid out in
:mod:`sim.world.fault_kernels` (read there for what each holds). The compiled rules read and
change the values in place; only the methods here change the layout: a new table when faults
start, end or are cleared, a new pool when draws are added. A row's kind and profile codes
come from :class:`sim.world.fault_types.FaultKind` and
:class:`~sim.world.fault_types.FaultProfile`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sim.world.fault_kernels import ENGINE_STATE, FAULT_ROW
from sim.world.fault_types import (
    DRAWING_KINDS,
    SENSOR_NAMES,
    ActuatorFault,
    Fault,
    FaultKind,
    FaultProfile,
    SensorFault,
)

RANDOM_BLOCK = 64  # random-profile gammas drawn at a time
SEQUENTIAL_BLOCK = 256  # loss-of-accuracy normals or calibration readings drawn at a time


def new_row(fault_id: int, fault: Fault, t0_s: float) -> np.ndarray:
    """The FAULT_ROW of an actuator or sensor fault that started at ``t0_s`` (no held value,
    no draws yet)."""
    row = np.zeros((), dtype=FAULT_ROW)
    row["fault_id"] = fault_id
    row["kind"] = FaultKind.of(getattr(fault, "kind", ""))
    row["t0_s"] = t0_s
    row["axis"] = -1
    if isinstance(fault, ActuatorFault):
        row["target"] = fault.motor - 1
        row["profile"] = FaultProfile.of(fault.profile)
        for name in ("loe", "period_s", "pulse_width_s", "hold_s"):
            row[name] = getattr(fault, name)
    elif isinstance(fault, SensorFault):
        row["target"] = SENSOR_NAMES.index(fault.sensor)
        row["axis"] = -1 if fault.axis is None else fault.axis
        row["magnitude"] = fault.magnitude
        row["rate"] = fault.rate
        if fault.kind == "loss_of_accuracy":
            row["noise_gain"] = math.sqrt((1.0 + fault.magnitude / 100.0) ** 2 - 1.0)
    return row


def keeps_all_draws(row: np.void) -> bool:
    """A random profile indexes its draws from the start; other rows consume them in order."""
    return bool(row["kind"] == FaultKind.LOE and row["profile"] == FaultProfile.RANDOM)


def _draws(row: np.void) -> bool:
    """The row owns a segment of the pool."""
    return keeps_all_draws(row) or int(row["kind"]) in DRAWING_KINDS


class FaultArrays:
    """The arrays of :mod:`sim.world.fault_kernels`, created complete (no active fault).

    Parameters
    ----------
    pwm_max : float
        PWM duty of a hard-over motor.

    Attributes
    ----------
    state : numpy.ndarray
        One ENGINE_STATE record; the same array for the object's life.
    table : numpy.ndarray
        FAULT_ROW records of the active faults; replaced by :meth:`lay_out`.
    pool : numpy.ndarray
        float64 draws; replaced whenever draws are added or rows go.
    """

    def __init__(self, pwm_max: float) -> None:
        self._pwm_max = float(pwm_max)
        self.state = np.zeros(1, dtype=ENGINE_STATE)
        self._s = self.state[0]  # a view: writes go to the array
        self._last = self.state["last_reading"][0]  # (5, 3) view
        self._has_last = self.state["has_last"][0]  # (5,) view
        self._clock = self.state["clock_s"]  # (1,) view
        self.reset()

    def reset(self) -> None:
        """No active fault, no reading, clock 0, nothing scheduled."""
        self.state[0] = np.zeros((), dtype=ENGINE_STATE)
        self._s["pwm_max"] = self._pwm_max
        self._s["next_change_s"] = np.inf
        self._s["refill_row"] = -1
        self.table = np.zeros(0, dtype=FAULT_ROW)
        self.pool = np.zeros(0)

    # ---- the engine's scalars ------------------------------------------------------------
    @property
    def clock_s(self) -> float:
        """Latest simulated time given to the engine, s."""
        return float(self._clock[0])

    @clock_s.setter
    def clock_s(self, time_s: float) -> None:
        self._clock[0] = time_s

    def set_next_change(self, time_s: float) -> None:
        """Record the next time a fault starts or ends, s (the compiled steps stop before)."""
        self._s["next_change_s"] = time_s

    # ---- readings ------------------------------------------------------------------------
    def remember(self, sensor: int, value: np.ndarray) -> None:
        """Keep ``value`` as the last reading reported by ``sensor`` (for freeze faults)."""
        self._last[sensor, :value.shape[0]] = value
        self._has_last[sensor] = 1

    # ---- layout --------------------------------------------------------------------------
    def lay_out(self, rows: Sequence[int | np.ndarray], act_start: Sequence[int],
                sens_start: Sequence[int], mass_kg: float) -> None:
        """A new table: row ``r`` is the current row ``rows[r]`` (an int: a fault still
        active, its held values and draws kept) or a new FAULT_ROW record; ``act_start`` and
        ``sens_start`` as in ENGINE_STATE. Draws of the rows gone are dropped."""
        old = self.table
        table = np.zeros(len(rows), dtype=FAULT_ROW)
        for r, row in enumerate(rows):
            table[r] = old[row] if isinstance(row, int) else row
        self.table = table
        self._repack({})
        self._s["act_start"] = act_start
        self._s["sens_start"] = sens_start
        self._s["mass_kg"] = mass_kg

    # ---- draws ---------------------------------------------------------------------------
    def refill_request(self) -> tuple[int, int] | None:
        """``(row, count)`` a compiled kernel asked for (and forget the request), or None."""
        r = int(self._s["refill_row"])
        if r < 0:
            return None
        self._s["refill_row"] = -1
        return r, int(self._s["refill_count"])

    def drawn(self, r: int) -> int:
        """Draws row ``r`` holds from its start (a random profile's gammas)."""
        row = self.table[r]
        return int(row["draw_end"] - row["draw_start"])

    def unused(self, r: int) -> int:
        """Draws row ``r`` has not consumed yet (loss of accuracy, calibration)."""
        row = self.table[r]
        return int(row["draw_end"] - row["draw_next"])

    def ensure_gammas(self, r: int, count: int, rng: np.random.Generator,
                      fault: ActuatorFault) -> None:
        """Give random-profile row ``r`` at least ``count`` gammas: uniform in [low, loe],
        drawn from the fault's ``rng`` in blocks of RANDOM_BLOCK."""
        have = self.drawn(r)
        if have < count:
            blocks = (count - have + RANDOM_BLOCK - 1) // RANDOM_BLOCK
            new = [rng.uniform(fault.low, fault.loe, size=RANDOM_BLOCK) for _ in range(blocks)]
            self._repack({r: np.concatenate(new)})

    def ensure_unused(self, r: int, count: int, rng: np.random.Generator,
                      fault: SensorFault) -> None:
        """Give loss-of-accuracy or calibration row ``r`` at least ``count`` unused draws
        (:meth:`SensorFault.draws`), drawn from the fault's ``rng`` in blocks of
        SEQUENTIAL_BLOCK."""
        left = self.unused(r)
        if left < count:
            size = (count - left + SEQUENTIAL_BLOCK - 1) // SEQUENTIAL_BLOCK * SEQUENTIAL_BLOCK
            self._repack({r: fault.draws(rng, size)})

    def _repack(self, new_draws: dict[int, np.ndarray]) -> None:
        """Rebuild the pool from the rows' draws still needed (a random profile's all, the
        others' unused ones), appending ``new_draws[row]``; row offsets follow."""
        table, pool = self.table, self.pool
        parts: list[np.ndarray] = []
        at = 0
        for r in range(table.shape[0]):
            row = table[r]
            if not _draws(row):
                continue
            first = int(row["draw_start"] if keeps_all_draws(row) else row["draw_next"])
            seg = pool[first:int(row["draw_end"])]
            if r in new_draws:
                seg = np.concatenate((seg, new_draws[r]))
            parts.append(seg)
            row["draw_start"] = row["draw_next"] = at
            row["draw_end"] = at + seg.shape[0]
            at += seg.shape[0]
        self.pool = np.concatenate(parts) if parts else np.zeros(0)


__all__ = ["RANDOM_BLOCK", "SEQUENTIAL_BLOCK", "FaultArrays", "keeps_all_draws", "new_row"]
