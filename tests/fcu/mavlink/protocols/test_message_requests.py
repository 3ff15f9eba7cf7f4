"""Every message id asked for: what the vehicle produces is requestable (SET_MESSAGE_INTERVAL,
REQUEST_MESSAGE), everything else is UNSUPPORTED, never DENIED (DENIED is for bad
parameters). Swept over every message of the dialect, PX4's ESC_INFO and ESC_STATUS (not in
it) and a few ids nobody defines."""

from __future__ import annotations

from mavlink_testkit import MemoryGcs, MemoryLink, memory_endpoint

from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
DT_S = 0.01  # s, one autopilot tick
SWEEP_TIME_S = 1.0  # s: the vehicle's clock stands still during the sweep
ESC_INFO, ESC_STATUS = 290, 291  # PX4's; WIP in common.xml, in no dialect of pymavlink 2.4
# Replies and events: sent when something happens, not telemetry one could ask for
NOT_TELEMETRY = {"COMMAND_ACK", "STATUSTEXT", "PARAM_VALUE", "TIMESYNC", "MESSAGE_INTERVAL",
                 "MISSION_ACK", "MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_REQUEST_INT",
                 "MISSION_ITEM_REACHED", "DEBUG_FLOAT_ARRAY", "AUTOPILOT_VERSION"}


def result_of(endpoint: MavlinkEndpoint, link: MemoryLink, gcs: MemoryGcs, command: int,
              *params: float) -> int:
    """Send one COMMAND_LONG, tick once, return its ACK's result."""
    p = list(params) + [0.0] * (7 - len(params))
    gcs.put(M.MAVLink_command_long_message(1, 1, command, 0, *p))
    endpoint.tick(SWEEP_TIME_S, 0.0)
    acks = [m for m in link.take("COMMAND_ACK") if m.command == command]
    assert len(acks) == 1
    return int(acks[0].result)


def test_every_message_id_is_accepted_or_unsupported_never_denied() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    vehicle.target = vehicle.pos_ned.copy()  # a position reference exists
    for k in range(101):  # a second of telemetry: every sample exists
        vehicle.time_s = k * DT_S
        endpoint.tick(vehicle.time_s, 0.0)
    streamed = {m.get_type() for m in link.take()} - NOT_TELEMETRY
    assert len(streamed) >= 19  # the usual telemetry (SYS_STATUS, ATTITUDE, ...)

    ids = {int(i) for i in M.mavlink_map} | {ESC_INFO, ESC_STATUS, 5000, 65535}
    interval: dict[int, int] = {}
    requested: dict[int, int] = {}
    for msg_id in sorted(ids):
        interval[msg_id] = result_of(endpoint, link, gcs, M.MAV_CMD_SET_MESSAGE_INTERVAL,
                                     msg_id, 1_000_000)
        requested[msg_id] = result_of(endpoint, link, gcs, M.MAV_CMD_REQUEST_MESSAGE, msg_id)
    assert set(interval.values()) == {M.MAV_RESULT_ACCEPTED, M.MAV_RESULT_UNSUPPORTED}
    assert set(requested.values()) <= {M.MAV_RESULT_ACCEPTED, M.MAV_RESULT_UNSUPPORTED,
                                       M.MAV_RESULT_TEMPORARILY_REJECTED}  # (no sample yet)
    # what the vehicle sends by itself can be asked for, at a rate and once
    by_name = {M.mavlink_map[i].msgname: i for i in M.mavlink_map}
    for name in streamed:
        assert interval[by_name[name]] == M.MAV_RESULT_ACCEPTED, name
        assert requested[by_name[name]] == M.MAV_RESULT_ACCEPTED, name
    # a rate accepted means a message that can be made; PX4's ESC messages cannot
    for msg_id in (ESC_INFO, ESC_STATUS, 5000, 65535, M.MAVLINK_MSG_ID_OPTICAL_FLOW):
        assert interval[msg_id] == requested[msg_id] == M.MAV_RESULT_UNSUPPORTED
    for msg_id in (M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, M.MAVLINK_MSG_ID_HIGHRES_IMU,
                   M.MAVLINK_MSG_ID_ODOMETRY, M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS,
                   M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4):
        assert interval[msg_id] == M.MAV_RESULT_ACCEPTED, msg_id
