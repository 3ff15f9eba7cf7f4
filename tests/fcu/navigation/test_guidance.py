"""Guidance: cubic segments, trajectories through waypoints, take-off/landing helpers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fcu.floats import wrap_pi
from fcu.navigation.guidance import (
    SpeedLimits,
    Trajectory,
    Waypoint,
    hold_trajectory,
    landing_trajectory,
    leg_duration_s,
    takeoff_trajectory,
)
from fcu.navigation.reference import Reference, reference_from_nine
from fcu.navigation.segments import CubicSegment, HoldSegment, RampSegment
from flightdata.mission import thesis_mission

coord = st.floats(min_value=-5.0, max_value=5.0, allow_nan=False)
speed = st.floats(min_value=0.05, max_value=3.0, allow_nan=False)


def sample(traj_or_seg: Trajectory | CubicSegment, t0: float, t1: float, n: int = 2001
           ) -> tuple[np.ndarray, list[Reference]]:
    times = np.linspace(t0, t1, n)
    return times, [traj_or_seg.evaluate(float(t)) for t in times]


def test_cubic_closed_form_at_quarter_points() -> None:
    seg = CubicSegment(2.0, 4.0, np.array([0.0, 0.0, -1.0]), np.array([2.0, 0.0, -1.0]))
    # s = 0.25: h = 3/16 - 2/64 = 0.15625; h' = (1.5 - 0.375)/T; h'' = (6 - 3)/T^2
    ref = seg.evaluate(3.0)
    np.testing.assert_allclose(ref.pos_ned, [2.0 * 0.15625, 0.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(ref.vel_ned, [2.0 * 1.125 / 4.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(ref.acc_ned, [2.0 * 3.0 / 16.0, 0.0, 0.0], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.tuples(coord, coord, coord), st.tuples(coord, coord, coord), speed, speed, speed,
       st.floats(min_value=0.05, max_value=5.0))
def test_leg_reaches_waypoint_at_rest_within_limits(start, end, v_h, v_up, a_max_scale,
                                                      v_down) -> None:
    limits = SpeedLimits(horizontal_m_s=v_h, up_m_s=v_up, down_m_s=v_down,
                         accel_m_s2=a_max_scale, min_duration_s=0.1)
    traj = Trajectory.from_waypoints(1.0, start, [Waypoint(pos_ned=end)], limits)
    t_arr = traj.arrival_times_s[0]
    ref_end = traj.evaluate(t_arr)
    np.testing.assert_allclose(ref_end.pos_ned, end, atol=1e-9)  # exact arrival (rounding)
    np.testing.assert_allclose(ref_end.vel_ned, 0.0, atol=1e-12)
    np.testing.assert_allclose(traj.evaluate(1.0).vel_ned, 0.0, atol=1e-12)  # starts at rest
    if t_arr == 1.0:
        return  # no motion at all
    _, refs = sample(traj, 1.0, t_arr)
    vel = np.array([r.vel_ned for r in refs])
    acc = np.array([r.acc_ned for r in refs])
    # Samples include s = 1/2 (odd count), where the speed peaks, so the bounds are tight.
    rel = 1.0 + 1e-9  # float rounding of T
    assert np.max(np.hypot(vel[:, 0], vel[:, 1])) <= v_h * rel
    assert np.max(-vel[:, 2]) <= v_up * rel
    assert np.max(vel[:, 2]) <= v_down * rel
    assert np.max(np.linalg.norm(acc, axis=1)) <= a_max_scale * rel
    # The leg is as short as the binding limit allows: one of the peaks meets its limit
    # (or the minimum leg time binds).
    d = np.asarray(end) - np.asarray(start)
    T = t_arr - 1.0
    ratios = [1.5 * math.hypot(d[0], d[1]) / T / v_h, 1.5 * max(-d[2], 0.0) / T / v_up,
              1.5 * max(d[2], 0.0) / T / v_down, 6.0 * np.linalg.norm(d) / T**2 / a_max_scale]
    assert max(ratios) == pytest.approx(1.0, rel=1e-9) or T == pytest.approx(0.1)


def test_peak_speed_is_one_and_a_half_mean_speed() -> None:
    limits = SpeedLimits(horizontal_m_s=0.15, accel_m_s2=10.0)
    seg = Trajectory.from_waypoints(0.0, [0, 0, -0.6], [Waypoint(pos_ned=(1, 0, -0.6))],
                                    limits).segments[0]
    assert isinstance(seg, CubicSegment)
    assert seg.duration_s == pytest.approx(10.0)  # T = 1.5 d / v_max = 1.5 * 1 / 0.15
    assert seg.peak_speed_m_s == pytest.approx(0.15)
    assert np.linalg.norm(seg.evaluate(5.0).vel_ned) == pytest.approx(0.15)  # at s = 1/2


def test_acceleration_limit_sets_short_legs() -> None:
    limits = SpeedLimits(horizontal_m_s=10.0, accel_m_s2=0.5, min_duration_s=0.0)
    # d = 0.3 m: speed needs 1.5*0.3/10 = 0.045 s; acceleration needs sqrt(6*0.3/0.5) = 1.897 s
    assert leg_duration_s([0, 0, 0], [0.3, 0, 0], limits) == pytest.approx(math.sqrt(3.6))
    assert leg_duration_s([1, 2, -3], [1, 2, -3], limits) == 0.0  # no motion, no time
    assert leg_duration_s([0, 0, 0], [0.001, 0, 0], SpeedLimits(min_duration_s=2.0)) == 2.0


def test_velocity_and_acceleration_are_derivatives_of_position() -> None:
    seg = CubicSegment(0.0, 3.0, np.array([0.0, 1.0, -0.5]), np.array([1.0, -1.0, -2.0]),
                       0.3, 1.2)
    h = 1e-5
    for t in (0.2, 1.0, 1.5, 2.7):
        ref, ahead, behind = seg.evaluate(t), seg.evaluate(t + h), seg.evaluate(t - h)
        # central differences of a cubic: error O(h^2) * third derivative, ~1e-10
        np.testing.assert_allclose((ahead.pos_ned - behind.pos_ned) / (2 * h), ref.vel_ned,
                                   atol=1e-8)
        np.testing.assert_allclose((ahead.vel_ned - behind.vel_ned) / (2 * h), ref.acc_ned,
                                   atol=1e-8)
        assert (ahead.yaw_rad - behind.yaw_rad) / (2 * h) == pytest.approx(
            ref.yaw_rate_rad_s, abs=1e-8)


def test_position_and_velocity_continuous_at_joins() -> None:
    limits = SpeedLimits(horizontal_m_s=0.4, up_m_s=0.3, down_m_s=0.2, accel_m_s2=1.0)
    wps = [Waypoint(pos_ned=(0, 0, -1)), Waypoint(pos_ned=(1, 0, -1), hold_s=1.5),
           Waypoint(pos_ned=(1, 2, -0.5), yaw_rad=1.0), Waypoint(pos_ned=(0, 0, -1.5),
                                                                  hold_s=0.5)]
    traj = Trajectory.from_waypoints(10.0, [0, 0, 0], wps, limits)
    assert len(traj.segments) == 6  # 4 cubics + 2 holds
    eps = 1e-9
    for a, b in zip(traj.segments[:-1], traj.segments[1:], strict=True):
        join = b.t0_s
        assert a.end_time_s == pytest.approx(join)
        left, right = traj.evaluate(join - eps), traj.evaluate(join)
        np.testing.assert_allclose(left.pos_ned, right.pos_ned, atol=1e-8)
        np.testing.assert_allclose(left.vel_ned, right.vel_ned, atol=1e-8)  # both ~0
        assert traj.segment_index(join) == traj.segments.index(b)
    for wp, t_arr in zip(wps, traj.arrival_times_s, strict=True):
        np.testing.assert_allclose(traj.evaluate(t_arr).pos_ned, wp.pos_ned, atol=1e-12)
    assert traj.end_time_s == pytest.approx(traj.arrival_times_s[-1] + 0.5)
    after = traj.evaluate(traj.end_time_s + 100.0)
    np.testing.assert_allclose(after.pos_ned, wps[-1].pos_ned)
    np.testing.assert_allclose(after.vel_ned, 0.0)
    assert after.yaw_rad == pytest.approx(1.0)  # yaw kept from the third waypoint


def test_yaw_takes_the_shortest_way_round() -> None:
    start, end = math.radians(170.0), math.radians(-170.0)
    seg = CubicSegment(0.0, 2.0, np.zeros(3), np.zeros(3), start, end)
    mid = seg.evaluate(1.0)
    assert abs(mid.yaw_rad) == pytest.approx(math.pi)  # passes through 180 deg, not 0
    assert mid.yaw_rate_rad_s > 0  # turning right (clockwise), +20 deg
    assert mid.yaw_rate_rad_s == pytest.approx(1.5 * math.radians(20.0) / 2.0)
    assert seg.evaluate(2.0).yaw_rad == pytest.approx(end)
    # A yaw-only leg gets its time from the yaw-rate limit: 1.5 * dpsi / r_max.
    limits = SpeedLimits(yaw_rate_rad_s=0.2, min_duration_s=0.0)
    assert leg_duration_s([0, 0, 0], [0, 0, 0], limits, math.radians(20.0)) == pytest.approx(
        1.5 * math.radians(20.0) / 0.2)


def test_takeoff_is_vertical_to_altitude() -> None:
    limits = SpeedLimits(up_m_s=0.18)
    traj = takeoff_trajectory(3.0, [0.2, -0.1, 0.01], 0.6, limits, yaw_rad=0.5)
    t_arr = traj.arrival_times_s[0]
    assert t_arr == pytest.approx(3.0 + 1.5 * 0.61 / 0.18)
    _, refs = sample(traj, 3.0, t_arr)
    xy = np.array([r.pos_ned[:2] for r in refs])
    np.testing.assert_allclose(xy, [[0.2, -0.1]] * len(refs))  # no horizontal motion
    assert max(-r.vel_ned[2] for r in refs) == pytest.approx(0.18, rel=1e-6)
    assert all(r.yaw_rad == pytest.approx(0.5) for r in refs)
    np.testing.assert_allclose(traj.evaluate(t_arr + 5).pos_ned, [0.2, -0.1, -0.6])


def test_landing_reaches_ground_at_rest_then_creeps_down() -> None:
    limits = SpeedLimits(down_m_s=0.2)
    traj = landing_trajectory(0.0, [1.0, 2.0, -0.6], limits, creep_speed_m_s=0.1)
    t_touch = traj.arrival_times_s[0]
    assert t_touch == pytest.approx(1.5 * 0.6 / 0.2)
    touch = traj.evaluate(t_touch)
    np.testing.assert_allclose(touch.pos_ned, [1.0, 2.0, 0.0], atol=1e-12)
    assert math.isinf(traj.end_time_s)
    later = traj.evaluate(t_touch + 3.0)
    np.testing.assert_allclose(later.pos_ned, [1.0, 2.0, 0.3], atol=1e-12)  # below ground
    np.testing.assert_allclose(later.vel_ned, [0.0, 0.0, 0.1])
    before = traj.evaluate(t_touch - 1e-9)
    assert before.vel_ned[2] == pytest.approx(0.0, abs=1e-6)  # cubic arrives at rest
    # Already on the ground: only the creep.
    flat = landing_trajectory(0.0, [0.0, 0.0, 0.0], limits, creep_speed_m_s=0.1)
    assert isinstance(flat.segments[0], RampSegment) and len(flat.segments) == 1


def test_hold_is_constant_and_reference_is_read_only() -> None:
    traj = hold_trajectory(5.0, [1.0, 2.0, -3.0], yaw_rad=4.0)
    for t in (0.0, 5.0, 1e6):
        ref = traj.evaluate(t)
        np.testing.assert_array_equal(ref.pos_ned, [1.0, 2.0, -3.0])
        np.testing.assert_array_equal(ref.vel_ned, 0.0)
        assert ref.yaw_rad == pytest.approx(4.0 - 2 * math.pi)  # wrapped to [-pi, pi)
    with pytest.raises(ValueError):
        ref.pos_ned[0] = 0.0


def test_a_trajectory_gives_the_same_reference_whatever_it_was_asked_before() -> None:
    # it remembers the segment of its previous answer: asked in any order (back in time,
    # at joins, across a zero-length leg), each answer is a fresh trajectory's
    limits = SpeedLimits()
    waypoints = [Waypoint(pos_ned=(1.0, 0.0, -0.6), hold_s=1.0),
                 Waypoint(pos_ned=(1.0, 0.0, -0.6)),  # no move, no turn: no segment
                 Waypoint(pos_ned=(1.0, 1.0, -0.6), yaw_rad=1.0)]

    def build() -> Trajectory:
        return Trajectory.from_waypoints(2.0, (0.0, 0.0, -0.6), waypoints, limits)

    traj = build()
    joins = [seg.t0_s for seg in traj.segments] + [traj.end_time_s]
    rng = np.random.default_rng(7)
    times = [*joins, *rng.uniform(1.0, traj.end_time_s + 1.0, 200), *reversed(joins)]
    for t in times:
        got, fresh = traj.evaluate(float(t)), build().evaluate(float(t))
        for name in ("pos_ned", "vel_ned", "acc_ned"):
            np.testing.assert_array_equal(getattr(got, name), getattr(fresh, name))
        assert (got.yaw_rad, got.yaw_rate_rad_s) == (fresh.yaw_rad, fresh.yaw_rate_rad_s)


def test_trajectory_rejects_gaps_and_endless_middle_segments() -> None:
    a = HoldSegment(0.0, 1.0, np.zeros(3))
    with pytest.raises(ValueError, match="t0_s"):
        Trajectory([a, HoldSegment(1.5, 1.0, np.zeros(3))])
    with pytest.raises(ValueError, match="never ends"):
        Trajectory([HoldSegment(0.0, math.inf, np.zeros(3)), a])
    with pytest.raises(ValueError, match="at least one"):
        Trajectory([])
    with pytest.raises(ValueError, match="accel_m_s2"):
        SpeedLimits(accel_m_s2=0.0)


def _speeds(items) -> dict[str, float]:
    return {item.speed_type: item.speed_m_s for item in items if item.command == "change_speed"}


def test_thesis_mission_data_gives_the_documented_timeline() -> None:
    items = thesis_mission()
    speeds = _speeds(items)
    limits = SpeedLimits(horizontal_m_s=speeds["ground"], up_m_s=speeds["climb"],
                         down_m_s=speeds["descent"])
    takeoff = takeoff_trajectory(0.0, [0, 0, 0], 0.6, limits)
    assert takeoff.arrival_times_s[0] == pytest.approx(5.0)
    waypoints = [Waypoint(pos_ned=item.pos_ned, hold_s=item.hold_s) for item in items
                 if item.command == "waypoint" and item.pos_ned is not None]
    assert [wp.pos_ned for wp in waypoints] == [
        (0, 0, -0.6), (1, 0, -0.6), (1, 1, -0.6), (0, 1, -0.6), (0, 0, -0.6)]
    square = Trajectory.from_waypoints(5.0, [0, 0, -0.6], waypoints, limits)
    np.testing.assert_allclose(square.arrival_times_s, [5.0, 17.0, 28.0, 39.0, 50.0])
    assert square.end_time_s == pytest.approx(52.0)
    land = landing_trajectory(52.0, [0, 0, -0.6], limits, creep_speed_m_s=0.1)
    assert land.arrival_times_s[0] == pytest.approx(56.0)
    # The thesis's faults (22, 38, 48 s) fall inside square legs, at 0.6 m, moving.
    legs = [seg for seg in square.segments if isinstance(seg, CubicSegment)]
    for fault_s in (22.0, 38.0, 48.0):
        ref = square.evaluate(fault_s)
        assert any(seg.t0_s < fault_s < seg.end_time_s for seg in legs)
        assert ref.pos_ned[2] == pytest.approx(-0.6)
        assert np.linalg.norm(ref.vel_ned) > 0.01  # m/s; at least 7 % of the leg's peak


def test_cubic_reference_is_the_closed_form_bit_for_bit_read_only_and_its_own() -> None:
    start, end = np.array([0.5, -1.0, -0.2]), np.array([2.0, 0.25, -1.5])
    seg = CubicSegment(1.0, 3.0, start, end, 0.3, -0.4)
    refs = [seg.evaluate(t) for t in (1.5, 2.2, 3.7)]
    for t, ref in zip((1.5, 2.2, 3.7), refs, strict=True):
        # the module docstring's formulas, written out here in the same order of operations
        s = (t - 1.0) / 3.0
        h, dh, ddh = 3.0 * s**2 - 2.0 * s**3, (6.0 * s - 6.0 * s**2) / 3.0, \
            (6.0 - 12.0 * s) / 3.0**2
        delta, dyaw = end - start, wrap_pi(-0.4 - 0.3)
        public = Reference(pos_ned=start + delta * h, vel_ned=delta * dh, acc_ned=delta * ddh,
                           yaw_rad=0.3 + dyaw * h, yaw_rate_rad_s=dyaw * dh)
        for name in ("pos_ned", "vel_ned", "acc_ned"):
            value = getattr(ref, name)
            np.testing.assert_array_equal(value, getattr(public, name))
            assert value.shape == (3,) and value.dtype == np.float64
            with pytest.raises(ValueError):  # read-only
                value[0] = 0.0
        assert (ref.yaw_rad, ref.yaw_rate_rad_s) == (public.yaw_rad, public.yaw_rate_rad_s)
    # each evaluation owns its vectors: the earlier ones did not move
    assert refs[0].pos_ned[0] < refs[1].pos_ned[0] < refs[2].pos_ned[0]


def test_a_non_finite_cubic_reference_raises_the_public_error() -> None:
    seg = CubicSegment(0.0, 1.0, np.zeros(3), np.array([1.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="yaw_rad"):
        reference_from_nine(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, math.nan, 0.0)
    with pytest.raises(ValueError, match="vel_ned"):
        reference_from_nine(0.0, 0.0, 0.0, math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    # huge finite values whose sum overflows are still a valid reference
    big = reference_from_nine(1e308, 1e308, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    np.testing.assert_array_equal(big.pos_ned, [1e308, 1e308, 0.0])
    assert seg.evaluate(0.5).pos_ned[0] == 0.5


def test_ramp_reference_is_the_constant_velocity_line() -> None:
    ramp = RampSegment(2.0, math.inf, np.array([1.0, 2.0, -0.5]), np.array([0.0, 0.0, 0.1]),
                       yaw_rad=0.2)
    ref = ramp.evaluate(4.5)
    np.testing.assert_array_equal(ref.pos_ned, [1.0 + 0.0 * 2.5, 2.0 + 0.0 * 2.5,
                                                -0.5 + 0.1 * 2.5])
    np.testing.assert_array_equal(ref.vel_ned, [0.0, 0.0, 0.1])
    np.testing.assert_array_equal(ref.acc_ned, 0.0)
    assert ref.yaw_rad == wrap_pi(0.2)


def test_moving_span_gives_what_evaluate_gives_while_the_reference_moves() -> None:
    limits = SpeedLimits()
    traj = Trajectory.from_waypoints(2.0, (0.0, 0.0, -0.6),
                                     [Waypoint(pos_ned=(1.0, 0.0, -0.6), hold_s=1.0),
                                      Waypoint(pos_ned=(1.0, 1.0, -0.6), yaw_rad=1.0)], limits)
    cubic1, hold, cubic2 = traj.segments
    assert traj.moving_span(1.9) is None  # before the start: a constant reference
    assert traj.moving_span(hold.t0_s + 0.5) is None  # holding
    assert traj.moving_span(traj.end_time_s) is None  # arrived
    assert traj.moving_span(2.5) == (cubic1.inside, cubic1.end_time_s)
    assert traj.moving_span(cubic2.t0_s) == (cubic2.inside, traj.end_time_s)
    for cubic in (cubic1, cubic2):
        for t in np.linspace(cubic.t0_s, cubic.end_time_s, 50, endpoint=False):
            span = traj.moving_span(float(t))
            assert span is not None
            got, inside = traj.evaluate(float(t)), span[0](float(t))
            for name in ("pos_ned", "vel_ned", "acc_ned"):
                np.testing.assert_array_equal(getattr(got, name), getattr(inside, name))
            assert (got.yaw_rad, got.yaw_rate_rad_s) == (inside.yaw_rad, inside.yaw_rate_rad_s)
    landing = landing_trajectory(0.0, (0.0, 0.0, -0.5), limits, 0.1)
    ramp = landing.segments[-1]
    span = landing.moving_span(ramp.t0_s + 3.0)  # the endless creep
    assert span is not None and span[1] == math.inf
    np.testing.assert_array_equal(span[0](ramp.t0_s + 3.0).pos_ned,
                                  landing.evaluate(ramp.t0_s + 3.0).pos_ned)
