"""Mission protocol, ArduPilot flavour: upload, download, retries, validation."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from mavlink_testkit import (
    GCS_ADDR,
    ORIGIN,
    WAIT_S,
    FakeVehicle,
    Gcs,
    Item,
    MemoryGcs,
    MemoryLink,
    VehicleThread,
    download,
    linked,
    memory_endpoint,
    upload,
)
from numpy.testing import assert_allclose

from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.endpoint_config import EndpointConfig
from fcu.mavlink.geo import geo_to_ned, ned_to_geo
from fcu.mavlink.port_records import GeoPoint, MissionState
from fcu.mavlink.protocols.mission_items import (
    MissionConfig,
    WireItem,
    to_mission_item,
    validate_item,
)
from fcu.mavlink.transport.codec import mavlink2
from fcu.navigation.modes import Mode
from flightdata.mission import MissionItem as PlannedItem
from flightdata.mission import thesis_mission

M = mavlink2
NAN, INF = math.nan, math.inf
FAST = EndpointConfig(mission=MissionConfig(retry_interval_s=0.25, upload_timeout_s=1.0))
LAT, LON = ORIGIN.lat_deg, ORIGIN.lon_deg


def lat_lon(north_m: float, east_m: float) -> tuple[float, float]:
    lat, lon, _ = ned_to_geo(np.array([north_m, east_m, 0.0]), ORIGIN)
    return lat, lon


def square() -> list[Item]:
    """Home, take-off to 2 m, two waypoints (one local), change speed, land."""
    a = lat_lon(3.0, 0.0)
    return [
        Item(M.MAV_CMD_NAV_WAYPOINT, LAT, LON, 0.0, frame=M.MAV_FRAME_GLOBAL_INT),  # home
        Item(M.MAV_CMD_NAV_TAKEOFF, 0.0, 0.0, 2.0, current=1),
        Item(M.MAV_CMD_NAV_WAYPOINT, a[0], a[1], 2.0, params=(1.0, 0.5, 0.0, NAN)),
        Item(M.MAV_CMD_DO_CHANGE_SPEED, frame=M.MAV_FRAME_MISSION, params=(1.0, 3.0, -1, 0)),
        Item(M.MAV_CMD_NAV_WAYPOINT, 3.0, 3.0, -2.0, frame=M.MAV_FRAME_LOCAL_NED,
             params=(0.0, 0.0, 0.0, 90.0)),
        Item(M.MAV_CMD_NAV_LAND, 0.0, 0.0, 0.0),
    ]


@pytest.fixture
def link() -> Iterator[tuple[Gcs, VehicleThread]]:
    with linked(speedup=5.0, config=FAST) as pair:
        yield pair


# ------------------------------------------------------------------------ validation (unit)

def wire_item(command: int = M.MAV_CMD_NAV_WAYPOINT, frame: int = 6,
              params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
              x: float = LAT, y: float = LON, z: float = 10.0) -> WireItem:
    return WireItem(seq=1, frame=frame, command=command, current=0, autocontinue=1,
                    params=params, x=x, y=y, z=z)


@pytest.mark.parametrize("item, code", [
    (wire_item(), M.MAV_MISSION_ACCEPTED),
    (wire_item(params=(NAN, 0, 0, 0)), M.MAV_MISSION_INVALID_PARAM1),
    (wire_item(params=(0, 0, INF, 0)), M.MAV_MISSION_INVALID_PARAM3),
    (wire_item(params=(0, 0, 0, INF)), M.MAV_MISSION_INVALID_PARAM4),
    (wire_item(params=(0, 0, 0, NAN)), M.MAV_MISSION_ACCEPTED),  # yaw NaN: keep heading
    (wire_item(command=M.MAV_CMD_DO_CHANGE_SPEED, frame=M.MAV_FRAME_MISSION,
               params=(1, 2, 0, NAN)), M.MAV_MISSION_INVALID_PARAM4),
    (wire_item(x=NAN), M.MAV_MISSION_INVALID_PARAM5_X),
    (wire_item(x=91.0), M.MAV_MISSION_INVALID_PARAM5_X),
    (wire_item(y=-180.5), M.MAV_MISSION_INVALID_PARAM6_Y),
    (wire_item(z=20_000.0), M.MAV_MISSION_INVALID_PARAM7),
    (wire_item(z=INF), M.MAV_MISSION_INVALID_PARAM7),
    (wire_item(frame=M.MAV_FRAME_LOCAL_NED, x=1.0, y=20_000.0, z=-1.0),
     M.MAV_MISSION_INVALID_PARAM6_Y),
    (wire_item(frame=M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT), M.MAV_MISSION_UNSUPPORTED_FRAME),
    (wire_item(frame=M.MAV_FRAME_BODY_FRD), M.MAV_MISSION_UNSUPPORTED_FRAME),
    (wire_item(frame=M.MAV_FRAME_MISSION, x=NAN), M.MAV_MISSION_ACCEPTED),  # x unused
])
def test_item_validation(item: WireItem, code: int) -> None:
    got, reason = validate_item(item, MissionConfig())
    assert got == code
    assert bool(reason) == (code != M.MAV_MISSION_ACCEPTED)


def test_conversion_to_ned_and_relative_altitude() -> None:
    home_ned = np.array([0.0, 0.0, -1.5])  # home 1.5 m above the origin
    lat, lon = lat_lon(5.0, -2.0)
    item = to_mission_item(wire_item(frame=M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, x=lat, y=lon,
                                     z=2.0, params=(0, 0, 0, 90.0)), ORIGIN, home_ned)
    assert item.north_east_m is not None
    assert_allclose(item.north_east_m, [5.0, -2.0], atol=1e-9)
    assert item.down_m == pytest.approx(-3.5)  # 2 m above a home 1.5 m up
    assert item.alt_m == pytest.approx(2.0)
    assert item.yaw_rad == pytest.approx(math.pi / 2)
    amsl = to_mission_item(wire_item(frame=M.MAV_FRAME_GLOBAL_INT, x=lat, y=lon, z=103.0),
                           ORIGIN, home_ned)
    assert amsl.down_m == pytest.approx(-3.0) and amsl.alt_m == pytest.approx(1.5)
    here = to_mission_item(wire_item(command=M.MAV_CMD_NAV_TAKEOFF, x=0.0, y=0.0, z=4.0),
                           ORIGIN, None)
    assert here.north_east_m is None and here.alt_m == pytest.approx(4.0)
    assert here.yaw_rad == 0.0
    local = to_mission_item(wire_item(frame=M.MAV_FRAME_LOCAL_NED, x=1.0, y=2.0, z=-3.0,
                                      params=(0, 0, 0, NAN)), ORIGIN, home_ned)
    assert local.north_east_m == (1.0, 2.0) and local.down_m == -3.0
    assert local.alt_m == pytest.approx(1.5) and local.yaw_rad is None
    speed = to_mission_item(wire_item(command=M.MAV_CMD_DO_CHANGE_SPEED,
                                      frame=M.MAV_FRAME_MISSION, params=(1, 3, -1, 0)),
                            ORIGIN, home_ned)
    assert speed.north_east_m is None and speed.down_m is None and speed.yaw_rad is None


# ------------------------------------------------------------------------ time-outs (deterministic)

def test_missing_item_is_re_requested_on_the_clock_passed_in() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint(FAST)
    gcs.put(M.MAVLink_mission_count_message(1, 1, 3, 0))
    endpoint.tick(0.0, 100.0)
    assert [m.seq for m in link.take("MISSION_REQUEST_INT")] == [0]
    endpoint.tick(50.0, 100.24)  # simulated time racing ahead does not matter
    assert link.take("MISSION_REQUEST_INT") == []
    endpoint.tick(50.0, 100.26)
    assert [m.seq for m in link.take("MISSION_REQUEST_INT")] == [0]  # re-requested
    for seq in range(3):
        gcs.put(square()[seq].message(seq, legacy=False))
        endpoint.tick(50.0, 100.4)
    (ack,) = link.take("MISSION_ACK")
    assert ack.type == M.MAV_MISSION_ACCEPTED
    assert len(vehicle.mission) == 2


def square_upload_after_item_0(
) -> tuple[MavlinkEndpoint, FakeVehicle, MemoryLink, MemoryGcs]:
    """An endpoint (``FAST`` timeouts) whose upload of the 3-item square has received item
    0, at wall time 0.125 s: (endpoint, vehicle, link, gcs) as :func:`memory_endpoint`."""
    endpoint, vehicle, link, gcs = memory_endpoint(FAST)
    gcs.put(M.MAVLink_mission_count_message(1, 1, 3, 0))
    endpoint.tick(0.0, 0.0)
    gcs.put(square()[0].message(0, legacy=False))
    endpoint.tick(0.0, 0.125)
    return endpoint, vehicle, link, gcs


def test_a_repeated_item_draws_the_missing_request_at_once_and_keeps_the_upload() -> None:
    endpoint, vehicle, link, gcs = square_upload_after_item_0()
    assert [m.seq for m in link.take("MISSION_REQUEST_INT")] == [0, 1]
    for k in range(1, 13):  # the request for 1 keeps getting lost: item 0 comes again
        gcs.put(square()[0].message(0, legacy=False))
        endpoint.tick(0.0, 0.125 + 0.25 * k)  # 3 s in all, longer than upload_timeout_s
        assert [m.seq for m in link.take("MISSION_REQUEST_INT")][:1] == [1]
    assert link.take("MISSION_ACK") == [] and endpoint.mission.uploading
    for seq in (1, 2):
        gcs.put(square()[seq].message(seq, legacy=False))
        endpoint.tick(0.0, 3.25)
    (ack,) = link.take("MISSION_ACK")
    assert ack.type == M.MAV_MISSION_ACCEPTED


def test_stalled_upload_times_out_with_a_statustext() -> None:
    endpoint, vehicle, link, gcs = square_upload_after_item_0()
    link.take()
    for k in range(2, 24):  # 2.75 s of silence (times exact in binary)
        endpoint.tick(0.0, 0.125 * k)
    out = link.take()
    requests = [m.seq for m in out if m.get_type() == "MISSION_REQUEST_INT"]
    acks = [m for m in out if m.get_type() == "MISSION_ACK"]
    texts = [m.text for m in out if m.get_type() == "STATUSTEXT"]
    # re-requested every retry_interval_s (0.375, 0.625, 0.875, 1.125 s) until
    # upload_timeout_s after the last item (0.125 s), then cancelled at 1.25 s
    assert requests == [1, 1, 1, 1]
    assert [a.type for a in acks] == [M.MAV_MISSION_OPERATION_CANCELLED]
    assert any("timed out" in t and "item 1" in t for t in texts)
    assert not endpoint.mission.uploading
    assert vehicle.mission == []  # the old (empty) mission is intact


# ------------------------------------------------------------------------ over UDP

def test_upload_download_round_trip_with_mission_item_int(
        link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    items = square()
    result = upload(gcs, items)
    assert result.ack is not None and result.ack.type == M.MAV_MISSION_ACCEPTED
    assert result.requests == [("MISSION_REQUEST_INT", s) for s in range(len(items))]
    got = download(gcs)
    assert len(got) == len(items)
    assert got[0].x == round(LAT * 1e7) and got[0].frame == M.MAV_FRAME_GLOBAL  # home
    for sent, back in zip(items[1:], got[1:], strict=True):
        expected = sent.message(back.seq, legacy=False)
        for field in ("frame", "command", "x", "y", "autocontinue"):
            assert getattr(back, field) == getattr(expected, field), (back.seq, field)
        assert back.z == pytest.approx(expected.z)
        assert_allclose([back.param1, back.param2, back.param3, back.param4],
                        [expected.param1, expected.param2, expected.param3, expected.param4])
    with vehicle.lock:
        handed = list(vehicle.vehicle.mission)
    assert [i.seq for i in handed] == [1, 2, 3, 4, 5]
    assert handed[1].north_east_m is not None
    assert_allclose(handed[1].north_east_m, [3.0, 0.0], atol=0.02)  # degE7 ~ 1 cm
    assert handed[1].yaw_rad is None
    assert handed[3].north_east_m == (3.0, 3.0) and handed[3].down_m == -2.0


def test_legacy_mission_item_upload_and_download(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    items = square()
    result = upload(gcs, items, legacy=True)
    assert result.ack is not None and result.ack.type == M.MAV_MISSION_ACCEPTED
    # the first request is MISSION_REQUEST_INT; a peer answering MISSION_ITEM is then
    # asked with the legacy MISSION_REQUEST
    assert result.requests[0] == ("MISSION_REQUEST_INT", 0)
    assert all(kind == "MISSION_REQUEST" for kind, _ in result.requests[1:])
    got = download(gcs, legacy=True)
    assert [m.get_type() for m in got] == ["MISSION_ITEM"] * len(items)
    assert got[2].x == pytest.approx(np.float32(items[2].x))
    assert got[4].y == pytest.approx(3.0)


def test_upload_survives_a_dropped_item(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    items = square()
    result = upload(gcs, items, drop_first=[2])
    assert result.ack is not None and result.ack.type == M.MAV_MISSION_ACCEPTED
    assert result.requests.count(("MISSION_REQUEST_INT", 2)) >= 2  # asked again
    assert len(vehicle.vehicle.mission) == len(items) - 1


def test_stalled_upload_is_cancelled_over_udp(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    result = upload(gcs, square(), answer_until=3)
    assert result.ack is not None and result.ack.type == M.MAV_MISSION_OPERATION_CANCELLED
    # the first and at least one re-request (every 0.25 s until 1 s of silence; fewer on
    # a loaded machine, whose vehicle thread may tick late)
    assert result.requests.count(("MISSION_REQUEST_INT", 3)) >= 2
    assert not vehicle.endpoint.mission.uploading


@pytest.mark.parametrize("bad, code", [
    (Item(M.MAV_CMD_NAV_WAYPOINT, LAT, LON, 2.0, params=(NAN, 0, 0, 0)),
     M.MAV_MISSION_INVALID_PARAM1),
    (Item(M.MAV_CMD_NAV_WAYPOINT, 95.0, LON, 2.0, frame=M.MAV_FRAME_GLOBAL_RELATIVE_ALT),
     M.MAV_MISSION_INVALID_PARAM5_X),
    (Item(M.MAV_CMD_NAV_WAYPOINT, LAT, LON, 1e6), M.MAV_MISSION_INVALID_PARAM7),
    (Item(M.MAV_CMD_NAV_WAYPOINT, LAT, LON, 2.0, frame=M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT),
     M.MAV_MISSION_UNSUPPORTED_FRAME),
    (Item(M.MAV_CMD_NAV_WAYPOINT, 50_000.0, 0.0, -2.0, frame=M.MAV_FRAME_LOCAL_NED),
     M.MAV_MISSION_INVALID_PARAM5_X),
])
def test_bad_items_are_refused_and_the_old_mission_kept(
        link: tuple[Gcs, VehicleThread], bad: Item, code: int) -> None:
    gcs, vehicle = link
    assert upload(gcs, square()).ack.type == M.MAV_MISSION_ACCEPTED
    items = square()
    items[2] = bad
    result = upload(gcs, items)
    assert result.ack is not None and result.ack.type == code
    assert result.requests[-1][1] == 2  # refused at the bad item
    assert gcs.recv("STATUSTEXT", condition=lambda m: "item 2" in m.text) is not None
    assert len(download(gcs)) == len(square())  # the previous mission is still there


def test_unsupported_command_is_refused_by_the_vehicle(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, _ = link
    items = square()[:2] + [Item(M.MAV_CMD_DO_SET_SERVO, frame=M.MAV_FRAME_MISSION,
                                 params=(5, 1500, 0, 0))]
    result = upload(gcs, items)
    assert result.ack is not None and result.ack.type == M.MAV_MISSION_UNSUPPORTED
    assert gcs.recv("STATUSTEXT", condition=lambda m: "Mission rejected" in m.text)


def plan_round_trip(gcs: Gcs, mission_type: int, items: list[Any]) -> tuple[Any, list[Any]]:
    """Upload ``items`` (MISSION_ITEM_INT messages, seq 0..) as ``mission_type``; then the
    upload's MISSION_ACK and the items downloaded back."""
    gcs.mav.mission_count_send(1, 1, len(items), mission_type)
    ack = None
    while ack is None:
        msg = gcs.recv(["MISSION_REQUEST_INT", "MISSION_ACK"])
        assert msg is not None and msg.mission_type == mission_type
        if msg.get_type() == "MISSION_ACK":
            ack = msg
        else:
            gcs.mav.send(items[msg.seq])
    gcs.mav.mission_request_list_send(1, 1, mission_type)
    count = gcs.recv("MISSION_COUNT")
    assert count is not None and count.mission_type == mission_type
    back = []
    for seq in range(count.count):
        gcs.mav.mission_request_int_send(1, 1, seq, mission_type)
        back.append(gcs.recv("MISSION_ITEM_INT", condition=lambda m, s=seq: m.seq == s))
    return ack, back


def plan_item(seq: int, command: int, mission_type: int, p1: float = 0.0,
              north_m: float = 0.0) -> Any:
    lat, lon = lat_lon(north_m, 0.0)
    return M.MAVLink_mission_item_int_message(
        1, 1, seq, M.MAV_FRAME_GLOBAL_INT, command, int(seq == 0), 0, p1, 0, 0, 0,
        round(lat * 1e7), round(lon * 1e7), 0.0, mission_type)


def test_fence_and_rally_upload_download_and_clear(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    fence = M.MAV_MISSION_TYPE_FENCE
    vertex = M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    polygon = [plan_item(i, vertex, fence, 3, north_m=10.0 * i) for i in range(3)]
    circle = [plan_item(3, M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, fence, 5.0)]
    ack, back = plan_round_trip(gcs, fence, polygon + circle)
    assert ack.type == M.MAV_MISSION_ACCEPTED and ack.mission_type == fence
    assert [(m.command, m.x, m.y, m.param1) for m in back] == \
        [(m.command, m.x, m.y, m.param1) for m in polygon + circle]  # no home item
    with vehicle.lock:  # handed to the vehicle as local areas, to enforce
        areas = vehicle.vehicle.fence
    assert len(areas.inclusion_polygons) == 1 and not areas.exclusion_polygons
    np.testing.assert_allclose(areas.inclusion_polygons[0][:, 0], [0.0, 10.0, 20.0], atol=0.02)
    assert areas.exclusion_circles[0][2] == 5.0  # m, the radius
    rally = M.MAV_MISSION_TYPE_RALLY
    points = [plan_item(i, M.MAV_CMD_NAV_RALLY_POINT, rally, north_m=5.0 * i) for i in range(2)]
    ack, back = plan_round_trip(gcs, rally, points)
    assert ack.type == M.MAV_MISSION_ACCEPTED and len(back) == 2
    assert len(vehicle.endpoint.mission.plan_items(fence)) == 4  # the mission untouched
    assert vehicle.endpoint.mission.total == 0
    gcs.mav.mission_clear_all_send(1, 1, fence)
    ack = gcs.recv("MISSION_ACK")
    assert ack is not None and (ack.type, ack.mission_type) == (M.MAV_MISSION_ACCEPTED, fence)
    assert vehicle.endpoint.mission.plan_items(fence) == []
    with vehicle.lock:
        assert vehicle.vehicle.fence.empty
    assert len(vehicle.endpoint.mission.plan_items(rally)) == 2


@pytest.mark.parametrize("bad, code", [
    (plan_item(0, M.MAV_CMD_NAV_WAYPOINT, M.MAV_MISSION_TYPE_FENCE), M.MAV_MISSION_UNSUPPORTED),
    (plan_item(0, M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, M.MAV_MISSION_TYPE_FENCE, 2),
     M.MAV_MISSION_INVALID_PARAM1),  # a polygon of 2 vertices
    (plan_item(0, M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, M.MAV_MISSION_TYPE_FENCE, 0.0),
     M.MAV_MISSION_INVALID_PARAM1),  # radius 0
])
def test_bad_fence_items_are_refused(link: tuple[Gcs, VehicleThread], bad: Any,
                                     code: int) -> None:
    gcs, _ = link
    ack, _ = plan_round_trip(gcs, M.MAV_MISSION_TYPE_FENCE, [bad])
    assert ack.type == code


def test_other_mission_types_are_unsupported(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, _ = link
    gcs.mav.mission_count_send(1, 1, 2, 7)  # not a mission type the vehicle keeps
    ack = gcs.recv("MISSION_ACK")
    assert ack is not None and ack.type == M.MAV_MISSION_UNSUPPORTED and ack.mission_type == 7


def test_clear_all_and_set_current(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    assert upload(gcs, square()).ack.type == M.MAV_MISSION_ACCEPTED
    gcs.mav.mission_set_current_send(1, 1, 3)
    current = gcs.recv("MISSION_CURRENT", condition=lambda m: m.seq == 3)
    assert current is not None and current.total == len(square()) - 1
    assert gcs.ack(M.MAV_CMD_DO_SET_MISSION_CURRENT, 2).result == M.MAV_RESULT_ACCEPTED
    assert gcs.ack(M.MAV_CMD_DO_SET_MISSION_CURRENT, 99).result == M.MAV_RESULT_DENIED
    gcs.mav.mission_clear_all_send(1, 1, M.MAV_MISSION_TYPE_MISSION)
    ack = gcs.recv("MISSION_ACK")
    assert ack is not None and ack.type == M.MAV_MISSION_ACCEPTED
    assert len(download(gcs)) == 1  # home only
    assert vehicle.vehicle.mission == []
    assert gcs.recv("MISSION_CURRENT", condition=lambda m: m.total == 0xFFFF) is not None


def test_repeated_last_item_is_acknowledged_again(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, _ = link
    items = square()
    assert upload(gcs, items).ack.type == M.MAV_MISSION_ACCEPTED
    last = len(items) - 1
    gcs.mav.send(items[last].message(last, legacy=False))  # as if our ACK had been lost
    ack = gcs.recv("MISSION_ACK")
    assert ack is not None and ack.type == M.MAV_MISSION_ACCEPTED


def test_mission_flight_reports_reached_items_and_completion(
        link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    items = square()
    assert upload(gcs, items).ack.type == M.MAV_MISSION_ACCEPTED
    assert gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED).result == M.MAV_RESULT_ACCEPTED
    assert gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
    assert gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.AUTO).result == M.MAV_RESULT_ACCEPTED
    gcs.command_long(M.MAV_CMD_MISSION_START, 0, 0)
    acks: list[int] = []
    reached: list[int] = []
    complete = None
    for _ in range(200):  # bounded; the flight takes a few wall seconds at 5x
        msg = gcs.recv(["COMMAND_ACK", "MISSION_ITEM_REACHED", "MISSION_CURRENT"], 4 * WAIT_S)
        assert msg is not None, f"stalled after reaching {reached}"
        if msg.get_type() == "COMMAND_ACK":
            acks.append(msg.result)
        elif msg.get_type() == "MISSION_ITEM_REACHED":
            reached.append(msg.seq)
        elif msg.mission_state == MissionState.COMPLETE:
            complete = msg
            break
    assert acks == [M.MAV_RESULT_ACCEPTED]
    assert reached == [1, 2, 3, 4, 5]
    assert complete is not None and complete.total == 5 and complete.seq == 5


def test_global_item_lands_where_it_should(link: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = link
    lat, lon = lat_lon(-7.0, 11.0)
    items = [square()[0], Item(M.MAV_CMD_NAV_WAYPOINT, lat, lon, 105.0,
                               frame=M.MAV_FRAME_GLOBAL_INT)]
    assert upload(gcs, items).ack.type == M.MAV_MISSION_ACCEPTED
    (item,) = vehicle.vehicle.mission
    expected = geo_to_ned(lat, lon, 105.0, ORIGIN)
    assert item.north_east_m is not None
    assert_allclose(item.north_east_m, expected[:2], atol=0.02)
    assert item.down_m == pytest.approx(-5.0)


def test_items_from_another_gcs_during_an_upload_are_denied() -> None:
    endpoint, _, link, gcs = memory_endpoint(FAST)
    gcs.put(M.MAVLink_mission_count_message(1, 1, 2, 0))
    endpoint.tick(0.0, 0.0)
    other = M.MAVLink(None, srcSystem=245, srcComponent=190)
    link.inbox.append((square()[0].message(0, legacy=False).pack(other), GCS_ADDR))
    endpoint.tick(0.0, 0.1)
    acks = link.take("MISSION_ACK")
    assert [(a.type, a.target_system) for a in acks] == [(M.MAV_MISSION_DENIED, 245)]
    assert endpoint.mission.uploading  # the first GCS's upload goes on


def test_download_seq_0_is_the_current_home() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    vehicle.home_pos_ned = np.array([10.0, 0.0, 0.0])
    gcs.put(M.MAVLink_mission_request_int_message(1, 1, 0, 0))
    endpoint.tick(0.0, 0.0)
    (home,) = link.take("MISSION_ITEM_INT")
    lat, _, _ = ned_to_geo(np.array([10.0, 0.0, 0.0]), GeoPoint(LAT, LON, 100.0))
    assert home.x == round(lat * 1e7)


def test_a_boot_mission_is_handed_over_and_downloaded_as_uploaded() -> None:
    """:meth:`MissionProtocol.load`: the thesis mission reaches the vehicle as it would from
    a ground station (NED targets kept to the millimetre), and a download returns it."""
    endpoint, vehicle, link, gcs = memory_endpoint()
    planned = thesis_mission()
    assert endpoint.mission.load(planned).accepted
    assert endpoint.mission.total == len(vehicle.mission) == len(planned) == 10
    for item, flown in zip(planned, vehicle.mission, strict=True):
        assert flown.command == item.mav_cmd
        if item.command == "waypoint":
            assert item.pos_ned is not None and flown.north_east_m is not None
            assert_allclose([*flown.north_east_m, flown.down_m], item.pos_ned, atol=1e-9)
    gcs.put(M.MAVLink_mission_request_int_message(1, 1, 6, 0))  # (1, 1, -0.6) hold 1 s
    endpoint.tick(0.0, 0.0)
    (wp,) = link.take("MISSION_ITEM_INT")
    assert (wp.frame, wp.x, wp.y, wp.z, wp.param1) == (M.MAV_FRAME_LOCAL_NED, 10000, 10000,
                                                       pytest.approx(-0.6), 1.0)


def test_a_boot_mission_out_of_bounds_is_refused_and_the_vehicle_keeps_none() -> None:
    endpoint, vehicle, _, _ = memory_endpoint()
    far = PlannedItem(command="waypoint", pos_ned=(2e6, 0.0, -1.0))
    result = endpoint.mission.load([*thesis_mission()[:3], far])
    assert not result.accepted and "Mission item 4: x 2e+06 m" in result.reason
    assert endpoint.mission.total == len(vehicle.mission) == 0


@pytest.mark.parametrize(("item", "words"), [
    # finite in a scenario file, beyond what MISSION_ITEM_INT's float32 params can carry
    (PlannedItem(command="waypoint", pos_ned=(1.0, 0.0, -1.0), hold_s=1e300),
     "Mission item 2: param1 = 1e+300 beyond float32"),
    (PlannedItem(command="waypoint", pos_ned=(1.0, 0.0, -1.0), yaw_rad=1e300),
     "Mission item 2: param4 = 5.72958e+301 beyond float32"),
])
def test_a_boot_mission_the_wire_cannot_carry_is_refused(item: PlannedItem, words: str) -> None:
    endpoint, vehicle, _, _ = memory_endpoint()
    result = endpoint.mission.load([thesis_mission()[1], item])
    assert not result.accepted and result.reason == words
    assert endpoint.mission.total == len(vehicle.mission) == 0


def test_a_boot_mission_longer_than_the_vehicle_holds_is_refused() -> None:
    endpoint, vehicle, _, _ = memory_endpoint()
    hover = PlannedItem(command="waypoint", pos_ned=(0.0, 0.0, -1.0))
    assert endpoint.mission.load([hover] * 699).accepted  # 700 with home: the upload limit
    result = endpoint.mission.load([hover] * 700)
    assert not result.accepted and result.reason == "Mission of 701 items exceeds 700"
    assert endpoint.mission.total == 699  # the mission before is kept


def test_set_current_without_a_mission_says_there_is_none() -> None:
    """MISSION_SET_CURRENT and DO_SET_MISSION_CURRENT on a vehicle with no mission: refused
    with the same words (was "1 not in 1..0")."""
    endpoint, _, link, gcs = memory_endpoint()
    gcs.put(M.MAVLink_mission_set_current_message(1, 1, 1))
    gcs.put(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_DO_SET_MISSION_CURRENT, 0,
                                           1, 0, 0, 0, 0, 0, 0))
    endpoint.tick(0.0, 0.0)
    sent = link.take()
    texts = [m.text for m in sent if m.get_type() == "STATUSTEXT"]
    assert texts == ["Set mission current: no mission loaded"] * 2
    (ack,) = [m for m in sent if m.get_type() == "COMMAND_ACK"]
    assert ack.result == M.MAV_RESULT_DENIED
