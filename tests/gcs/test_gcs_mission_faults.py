"""Missions and fault schedules as the ground station reads and sends them."""

from __future__ import annotations

import math
import socket
import time
from pathlib import Path

import pytest

from gcs.faults import (
    TABLE_7_3,
    FaultScheduleError,
    FaultSpec,
    load_schedule,
    parse_fault_flag,
)
from gcs.mavlink import decode_packet, mavlink2, open_link
from gcs.mission import MissionFileError, load_mission, thesis_mission
from gcs.station import GroundStation

M = mavlink2
ROOT = Path(__file__).resolve().parents[2]


def test_thesis_mission_is_the_chapter_7_flight() -> None:
    items = thesis_mission()
    assert [i.command for i in items] == [178, 22, 16, 178, 16, 16, 16, 16, 178, 21]
    assert items[0].params[:2] == (2.0, pytest.approx(0.18))  # climb 1.5 * 0.6 / 5
    assert items[1].z == 0.6 and items[1].frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    corners = [(i.x, i.y, i.z) for i in items[4:8]]
    assert corners == [(1.0, 0.0, -0.6), (1.0, 1.0, -0.6), (0.0, 1.0, -0.6), (0.0, 0.0, -0.6)]
    assert [i.params[0] for i in items[4:8]] == [1.0, 1.0, 1.0, 2.0]  # holds, s
    assert items[3].params[:2] == (1.0, pytest.approx(0.15))  # ground 1.5 * 1 / 10
    assert items[8].params[:2] == (3.0, pytest.approx(0.225))  # descent 1.5 * 0.6 / 4


def test_local_items_travel_in_1e4_metres_and_nan_yaw_survives() -> None:
    wp = thesis_mission()[5]  # (1, 1, -0.6)
    msg = wp.to_message(6, 1, 1)
    decoded = decode_packet(msg.pack(M.MAVLink(None, 255, 190)))
    assert decoded is not None
    assert (decoded.x, decoded.y, decoded.z) == (10000, 10000, pytest.approx(-0.6))
    assert math.isnan(decoded.param4)


def test_waypoint_file_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "m.waypoints"
    path.write_text("QGC WPL 110\n"
                    "0\t1\t0\t16\t0\t0\t0\t0\t-35.36\t149.16\t584\t1\n"
                    "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t0.6\t1\n"
                    "2\t0\t1\t16\t1\t0\t0\t0\t1.0\t0\t-0.6\t1\n")
    items = load_mission(path)
    assert [(i.command, i.frame) for i in items] == [(22, 3), (16, 1)]


def test_toml_mission_with_named_and_raw_items(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text('[[items]]\ncommand = "takeoff"\nalt_m = 0.5\n'
                    '[[items]]\ncommand = "waypoint"\npos_ned = [0.5, 0, -0.5]\nhold_s = 1\n'
                    '[[items]]\nmav_cmd = 21\nframe = 6\n')
    items = load_mission(path)
    assert [i.command for i in items] == [22, 16, 21]
    assert items[1].params[0] == 1.0


@pytest.mark.parametrize("body, words", [
    ('[[items]]\ncommand = "jump"\n', r"items\[0\]\.command"),
    ('[[items]]\ncommand = "waypoint"\n', "needs pos_ned"),
    ('[[items]]\ncommand = "takeoff"\nalt = 1\n', "unknown key alt"),
    ('items = 3\n', "non-empty array"),
])
def test_bad_toml_mission_names_the_key(tmp_path: Path, body: str, words: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(body)
    with pytest.raises(MissionFileError, match=words):
        load_mission(path)


def test_table_7_3() -> None:
    assert [(f.motor, f.loe, f.at_s) for f in TABLE_7_3] == [(3, 0.2, 22.0), (1, 0.3, 38.0),
                                                             (4, 0.15, 48.0)]


def test_fault_flags() -> None:
    assert parse_fault_flag("3:0.20@22") == FaultSpec(motor=3, loe=0.2, at_s=22.0)
    assert parse_fault_flag("sim_baro_glitch=0.1@30") == FaultSpec(
        param="SIM_BARO_GLITCH", value=0.1, at_s=30.0)
    for bad in ("5:0.2@22", "3:1.5@22", "3:0.2", "nonsense"):
        with pytest.raises(FaultScheduleError):
            parse_fault_flag(bad)


def test_scenario_files_load_as_schedules() -> None:
    faults = load_schedule(ROOT / "sim" / "scenarios" / "lqg_loe.toml")
    assert faults == list(TABLE_7_3)


def test_schedule_file_errors_name_the_key(tmp_path: Path) -> None:
    path = tmp_path / "f.toml"
    path.write_text('[[faults]]\ntype = "sensor"\nsensor = "baro"\nstart_s = 1.0\n')
    with pytest.raises(FaultScheduleError, match=r"faults\[0\].type"):
        load_schedule(path)
    path.write_text('[[faults]]\nmotor = 2\nloe = 0.1\n')
    with pytest.raises(FaultScheduleError, match="needs at_s"):
        load_schedule(path)
    path.write_text('[[faults]]\nparam = "SIM_MASS_DROP"\nvalue = 0.3\nat_s = 22\n'
                    '[[faults]]\nmotor = 2\nloe = 0.1\nat_s = 5\n')
    assert [f.at_s for f in load_schedule(path)] == [5.0, 22.0]


def test_a_station_behind_on_its_messages_does_not_resend_an_injection_early() -> None:
    # A PARAM_SET injection is sent again when no echo came 0.5 s of vehicle time after it
    # left. A station handling a backlog (messages received before it sent) must not count
    # their clock: they left the vehicle before the PARAM_SET could reach it.
    vehicle = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    vehicle.bind(("127.0.0.1", 0))
    vehicle.settimeout(0.0)
    url = f"udpout:127.0.0.1:{vehicle.getsockname()[1]}"
    gs = GroundStation(open_link(url), url)
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)

    def param_sets() -> int:
        n = 0
        try:
            while True:
                packet = vehicle.recv(65536)
                msg = decode_packet(packet)
                n += msg is not None and msg.get_type() == "PARAM_SET"
        except BlockingIOError:
            return n

    def handle(time_ms: int, received_wall_s: float) -> None:
        msg = mavlink2.MAVLink_attitude_message(time_ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        gs._handle(mav.decode(bytearray(msg.pack(mav))), received_wall_s)

    try:
        hb = mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_QUADROTOR,
                                                mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 3, 3)
        gs._handle(mav.decode(bytearray(hb.pack(mav))), time.time())
        gs.on_clock(gs.resend_lost_injections)
        handle(1000, time.time())
        before_send = time.time()
        time.sleep(0.01)  # (wall stamps strictly before the send)
        gs.inject(FaultSpec(at_s=0.0, motor=2, loe=0.25), 1.0, via="param")
        deadline = time.monotonic() + 10.0
        sent = 0
        while sent == 0 and time.monotonic() < deadline:
            sent = param_sets()
        assert sent == 1
        # a second of vehicle time received before the PARAM_SET left: no resend
        for ms in range(1010, 2010, 10):
            handle(ms, before_send)
        # then 0.4 s received after it: still within the wait
        for ms in range(2010, 2410, 10):
            handle(ms, time.time())
        time.sleep(0.2)
        assert param_sets() == 0
        # past 0.5 s of vehicle time since the first message received after it: sent again
        for ms in range(2410, 2610, 10):
            handle(ms, time.time())
        deadline = time.monotonic() + 10.0
        while sent == 1 and time.monotonic() < deadline:
            sent += param_sets()
        assert sent == 2
    finally:
        gs.close()
        vehicle.close()


@pytest.mark.parametrize(("round_trips_s", "nudge_s"), [
    ([], 1.0),  # nothing measured yet: a radio link's patience
    ([0.003, 0.01], 0.2),  # loopback: the floor
    ([0.02, 0.1, 0.05], 0.4),  # four of the slowest
    ([0.1, 0.5], 1.0),  # a slow link: the ceiling
])
def test_a_request_is_sent_again_after_four_round_trips(round_trips_s: list[float],
                                                         nudge_s: float) -> None:
    gs = GroundStation(None, "test")
    gs.round_trips.samples_s.extend(round_trips_s)
    assert gs.round_trips.retry_wait_s(1.0) == pytest.approx(nudge_s)
