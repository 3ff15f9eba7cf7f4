"""A go-to sent at the tick the vehicle lifts off is flown, not taken for a crash.

MAVSDK's ``goto.py`` sends its go-to as soon as the vehicle reads in the air. The new leg's
reference starts where the vehicle is, on the ground; on a long, shallow leg (the example's:
190 m west, 20 m up) it stays within 5 cm of the ground for more than the ground-contact
check's 1 s. That once disarmed the vehicle as "crash detected"
(:func:`fcu.monitoring.crash_check.contact_counts`).
"""

from __future__ import annotations

import pytest

from fcu.navigation.modes import Mode
from sim.scenario import load_scenario
from sim.stack import SimulatedStack

FLIGHT_S = 30.0  # s simulated after the go-to: the leg starts slowly, about 0.15 m up by then


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_go_to_at_lift_off_climbs_away_without_a_crash(seed: int) -> None:
    scenario = load_scenario("baseline")
    stack = SimulatedStack(scenario.world, scenario.autopilot, seed)
    stack.first_tick()
    nav = stack.autopilot.navigator
    assert nav.set_mode(int(Mode.GUIDED)).accepted
    assert nav.arm().accepted
    assert nav.takeoff(2.5).accepted
    events = []
    while not any(e.kind == "liftoff" for e in stack.world.drain_events()):
        stack.tick()
        assert stack.time_s < 10.0, "no lift-off"
    assert nav.reposition([-15.0, -190.0, -20.0]).accepted  # the tick of lift-off
    lift_off_s = stack.time_s
    while stack.time_s < lift_off_s + FLIGHT_S:
        stack.tick()
        events += stack.autopilot.drain_events()
    crashes = [e.text for e in events if e.record is not None and e.record.kind == "crash"]
    assert not crashes
    assert nav.armed
    assert -stack.world.truth().pos_ned[2] > 0.1  # m: on its way up to 20 m
