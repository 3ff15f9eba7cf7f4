"""Circling: ArduCopter's CIRCLE mode and DO_ORBIT fly one circle implementation; the
reference is checked against the closed form of a circle and its derivatives."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_navigator import airborne

from fcu.navigation.circle import Circle, circle_entry
from fcu.navigation.modes import Mode
from fcu.navigation.settings import NavigatorConfig


def test_reference_is_a_circle_with_consistent_derivatives() -> None:
    c = Circle(np.array([1.0, 2.0, -5.0]), 4.0, 0.5, 0.3, 10.0, 0.5)
    assert c.ramp_s == pytest.approx(4.0)  # |omega| r / a = 2 m/s / 0.5 m/s^2
    for t in (10.5, 11.0, 13.9, 14.1, 30.0):  # (central differences: after the start)
        ref = c.reference(t)
        assert np.linalg.norm(ref.pos_ned - c.centre_ned) == pytest.approx(4.0)
        assert ref.pos_ned[2] == -5.0
        # the velocity and acceleration are the derivatives (central differences)
        h = 1e-5
        before, after = c.reference(t - h), c.reference(t + h)
        np.testing.assert_allclose((after.pos_ned - before.pos_ned) / (2 * h), ref.vel_ned,
                                   atol=1e-6)
        np.testing.assert_allclose((after.vel_ned - before.vel_ned) / (2 * h), ref.acc_ned,
                                   atol=1e-4)
        # facing the centre
        to_centre = c.centre_ned[:2] - ref.pos_ned[:2]
        assert ref.yaw_rad == pytest.approx(math.atan2(to_centre[1], to_centre[0]))
    assert np.linalg.norm(c.reference(10.0).vel_ned) == 0.0  # starts at rest
    assert np.linalg.norm(c.reference(20.0).vel_ned) == pytest.approx(2.0)  # omega r


def test_entry_is_the_nearest_point() -> None:
    point, theta = circle_entry(np.array([10.0, 0.0, -1.0]), np.array([0.0, 0.0, -3.0]), 4.0)
    np.testing.assert_allclose(point, [4.0, 0.0, -3.0])
    assert theta == 0.0


def test_circle_mode_starts_on_the_circle_ahead() -> None:
    f = airborne(2.0, NavigatorConfig(circle_radius_m=3.0, circle_rate_deg_s=30.0))
    assert f.nav.set_mode(Mode.CIRCLE).accepted
    start = f.vehicle.pos_ned.copy()
    f.run_until(f.time_s + 60.0)
    ref = f.outputs[-1][1].reference
    assert ref is not None
    centre = start + np.array([3.0, 0.0, 0.0])  # yaw 0: north of the vehicle
    assert np.linalg.norm(ref.pos_ned - centre) == pytest.approx(3.0)
    assert np.linalg.norm(ref.vel_ned) == pytest.approx(3.0 * math.radians(30.0))
    assert f.nav.mode == Mode.CIRCLE


def test_orbit_flies_to_the_circle_then_round() -> None:
    f = airborne(2.0)
    centre = np.array([5.0, 0.0, -2.0])
    assert f.nav.orbit(centre, 2.0, 0.5).accepted
    assert f.nav.mode == Mode.CIRCLE
    f.run_until(f.time_s + 120.0)
    ref = f.outputs[-1][1].reference
    assert ref is not None
    assert np.linalg.norm(ref.pos_ned - centre) == pytest.approx(2.0)
    assert np.linalg.norm(ref.vel_ned) == pytest.approx(0.5)
    texts = [e.text for e in f.events if e.kind == "circle"]
    assert texts[0].startswith("flying to the circle") and texts[1].startswith("circling")
    assert not f.nav.orbit(centre, -1.0, 0.5).accepted
    assert not f.nav.orbit(centre, 2.0, 50.0).accepted  # faster than max_speed_m_s
