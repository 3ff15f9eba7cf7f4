"""Navigator: modes, arming, take-off/land/RTL, GUIDED, missions and failsafes.

The navigator is driven by a kinematic "vehicle" that adopts each reference exactly (one
tick late, as a real loop would see it) and cannot go below the ground, so the navigator's
logic is tested on its own, without controllers or physics.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest
from pymavlink import mavutil

from fcu.navigation.events import NavEvent
from fcu.navigation.fence import FenceConfig
from fcu.navigation.landing import LandedState
from fcu.navigation.mission import MissionState
from fcu.navigation.modes import ARDUCOPTER_MODE_NAMES, Mode
from fcu.navigation.navigator import Navigator, NavOutput
from fcu.navigation.reference import Reference
from fcu.navigation.settings import NavigatorConfig
from flightdata.mission import MissionItem, thesis_mission

DT_S = 0.01  # s, the autopilot's 100 Hz tick


def ref(out: NavOutput) -> Reference:
    """The output's reference, which the caller expects to exist (in flight)."""
    assert out.reference is not None
    return out.reference


@dataclass
class Vehicle:
    """Follows the reference exactly; the ground (z = 0) stops it; idle motors: it stays."""

    pos_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    vel_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    yaw_rad: float = 0.0
    frozen: bool = False  # True: ignores the reference (a stuck vehicle)

    def follow(self, out: NavOutput) -> None:
        ref = out.reference
        if self.frozen:
            self.vel_ned = np.zeros(3)
            return
        if ref is None:
            self.vel_ned = np.zeros(3)
            return
        pos, vel = ref.pos_ned.copy(), ref.vel_ned.copy()
        if pos[2] >= 0.0:  # on the ground
            pos[2], vel[2] = 0.0, min(vel[2], 0.0)
        self.pos_ned, self.vel_ned, self.yaw_rad = pos, vel, ref.yaw_rad


@dataclass
class Flight:
    """Runs a navigator and a vehicle tick by tick, keeping outputs and events."""

    nav: Navigator
    vehicle: Vehicle = field(default_factory=Vehicle)
    time_s: float = 0.0
    ticks: int = 0
    outputs: list[tuple[float, NavOutput]] = field(default_factory=list)
    events: list[NavEvent] = field(default_factory=list)
    healthy: bool = True

    def tick(self) -> NavOutput:
        self.time_s = self.ticks * DT_S
        out = self.nav.step(self.time_s, self.vehicle.pos_ned, self.vehicle.vel_ned,
                            self.vehicle.yaw_rad, estimator_healthy=self.healthy)
        self.vehicle.follow(out)
        self.outputs.append((self.time_s, out))
        self.events.extend(out.events)
        self.ticks += 1
        return out

    def run_until(self, end_s: float) -> NavOutput:
        out = self.tick()
        while self.time_s < end_s - 1e-9:
            out = self.tick()
        return out

    def first(self, kind: str, after_s: float = -1.0) -> NavEvent:
        return next(e for e in self.events if e.kind == kind and e.time_s > after_s)

    def kinds(self) -> list[str]:
        return [e.kind for e in self.events]


def flight(config: NavigatorConfig | None = None) -> Flight:
    f = Flight(Navigator(config))
    f.tick()  # the navigator has an estimate from t = 0
    return f


def airborne(alt_m: float = 1.0, config: NavigatorConfig | None = None) -> Flight:
    """A flight in GUIDED hovering at ``alt_m`` above home."""
    f = flight(config)
    assert f.nav.set_mode(Mode.GUIDED).accepted
    assert f.nav.arm().accepted
    assert f.nav.takeoff(alt_m).accepted
    f.run_until(f.time_s + 1.5 * alt_m / f.nav.speed_limits.up_m_s + 0.5)
    assert f.nav.landed_state == LandedState.IN_AIR
    return f


# ---------------------------------------------------------------- modes
def test_mode_numbers_are_arducopter_custom_modes() -> None:
    assert {m.name: int(m) for m in Mode} == {
        "STABILIZE": 0, "ALT_HOLD": 2, "AUTO": 3, "GUIDED": 4, "LOITER": 5, "RTL": 6,
        "CIRCLE": 7, "LAND": 9, "POSHOLD": 16, "BRAKE": 17, "FOLLOW": 23}
    for number, name in ARDUCOPTER_MODE_NAMES.items():
        assert mavutil.mode_mapping_acm[number] == name  # pymavlink's table agrees


@pytest.mark.parametrize(("number", "reason"), [
    (15, "AUTOTUNE (15) is not supported"), (21, "SMART_RTL (21) is not supported"),
    (1, "ACRO (1) is not supported"), (42, "unknown mode number 42")])
def test_unsupported_modes_are_refused_with_a_reason(number: int, reason: str) -> None:
    f = flight()
    result = f.nav.set_mode(number)
    assert not result.accepted and result.reason == reason
    assert f.nav.mode == Mode.STABILIZE
    assert f.tick().events[-1].kind == "refused" and reason in f.events[-1].text


def test_position_modes_need_a_healthy_estimator_and_auto_a_mission() -> None:
    f = flight()
    f.healthy = False
    f.tick()
    for mode in (Mode.GUIDED, Mode.LOITER, Mode.BRAKE, Mode.RTL, Mode.AUTO):
        result = f.nav.set_mode(mode)
        assert not result.accepted and result.reason == "position estimate not healthy"
    assert f.nav.set_mode(Mode.LAND).accepted  # always possible
    assert f.nav.set_mode(Mode.ALT_HOLD).accepted
    f.healthy = True
    f.tick()
    assert f.nav.set_mode(Mode.AUTO).reason == "no mission loaded"
    assert f.nav.set_mode(Mode.BRAKE).accepted  # MAVSDK asks for BRAKE before arming


# ---------------------------------------------------------------- arming
def test_arming_refusals_name_the_failed_check() -> None:
    nav = Navigator()
    assert nav.arm().reason == "no state estimate yet"
    f = flight()
    f.nav.set_mode(Mode.AUTO)  # refused (no mission); stays STABILIZE
    f.nav.load_mission(thesis_mission())
    assert f.nav.set_mode(Mode.AUTO).accepted
    assert f.nav.arm().reason == ("mode AUTO does not allow arming "
                                  "(use STABILIZE, ALT_HOLD, GUIDED, LOITER, POSHOLD; "
                                  "AUTO_OPTIONS bit 0 allows AUTO)")
    f.nav.set_mode(Mode.GUIDED)
    f.nav.trigger_failsafe("gcs")
    assert f.nav.arm().reason == "failsafe active: gcs"
    f.nav.clear_failsafe("gcs")
    f.healthy = False
    f.tick()
    assert f.nav.arm().reason == "estimator not healthy"
    f.healthy = True
    f.vehicle.pos_ned = np.array([0.0, 0.0, -1.0])
    f.tick()
    assert f.nav.arm().reason.startswith("not on the ground (altitude 1.00 m")
    f.vehicle.pos_ned = np.zeros(3)
    f.nav.step(f.time_s + DT_S, np.zeros(3), np.zeros(3), 0.0, on_ground_hint=False)
    assert f.nav.arm().reason.startswith("not on the ground")
    assert not f.nav.armed
    f.nav.step(f.time_s + 2 * DT_S, np.zeros(3), np.zeros(3), 0.0)
    assert f.nav.arm().accepted and f.nav.armed
    assert f.nav.arm().reason == "already armed"


def test_force_arm_skips_checks_and_disarm_in_flight_needs_force() -> None:
    f = flight()
    f.healthy = False
    f.tick()
    assert f.nav.arm(force=True).accepted  # STABILIZE, unhealthy estimator: forced anyway
    f.nav.disarm()
    f = airborne(0.8)
    result = f.nav.disarm()
    assert not result.accepted and result.reason == "flying: land first (or force)"
    assert f.nav.disarm(force=True).accepted
    out = f.tick()
    assert not out.armed and out.reference is None


def test_idle_auto_disarm_when_armed_without_take_off() -> None:
    f = flight(NavigatorConfig(idle_disarm_delay_s=3.0))
    f.nav.set_mode(Mode.GUIDED)
    f.nav.arm()
    out = f.run_until(2.9)
    assert out.armed and out.reference is None  # armed on the ground: motors idle
    f.run_until(3.1)
    assert not f.nav.armed
    assert f.first("disarm").time_s == pytest.approx(3.0, abs=DT_S)


# ---------------------------------------------------------------- take-off, land, RTL
def test_guided_takeoff_refusals_then_climb_to_altitude() -> None:
    f = flight()
    assert f.nav.takeoff(1.0).reason == "needs GUIDED (mode is STABILIZE)"
    f.nav.set_mode(Mode.GUIDED)
    assert f.nav.takeoff(1.0).reason == "not armed"
    f.nav.arm()
    assert not f.nav.takeoff(0.05).accepted  # not above the landed-detection height
    assert f.nav.takeoff(1.0).accepted
    t0 = f.time_s
    assert f.tick().landed_state == LandedState.TAKEOFF
    t_arr = t0 + 1.5 * 1.0 / 0.3  # default climb speed 0.3 m/s
    out = f.run_until(t_arr + 1.0)
    assert out.landed_state == LandedState.IN_AIR and not out.landed
    np.testing.assert_allclose(ref(out).pos_ned, [0, 0, -1.0], atol=1e-12)
    assert f.first("takeoff_complete").time_s == pytest.approx(t_arr, abs=DT_S)
    assert f.nav.takeoff(2.0).reason == "already flying"
    climb = [-o.reference.vel_ned[2] for _, o in f.outputs if o.reference is not None]
    assert max(climb) == pytest.approx(0.3, rel=1e-3)


def test_land_descends_detects_landing_and_auto_disarms() -> None:
    cfg = NavigatorConfig()
    f = airborne(0.6, cfg)
    assert f.nav.land().accepted and f.nav.mode == Mode.LAND
    t0 = f.time_s
    assert f.tick().landed_state == LandedState.LANDING
    f.run_until(t0 + 10.0)
    touchdown_s = t0 + 1.5 * 0.6 / cfg.speed_down_m_s
    landed = f.first("landed")
    # Landing is detected land_detect_time_s after the vehicle is low and slow (<= touchdown).
    assert touchdown_s - 0.5 < landed.time_s - cfg.land_detect_time_s <= touchdown_s
    disarm = f.first("disarm")
    assert disarm.time_s == pytest.approx(landed.time_s + cfg.landed_disarm_delay_s,
                                          abs=DT_S)
    after = [o for t, o in f.outputs if t > landed.time_s]
    assert all(o.landed and o.reference is None for o in after)
    assert f.vehicle.pos_ned[2] == 0.0


def test_landing_is_not_detected_while_the_vehicle_hovers() -> None:
    f = airborne(0.6)
    f.vehicle.frozen = True  # stays at 0.6 m whatever the reference says
    f.nav.land()
    f.run_until(f.time_s + 20.0)
    assert "landed" not in f.kinds() and f.nav.armed and not f.nav.landed
    f.vehicle.frozen = False  # now it descends: landing follows
    f.run_until(f.time_s + 15.0)
    assert "landed" in f.kinds()


def test_rtl_climbs_first_flies_home_and_lands_there() -> None:
    cfg = NavigatorConfig(rtl_alt_m=1.2, rtl_hold_s=1.0)
    f = airborne(0.5, cfg)
    f.nav.go_to((1.0, 1.0, -0.5))
    f.run_until(f.time_s + 12.0)
    np.testing.assert_allclose(f.vehicle.pos_ned, [1.0, 1.0, -0.5], atol=1e-9)
    t0 = f.time_s
    assert f.nav.return_to_launch().accepted
    f.run_until(t0 + 40.0)
    path = np.array([o.reference.pos_ned for t, o in f.outputs
                     if t > t0 and o.reference is not None])
    horizontal = np.hypot(path[:, 0] - 1.0, path[:, 1] - 1.0)
    # No horizontal motion until the RTL altitude is reached, then it stays at 1.2 m
    # until above home.
    first_move = np.argmax(horizontal > 1e-9)
    assert -path[first_move, 2] == pytest.approx(1.2, abs=1e-9)
    above_home = np.argmax(np.hypot(path[:, 0], path[:, 1]) < 1e-9)
    assert np.all(np.abs(path[first_move:above_home, 2] + 1.2) < 1e-9)
    assert f.nav.mode == Mode.RTL and "landed" in f.kinds() and not f.nav.armed
    np.testing.assert_allclose(f.vehicle.pos_ned, [0.0, 0.0, 0.0], atol=1e-9)


def test_rtl_keeps_altitude_when_already_higher() -> None:
    f = airborne(2.0, NavigatorConfig(rtl_alt_m=1.0))
    f.nav.go_to((0.5, 0.0, -2.0))
    f.run_until(f.time_s + 10.0)
    t0 = f.time_s
    f.nav.return_to_launch()
    f.run_until(t0 + 8.0)
    refs = [o.reference for t, o in f.outputs if t > t0 and o.reference is not None]
    away = [-r.pos_ned[2] for r in refs if np.hypot(*r.pos_ned[:2]) > 0.0]
    assert len(away) > 100 and min(away) == pytest.approx(2.0)  # no descent until home
    assert min(-r.pos_ned[2] for r in refs) < 1.8  # then it descends (the filter matters)


# ---------------------------------------------------------------- GUIDED, LOITER
def test_guided_go_to_arrives_on_time_at_rest() -> None:
    f = airborne(1.0)
    assert f.nav.go_to((2.0, 0.0, -1.0), yaw_rad=0.5).accepted
    t0 = f.time_s
    t_arr = t0 + 1.5 * 2.0 / 0.5  # default horizontal speed 0.5 m/s
    f.run_until(t_arr + 0.5)
    reached = f.first("target_reached", after_s=t0)
    assert reached.time_s == pytest.approx(t_arr, abs=DT_S)
    out = f.outputs[-1][1]
    np.testing.assert_allclose(ref(out).pos_ned, [2.0, 0.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(ref(out).vel_ned, 0.0, atol=1e-12)
    assert ref(out).yaw_rad == pytest.approx(0.5)


def test_streaming_the_same_target_does_not_restart_the_leg() -> None:
    f = airborne(1.0)
    f.nav.go_to((2.0, 0.0, -1.0))
    t0 = f.time_s
    while f.time_s < t0 + 8.0:
        if f.ticks % 10 == 0:  # a GCS repeating its setpoint at 10 Hz
            assert f.nav.go_to((2.0, 0.0, -1.0)).accepted
        f.tick()
    assert f.first("target_reached", after_s=t0).time_s == pytest.approx(t0 + 6.0, abs=DT_S)
    assert [e.kind for e in f.events if e.time_s > t0].count("mission") == 0  # no replans


def test_go_to_refusals_and_reposition_switches_to_guided() -> None:
    f = flight()
    f.nav.set_mode(Mode.GUIDED)
    f.nav.arm()
    # on the ground: a target on the ground is refused, one up takes off (as PX4's OFFBOARD)
    assert f.nav.go_to((1, 0, -0.05)).reason == "not flying: the target is on the ground"
    assert f.nav.go_to((1, 0, -1)).accepted and f.nav.leg_kind == "takeoff"
    f = airborne(1.0)
    assert f.nav.go_to((1, 0, 0.5)).reason.startswith("target altitude -0.50 m outside")
    assert f.nav.go_to((np.nan, 0, -1)).reason.endswith("is not three finite numbers")
    f.nav.set_mode(Mode.LOITER)
    assert f.nav.go_to((1, 0, -1)).reason == "needs GUIDED (mode is LOITER)"
    assert f.nav.reposition((1, 0, -1)).accepted and f.nav.mode == Mode.GUIDED
    f.run_until(f.time_s + 10.0)
    np.testing.assert_allclose(f.vehicle.pos_ned, [1, 0, -1], atol=1e-12)


def test_change_speed_sets_the_next_leg_time() -> None:
    f = airborne(1.0)
    assert not f.nav.change_speed(0.0).accepted
    assert not f.nav.change_speed(0.2, "sideways").accepted
    assert f.nav.change_speed(0.25).accepted
    f.nav.go_to((1.0, 0.0, -1.0))
    t0 = f.time_s
    f.run_until(t0 + 8.0)
    assert f.first("target_reached", after_s=t0).time_s == pytest.approx(t0 + 6.0, abs=DT_S)


@pytest.mark.parametrize("mode", [Mode.LOITER, Mode.BRAKE])
def test_loiter_and_brake_hold_where_the_vehicle_stops(mode: Mode) -> None:
    f = airborne(1.0)
    f.nav.go_to((2.0, 0.0, -1.0))
    f.run_until(f.time_s + 3.0)  # mid-leg, moving north
    north, speed = f.vehicle.pos_ned[0], f.vehicle.vel_ned[0]  # the next tick's estimate
    assert speed > 0.3
    f.tick()
    t0 = f.time_s
    assert f.nav.set_mode(mode).accepted
    f.run_until(t0 + 5.0)
    refs = np.array([ref(o).pos_ned for t, o in f.outputs if t > t0])
    assert np.ptp(refs, axis=0).max() == 0.0  # constant
    # Held at the stopping point v|v| / (2 a) ahead, a = 0.5 m/s^2.
    assert refs[0, 0] == pytest.approx(north + speed**2 / (2 * 0.5))


def test_alt_hold_keeps_altitude_and_lets_position_free() -> None:
    f = airborne(0.8)
    f.nav.set_mode(Mode.ALT_HOLD)
    f.vehicle.frozen = True
    f.vehicle.pos_ned = np.array([0.3, -0.2, -0.8])  # pushed by wind
    out = f.tick()
    np.testing.assert_allclose(ref(out).pos_ned, [0.3, -0.2, -0.8])


# ---------------------------------------------------------------- missions
def fly_thesis() -> Flight:
    f = flight()
    f.nav.set_mode(Mode.GUIDED)
    f.nav.arm()
    assert f.nav.load_mission(thesis_mission()).accepted
    assert f.nav.mission_progress().state == MissionState.NOT_STARTED
    assert f.nav.start_mission().accepted
    assert f.nav.mode == Mode.AUTO
    return f


def test_thesis_mission_timeline_items_in_order_and_complete() -> None:
    f = fly_thesis()
    f.run_until(15.0)
    progress = f.nav.mission_progress()
    assert progress.state == MissionState.ACTIVE and progress.total == 11
    assert progress.current_seq == 5  # flying the first side
    f.run_until(60.0)
    progress = f.nav.mission_progress()
    assert progress.state == MissionState.COMPLETE and progress.current_seq == 10
    reached = {r.seq: r.time_s for r in progress.reached}
    assert list(reached) == list(range(1, 11))  # every item, in order, once
    planned = {1: 0.0, 2: 5.0, 3: 5.0, 4: 7.0, 5: 17.0, 6: 28.0, 7: 39.0, 8: 50.0, 9: 52.0}
    for seq, t in planned.items():
        assert reached[seq] == pytest.approx(t, abs=DT_S)  # one tick of slack
    assert 56.0 < reached[10] <= 57.0 + 2 * DT_S  # landed: touchdown + land_detect_time_s
    assert [e.seq for e in f.events if e.kind == "item_reached"] == list(range(1, 11))
    assert f.first("mission_complete").time_s == pytest.approx(reached[10])
    assert f.first("disarm").time_s == pytest.approx(reached[10] + 2.0, abs=DT_S)
    # Where the vehicle is when the thesis's faults strike: on the square, at 0.6 m.
    at = {round(t, 2): o for t, o in f.outputs}
    for fault_s, expected in ((22.0, (1.0, 0.352)), (38.0, (0.028, 1.0)),
                              (48.0, (0.0, 0.104))):
        np.testing.assert_allclose(ref(at[fault_s]).pos_ned, [*expected, -0.6], atol=1e-3)
    assert f.vehicle.pos_ned[2] == 0.0 and not f.nav.armed


def test_pausing_and_resuming_the_mission() -> None:
    f = fly_thesis()
    f.run_until(12.0)  # halfway along the first side
    assert f.nav.set_mode(Mode.LOITER).accepted
    assert f.nav.mission_progress().state == MissionState.PAUSED
    f.run_until(20.0)
    north = f.vehicle.pos_ned[0]
    assert 0.4 < north < 0.6  # stopped mid-leg
    assert f.nav.set_mode(Mode.AUTO).accepted
    assert f.nav.mission_progress().state == MissionState.ACTIVE
    t0 = f.time_s
    f.run_until(t0 + 10.0)
    # Resumes item 5 from where it stopped: the remaining 1 - north metres at 0.15 m/s.
    reached5 = next(r for r in f.nav.mission_progress().reached if r.seq == 5)
    assert reached5.time_s == pytest.approx(t0 + 1.5 * (1.0 - north) / 0.15, abs=DT_S)


def test_set_current_item_jumps_in_flight_and_refuses_bad_seqs() -> None:
    f = fly_thesis()
    f.run_until(10.0)
    assert f.nav.set_current_item(99).reason == "seq 99 outside 1..10"
    assert f.nav.set_current_item(7).accepted
    assert f.nav.mission_progress().current_seq == 7
    f.run_until(40.0)
    seqs = [r.seq for r in f.nav.mission_progress().reached]
    assert seqs[:4] == [1, 2, 3, 4] and seqs[4] == 7  # items 5 and 6 skipped
    assert 5 not in seqs and 6 not in seqs


def test_mission_start_refusals() -> None:
    f = flight()
    assert f.nav.start_mission().reason == "no mission loaded"
    f.nav.load_mission(thesis_mission())
    assert f.nav.start_mission().reason == "not armed"
    f.nav.set_mode(Mode.GUIDED)
    f.nav.arm()
    f.nav.load_mission([MissionItem(command="waypoint", pos_ned=(1, 0, -1))])
    assert f.nav.start_mission().reason == ("on the ground the next NAV item must be "
                                            "NAV_TAKEOFF (item 1 is NAV_WAYPOINT "
                                            "(1.00, 0.00, -1.00) hold 0.0 s)")
    assert f.nav.mode == Mode.GUIDED


def test_mission_waits_for_a_lagging_vehicle() -> None:
    f = fly_thesis()
    f.run_until(15.0)
    f.vehicle.frozen = True  # stuck at ~0.9 m north while the leg ends at 17 s
    f.run_until(20.0)
    assert 5 not in [r.seq for r in f.nav.mission_progress().reached]
    f.vehicle.frozen = False
    f.run_until(21.0)
    reached5 = next(r for r in f.nav.mission_progress().reached if r.seq == 5)
    assert reached5.time_s == pytest.approx(20.0, abs=2 * DT_S)
    # The corner hold (1 s) now counts from when it was reached: next leg from ~21 s.
    f.run_until(35.0)
    reached6 = next(r for r in f.nav.mission_progress().reached if r.seq == 6)
    assert reached6.time_s == pytest.approx(31.0, abs=2 * DT_S)


def test_mission_with_rtl_item_lands_at_home() -> None:
    items = [MissionItem(command="takeoff", alt_m=0.5),
             MissionItem(command="waypoint", pos_ned=(1.0, 0.0, -0.5)),
             MissionItem(command="rtl")]
    f = flight(NavigatorConfig(rtl_alt_m=0.8))
    f.nav.set_mode(Mode.GUIDED)
    f.nav.arm()
    f.nav.load_mission(items)
    f.nav.start_mission()
    f.run_until(40.0)
    progress = f.nav.mission_progress()
    assert [r.seq for r in progress.reached] == [1, 2, 3]
    assert progress.state == MissionState.COMPLETE
    np.testing.assert_allclose(f.vehicle.pos_ned, 0.0, atol=1e-9)
    assert min(ref(o).pos_ned[2] for _, o in f.outputs if o.reference is not None) == \
        pytest.approx(-0.8)


def test_mission_item_validation_and_numbers() -> None:
    with pytest.raises(ValueError, match="alt_m"):
        MissionItem(command="takeoff")
    with pytest.raises(ValueError, match="command"):
        MissionItem(command="loiter_turns")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="pos_ned"):
        MissionItem(pos_ned=(0.0, float("inf"), -1.0))
    assert [i.mav_cmd for i in thesis_mission()] == [178, 22, 16, 178, 16, 16, 16, 16, 178, 21]
    nav = Navigator(NavigatorConfig(fence=FenceConfig(enable=1, alt_max_m=10.0)))
    result = nav.load_mission([MissionItem(pos_ned=(0.0, 0.0, -50.0))])
    assert not result.accepted and result.reason.startswith("item 1: altitude 50.00 m")
    assert "FENCE_ALT_MAX" in result.reason
    assert nav.mission_progress().state == MissionState.NO_MISSION


# ---------------------------------------------------------------- failsafe
def test_failsafe_rtl_in_flight_then_arming_blocked_until_cleared() -> None:
    f = fly_thesis()
    f.run_until(22.0)
    assert f.nav.trigger_failsafe("gcs", action="rtl").accepted
    out = f.tick()
    assert out.mode == Mode.RTL and out.failsafe
    assert any(e.kind == "failsafe" and e.severity == "critical" for e in out.events)
    assert f.nav.mission_progress().state == MissionState.PAUSED
    f.run_until(60.0)
    assert "landed" in f.kinds() and not f.nav.armed
    np.testing.assert_allclose(f.vehicle.pos_ned, 0.0, atol=1e-9)
    assert f.nav.set_mode(Mode.GUIDED).accepted
    assert f.nav.arm().reason == "failsafe active: gcs"
    f.nav.clear_failsafe("gcs")
    assert f.nav.arm().accepted


def test_failsafe_land_and_on_the_ground() -> None:
    f = airborne(1.0)
    f.nav.go_to((1.0, 0.0, -1.0))
    f.run_until(f.time_s + 2.0)
    f.nav.trigger_failsafe("battery", action="land")
    assert f.nav.mode == Mode.LAND
    f.nav.trigger_failsafe("gcs", action="rtl")  # already landing: stays in LAND
    assert f.nav.mode == Mode.LAND
    assert not f.nav.trigger_failsafe("gcs", action="explode").accepted
    f.run_until(f.time_s + 20.0)
    assert "landed" in f.kinds()
    assert 0.0 < f.vehicle.pos_ned[0] < 1.0  # landed where it was, not at home or target
    g = flight()
    g.nav.set_mode(Mode.GUIDED)
    g.nav.arm()
    g.nav.trigger_failsafe("gcs")
    assert not g.nav.armed  # armed on the ground: disarmed


def test_step_rejects_time_going_backwards_and_reset_restores_boot_state() -> None:
    f = airborne(1.0)
    with pytest.raises(ValueError, match="earlier"):
        f.nav.step(f.time_s - 1.0, np.zeros(3), np.zeros(3), 0.0)
    f.nav.load_mission(thesis_mission()) if not f.nav.mission_items else None
    f.nav.reset()
    assert not f.nav.armed and f.nav.landed and f.nav.mode == Mode.STABILIZE
    out = f.nav.step(0.0, np.zeros(3), np.zeros(3), 0.0)
    assert out.reference is None and out.events == ()


def test_step_output_is_reused_only_while_nothing_changes() -> None:
    f = airborne(1.0)
    hold = [f.tick() for _ in range(3)]
    # hovering at the take-off target: the same reference object, hence the same output
    assert hold[1] is hold[0] and hold[2] is hold[0] and hold[0].events == ()
    assert f.nav.go_to((1.0, 0.0, -1.0)).accepted
    moving = [f.tick() for _ in range(3)]
    assert moving[0].events and moving[0] is not hold[0]  # the go-to's event
    assert moving[1] is not moving[0] and moving[2] is not moving[1]
    # each tick's reference keeps its values: later ticks do not overwrite them
    xs = [ref(o).pos_ned[0] for o in moving]
    assert xs[0] < xs[1] < xs[2]
    for out in (hold[0], *moving):
        public = NavOutput(reference=out.reference, armed=out.armed, mode=out.mode,
                           landed=out.landed, landed_state=out.landed_state,
                           failsafe=out.failsafe, events=out.events)
        assert vars(out) == vars(public)
    assert f.nav.set_mode(Mode.LOITER).accepted
    assert f.tick().mode == Mode.LOITER  # a change of mode is a new output


def test_ticks_along_a_segment_match_the_full_step_bit_for_bit() -> None:
    # The ticks that only move along a segment take a shortcut (Navigator._cruise_from);
    # a navigator that never takes it must give the same outputs and events, tick for tick,
    # through a mission, a lagging vehicle, commands between ticks and a lost position fix.
    fast, full = fly_thesis(), fly_thesis()
    full.nav._cruise_from = lambda t, out: None  # type: ignore[method-assign]
    shortcuts = 0
    for tick in range(7600):
        if tick == 1500:  # mid-leg: a refused command, then GUIDED and a go-to
            for f in (fast, full):
                assert not f.nav.takeoff(0.8).accepted
                assert f.nav.set_mode(Mode.GUIDED).accepted
                assert f.nav.go_to((0.5, 0.5, -0.8), yaw_rad=1.0).accepted
        if tick == 1650:  # the vehicle stalls: the leg waits for it
            fast.vehicle.frozen = full.vehicle.frozen = True
        if tick == 1900:
            fast.vehicle.frozen = full.vehicle.frozen = False
        if tick == 2400:  # then back to the mission
            assert fast.nav.start_mission().accepted and full.nav.start_mission().accepted
        fix = not 3000 <= tick < 3100  # the position fix lost for 1 s, mid-leg
        outs = []
        for f in (fast, full):
            f.time_s = f.ticks * DT_S
            out = f.nav.step(f.time_s, f.vehicle.pos_ned, f.vehicle.vel_ned,
                             f.vehicle.yaw_rad, position_fix=fix)
            f.vehicle.follow(out)
            f.ticks += 1
            outs.append(out)
        shortcuts += fast.nav._cruise is not None
        a, b = outs
        assert (a.reference is None) == (b.reference is None)
        if a.reference is not None and b.reference is not None:
            for name in ("pos_ned", "vel_ned", "acc_ned"):
                np.testing.assert_array_equal(getattr(a.reference, name),
                                              getattr(b.reference, name))
            assert (a.reference.yaw_rad, a.reference.yaw_rate_rad_s) == \
                (b.reference.yaw_rad, b.reference.yaw_rate_rad_s)
        assert {k: v for k, v in vars(a).items() if k != "reference"} == \
            {k: v for k, v in vars(b).items() if k != "reference"}
    assert shortcuts > 3000  # most ticks move along a segment
    assert not fast.nav.armed and fast.nav.mission_progress().state == MissionState.COMPLETE


@pytest.mark.parametrize(("pos_ned", "taken"), [
    (np.array([0.5, -0.25, 0.0]), True),  # an estimator's float64 3-vector
    (np.array([1, 2, 0]), True),  # integers: as floats
    (np.array([0.5, -0.25, 0.0], dtype=np.float32), True),
    ([0.5, -0.25, 0.0], True),
    (np.array([[0.5], [-0.25], [0.0]]), True),  # (3, 1): flattened
    (np.array([1e308, 1e308, 0.0]), True),  # finite, though its sum overflows
    (np.array([np.nan, 0.0, 0.0]), False),  # non-finite: ignored, the estimator unhealthy
    (np.array([0.0, -np.inf, 0.0]), False),
    (np.zeros(4), False),  # not a 3-vector
])
def test_the_estimate_is_taken_as_floats_when_finite_else_kept(pos_ned: object,
                                                                taken: bool) -> None:
    nav = Navigator()
    nav.step(0.0, np.array([0.1, 0.2, 0.0]), np.zeros(3), 0.0)
    nav.step(0.01, pos_ned, np.zeros(3), 0.0)  # type: ignore[arg-type]
    expected = np.asarray(pos_ned, dtype=float).reshape(-1) if taken else [0.1, 0.2, 0.0]
    assert [type(v) for v in nav._est_pos_f] == [float] * 3
    np.testing.assert_array_equal(nav._est_pos_f, expected)
    result = nav.set_mode(Mode.GUIDED)
    assert result.accepted is taken
    assert taken or result.reason == "position estimate not healthy"
