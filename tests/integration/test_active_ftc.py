"""Active fault-tolerant control: the allocation uses the estimated motor effectiveness.

Headless and seeded. Passive control is the thesis's (robust control, estimates reported
only); active reconfigures the mixer for the motors the detector declared (or suspects), so
the controllers see the nominal airframe again (fcu/control/allocation.py).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from flown import metrics

from sim.runner import fly
from sim.scenario import load_scenario

pytestmark = pytest.mark.slow


@cache
def height_dip_m(name: str, ftc: str) -> float:
    """Largest sag below the height reference within 5 s of the scenario's (one) fault, m."""
    scenario = load_scenario(name)
    scenario = replace(scenario, autopilot=replace(scenario.autopilot, ftc=ftc))
    (fault,) = scenario.faults
    log = fly(scenario).log
    window = (log.time_s >= fault.start_s) & (log.time_s < fault.start_s + 5.0)
    # NED: z below the reference is z - z_ref > 0
    return float(np.max(log.pos_ned[window, 2] - log.ref_pos_ned[window, 2]))


@pytest.mark.parametrize(("name", "limit_m"), [("active_loe40", 0.05), ("active_loe55", 0.10)])
def test_active_ftc_holds_height_through_a_large_loss(name: str, limit_m: float) -> None:
    active, passive = height_dip_m(name, "active"), height_dip_m(name, "passive")
    assert active < limit_m, (active, passive)
    assert active < 0.5 * passive  # what reconfiguration saves (passive: 16 and 30 cm)
    assert metrics(name)["outcome"]["kind"] == "landed"


def test_active_ftc_tracks_the_table_7_3_faults_better_than_passive() -> None:
    active, passive = metrics("lqg_abdob_loe_active"), metrics("lqg_abdob_loe")
    assert active["outcome"]["kind"] == "landed"
    assert active["rms"]["z"] < 0.5 * passive["rms"]["z"], (active["rms"], passive["rms"])
    for axis in ("x", "y"):
        assert active["rms"][axis] <= passive["rms"][axis], axis
        # within 5 % of the fault-free flight: the faults cost almost nothing in x and y
        assert active["rms"][axis] <= 1.05 * metrics("baseline")["rms"][axis], axis
    # the same detections: reconfiguration does not blind the detector
    assert [d["motor"] for d in active["detections"]] == [3, 1, 4]
