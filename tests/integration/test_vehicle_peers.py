"""A crowd of chattering clients never starves a ground station of the vehicle's telemetry.

A real ``ftc-vehicle`` on loopback with one configured destination (``--out``) and one client
that connected first by writing to it (``udpout``, then silent), then 40 more clients that
keep writing. The first sixteen learned peers keep their places; the rest are refused with one
notice each in the vehicle's log; both ground stations keep receiving every broadcast.
"""

from __future__ import annotations

import socket
import time

from conftest import VehicleFactory
from vehicle_harness import ANSWER_S, STARTUP_S, Gcs, M

CHATTERERS = 40
CHATTER_WALL_S = 3.0  # s of chatter (what is asserted is counts, not timing)


def attitudes(gcs: Gcs, since: int) -> int:
    return len(gcs.messages("ATTITUDE", since=since))


def test_forty_chattering_peers_do_not_starve_earlier_clients(
        start_vehicle: VehicleFactory, gcs: Gcs) -> None:
    vehicle = start_vehicle("--speedup", "2", outs=[gcs.port])
    gcs.wait_heartbeat()  # sent as soon as the vehicle answers, before it warms up
    gcs.wait("ATTITUDE", lambda m: m.time_boot_ms > 0, timeout_s=STARTUP_S)  # time runs
    client = Gcs()  # connects like MAVProxy's udpout: writes first, to the vehicle's address
    chatter = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(CHATTERERS)]
    try:
        client.vehicle = vehicle.address
        client.heartbeat()
        client.wait_heartbeat(ANSWER_S)
        other = M.MAVLink(None, srcSystem=200, srcComponent=190)
        hello = M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                            M.MAV_STATE_ACTIVE, 3).pack(other)
        for s in chatter:
            s.bind(("127.0.0.1", 0))
        mark_gcs, mark_client = gcs.mark(), client.mark()
        deadline = time.monotonic() + CHATTER_WALL_S
        while time.monotonic() < deadline:
            for s in chatter:
                s.sendto(hello, vehicle.address)
            gcs.pump(0.0)
            client.pump(0.02)
        gcs.pump(0.3)
        client.pump(0.3)
        gcs.collect(0.5)
        client.collect(0.5)
        to_out, to_client = attitudes(gcs, mark_gcs), attitudes(client, mark_client)
    finally:
        for s in chatter:
            s.close()
        client.close()
    # ATTITUDE at 20 Hz simulated, speed-up 2: about 120 over the 3 s; a starved client got
    # none after the 16th chatterer arrived
    assert to_out > 60
    assert to_client >= 0.9 * to_out, (to_client, to_out)
    assert vehicle.stop() == 0
    refusals = [line for line in vehicle.stderr_text.splitlines() if "refused" in line]
    assert len(refusals) == CHATTERERS - 15  # 16 places: the client and 15 chatterers
    assert "Traceback" not in vehicle.stderr_text
