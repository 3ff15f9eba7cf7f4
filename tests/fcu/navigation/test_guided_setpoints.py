"""GUIDED's velocity, attitude and position set-points flown by the whole stack (headless,
simulated time): what MAVSDK's offboard and go-to examples send, checked against the true
state."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcu.navigation.modes import Mode
from sim.scenario import load_scenario
from sim.stack import SimulatedStack

SEED = 4


def armed_in_guided(seed: int = SEED) -> SimulatedStack:
    """The baseline stack booted, in GUIDED, armed on the ground."""
    scenario = load_scenario("baseline")
    stack = SimulatedStack(scenario.world, scenario.autopilot, seed)
    stack.first_tick()
    nav = stack.autopilot.navigator
    assert nav.set_mode(int(Mode.GUIDED)).accepted
    assert nav.arm().accepted
    return stack


def fly(stack: SimulatedStack, seconds: float, resend: object = None) -> None:
    """Tick ``seconds`` of simulated time, calling ``resend()`` every 0.1 s if given (a
    ground station streaming its set-point)."""
    end = stack.time_s + seconds
    next_send = stack.time_s
    while stack.time_s < end:
        if callable(resend) and stack.time_s >= next_send:
            assert resend().accepted
            next_send += 0.1
        stack.tick()


def test_a_climbing_velocity_takes_off_and_a_velocity_is_flown() -> None:
    stack = armed_in_guided()
    nav = stack.autopilot.navigator
    assert nav.set_velocity(np.zeros(3)).accepted  # on the ground, not climbing: kept
    fly(stack, 1.0)
    assert nav.landed
    up = np.array([0.0, 0.0, -0.5])
    fly(stack, 4.0, lambda: nav.set_velocity(up))
    truth = stack.world.truth()
    assert not nav.landed and -truth.pos_ned[2] > 1.0  # m: 0.5 m/s for 4 s, after the ramp
    assert truth.vel_ned[2] == pytest.approx(-0.5, abs=0.1)  # m/s: tracking noise, wind 0
    north = np.array([1.0, 0.0, 0.0])
    fly(stack, 4.0, lambda: nav.set_velocity(north))
    truth = stack.world.truth()
    np.testing.assert_allclose(truth.vel_ned, [1.0, 0.0, 0.0], atol=0.15)
    # the set-points stop: after GUID_TIMEOUT (3 s) the vehicle brakes and holds
    fly(stack, nav.config.guided_timeout_s + 4.0)
    np.testing.assert_allclose(stack.world.truth().vel_ned, np.zeros(3), atol=0.1)


def test_a_body_frame_velocity_with_a_yaw_rate_flies_a_circle() -> None:
    stack = armed_in_guided()
    nav = stack.autopilot.navigator
    fly(stack, 3.0, lambda: nav.set_velocity(np.array([0.0, 0.0, -0.5])))
    forward_turning = np.array([0.5, 0.0, 0.0])
    rate = math.radians(30.0)
    headings = []
    for _ in range(4):
        fly(stack, 3.0, lambda: nav.set_velocity(forward_turning, yaw_rate_rad_s=rate,
                                                 heading_frame=True))
        truth = stack.world.truth()
        yaw = truth.euler_rad[2]
        # the velocity turns with the heading: along it, at 0.5 m/s
        np.testing.assert_allclose(truth.vel_ned[:2], [0.5 * math.cos(yaw),
                                                       0.5 * math.sin(yaw)], atol=0.15)
        headings.append(yaw)
    turned = np.unwrap(headings)
    assert np.all(np.diff(turned) > math.radians(60.0))  # 30 deg/s for 3 s: about 90 deg


def test_an_attitude_set_point_leans_and_its_thrust_reads_as_a_climb_rate() -> None:
    stack = armed_in_guided()
    nav = stack.autopilot.navigator
    fly(stack, 4.0, lambda: nav.set_attitude(0.0, 0.0, 0.0, 0.8))  # climb: take-off
    alt = -stack.world.truth().pos_ned[2]
    assert alt > 0.3
    roll = math.radians(10.0)
    fly(stack, 1.5, lambda: nav.set_attitude(roll, 0.0, 0.0, 0.5))
    truth = stack.world.truth()
    assert truth.euler_rad[0] == pytest.approx(roll, abs=math.radians(3.0))
    assert truth.vel_ned[1] > 0.3  # m/s: leaning right moves east (yaw 0)
    # thrust 0.5: the altitude held while leaning
    assert -truth.pos_ned[2] == pytest.approx(alt, abs=0.15)


def test_a_position_set_point_on_the_ground_takes_off_to_it() -> None:
    stack = armed_in_guided()
    nav = stack.autopilot.navigator
    target = np.array([1.0, 0.5, -1.5])
    fly(stack, 20.0, lambda: nav.go_to(target))
    np.testing.assert_allclose(stack.world.truth().pos_ned, target, atol=0.1)
    assert nav.go_to(np.array([0.0, 0.0, -0.05])).accepted  # in the air: any target
    stack2 = armed_in_guided()
    refused = stack2.autopilot.navigator.go_to(np.array([1.0, 0.0, 0.0]))
    assert not refused.accepted and "on the ground" in refused.reason



@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_go_to_at_lift_off_climbs_away_without_a_crash(seed: int) -> None:
    """MAVSDK's ``goto.py`` sends its go-to as soon as the vehicle reads in the air. The new
    leg's reference starts where the vehicle is, on the ground; on a long, shallow leg (the
    example's: 190 m west, 20 m up) it stays within 5 cm of the ground for more than the
    ground-contact check's 1 s. That once disarmed the vehicle as "crash detected"
    (:func:`fcu.monitoring.crash_check.contact_counts`)."""
    stack = armed_in_guided(seed)
    nav = stack.autopilot.navigator
    assert nav.takeoff(2.5).accepted
    while not any(e.kind == "liftoff" for e in stack.world.drain_events()):
        stack.tick()
        assert stack.time_s < 10.0, "no lift-off"
    assert nav.reposition([-15.0, -190.0, -20.0]).accepted  # the tick of lift-off
    events = []
    lift_off_s = stack.time_s
    while stack.time_s < lift_off_s + 30.0:  # s: the leg starts slowly, ~0.15 m up by then
        stack.tick()
        events += stack.autopilot.drain_events()
    crashes = [e.text for e in events if e.record is not None and e.record.kind == "crash"]
    assert not crashes
    assert nav.armed
    assert -stack.world.truth().pos_ned[2] > 0.1  # m: on its way up to 20 m
