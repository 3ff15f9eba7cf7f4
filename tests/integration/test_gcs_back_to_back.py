"""``ftc-gcs fly`` again and again against one running ``ftc-vehicle``, as a user flies it.

One vehicle, never restarted by the test, at speed-up 20: flights with the Table 7.3 faults
(thesis mission) alternate with flights without (a hover mission, or a QGroundControl
``.plan``). Each flight finds the vehicle where the last one left it: in AUTO (which does not
allow arming), and after a faulted flight with motors declared failed (arming refused until
the autopilot restarts). The ground station switches to STABILIZE, restarts the autopilot when
given ``--reboot`` (and says in one line what to do when not), and clears its injected faults
at the end of each flight. Through a lossy link: ``test_gcs_back_to_back_lossy.py``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gcs_runs import assert_landed, gcs_fly
from pymavlink import mavutil
from vehicle_harness import Gcs, M, VehicleProcess, free_port, write_hover_mission

from fcu.mavlink.geo import ned_to_geo
from gcs.mission import load_mission
from sim.vehicle import DEFAULT_HOME

SPEEDUP = "20"

pytestmark = pytest.mark.slow


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
    # the plan's geofence circle and rally point go up after the mission, as QGC sends them
    assert "upload of geofence: 1 items accepted" in events  # the circle
    assert "upload of rally points: 1 items accepted" in events
    # s in the air: take-off, four 1 m legs with 1 s holds, landing (25 s when written)
    assert data is not None and data["flight_s"] > 20.0


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


@pytest.mark.vehicle(speedup=20, seed=1)
def test_a_lost_mission_start_answer_is_made_up_for(vehicle_link, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """Every COMMAND_ACK of MISSION_START is lost on the way back: the mission running in
    MISSION_CURRENT counts as the answer, and the held clock dates the start exactly."""
    handle = vehicle_link._handle
    lost = []

    def losing_start_acks(msg: Any, stamp: float | None = None) -> None:
        if msg.get_type() == "COMMAND_ACK" and msg.command == M.MAV_CMD_MISSION_START:
            lost.append(msg)
            return
        handle(msg, stamp)

    vehicle_link._handle = losing_start_acks
    outcome = vehicle_link.fly(mission=load_mission(write_hover_mission(tmp_path / "h.toml")))
    assert outcome.error is None, outcome.error
    assert lost  # the vehicle did answer: each answer was dropped here
    events = (tmp_path / "flight.events.log").read_text()
    assert "mission start: answer lost, the vehicle shows it done" in events
    # a vehicle started paused starts its mission at simulated time 0 exactly
    assert "mission start dated t = 0.000 s by the clock after it" in events
    assert vehicle_link.analyzer.mission_start_s == 0.0
