"""FOLLOW (ArduCopter mode 23): a lead's reports in, a chase reference out.

Driven by the kinematic vehicle of :mod:`test_navigator` (it adopts each reference), with a
lead that moves on a known path and reports every ``REPORT_TICKS`` ticks, as a lead's
FOLLOW_TARGET or GLOBAL_POSITION_INT would arrive.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest
from test_navigator import Flight, airborne, ref

from fcu.navigation.follow import FOLLOW_TIMEOUT_S, FollowConfig
from fcu.navigation.modes import Mode
from fcu.navigation.settings import NavigatorConfig
from flightdata.config import ConfigError

REPORT_TICKS = 10  # ticks between reports: 10 Hz, as a ground station sends FOLLOW_TARGET
LEAD = 2  # the lead's system id
Lead = Callable[[float], tuple[np.ndarray, np.ndarray, float | None]]


def following(config: FollowConfig, alt_m: float = 2.0) -> Flight:
    """A vehicle hovering ``alt_m`` up in GUIDED with FOLL_* = ``config``."""
    return airborne(alt_m, NavigatorConfig(follow=config))


def fly_with_lead(f: Flight, lead: Lead, duration_s: float, sysid: int = LEAD) -> None:
    """Tick for ``duration_s`` (s) with the lead reporting every ``REPORT_TICKS`` ticks."""
    end_s = f.time_s + duration_s
    while f.time_s < end_s - 1e-9:
        if f.ticks % REPORT_TICKS == 0:
            pos, vel, heading = lead(f.time_s)
            f.nav.follow_report(sysid, pos, vel, heading)
        f.tick()


def walking(start_ned: tuple[float, float, float], vel_ned: tuple[float, float, float],
            heading_rad: float | None = None) -> Lead:
    """A lead moving at constant velocity from ``start_ned`` at t = 0 (m, m/s)."""
    p0, v = np.array(start_ned), np.array(vel_ned)
    return lambda t: (p0 + v * t, v.copy(), heading_rad)


def test_config_errors_name_the_key_and_the_range() -> None:
    with pytest.raises(ConfigError, match=r"offset_type = 2: must be a whole number in 0..1"):
        FollowConfig(offset_type=2)
    with pytest.raises(ConfigError, match=r"pos_p = 0.0: must be a finite number > 0"):
        FollowConfig(pos_p=0.0)


def test_follow_is_refused_until_foll_enable_as_arducopter_says() -> None:
    f = airborne(2.0)
    result = f.nav.set_mode(Mode.FOLLOW)
    assert not result.accepted and result.reason == "Set FOLL_ENABLE = 1"
    assert f.nav.mode == Mode.GUIDED


def test_follows_a_walking_lead_at_the_offset() -> None:
    offset = (-3.0, 1.0, -2.0)  # 3 m behind (south), 1 m east, 2 m above the lead
    f = following(FollowConfig(enable=1, offset_x_m=offset[0], offset_y_m=offset[1],
                               offset_z_m=offset[2]))
    lead = walking((2.0, 0.0, 0.0), (0.2, 0.1, 0.0))
    fly_with_lead(f, lead, 0.5)
    assert f.nav.set_mode(Mode.FOLLOW).accepted
    assert "following system 2" in [e.text for e in f.tick().events]
    fly_with_lead(f, lead, 80.0)  # 8 time constants of FOLL_POS_P (0.1 1/s)
    r = ref(f.outputs[-1][1])
    pos, vel, _ = lead(f.time_s)
    # the chase converges on the goal at exp(-0.1 t) from ~4 m: 1.5 cm after 80 s
    np.testing.assert_allclose(r.pos_ned, pos + np.array(offset), atol=0.05)
    np.testing.assert_allclose(r.vel_ned, vel, atol=0.01)  # 0.1 x the position error
    # FOLL_YAW_BEHAVE 1: facing the lead (north-north-east of the vehicle)
    assert r.yaw_rad == pytest.approx(math.atan2(-offset[1], -offset[0]), abs=0.02)


def test_all_zero_offsets_keep_the_offset_found_at_the_first_report() -> None:
    f = following(FollowConfig(enable=1), alt_m=2.0)
    assert f.nav.set_mode(Mode.FOLLOW).accepted  # before any report: waits, holding
    assert "waiting for the lead" in f.tick().events[-1].text
    start = f.vehicle.pos_ned.copy()
    lead = walking((4.0, -3.0, 0.0), (0.0, 0.25, 0.0))
    fly_with_lead(f, lead, 100.0)
    pos, _, _ = lead(f.time_s)
    # the offset taken at the first report (t ~ time of entry) is kept
    found = start - lead(f.time_s - 100.0)[0]
    np.testing.assert_allclose(ref(f.outputs[-1][1]).pos_ned, pos + found, atol=0.05)


def test_a_silent_lead_is_lost_after_the_timeout_and_the_vehicle_brakes_and_holds() -> None:
    f = following(FollowConfig(enable=1, offset_x_m=-2.0))
    lead = walking((0.0, 0.0, -2.0), (0.3, 0.0, 0.0))
    assert f.nav.set_mode(Mode.FOLLOW).accepted
    fly_with_lead(f, lead, 40.0)
    assert ref(f.outputs[-1][1]).vel_ned[0] == pytest.approx(0.3, abs=0.01)
    silent_from = f.time_s
    f.run_until(f.time_s + FOLLOW_TIMEOUT_S - 0.2)  # extrapolated at 0.3 m/s meanwhile
    assert ref(f.outputs[-1][1]).vel_ned[0] == pytest.approx(0.3, abs=0.01)
    f.run_until(silent_from + FOLLOW_TIMEOUT_S + 5.0)
    held = ref(f.outputs[-1][1])
    assert np.linalg.norm(held.vel_ned) == 0.0  # braked at 0.5 m/s^2: 0.6 s
    f.run_until(f.time_s + 5.0)
    np.testing.assert_array_equal(ref(f.outputs[-1][1]).pos_ned, held.pos_ned)
    assert f.nav.mode == Mode.FOLLOW


def test_foll_sysid_chooses_the_lead_and_zero_takes_the_first_heard() -> None:
    f = following(FollowConfig(enable=1, sysid=3, offset_x_m=-1.0))
    assert f.nav.set_mode(Mode.FOLLOW).accepted
    start = f.vehicle.pos_ned.copy()
    fly_with_lead(f, walking((10.0, 0.0, -2.0), (0.0, 0.0, 0.0)), 10.0, sysid=2)
    np.testing.assert_allclose(f.vehicle.pos_ned, start, atol=1e-9)  # not FOLL_SYSID
    assert f.nav.follow_report(3, np.array([1.0, 0.0, -2.0]), None, None)

    f = following(FollowConfig(enable=1, offset_x_m=-1.0))
    assert f.nav.follow_report(5, np.array([1.0, 0.0, -2.0]), None, None)
    assert not f.nav.follow_report(6, np.array([1.0, 0.0, -2.0]), None, None)  # locked on 5
    assert "follow: lead is system 5" in [e.text for e in f.tick().events]


def test_offsets_relative_to_the_leads_heading() -> None:
    # 2 m behind and 1 m right of a lead heading east: 2 m west, 1 m south of it
    f = following(FollowConfig(enable=1, offset_type=1, offset_x_m=-2.0, offset_y_m=1.0,
                               offset_z_m=0.0, yaw_behave=2))
    lead = walking((3.0, 3.0, -2.0), (0.0, 0.0, 0.0), heading_rad=math.pi / 2)
    assert f.nav.set_mode(Mode.FOLLOW).accepted
    fly_with_lead(f, lead, 120.0)
    r = ref(f.outputs[-1][1])
    np.testing.assert_allclose(r.pos_ned, [3.0 - 1.0, 3.0 - 2.0, -2.0], atol=0.01)
    assert r.yaw_rad == pytest.approx(math.pi / 2)  # FOLL_YAW_BEHAVE 2: the lead's heading


def test_a_lead_beyond_foll_dist_max_is_not_followed() -> None:
    f = following(FollowConfig(enable=1, dist_max_m=20.0, offset_x_m=-1.0))
    assert f.nav.set_mode(Mode.FOLLOW).accepted
    start = f.vehicle.pos_ned.copy()
    fly_with_lead(f, walking((30.0, 0.0, -2.0), (0.0, 0.0, 0.0)), 10.0)
    np.testing.assert_allclose(f.vehicle.pos_ned, start, atol=1e-9)
    f.nav.set_follow(replace(f.nav.config.follow, dist_max_m=0.0))  # FOLL_DIST_MAX 0: any
    fly_with_lead(f, walking((30.0, 0.0, -2.0), (0.0, 0.0, 0.0)), 10.0)
    assert f.vehicle.pos_ned[0] > start[0] + 1.0


def test_leaving_follow_holds_where_the_chase_was() -> None:
    f = following(FollowConfig(enable=1, offset_x_m=-1.0))
    assert f.nav.set_mode(Mode.FOLLOW).accepted
    fly_with_lead(f, walking((5.0, 0.0, -2.0), (0.0, 0.0, 0.0)), 10.0)
    assert f.nav.set_mode(Mode.LOITER).accepted
    f.run_until(f.time_s + 10.0)
    r = ref(f.outputs[-1][1])
    assert np.linalg.norm(r.vel_ned) == 0.0 and f.nav.mode == Mode.LOITER
