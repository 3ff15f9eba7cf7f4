"""The geofence in flight: a 10 m-high outdoor mission planned past the fence (uploaded with
the fence off, as ArduCopter takes it), the fence enabled (DO_FENCE_ENABLE, MAVProxy's
``fence enable``), and the breach triggers FENCE_ACTION, announced."""

from __future__ import annotations

from test_extended_telemetry import no_idle_disarm
from vehicle_harness import Gcs, M, mission_item

ACCEPTED = M.MAV_RESULT_ACCEPTED
GUIDED, RTL, LAND = 4, 6, 9
PX4_HOME = "47.397742,8.545594,488"


def fenced_mission() -> list:
    """Home, take-off to 10 m, a waypoint 40 m north at 10 m, land (local NED)."""
    return [mission_item(0, M.MAV_CMD_NAV_WAYPOINT),
            mission_item(1, M.MAV_CMD_NAV_TAKEOFF, z=-10.0, current=1),
            mission_item(2, M.MAV_CMD_NAV_WAYPOINT, x=40.0, z=-10.0),
            mission_item(3, M.MAV_CMD_NAV_LAND, x=40.0)]


def test_a_breach_of_the_fence_triggers_its_action(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--home", PX4_HOME, "--speedup", "10", outs=[gcs.port])
    gcs.wait_heartbeat()
    gcs.wait("HOME_POSITION", timeout_s=60.0)
    no_idle_disarm(gcs)
    assert gcs.param_set("FENCE_RADIUS", 25.0).param_value == 25.0
    ack, _ = gcs.upload_mission(fenced_mission())
    assert ack.type == M.MAV_MISSION_ACCEPTED  # the fence is off: nothing refuses it
    since = gcs.mark()
    assert gcs.command(M.MAV_CMD_DO_FENCE_ENABLE, 1).result == ACCEPTED
    assert gcs.param_get("FENCE_ENABLE") == 1.0
    assert gcs.set_mode(GUIDED).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_MISSION_START, 0, 0).result == ACCEPTED
    text = gcs.wait_text("fence breach", since, timeout_s=300.0)
    assert "FENCE_RADIUS" in text and "FENCE_ACTION 1: RTL" in text
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == RTL, since=since, timeout_s=30.0)
    position = gcs.wait("LOCAL_POSITION_NED", since=gcs.mark())
    assert 20.0 < position.x < 40.0  # turned back between the fence and the waypoint
    gcs.wait_text("back inside the fence", since, timeout_s=300.0)
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == RTL, since=gcs.mark(), timeout_s=30.0)
