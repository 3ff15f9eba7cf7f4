"""The vehicle process against a pymavlink ground station over loopback UDP.

Commands and their ACKs, parameters, the mission protocol with a lost packet, malformed and
NaN input (bursts of random and extreme input: test_mavlink_fuzz.py). The vehicle runs in a
subprocess at a speed-up.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest
from vehicle_harness import ANSWER_S, STARTUP_S, Gcs, M, VehicleProcess, mission_item

GROUND_SPEEDUP = "5"  # the ground tests need no speed, and leave CPU to parallel tests
FLIGHT_SPEEDUP = "10"
GUIDED, AUTO, LOITER, LAND = 4, 3, 5, 9
ACCEPTED, DENIED, UNSUPPORTED = (M.MAV_RESULT_ACCEPTED, M.MAV_RESULT_DENIED,
                                 M.MAV_RESULT_UNSUPPORTED)
EXPECTED_PARAMS = {
    # endpoint
    "SYSID_THISMAV", "SYSID_MYGCS", "FS_GCS_ENABLE", "FS_GCS_TIMEOUT",
    # autopilot configuration
    "ATT_CTRL", "EST_TYPE", "DOB_TYPE", "HGT_SOURCE", "SCHED_LOOP_RATE", "POS_XY_KP",
    "ATT_PD_RP_KP", "LQR_QANG_RP", "FD_THRESH", "WPNAV_SPEED", "RTL_ALT", "DISARM_DELAY",
    # simulator
    "SIM_ENGINE_FAIL", "SIM_ENGINE_MUL", "SIM_MOT1_LOE", "SIM_MOT4_LOE", "SIM_BARO_GLITCH",
    "SIM_BARO_DRIFT", "SIM_BARO_FREEZE", "SIM_MASS_DROP", "SIM_WIND_SPD", "SIM_WIND_DIR",
    "SIM_WIND_TURB", "SIM_SPEEDUP", "SIM_PAUSE", "SIM_FI_LOE", "SIM_FI_BAR_BIAS",
    "SYS_FAILURE_EN", "AUTO_OPTIONS",
}
PARAM_TYPES = {M.MAV_PARAM_TYPE_REAL32, M.MAV_PARAM_TYPE_INT8, M.MAV_PARAM_TYPE_INT16,
               M.MAV_PARAM_TYPE_INT32}  # as ArduPilot types its parameters


@pytest.fixture(scope="module")
def ground() -> Iterator[tuple[VehicleProcess, Gcs]]:
    """One vehicle on the ground shared by the tests that do not fly it."""
    station = Gcs()
    vehicle = VehicleProcess(["--out", f"127.0.0.1:{station.port}", "--speedup",
                              GROUND_SPEEDUP])
    try:
        station.wait_heartbeat()
        yield vehicle, station
    finally:
        code = vehicle.stop()
        station.close()
    assert code == 0, vehicle.stderr_text[-2000:]


def statustexts(gcs: Gcs, since: int) -> list[str]:
    return [m.text for m in gcs.messages("STATUSTEXT", since=since)]


def test_every_command_gets_exactly_one_ack(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", FLIGHT_SPEEDUP, outs=[gcs.port])
    gcs.wait_heartbeat()
    nan = math.nan
    # (COMMAND_LONG or COMMAND_INT, command, params): distinct command numbers, so each ACK
    # names its command; they cover accepted, denied and unsupported answers in flight.
    plan: list[tuple[str, int, tuple[float, ...]]] = [
        ("long", M.MAV_CMD_DO_SET_MODE, (1, GUIDED)),
        ("long", M.MAV_CMD_COMPONENT_ARM_DISARM, (1,)),
        ("long", M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, nan, 0, 0, 1.0)),
        ("long", M.MAV_CMD_DO_CHANGE_SPEED, (1, 0.4, -1)),
        ("long", M.MAV_CMD_SET_MESSAGE_INTERVAL, (M.MAVLINK_MSG_ID_ATTITUDE, 100000)),
        ("long", M.MAV_CMD_GET_MESSAGE_INTERVAL, (M.MAVLINK_MSG_ID_ATTITUDE,)),
        ("long", M.MAV_CMD_REQUEST_MESSAGE, (M.MAVLINK_MSG_ID_AUTOPILOT_VERSION,)),
        ("long", M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, (1,)),
        ("long", M.MAV_CMD_GET_HOME_POSITION, ()),
        ("long", M.MAV_CMD_DO_SET_HOME, (1,)),
        ("long", M.MAV_CMD_DO_SET_MISSION_CURRENT, (1,)),  # no mission: denied
        ("long", M.MAV_CMD_MISSION_START, ()),  # no mission: denied
        ("long", M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (0,)),  # no-op
        ("long", M.MAV_CMD_INJECT_FAILURE, (M.FAILURE_UNIT_SENSOR_GYRO, M.FAILURE_TYPE_OK, 0)),
        ("int", M.MAV_CMD_DO_REPOSITION, (-1, 0, 0, nan)),
        ("long", 31010, (1, 2, 3)),  # MAV_CMD_USER_1: unknown here
        ("int", 31011, ()),  # MAV_CMD_USER_2 as COMMAND_INT: unknown here
        ("long", M.MAV_CMD_NAV_LAND, ()),
        ("long", M.MAV_CMD_NAV_RETURN_TO_LAUNCH, ()),
    ]
    since = gcs.mark()
    for kind, command, params in plan:
        p = list(params) + [0.0] * (7 - len(params))
        if kind == "long":
            gcs.send(M.MAVLink_command_long_message(1, 1, command, 0, *p))
        else:
            gcs.send(M.MAVLink_command_int_message(
                1, 1, M.MAV_FRAME_LOCAL_NED, command, 0, 0, *p[:4], 0, 0, -1.0))
    # A command for another system must not be answered by this one.
    gcs.send(M.MAVLink_command_long_message(42, 1, 31012, 0, 0, 0, 0, 0, 0, 0, 0))
    deadline = time.monotonic() + 3 * ANSWER_S
    while time.monotonic() < deadline:
        acked = {m.command for m in gcs.messages("COMMAND_ACK", since=since)}
        if acked >= {c for _, c, _ in plan}:
            break
        gcs.pump(0.1)
    gcs.collect(2.0)  # time for any duplicate to show up
    acks = gcs.messages("COMMAND_ACK", since=since)
    counts = Counter(m.command for m in acks)
    assert {c: counts[c] for _, c, _ in plan} == {c: 1 for _, c, _ in plan}
    assert counts[31012] == 0
    result = {m.command: m.result for m in acks}
    assert result[M.MAV_CMD_DO_SET_MODE] == ACCEPTED
    assert result[M.MAV_CMD_COMPONENT_ARM_DISARM] == ACCEPTED
    assert result[M.MAV_CMD_NAV_TAKEOFF] == ACCEPTED
    assert result[M.MAV_CMD_MISSION_START] == DENIED
    assert result[31010] == UNSUPPORTED and result[31011] == UNSUPPORTED
    assert all(m.target_system == 255 and m.target_component == 190 for m in acks)


def test_unknown_command_is_unsupported(ground: tuple[VehicleProcess, Gcs]) -> None:
    _, gcs = ground
    for command in (31013, 42700, 65535):
        ack = gcs.command(command, 1, 2, 3)
        assert ack.result == UNSUPPORTED, command
    since = gcs.mark()
    gcs.send(M.MAVLink_command_int_message(1, 1, 0, 31014, 0, 0, 0, 0, 0, 0, 0, 0, 0))
    ack = gcs.wait("COMMAND_ACK", lambda m: m.command == 31014, since=since)
    assert ack.result == UNSUPPORTED


def test_mavlink_ftp_is_refused_at_once(ground: tuple[VehicleProcess, Gcs]) -> None:
    _, gcs = ground
    # OpenFileRO "@PARAM/param.pck" (what MAVProxy asks first): NAK FileNotFound, seq + 1
    name = b"@PARAM/param.pck"
    request = (41).to_bytes(2, "little") + bytes([0, 4, len(name), 0, 0, 0]) + bytes(4) + name
    since = gcs.mark()
    gcs.send(M.MAVLink_file_transfer_protocol_message(0, 1, 1, list(request.ljust(251,
                                                                                  b"\0"))))
    reply = bytes(gcs.wait("FILE_TRANSFER_PROTOCOL", since=since).payload)
    seq, opcode, size, req_opcode = int.from_bytes(reply[0:2], "little"), reply[3], reply[4], \
        reply[5]
    assert (seq, opcode, size, req_opcode, reply[12]) == (42, 129, 1, 4, 10)


def test_parameter_list_is_complete_and_contiguous(ground: tuple[VehicleProcess, Gcs]) -> None:
    _, gcs = ground
    since = gcs.mark()
    gcs.send(M.MAVLink_param_request_list_message(1, 1))
    seen: dict[int, str] = {}
    counts: set[int] = set()
    deadline = time.monotonic() + 2 * ANSWER_S
    while time.monotonic() < deadline:
        for m in gcs.messages("PARAM_VALUE", since=since):
            counts.add(int(m.param_count))
            assert seen.setdefault(int(m.param_index), m.param_id) == m.param_id
            assert m.param_type in PARAM_TYPES, (m.param_id, m.param_type)
            assert math.isfinite(m.param_value), m.param_id
        if counts and len(seen) >= max(counts):
            break
        gcs.pump(0.1)
    assert len(counts) == 1, counts  # one consistent param_count
    count = counts.pop()
    assert sorted(seen) == list(range(count))  # indices 0..count-1, each once
    names = list(seen.values())
    assert len(set(names)) == count and all(1 <= len(n) <= 16 for n in names)
    assert EXPECTED_PARAMS <= set(names), EXPECTED_PARAMS - set(names)
    # Reading by index and by name agrees with the list.
    for index in (0, count // 2, count - 1):
        since = gcs.mark()
        gcs.send(M.MAVLink_param_request_read_message(1, 1, b"", index))
        m = gcs.wait("PARAM_VALUE", lambda m, i=index: m.param_index == i, since=since)
        assert m.param_id == seen[index]
    assert gcs.param_get("ATT_CTRL") == 1.0  # the baseline scenario flies LQG


def test_param_set_is_validated_and_echoed(ground: tuple[VehicleProcess, Gcs]) -> None:
    _, gcs = ground
    since = gcs.mark()
    assert gcs.param_set("ATT_CTRL", 5).param_value == 1.0  # not 0 or 1: unchanged
    assert gcs.param_set("SIM_FI_LOE", math.nan).param_value == pytest.approx(0.3)
    assert gcs.param_set("SIM_SPEEDUP", 1).param_value == float(GROUND_SPEEDUP)
    assert gcs.param_set("DISARM_DELAY", 2.5).param_value == 2.5
    gcs.wait("STATUSTEXT", lambda m: "SIM_SPEEDUP" in m.text and "read-only" in m.text,
             since=since)
    texts = statustexts(gcs, since)
    assert any("ATT_CTRL" in t and "5" in t for t in texts), texts
    assert any("SIM_FI_LOE" in t and "nan" in t for t in texts), texts
    # A controller change on the ground rebuilds the autopilot; it flies the new one.
    since = gcs.mark()
    assert gcs.param_set("ATT_CTRL", 0).param_value == 0.0
    gcs.wait("STATUSTEXT", lambda m: "rebuilt" in m.text, since=since)
    assert gcs.param_set("ATT_CTRL", 1).param_value == 1.0
    assert gcs.param_set("DISARM_DELAY", 10).param_value == 10.0


def test_malformed_and_nan_fields_are_refused(ground: tuple[VehicleProcess, Gcs]) -> None:
    _, gcs = ground
    nan, inf = math.nan, math.inf
    assert gcs.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, nan).result == DENIED
    assert gcs.command(M.MAV_CMD_DO_SET_MODE, 1, nan).result == DENIED
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0.5).result == DENIED
    assert gcs.command(M.MAV_CMD_DO_CHANGE_SPEED, 1, inf).result == DENIED
    assert gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE,
                       nan).result == DENIED
    assert gcs.command(M.MAV_CMD_INJECT_FAILURE, nan, 1, 1).result == DENIED
    # unsupported modes are refused with a reason
    since = gcs.mark()
    assert gcs.set_mode(1).result == DENIED  # ACRO
    gcs.wait("STATUSTEXT", lambda m: "ACRO" in m.text, since=since)
    # a mission item with NaN where a number is required ends the upload with an error
    items = [mission_item(0, M.MAV_CMD_NAV_WAYPOINT),
             mission_item(1, M.MAV_CMD_NAV_WAYPOINT, params=(nan, 0, 0, 0), z=-1.0)]
    ack, _ = gcs.upload_mission(items)
    assert ack.type == M.MAV_MISSION_INVALID_PARAM1
    items = [mission_item(0, M.MAV_CMD_NAV_WAYPOINT),
             mission_item(1, M.MAV_CMD_NAV_WAYPOINT, z=-1.0,
                          frame=M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)]
    items[1].x = 2**31 - 1  # INT32_MAX degE7: latitude 214.7 deg
    ack, _ = gcs.upload_mission(items)
    assert ack.type == M.MAV_MISSION_INVALID_PARAM5_X
    # a NaN set-point is refused with a STATUSTEXT (no ACK exists for set-points)
    since = gcs.mark()
    gcs.send(M.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0b0000_1111_1111_1000, nan, 0, -1, 0, 0, 0, 0, 0, 0,
        0, 0))
    gcs.wait("STATUSTEXT", lambda m: "not a number" in m.text, since=since)
    # malformed packets: a bad checksum and a truncated packet are counted, not obeyed
    good = M.MAVLink_command_long_message(1, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 21196,
                                          0, 0, 0, 0, 0).pack(gcs.mav)
    bad_crc = good[:-2] + bytes([good[-2] ^ 0xFF, good[-1]])
    since = gcs.mark()
    gcs.send_raw(bad_crc)
    gcs.send_raw(good[: len(good) // 2])
    sys_status = gcs.wait("SYS_STATUS", lambda m: m.errors_comm >= 2, since=since)
    assert sys_status.errors_comm >= 2
    assert not gcs.messages("COMMAND_ACK", since=since)
    heartbeat = gcs.wait_heartbeat(ANSWER_S)
    assert not heartbeat.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED


@pytest.mark.slow
def test_mission_with_a_dropped_packet_completes(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", FLIGHT_SPEEDUP, outs=[gcs.port])
    gcs.wait_heartbeat()
    nan = math.nan
    items = [
        mission_item(0, M.MAV_CMD_NAV_WAYPOINT),  # home (ArduPilot: seq 0, replaced)
        mission_item(1, M.MAV_CMD_NAV_TAKEOFF, z=-1.0, current=1),
        mission_item(2, M.MAV_CMD_DO_CHANGE_SPEED, params=(1, 0.6, -1, 0)),
        mission_item(3, M.MAV_CMD_NAV_WAYPOINT, params=(0.5, 0, 0, nan),
                     x=1.0, y=0.5, z=-1.0),
        mission_item(4, M.MAV_CMD_NAV_WAYPOINT, x=0.0, y=0.0, z=-1.0, params=(0, 0, 0, nan)),
        mission_item(5, M.MAV_CMD_NAV_LAND),
    ]
    ack, requests = gcs.upload_mission(items, drop_seqs=[3])
    assert ack.type == M.MAV_MISSION_ACCEPTED
    assert requests[3] >= 2 and all(requests[s] >= 1 for s in range(len(items)))
    # read it back: home plus the five items, as uploaded
    since = gcs.mark()
    gcs.send(M.MAVLink_mission_request_list_message(1, 1, M.MAV_MISSION_TYPE_MISSION))
    assert gcs.wait("MISSION_COUNT", since=since).count == len(items)
    since = gcs.mark()
    gcs.send(M.MAVLink_mission_request_int_message(1, 1, 3, M.MAV_MISSION_TYPE_MISSION))
    item = gcs.wait("MISSION_ITEM_INT", since=since)
    assert (item.command, item.x, item.y) == (M.MAV_CMD_NAV_WAYPOINT, 10000, 5000)
    gcs.send(M.MAVLink_mission_ack_message(1, 1, M.MAV_MISSION_ACCEPTED,
                                           M.MAV_MISSION_TYPE_MISSION))
    # fly it: arm (STABILIZE), AUTO, MISSION_START; every item is reached, then it lands
    since = gcs.mark()
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert gcs.set_mode(AUTO).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_MISSION_START).result == ACCEPTED
    gcs.wait("MISSION_CURRENT", lambda m: m.mission_state == M.MISSION_STATE_COMPLETE,
             timeout_s=90.0, since=since)
    reached = [m.seq for m in gcs.messages("MISSION_ITEM_REACHED", since=since)]
    assert reached == [1, 2, 3, 4, 5]
    gcs.wait("HEARTBEAT", lambda m: m.get_srcComponent() == 1
             and not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED, timeout_s=30.0)
    landed = gcs.wait("EXTENDED_SYS_STATE", timeout_s=ANSWER_S)
    assert landed.landed_state == M.MAV_LANDED_STATE_ON_GROUND
    sim = gcs.wait("SIM_STATE")
    assert abs(sim.vd) < 0.05  # at rest on the ground (truth)


def test_a_mission_loaded_at_boot_is_the_one_a_ground_station_sees(start_vehicle,
                                                                     gcs: Gcs) -> None:
    """``--load-mission``: the download, MISSION_CURRENT and MISSION_SET_CURRENT all see
    the scenario's mission (the thesis mission: 10 items after home)."""
    start_vehicle("--load-mission", "--speedup", GROUND_SPEEDUP, outs=[gcs.port])
    gcs.wait_heartbeat()  # the boot beacon: the autopilot streams once it has loaded
    assert gcs.wait("MISSION_CURRENT", timeout_s=STARTUP_S).total == 10
    since = gcs.mark()
    gcs.send(M.MAVLink_mission_request_list_message(1, 1, M.MAV_MISSION_TYPE_MISSION))
    assert gcs.wait("MISSION_COUNT", since=since).count == 11
    since = gcs.mark()
    gcs.send(M.MAVLink_mission_request_int_message(1, 1, 5, M.MAV_MISSION_TYPE_MISSION))
    item = gcs.wait("MISSION_ITEM_INT", since=since)  # NAV_WAYPOINT (1, 0, -0.6) hold 1 s
    assert (item.seq, item.command, item.frame) == (5, M.MAV_CMD_NAV_WAYPOINT,
                                                    M.MAV_FRAME_LOCAL_NED)
    assert (item.x, item.y, item.z, item.param1) == (10000, 0, pytest.approx(-0.6), 1.0)
    gcs.send(M.MAVLink_mission_ack_message(1, 1, M.MAV_MISSION_ACCEPTED,
                                           M.MAV_MISSION_TYPE_MISSION))
    since = gcs.mark()
    gcs.send(M.MAVLink_mission_set_current_message(1, 1, 3))
    assert gcs.wait("MISSION_CURRENT", lambda m: m.seq == 3, since=since).total == 10
    assert not [t for t in statustexts(gcs, since) if "not in" in t]


def test_a_boot_mission_the_vehicle_refuses_is_announced_and_none_is_held(
        start_vehicle, gcs: Gcs, tmp_path: Path) -> None:
    scenario = tmp_path / "far.toml"
    scenario.write_text('name = "far"\nduration_s = 60.0\n[mission]\nkind = "items"\n'
                        '[[mission.items]]\ncommand = "takeoff"\nalt_m = 1.0\n'
                        '[[mission.items]]\ncommand = "waypoint"\npos_ned = [1e6, 0.0, -1.0]\n')
    start_vehicle("--scenario", str(scenario), "--load-mission", "--speedup", GROUND_SPEEDUP,
                  outs=[gcs.port])
    gcs.wait_heartbeat()
    text = gcs.wait_text("Boot mission refused", since=0, timeout_s=STARTUP_S)
    assert text == "Boot mission refused: Mission item 2: x 1e+06 m beyond +-10000 m"
    assert gcs.wait("MISSION_CURRENT", timeout_s=STARTUP_S).total == 65535  # no mission
