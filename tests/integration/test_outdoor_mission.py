"""The outdoor mission (sim/scenarios/outdoor_square.toml): 10 m up, a 30 m square at 3 m/s
and down, in a 4 m/s wind with moderate turbulence, fault-free, with active FTC: flown
headless on several seeds, it lands at home without a single detection (the campaign
false_alarms_outdoor flies 300 seeds of it)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from sim.runner import fly
from sim.scenario import load_scenario

pytestmark = pytest.mark.slow

SIDE_M = 30.0  # m, the square's side
ALT_M = 10.0  # m, the cruise altitude


@pytest.mark.parametrize("seed", [2, 17, 301])
def test_the_outdoor_mission_lands_at_home_without_a_detection(seed: int) -> None:
    base = load_scenario("outdoor_square")
    scenario = replace(base, seed=seed, autopilot=replace(base.autopilot, ftc="active"))
    path: list[np.ndarray] = []

    def on_tick(world: Any, autopilot: Any) -> None:
        path.append(world.plant.state[0:3].copy())

    result = fly(scenario, on_tick=on_tick)
    assert result.outcome.kind == "landed", result.outcome
    assert result.outcome.impact_speed_m_s < 1.0
    assert result.detections == [], result.detections
    track = np.array(path)
    # it flew the square: up to the cruise altitude and out to the far corner
    assert -track[:, 2].min() == pytest.approx(ALT_M, abs=0.5)  # 0.5 m: gusts at 4 m/s
    assert track[:, 0].max() == pytest.approx(SIDE_M, abs=0.5)
    assert track[:, 1].max() == pytest.approx(SIDE_M, abs=0.5)
    # never far outside it, and down at home (1 m: the wind drifts the touchdown)
    assert track[:, :2].min() > -1.0 and track[:, :2].max() < SIDE_M + 1.0
    assert np.linalg.norm(track[-1, :2]) < 1.0
