"""GCS heartbeat-loss failsafe: wall-clock judgement, who counts as the GCS, actions."""

from __future__ import annotations

import time

import pytest
from mavlink_testkit import WAIT_S, Gcs, MemoryGcs, memory_endpoint, started

from fcu.mavlink.endpoint_config import EndpointConfig
from fcu.mavlink.enums import MavState
from fcu.mavlink.protocols.failsafe import FailsafeAction, GcsFailsafe, GcsFailsafeConfig
from fcu.mavlink.transport.codec import mavlink2
from fcu.navigation.modes import Mode

M = mavlink2
LAND = GcsFailsafeConfig(action=FailsafeAction.LAND, timeout_s=5.0, gcs_sysid=255)


def test_fires_once_after_the_timeout_and_clears_on_heartbeat() -> None:
    fs = GcsFailsafe(own_sysid=1)
    fs.on_heartbeat(255, M.MAV_TYPE_GCS, 10.0, LAND)
    assert fs.check(True, 14.99, LAND) is None
    assert fs.check(True, 15.0, LAND) == FailsafeAction.LAND
    assert fs.active
    assert fs.check(True, 20.0, LAND) is None  # once per loss
    assert fs.on_heartbeat(255, M.MAV_TYPE_GCS, 21.0, LAND)  # cleared
    assert not fs.active
    assert fs.check(True, 25.99, LAND) is None
    assert fs.check(True, 26.0, LAND) == FailsafeAction.LAND  # a second loss


@pytest.mark.parametrize("armed, seen, action", [(False, True, FailsafeAction.LAND),
                                                 (True, False, FailsafeAction.LAND),
                                                 (True, True, FailsafeAction.DISABLED)])
def test_never_fires_disarmed_unseen_or_disabled(armed: bool, seen: bool,
                                                  action: FailsafeAction) -> None:
    config = GcsFailsafeConfig(action=action)
    fs = GcsFailsafe(own_sysid=1)
    if seen:
        fs.on_heartbeat(255, M.MAV_TYPE_GCS, 0.0, config)
    assert fs.check(armed, 1000.0, config) is None


@pytest.mark.parametrize("sysid, mav_type, counts", [
    (255, M.MAV_TYPE_GCS, True),  # MAVProxy / QGC
    (245, M.MAV_TYPE_GCS, True),  # MAVSDK
    (245, M.MAV_TYPE_ONBOARD_CONTROLLER, True),  # MAVSDK as a companion: its id counts
    (200, M.MAV_TYPE_GCS, True),  # any ground station
    (2, M.MAV_TYPE_QUADROTOR, False),  # another vehicle
    (1, M.MAV_TYPE_GCS, False),  # our own id: never
])
def test_who_counts_as_the_gcs(sysid: int, mav_type: int, counts: bool) -> None:
    assert GcsFailsafe(own_sysid=1).is_gcs(sysid, mav_type, LAND) == counts


def test_sysid_mygcs_is_honoured() -> None:
    config = GcsFailsafeConfig(gcs_sysid=42)
    assert GcsFailsafe(own_sysid=1).is_gcs(42, M.MAV_TYPE_QUADROTOR, config)


def heartbeat_from(gcs: MemoryGcs) -> None:
    gcs.put(M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))


def test_speed_up_never_fires_it_but_silence_does() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    vehicle.armed, vehicle.mode, vehicle.pos_ned[2] = True, Mode.GUIDED, -2.0
    # 20 wall seconds of GCS heartbeats at 1 Hz while the simulation runs 100x faster.
    for k in range(2001):
        wall = k * 0.01
        if k % 100 == 0:
            heartbeat_from(gcs)
        endpoint.tick(100.0 * wall, wall)
    assert not endpoint.gcs_failsafe_active and vehicle.mode == Mode.GUIDED
    # Silence: 4.99 s after the last heartbeat nothing, at 5 s LAND.
    for k in range(1, 500):
        endpoint.tick(2000.0 + k, 20.0 + k * 0.01)
    assert not endpoint.gcs_failsafe_active
    endpoint.tick(3000.0, 25.0)
    assert endpoint.gcs_failsafe_active
    assert vehicle.mode == Mode.LAND
    assert ("trigger_failsafe", "gcs", "land") in vehicle.calls
    texts = [m.text for m in link.take("STATUSTEXT")]
    assert any("GCS failsafe" in t and "LAND" in t for t in texts)
    endpoint.tick(3000.0, 26.0)
    beats = link.take("HEARTBEAT")
    assert beats and beats[-1].system_status == MavState.CRITICAL
    heartbeat_from(gcs)
    endpoint.tick(3000.0, 27.0)
    assert not endpoint.gcs_failsafe_active
    assert ("clear_failsafe", "gcs") in vehicle.calls


def test_rtl_action_and_no_gcs_no_failsafe() -> None:
    config = EndpointConfig(gcs_failsafe_action=int(FailsafeAction.RTL))
    endpoint, vehicle, _, gcs = memory_endpoint(config)
    vehicle.armed, vehicle.mode, vehicle.pos_ned[2] = True, Mode.GUIDED, -2.0
    for k in range(100):  # no GCS ever: a headless run never fails safe
        endpoint.tick(k, k)
    assert not endpoint.gcs_failsafe_active
    heartbeat_from(gcs)
    endpoint.tick(100.0, 100.0)
    endpoint.tick(106.0, 106.0)
    assert vehicle.mode == Mode.RTL


def test_continue_mission_in_auto() -> None:
    config = EndpointConfig(gcs_failsafe_action=int(FailsafeAction.RTL_OR_CONTINUE_MISSION))
    endpoint, vehicle, _, gcs = memory_endpoint(config)
    vehicle.armed, vehicle.mode, vehicle.pos_ned[2] = True, Mode.AUTO, -2.0
    heartbeat_from(gcs)
    endpoint.tick(0.0, 0.0)
    endpoint.tick(10.0, 10.0)
    assert endpoint.gcs_failsafe_active and vehicle.mode == Mode.AUTO
    assert not [c for c in vehicle.calls if c[0] == "trigger_failsafe"]


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_failsafe_over_udp_at_50x() -> None:
    with Gcs() as gcs:
        vehicle = started(gcs, speedup=50.0)
        try:
            gcs.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", 2.0, M.MAV_PARAM_TYPE_REAL32)
            assert gcs.recv("PARAM_VALUE", condition=lambda m: m.param_value == 2.0)
            assert gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED).result == 0
            assert gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
            assert gcs.ack(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 5.0).result == 0
            # Heartbeats every 0.3 s for 4 wall s (200 simulated s): no failsafe.
            end = time.monotonic() + 4.0
            texts: list[str] = []
            while time.monotonic() < end:
                gcs.heartbeat()
                last_heartbeat = time.monotonic()
                texts += [m.text for m in gcs.collect("STATUSTEXT", 0.3)]
            assert not any("GCS failsafe" in t for t in texts)
            assert not vehicle.endpoint.gcs_failsafe_active
            text = gcs.text(lambda t: "GCS failsafe" in t, timeout_s=2.0 + WAIT_S)
            elapsed = time.monotonic() - last_heartbeat
            assert text is not None and "LAND" in text
            # Not before the 2 s timeout after the last heartbeat (wall clock), nor much after;
            # 0.1 s: a heartbeat is stamped with the wall time of the tick that reads it,
            # which may precede our send by up to one tick (a few ms).
            assert 2.0 - 0.1 <= elapsed <= 2.0 + WAIT_S
            hb = gcs.recv("HEARTBEAT", condition=lambda m: m.custom_mode == Mode.LAND)
            assert hb is not None and hb.system_status == MavState.CRITICAL
        finally:
            vehicle.stop()
