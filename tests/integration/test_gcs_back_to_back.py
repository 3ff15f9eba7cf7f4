"""``ftc-gcs fly`` again and again against one running ``ftc-vehicle``, as a user flies it.

One vehicle, never restarted by the test, at speed-up 20: flights with the Table 7.3 faults
(thesis mission) alternate with flights without (a hover mission, or a QGroundControl
``.plan``). Each flight finds the vehicle where the last one left it: in AUTO (which does not
allow arming), and after a faulted flight with motors declared failed (arming refused until
the autopilot restarts). The ground station switches to STABILIZE, restarts the autopilot when
given ``--reboot`` (and says in one line what to do when not), and clears its injected faults
at the end of each flight. The same runs through a proxy losing 30 % of the datagrams each way,
followed by mission uploads from a plain pymavlink client.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from lossy_proxy import LossyProxy
from pymavlink import mavutil
from vehicle_harness import ROOT, Gcs, M, VehicleProcess, free_port, write_hover_mission

from fcu.mavlink.geo import ned_to_geo
from gcs.mission import home_item, thesis_mission
from sim.vehicle import DEFAULT_HOME

SPEEDUP = "20"
FLIGHT_WALL_S = 400.0  # s: a ~60 s mission at speed-up 20 is ~5 s with set-up; loaded CI
LOSSY_FLIGHT_WALL_S = 600.0  # s: the set-up's round trips at 30 % loss each way
LOSS = 0.30  # each way
UPLOADS = 20
UPLOAD_RETRY_S = 3.0  # s: the plain client sends its last message again after this silence
UPLOAD_WALL_S = 120.0  # s for one upload, at most (about 5 s at 30 % loss)

pytestmark = pytest.mark.slow


def gcs_fly(connect: str, out: Path, name: str, *args: str,
            timeout_s: float = FLIGHT_WALL_S) -> tuple[subprocess.CompletedProcess[str],
                                                        dict[str, Any] | None, str]:
    """One ``ftc-gcs fly``; returns the process, its JSON (None when none was written) and
    its event log."""
    tlog, js = out / f"{name}.tlog", out / f"{name}.json"
    proc = subprocess.run(
        [sys.executable, "-m", "gcs", "fly", "--connect", connect, "--tlog", str(tlog),
         "--json", str(js), "--quiet", *args],
        cwd=ROOT, capture_output=True, text=True, timeout=timeout_s, stdin=subprocess.DEVNULL)
    events = tlog.with_suffix(".events.log")
    return (proc, json.loads(js.read_text()) if js.exists() else None,
            events.read_text() if events.exists() else "")


def write_qgc_plan(path: Path) -> Path:
    """A 1 m square at 0.6 m about the vehicle's home, written as QGroundControl writes a
    plan (its keys, a SimpleItem per item with seven params, null yaw), with a geofence
    circle and a rally point."""
    def latlon(north_m: float, east_m: float) -> list[float]:
        lat, lon, _ = ned_to_geo(np.array([north_m, east_m, 0.0]), DEFAULT_HOME)
        return [round(lat, 8), round(lon, 8)]

    def item(n: int, command: int, params: list[Any]) -> dict[str, Any]:
        return {"AMSLAltAboveTerrain": None, "Altitude": params[6], "AltitudeMode": 1,
                "autoContinue": True, "command": command, "doJumpId": n, "frame": 3,
                "params": params, "type": "SimpleItem"}

    home = latlon(0.0, 0.0)
    items = [item(1, 22, [0, 0, 0, None, *home, 0.6])]
    for n, (north, east) in enumerate([(1, 0), (1, 1), (0, 1), (0, 0)], start=2):
        items.append(item(n, 16, [1, 0, 0, None, *latlon(north, east), 0.6]))
    items.append(item(6, 21, [0, 0, 0, None, *home, 0]))
    plan = {"fileType": "Plan",
            "geoFence": {"circles": [{"circle": {"center": home, "radius": 20},
                                      "inclusion": True, "version": 1}],
                         "polygons": [], "version": 2},
            "groundStation": "QGroundControl",
            "mission": {"cruiseSpeed": 15, "firmwareType": 3, "globalPlanAltitudeMode": 1,
                        "hoverSpeed": 5, "items": items,
                        "plannedHomePosition": [*home, DEFAULT_HOME.alt_m],
                        "vehicleType": 2, "version": 2},
            "rallyPoints": {"points": [[*latlon(2.0, 2.0), 1.0]], "version": 2},
            "version": 1}
    path.write_text(json.dumps(plan, indent=4) + "\n")
    return path


def assert_landed(proc: subprocess.CompletedProcess[str], data: dict[str, Any] | None) -> None:
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert data is not None and data["result"] == "ok" and not data["crashed"]
    assert "Traceback" not in proc.stderr


def test_ten_flights_in_a_row_against_one_vehicle(tmp_path: Path) -> None:
    port = free_port()
    connect = f"udpin:127.0.0.1:{port}"
    hover = write_hover_mission(tmp_path / "hover.toml")
    vehicle = VehicleProcess(["--speedup", SPEEDUP, "--out", f"127.0.0.1:{port}"])
    results: list[int] = []
    try:
        for n in range(10):
            faulted = n % 2 == 0
            if faulted:
                proc, data, events = gcs_fly(connect, tmp_path, f"f{n}", "--faults", "table7.3")
            else:
                if n == 1:  # after a faulted flight, without --reboot: refused in one line
                    refused, _, refused_events = gcs_fly(connect, tmp_path, "refused",
                                                         "--mission", str(hover))
                    assert refused.returncode == 4, refused.stderr[-3000:]
                    assert "mode AUTO does not allow arming: switched to STABILIZE" in \
                        refused_events
                    lines = [ln for ln in refused.stderr.splitlines() if ln.startswith("ftc-")]
                    assert lines == ["ftc-gcs: restart needed: the vehicle arms only after its "
                                     "autopilot restarts (motors 1, 3, 4 detected failed in an "
                                     "earlier flight); add --reboot to restart it first"]
                proc, data, events = gcs_fly(connect, tmp_path, f"f{n}", "--mission",
                                             str(hover), "--reboot")
            results.append(proc.returncode)
            assert_landed(proc, data)
            assert data is not None
            if n > 1:  # the last flight left it in AUTO, which does not allow arming
                assert "mode AUTO does not allow arming: switched to STABILIZE" in events
            if faulted:
                assert sorted(d["motor"] for d in data["detections"]) == [1, 3, 4]
                assert "the flight's injected faults cleared" in events
            else:
                assert "restarting the autopilot" in events and "autopilot restarted" in events
                assert data["detections"] == []  # the faults were cleared: a healthy flight
                assert all(row["injected"] == 0.0 for row in data["loe"])
    finally:
        code = vehicle.stop()
    assert results == [0] * 10
    assert code == 0 and "Traceback" not in vehicle.stderr_text


def test_a_qgroundcontrol_plan_is_flown(tmp_path: Path) -> None:
    port = free_port()
    plan = write_qgc_plan(tmp_path / "square.plan")
    vehicle = VehicleProcess(["--speedup", SPEEDUP, "--out", f"127.0.0.1:{port}"])
    try:
        proc, data, events = gcs_fly(f"udpin:127.0.0.1:{port}", tmp_path, "plan",
                                     "--mission", str(plan))
    finally:
        vehicle.stop()
    assert_landed(proc, data)
    assert "upload of 6 items accepted" in events
    for seq in range(1, 7):
        assert f"item {seq} reached" in events
    # this vehicle keeps no geofence or rally points: said, and flown without them
    assert "the vehicle keeps no geofence (MAV_MISSION_UNSUPPORTED)" in events
    assert "the vehicle keeps no rally points (MAV_MISSION_UNSUPPORTED)" in events
    # s in the air: take-off, four 1 m legs with 1 s holds, landing (25 s when written)
    assert data is not None and data["flight_s"] > 20.0


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


def test_a_vehicle_found_flying_is_refused_in_one_line(tmp_path: Path) -> None:
    port = free_port()
    # speed-up 1: the other ground station's take-off is not over before ours connects
    vehicle = VehicleProcess(["--speedup", "1", "--out", f"127.0.0.1:{port}"])
    other = Gcs()
    try:
        other.vehicle = vehicle.address
        other.auto_heartbeat(0.5)
        other.heartbeat()
        other.wait_heartbeat(60.0)
        assert other.set_mode(M.COPTER_MODE_GUIDED).result == M.MAV_RESULT_ACCEPTED
        deadline = time.monotonic() + 60.0  # s: armable once its estimate has settled
        while other.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result != \
                M.MAV_RESULT_ACCEPTED:
            assert time.monotonic() < deadline, "the vehicle never became armable"
            other.collect(1.0)
        assert other.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 1.0).result == \
            M.MAV_RESULT_ACCEPTED
        proc, _, _ = gcs_fly(f"udpin:127.0.0.1:{port}", tmp_path, "busy")
        still = other.wait_heartbeat(10.0)
    finally:
        other.close()
        vehicle.stop()
    assert proc.returncode == 4, proc.stderr[-3000:]
    assert [ln for ln in proc.stderr.splitlines() if ln.startswith("ftc-")] == [
        "ftc-gcs: vehicle busy: the vehicle is armed (mode GUIDED): another flight is under "
        "way; land and disarm it first"]
    log = mavutil.mavlink_connection(str(tmp_path / "busy.tlog"))
    sent = set()
    while (msg := log.recv_match()) is not None:
        if msg.get_srcSystem() == 255:
            sent.add(msg.get_type())
    log.close()
    assert sent <= {"HEARTBEAT", "TIMESYNC"}, sent  # no command, parameter or mission
    assert still.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED  # still flying the other's flight
    assert still.custom_mode == M.COPTER_MODE_GUIDED
