"""AUTO from the ground, as ArduCopter: MISSION_START or AUTO_OPTIONS start the take-off.

ArduCopter's AUTO waits on the ground for "auto-armed" (a pilot's throttle raise, or
MISSION_START); AUTO_OPTIONS bit 1 takes off without it, bit 0 allows arming in AUTO; a
mission whose next NAV item is not a take-off cannot start from the ground.
"""

from __future__ import annotations

import pytest
from test_navigator import Flight, flight

from fcu.navigation.landing import LandedState
from fcu.navigation.modes import Mode
from fcu.navigation.settings import NavigatorConfig
from flightdata.mission import MissionItem

TAKEOFF_MISSION = [MissionItem(command="takeoff", alt_m=1.0),
                   MissionItem(command="waypoint", pos_ned=(0.5, 0.0, -1.0))]
WAYPOINT_FIRST = [MissionItem(command="waypoint", pos_ned=(0.5, 0.0, -1.0))]


def armed_on_the_ground(auto_options: int = 0, mode: Mode = Mode.GUIDED) -> Flight:
    f = flight(NavigatorConfig(auto_options=auto_options))
    assert f.nav.load_mission(TAKEOFF_MISSION).accepted
    assert f.nav.set_mode(mode).accepted
    return f


def climbs(f: Flight, seconds: float = 8.0) -> bool:
    """The vehicle leaves the ground within ``seconds`` (simulated)."""
    end_s = f.time_s + seconds
    while f.time_s < end_s:
        f.tick()
        if -f.vehicle.pos_ned[2] > 0.5:
            return True
    return False


def test_auto_on_the_ground_waits_for_mission_start_then_takes_off() -> None:
    f = armed_on_the_ground()
    assert f.nav.arm().accepted
    assert f.nav.set_mode(Mode.AUTO).accepted
    assert not climbs(f, 2.0)  # no MISSION_START: armed on the ground in AUTO
    assert f.nav.landed_state == LandedState.ON_GROUND and f.nav.armed
    assert f.nav.start_mission().accepted  # MISSION_START: ArduCopter's "auto-armed"
    assert climbs(f)
    f.run_until(f.time_s + 5.0)
    assert [e.seq for e in f.events if e.kind == "item_reached"][:1] == [1]  # the take-off


def test_auto_on_the_ground_without_mission_start_disarms_after_disarm_delay() -> None:
    f = armed_on_the_ground()
    f.nav.arm()
    f.nav.set_mode(Mode.AUTO)
    delay_s = f.nav.config.idle_disarm_delay_s
    f.run_until(f.time_s + delay_s + 0.1)
    assert not f.nav.armed
    assert "no take-off" in f.first("disarm").text


def test_auto_options_bit_1_takes_off_on_entering_auto() -> None:
    f = armed_on_the_ground(auto_options=2)
    f.nav.arm()
    assert f.nav.set_mode(Mode.AUTO).accepted
    assert climbs(f)
    assert f.nav.start_mission().accepted  # a MISSION_START after it changes nothing
    assert f.nav.mission_progress().current_seq in (1, 2)


def test_auto_from_the_ground_needs_a_take_off_first() -> None:
    f = armed_on_the_ground(auto_options=3)
    f.nav.load_mission(WAYPOINT_FIRST)
    f.nav.arm()
    result = f.nav.set_mode(Mode.AUTO)
    assert not result.accepted  # ArduCopter: "Auto: Missing Takeoff Cmd"
    assert result.reason == ("on the ground the next NAV item must be NAV_TAKEOFF (item 1 "
                             "is NAV_WAYPOINT (0.50, 0.00, -1.00) hold 0.0 s)")
    assert f.nav.mode == Mode.GUIDED and not climbs(f, 1.0)


@pytest.mark.parametrize(("auto_options", "takes_off"), [(1, False), (3, True)])
def test_auto_options_bit_0_allows_arming_in_auto(auto_options: int,
                                                   takes_off: bool) -> None:
    refused = armed_on_the_ground(auto_options=0, mode=Mode.AUTO)
    assert refused.nav.arm().reason.endswith("AUTO_OPTIONS bit 0 allows AUTO)")
    f = armed_on_the_ground(auto_options=auto_options, mode=Mode.AUTO)
    assert f.nav.prearm_check().ok
    assert f.nav.arm().accepted
    assert climbs(f, 3.0) == takes_off  # bit 1: at once; else on MISSION_START
    if not takes_off:
        assert f.nav.start_mission().accepted and climbs(f)


def test_arming_in_auto_needs_a_mission_that_starts_with_a_take_off() -> None:
    f = flight(NavigatorConfig(auto_options=3))
    f.nav.load_mission(WAYPOINT_FIRST)
    f.nav.set_mode(Mode.AUTO)  # disarmed: any mission may be selected
    assert f.nav.mode == Mode.AUTO
    assert f.nav.arm().reason.startswith("AUTO: on the ground the next NAV item must be "
                                         "NAV_TAKEOFF")


@pytest.mark.parametrize("bad", [-1, 4, 1.0, True])
def test_auto_options_outside_its_bits_are_refused(bad: object) -> None:
    with pytest.raises(ValueError, match="auto_options"):
        NavigatorConfig(auto_options=bad)  # type: ignore[arg-type]
