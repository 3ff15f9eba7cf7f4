"""The geofence as ArduCopter's FENCE_* parameters: off by default (no altitude or distance
limit), enabled it refuses targets outside it naming the parameter, and a breach in flight
triggers FENCE_ACTION once, announced."""

from __future__ import annotations

import numpy as np
import pytest
from test_navigator import airborne, flight

from fcu.navigation.fence import (
    FenceAreas,
    FenceConfig,
    area_problem,
    breach,
    inside_polygon,
    target_problem,
)
from fcu.navigation.modes import Mode
from fcu.navigation.settings import NavigatorConfig
from flightdata.mission import MissionItem

HOME = (0.0, 0.0, 0.0)


def fenced(**fields: float) -> NavigatorConfig:
    return NavigatorConfig(fence=FenceConfig(enable=1, **fields))  # type: ignore[arg-type]


def test_defaults_are_arducopters_and_off() -> None:
    fence = FenceConfig()
    assert (fence.enable, fence.types, fence.alt_max_m, fence.radius_m, fence.action) == \
        (0, 7, 100.0, 300.0, 1)
    assert target_problem((0.0, 0.0, -5000.0), HOME, fence) is None  # off: no ceiling
    assert breach((1e5, 0.0, -5000.0), HOME, fence) is None


def test_target_problems_name_the_parameter() -> None:
    fence = FenceConfig(enable=1, alt_max_m=10.0, radius_m=50.0)
    assert target_problem((0.0, 0.0, -9.9), HOME, fence) is None
    assert "FENCE_ALT_MAX" in (target_problem((0.0, 0.0, -10.1), HOME, fence) or "")
    assert "FENCE_RADIUS" in (target_problem((30.0, 40.1, -1.0), HOME, fence) or "")
    # FENCE_TYPE 2: the circle only
    circle_only = FenceConfig(enable=1, types=2, alt_max_m=10.0, radius_m=50.0)
    assert target_problem((0.0, 0.0, -20.0), HOME, circle_only) is None
    # altitude is measured above home, not the NED origin
    assert target_problem((0.0, 0.0, -11.0), (0.0, 0.0, -2.0), fence) is None


@pytest.mark.parametrize("bad", [{"enable": 2}, {"types": 8}, {"alt_max_m": 0.0},
                                 {"radius_m": float("nan")}, {"action": 6},
                                 {"margin_m": -1.0}])
def test_bad_settings_are_named(bad: dict[str, float]) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        FenceConfig(**bad)  # type: ignore[arg-type]


def test_no_hidden_ceiling_without_fence() -> None:
    f = flight()
    f.nav.set_mode(Mode.GUIDED)
    f.nav.arm()
    assert f.nav.takeoff(30.0).accepted  # ArduCopter: no altitude limit with the fence off
    assert Mode.GUIDED == f.nav.mode
    nav = flight().nav
    assert nav.load_mission([MissionItem(pos_ned=(500.0, 0.0, -120.0))]).accepted


def test_enabled_fence_refuses_take_off_goto_and_mission_items() -> None:
    f = airborne(1.0, fenced(alt_max_m=10.0, radius_m=50.0))
    result = f.nav.go_to((0.0, 0.0, -12.0))
    assert not result.accepted and "FENCE_ALT_MAX" in result.reason
    result = f.nav.go_to((60.0, 0.0, -1.0))
    assert not result.accepted and "FENCE_RADIUS" in result.reason
    assert f.nav.go_to((40.0, 0.0, -9.0)).accepted
    g = flight(fenced(alt_max_m=10.0))
    g.nav.set_mode(Mode.GUIDED)
    g.nav.arm()
    result = g.nav.takeoff(20.0)
    assert not result.accepted and "FENCE_ALT_MAX" in result.reason
    result = g.nav.load_mission([MissionItem(command="takeoff", alt_m=20.0)])
    assert not result.accepted and result.reason.startswith("item 1: take-off altitude")


@pytest.mark.parametrize("action, mode", [(1, Mode.RTL), (2, Mode.LAND), (4, Mode.BRAKE)])
def test_breach_triggers_the_action_once(action: int, mode: Mode) -> None:
    f = airborne(1.0, fenced(alt_max_m=5.0, action=action, margin_m=1.0))
    f.vehicle.frozen = True  # blown up through the ceiling: the estimate says 5.5 m
    f.vehicle.pos_ned = np.array([0.0, 0.0, -5.5])
    out = f.tick()
    assert out.mode == mode
    breaches = [e for e in f.events if e.kind == "fence"]
    assert len(breaches) == 1 and breaches[0].severity == "critical"
    assert "FENCE_ALT_MAX" in breaches[0].text and f"FENCE_ACTION {action}" in breaches[0].text
    f.run_until(f.time_s + 1.0)  # still outside: no second breach
    assert len([e for e in f.events if e.kind == "fence"]) == 1
    f.vehicle.pos_ned = np.array([0.0, 0.0, -3.5])  # back inside by the margin
    f.tick()
    assert [e.text for e in f.events if e.kind == "fence"][-1] == "back inside the fence"
    assert "fence" not in f.nav.failsafe_sources


def test_breach_report_only_keeps_the_mode() -> None:
    f = airborne(1.0, fenced(radius_m=3.0, action=0))
    f.vehicle.frozen = True
    f.vehicle.pos_ned = np.array([3.5, 0.0, -1.0])
    out = f.tick()
    assert out.mode == Mode.GUIDED and not out.failsafe
    assert "FENCE_RADIUS" in f.first("fence").text and "report only" in f.first("fence").text


def test_rtl_returns_below_the_fence() -> None:
    f = airborne(1.0, NavigatorConfig(rtl_alt_m=15.0, fence=FenceConfig(
        enable=1, alt_max_m=10.0, margin_m=2.0)))
    assert f.nav.return_to_launch().accepted
    f.run_until(f.time_s + 60.0)
    top = min(out.reference.pos_ned[2] for _, out in f.outputs if out.reference is not None)
    assert top == pytest.approx(-8.0, abs=1e-9)  # FENCE_ALT_MAX - FENCE_MARGIN


def test_fence_enabled_in_flight_outside_is_breached_and_disabling_clears_it() -> None:
    f = airborne(6.0)
    assert f.nav.set_fence(FenceConfig(enable=1, alt_max_m=5.0)).accepted
    out = f.tick()
    assert out.mode == Mode.RTL and "fence" in f.nav.failsafe_sources
    assert f.nav.set_fence(FenceConfig(enable=0)).accepted
    assert "fence" not in f.nav.failsafe_sources


SQUARE = np.array([[-10.0, -10.0], [10.0, -10.0], [10.0, 10.0], [-10.0, 10.0]])  # m, N E


def test_areas_inclusion_and_exclusion() -> None:
    assert inside_polygon(0.0, 0.0, SQUARE) and not inside_polygon(11.0, 0.0, SQUARE)
    keep_in = FenceAreas(inclusion_polygons=(SQUARE,))
    assert area_problem((0.0, 0.0, -5.0), keep_in) is None
    assert area_problem((0.0, 12.0, -5.0), keep_in) == "outside inclusion polygon 1"
    keep_out = FenceAreas(exclusion_polygons=(SQUARE,), exclusion_circles=((30.0, 0.0, 5.0),))
    assert area_problem((0.0, 0.0, -5.0), keep_out) == "inside exclusion polygon 1"
    assert area_problem((31.0, 0.0, -5.0), keep_out) == "inside exclusion circle 1"
    assert area_problem((20.0, 0.0, -5.0), keep_out) is None
    both = FenceAreas(inclusion_circles=((0.0, 0.0, 50.0),), exclusion_circles=((0.0, 0.0, 5.0),))
    assert area_problem((10.0, 0.0, 0.0), both) is None
    assert FenceAreas().empty and not both.empty


def test_uploaded_polygon_breach_needs_fence_type_bit_2() -> None:
    f = airborne(2.0, fenced())
    f.nav.set_fence_areas(FenceAreas(inclusion_polygons=(SQUARE,)))
    f.vehicle.frozen = True
    f.vehicle.pos_ned = np.array([0.0, 12.0, -2.0])  # blown out of the polygon
    assert f.tick().mode == Mode.RTL
    assert "outside inclusion polygon 1" in f.first("fence").text
    g = airborne(2.0, NavigatorConfig(fence=FenceConfig(enable=1, types=3)))  # no polygons
    g.nav.set_fence_areas(FenceAreas(inclusion_polygons=(SQUARE,)))
    g.vehicle.frozen = True
    g.vehicle.pos_ned = np.array([0.0, 12.0, -2.0])
    assert g.tick().mode == Mode.GUIDED
