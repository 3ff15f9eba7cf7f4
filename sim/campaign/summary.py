"""Statistics over a campaign's rows: configurations, outcomes, survival, distributions.

A row is a dict of :mod:`sim.campaign.rows` columns. A *configuration* is a combination of
the swept axes that are not the envelope's coordinates (not the seed, the magnitude, the
start time or the motor): e.g. ``ftc = active, wind = moderate``. A run *survived* when it
flew without error and ended ``landed`` or still ``airborne`` (not ``crashed``, not
``flyaway``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sim.campaign.axes import AXES

SURVIVED = ("landed", "airborne")
"""Outcomes that count as surviving the fault."""
OUTCOME_ORDER = ("landed", "airborne", "crashed", "flyaway", "error")
"""Outcome columns of the tables, ``error`` for a run that raised."""
COORDINATE_AXES = ("seed", "fault.magnitude", "fault.start_s", "fault.motor")
"""Swept axes that place a run inside a configuration rather than make one."""

Row = Mapping[str, Any]


@dataclass(frozen=True)
class Group:
    """The rows of one configuration, with its label (``"all runs"`` when there is one)."""

    label: str
    rows: list[Row]


def outcome(row: Row) -> str:
    """The row's outcome, ``"error"`` when its run raised."""
    return "error" if row.get("status") == "error" else str(row.get("outcome"))


def survived(row: Row) -> bool:
    """The run flew without error and did not crash or fly away."""
    return outcome(row) in SURVIVED


def configuration_columns(swept: Iterable[str]) -> list[str]:
    """Result columns of the swept axes that make a configuration (module docstring)."""
    return [AXES[name].column for name in swept if name not in COORDINATE_AXES]


def _value_text(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def configurations(rows: Sequence[Row], columns: Sequence[str]) -> list[Group]:
    """The rows grouped by their values of ``columns``, in order of first appearance."""
    groups: dict[tuple[Any, ...], list[Row]] = {}
    for row in rows:
        groups.setdefault(tuple(row.get(c) for c in columns), []).append(row)
    if not columns:
        return [Group("all runs", list(rows))] if rows else []
    return [Group(", ".join(f"{c} = {_value_text(v)}" for c, v in zip(columns, key,
                                                                       strict=True)), members)
            for key, members in groups.items()]


def outcome_counts(rows: Iterable[Row]) -> dict[str, int]:
    """Runs per outcome, every outcome of :data:`OUTCOME_ORDER` present."""
    counts = dict.fromkeys(OUTCOME_ORDER, 0)
    for row in rows:
        counts[outcome(row)] = counts.get(outcome(row), 0) + 1
    return counts


@dataclass(frozen=True)
class Spread:
    """How many values, and their median, 90th percentile and maximum (None when empty)."""

    count: int
    median: float | None
    p90: float | None
    max: float | None


def spread(values: Iterable[float | None]) -> Spread:
    """The :class:`Spread` of the finite values among ``values``."""
    finite = np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    if finite.size == 0:
        return Spread(0, None, None, None)
    return Spread(int(finite.size), float(np.median(finite)),
                  float(np.percentile(finite, 90)), float(finite.max()))


def fault_latencies(row: Row, n_faults: int) -> list[float]:
    """Detection latencies of every fault of a run that was detected, s."""
    values = (row.get(f"fault{k}_latency_s") for k in range(1, n_faults + 1))
    return [v for v in values if v is not None]


def ok_rows(rows: Iterable[Row]) -> list[Row]:
    """The rows of runs that flew without error."""
    return [r for r in rows if r.get("status") == "ok"]


def by_value(rows: Iterable[Row], column: str) -> dict[Any, list[Row]]:
    """Rows grouped by one column's value, in sorted order of the values (None last)."""
    groups: dict[Any, list[Row]] = {}
    for row in rows:
        groups.setdefault(row.get(column), []).append(row)
    return dict(sorted(groups.items(),
                       key=lambda kv: (kv[0] is None, kv[0] if kv[0] is not None else 0)))


def pairs(rows: Sequence[Row], column: str, first: Any, second: Any,
          keys: Sequence[str]) -> list[tuple[Row, Row]]:
    """Runs that differ only in ``column`` (``first`` against ``second``), matched on
    ``keys`` (the other axis columns)."""
    def key(row: Row) -> tuple[Any, ...]:
        return tuple(row.get(k) for k in keys if k != column)

    seconds = {key(r): r for r in rows if r.get(column) == second}
    return [(r, seconds[key(r)]) for r in rows
            if r.get(column) == first and key(r) in seconds]


def share(rows: Sequence[Row], test: Callable[[Row], bool]) -> float | None:
    """Fraction of ``rows`` passing ``test`` (None without rows)."""
    return sum(1 for r in rows if test(r)) / len(rows) if rows else None
