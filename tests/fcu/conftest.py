"""Fixtures of the autopilot's tests."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

from fcu.navigation.modes import Mode
from sim.scenario import load_scenario
from sim.stack import SimulatedStack
from sim.world.fault_types import SensorFault
from sim.world.samples import SensorSample

# (tick time s, PWM held over the tick, the tick's samples)
Tick = tuple[float, np.ndarray, Sequence[SensorSample]]


def _takeoff_ticks(n_ticks: int, seed: int, faults: Sequence[SensorFault] = ()
                   ) -> list[Tick]:
    """Each tick of a seeded ``lqg_abdob_loe`` stack taking off to 1 m in GUIDED (with the
    world's ``faults``), as an estimator fed beside the autopilot would see it."""
    scenario = load_scenario("lqg_abdob_loe")
    stack = SimulatedStack(scenario.world, scenario.autopilot, seed, faults=tuple(faults))
    stack.first_tick()
    nav = stack.autopilot.navigator
    nav.set_mode(int(Mode.GUIDED))
    nav.arm()
    nav.takeoff(1.0)
    ticks = []
    for _ in range(n_ticks):
        pwm = stack.pwm.copy()
        stack.tick()
        ticks.append((stack.world.time_s, pwm, stack.samples))
    return ticks


@pytest.fixture
def takeoff_ticks() -> Callable[..., list[Tick]]:
    """``takeoff_ticks(n_ticks, seed, faults=())``: the ticks of a seeded take-off."""
    return _takeoff_ticks
