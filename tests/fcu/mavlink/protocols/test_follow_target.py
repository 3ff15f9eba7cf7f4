"""A lead's FOLLOW_TARGET and GLOBAL_POSITION_INT, read off the wire for FOLLOW: units,
what makes a report unusable, altitude frames, and the endpoint passing other systems'
reports (never its own) to the vehicle."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mavlink_testkit import ORIGIN, MemoryGcs, memory_endpoint

from fcu.mavlink.geo import ned_to_geo
from fcu.mavlink.protocols.follow_target import lead_report
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
NAN = math.nan


def packed(msg: object, sysid: int = 2) -> object:
    """``msg`` as it arrives from system ``sysid`` (packed and parsed by pymavlink)."""
    mav = M.MAVLink(None, srcSystem=sysid, srcComponent=1)
    return mav.parse_char(msg.pack(mav))  # type: ignore[attr-defined]


def follow_target(lat: float, lon: float, alt_m: float, caps: int,
                  vel: tuple[float, float, float] = (0.0, 0.0, 0.0),
                  q: tuple[float, float, float, float] = (1.0, NAN, NAN, NAN)) -> object:
    return packed(M.MAVLink_follow_target_message(
        0, caps, round(lat * 1e7), round(lon * 1e7), alt_m, list(vel), [NAN] * 3, list(q),
        [NAN] * 3, [NAN] * 3, 0))


def global_position(lat: float, lon: float, alt_m: float, rel_m: float,
                    vel: tuple[float, float, float], hdg_cdeg: int, sysid: int = 2) -> object:
    return packed(M.MAVLink_global_position_int_message(
        0, round(lat * 1e7), round(lon * 1e7), round(alt_m * 1000), round(rel_m * 1000),
        *(round(v * 100) for v in vel), hdg_cdeg), sysid)


def test_follow_target_as_mavsdk_sends_it_position_only() -> None:
    lat, lon, _ = ned_to_geo(np.array([30.0, -20.0, 0.0]), ORIGIN)
    report = lead_report(follow_target(lat, lon, 112.5, caps=1, vel=(1.0, 2.0, 0.0)))
    assert report is not None and report.sysid == 2
    assert report.vel_ned_m_s is None and report.heading_rad is None  # bit 1 clear
    # FOLLOW_TARGET's altitude is AMSL whatever FOLL_ALT_TYPE says (no relative one)
    for alt_type in (0, 1):
        # degE7 rounding: 1.1 cm at most
        np.testing.assert_allclose(report.pos_ned(ORIGIN, np.zeros(3), alt_type),
                                   [30.0, -20.0, 100.0 - 112.5], atol=0.011)


def test_follow_target_velocity_and_heading_by_capability_bits() -> None:
    half = math.radians(30.0) / 2.0  # heading 30 deg: q = (cos, 0, 0, sin) of half of it
    report = lead_report(follow_target(40.9, 29.4, 100.0, caps=1 | 2 | 8, vel=(1.0, 2.0, -0.5),
                                       q=(math.cos(half), 0.0, 0.0, math.sin(half))))
    assert report is not None
    assert report.vel_ned_m_s == pytest.approx((1.0, 2.0, -0.5))
    assert report.heading_rad == pytest.approx(math.radians(30.0), abs=1e-6)  # float32 q


@pytest.mark.parametrize("msg", [
    follow_target(40.9, 29.4, 100.0, caps=2),  # no position bit
    follow_target(0.0, 0.0, 100.0, caps=1),  # 0, 0: no fix
    follow_target(40.9, 29.4, NAN, caps=1),
    global_position(0.0, 0.0, 100.0, 0.0, (0.0, 0.0, 0.0), 0)])
def test_reports_without_a_usable_position_are_ignored(msg: object) -> None:
    assert lead_report(msg) is None


def test_global_position_int_altitude_frames_velocity_and_heading() -> None:
    lat, lon, _ = ned_to_geo(np.array([5.0, 6.0, 0.0]), ORIGIN)
    home = np.array([1.0, 1.0, -3.0])  # home 3 m above the origin
    report = lead_report(global_position(lat, lon, 150.0, 7.0, (0.5, -0.25, 0.1), 9000))
    assert report is not None
    np.testing.assert_allclose(report.pos_ned(ORIGIN, home, 0), [5.0, 6.0, -50.0], atol=0.011)
    np.testing.assert_allclose(report.pos_ned(ORIGIN, home, 1), [5.0, 6.0, -10.0], atol=0.011)
    assert report.vel_ned_m_s == pytest.approx((0.5, -0.25, 0.1))
    assert report.heading_rad == pytest.approx(math.pi / 2)
    unknown = lead_report(global_position(lat, lon, 150.0, 7.0, (0.0, 0.0, 0.0), 65535))
    assert unknown is not None and unknown.heading_rad is None


def test_the_endpoint_passes_other_systems_reports_and_drops_its_own() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    lead = MemoryGcs(link, sysid=7, compid=1)
    lead.put(M.MAVLink_global_position_int_message(0, 408_908_000, 293_788_000, 110_000,
                                                   10_000, 0, 0, 0, 65535))
    own = MemoryGcs(link, sysid=1, compid=2)  # our system id, another component
    own.put(M.MAVLink_global_position_int_message(0, 408_908_000, 293_788_000, 110_000,
                                                  10_000, 0, 0, 0, 65535))
    gcs.put(M.MAVLink_follow_target_message(0, 1, 408_909_000, 293_788_000, 101.0, [0.0] * 3,
                                            [0.0] * 3, [1.0, 0.0, 0.0, 0.0], [0.0] * 3,
                                            [0.0] * 3, 0))
    endpoint.tick(0.0, 0.0)
    sysids = [call[1].sysid for call in vehicle.calls if call[0] == "follow_target"]
    assert sysids == [7, 255]
