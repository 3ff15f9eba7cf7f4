"""The thesis's chapter 7 as data: its tables, its fault schedule and its runs.

The transcribed figures live in ``flightdata/data/thesis_tables.toml`` (every table of the
thesis, machine-readable); the mission is :func:`flightdata.mission.thesis_mission`.
"""

from __future__ import annotations

import functools
import tomllib
from dataclasses import dataclass
from importlib import resources
from typing import Any

#: Table 7.2, 7.4-7.10 runs, in thesis order (names of the shipped scenarios).
THESIS_RUNS: tuple[str, ...] = ("baseline", "lqg_loe", "pd_loe", "pd_vbdob_loe", "lqg_vbdob_loe",
                                "lqg_abdob_loe", "tskf_pd_abdob_loe", "tskf_lqg_abdob_loe")
#: Table 7.11 cases.
THESIS_CASES: tuple[str, ...] = tuple(f"case{i}" for i in range(1, 9))
#: Runs the thesis has no table for but whose comparison it implies.
EXTRA_RUNS: tuple[str, ...] = ("pd_abdob_loe", "tskf_step")
#: Error axes of every table, with their units.
AXES: tuple[tuple[str, str], ...] = (("x", "m"), ("y", "m"), ("z", "m"), ("roll", "deg"),
                                     ("pitch", "deg"), ("yaw", "deg"))


@dataclass(frozen=True, kw_only=True)
class MotorLoss:
    """A step loss of effectiveness of one motor at a time of the flight."""

    motor: int  # -, 1..4 (thesis eq. 3.2 numbering)
    loe: float  # -, gamma of eq. 4.10
    start_s: float  # s after the start of the flight


TABLE_7_3: tuple[MotorLoss, ...] = (
    MotorLoss(motor=3, loe=0.20, start_s=22.0),
    MotorLoss(motor=1, loe=0.30, start_s=38.0),
    MotorLoss(motor=4, loe=0.15, start_s=48.0),
)
"""Thesis Table 7.3: the chapter-7 actuator faults, in time order."""


@functools.cache
def thesis_tables() -> dict[str, Any]:
    """The transcribed thesis figures (``flightdata/data/thesis_tables.toml``), read once."""
    text = (resources.files("flightdata") / "data" / "thesis_tables.toml").read_text()
    return tomllib.loads(text)
