"""``ftc-gcs fly`` and a plain pymavlink client, again and again, through a lossy link.

A proxy (:class:`lossy_proxy.LossyProxy`, loopback, seeded) drops 30 % of the datagrams each
way between the ground stations and one ``ftc-vehicle`` at speed-up 20, never restarted by
the test: a plain pymavlink client (3 s retry) uploads the 10-item thesis mission 20 times,
then ``ftc-gcs fly`` flies three times in a row (one with the Table 7.3 faults, then one that
must restart the autopilot). Without faults through a good link:
``test_gcs_back_to_back.py``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest
from gcs_runs import assert_landed, gcs_fly
from lossy_proxy import LossyProxy
from vehicle_harness import Gcs, M, VehicleProcess, write_hover_mission

from gcs.mission import home_item, thesis_mission

SPEEDUP = "20"
LOSSY_FLIGHT_WALL_S = 600.0  # s: the set-up's round trips at 30 % loss each way
LOSS = 0.30  # each way
UPLOADS = 20
UPLOAD_RETRY_S = 3.0  # s: the plain client sends its last message again after this silence
UPLOAD_WALL_S = 120.0  # s for one upload, at most (about 7 s at 30 % loss)

pytestmark = pytest.mark.slow


def upload_like_a_plain_client(gcs: Gcs, items: Sequence[Any]) -> int | None:
    """MISSION_COUNT, then each item asked for; after :data:`UPLOAD_RETRY_S` without an
    answer the last message goes again. Returns the MISSION_ACK type (None: no ACK within
    :data:`UPLOAD_WALL_S`)."""
    last = M.MAVLink_mission_count_message(1, 1, len(items), M.MAV_MISSION_TYPE_MISSION)
    since = gcs.mark()
    gcs.send(last)
    deadline = time.monotonic() + UPLOAD_WALL_S
    while (left := deadline - time.monotonic()) > 0:
        try:
            msg = gcs.wait(["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"],
                           lambda m: m.get_srcSystem() == 1 and m.mission_type == 0,
                           timeout_s=min(UPLOAD_RETRY_S, left), since=since)
        except TimeoutError:
            gcs.send(last)
            continue
        since = gcs.mark()
        if msg.get_type() == "MISSION_ACK":
            return int(msg.type)
        if 0 <= msg.seq < len(items):
            last = items[msg.seq]
            gcs.send(last)
    return None


def test_flights_and_uploads_through_a_link_losing_30_percent_each_way(
        tmp_path: Path) -> None:
    with LossyProxy(LOSS, seed=5) as proxy:
        vehicle = VehicleProcess(["--speedup", SPEEDUP, "--out",
                                  f"127.0.0.1:{proxy.vehicle_port}"])
        connect = f"udpout:127.0.0.1:{proxy.gcs_port}"
        hover = write_hover_mission(tmp_path / "hover.toml")
        acks: list[int | None] = []
        try:
            # a plain pymavlink client uploads the 10-item thesis mission, again and again
            # (first: the flights leave the streams at 100 Hz of simulated time, 2000
            # messages a second at speed-up 20, more than a plain client keeps up with)
            gcs = Gcs()
            gcs.vehicle = ("127.0.0.1", proxy.gcs_port)
            gcs.auto_heartbeat(1.0)
            gcs.heartbeat()  # the proxy learns our address from our first datagram
            gcs.wait_heartbeat(60.0)
            wire = [home_item(), *thesis_mission()]
            items = [w.to_message(seq, 1, 1, current=seq == 0) for seq, w in enumerate(wire)]
            try:
                for _ in range(UPLOADS):
                    acks.append(upload_like_a_plain_client(gcs, items))
            finally:
                gcs.close()
            assert acks == [M.MAV_MISSION_ACCEPTED] * UPLOADS
            flights = [("l0", ("--mission", str(hover))),
                       ("l1", ("--faults", "table7.3", "--reboot")),
                       ("l2", ("--mission", str(hover), "--reboot"))]
            for name, args in flights:
                proc, data, events = gcs_fly(connect, tmp_path, name, *args,
                                             timeout_s=LOSSY_FLIGHT_WALL_S)
                assert_landed(proc, data)
                if name != "l0":  # AUTO after the last mission
                    assert "switched to STABILIZE" in events
                if name == "l2":  # motors declared failed in l1: restarted, and healthy
                    assert "autopilot restarted" in events
                    assert data is not None and data["detections"] == []
        finally:
            code = vehicle.stop()
    assert code == 0 and "Traceback" not in vehicle.stderr_text
    for direction in (proxy.to_gcs, proxy.to_vehicle):  # the link really lost about 30 %
        n = direction.forwarded + direction.dropped
        assert direction.loss == pytest.approx(LOSS, abs=5 * math.sqrt(LOSS * (1 - LOSS) / n))
