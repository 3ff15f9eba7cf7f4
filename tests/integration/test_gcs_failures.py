"""``ftc-gcs fly`` fails with a non-zero exit code and a one-line reason, and keeps its records.

Against a real ``ftc-vehicle``: a mission item it rejects, and the vehicle killed mid-flight
(the .tlog and event log up to that moment stay readable). A vehicle left in AUTO, whose arm
was refused here before, is now switched to STABILIZE and flown (the refusals a ground
station cannot fix, a vehicle found armed or needing a restart, are in
``test_gcs_back_to_back.py``).
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from pymavlink import mavutil
from vehicle_harness import free_port

from gcs.analysis import analyze_tlog
from gcs.mission import thesis_mission
from gcs.spawn import SpawnedVehicle, VehicleSpec
from gcs.station import COPTER_MODE_AUTO, GroundStation

ROOT = Path(__file__).resolve().parents[2]
WALL_S = 300.0  # s: any one of these flights, on a loaded two-core machine
BOOT_S = 60.0  # s: a vehicle's start-up (imports, numba cache, LQR design)

pytestmark = pytest.mark.slow


def gcs_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "gcs", *args]


def last_line(text: str) -> str:
    return text.strip().splitlines()[-1]


def test_a_vehicle_left_in_auto_is_switched_to_stabilize_and_flown(tmp_path: Path) -> None:
    port = free_port()
    with SpawnedVehicle(VehicleSpec(speedup=10, seed=1), port,
                        log_path=tmp_path / "vehicle.log"):
        # someone left the vehicle in AUTO on the ground: ArduCopter does not arm in AUTO
        with GroundStation.open(f"udpin:127.0.0.1:{port}") as gs:
            gs.wait_vehicle(BOOT_S)
            gs.upload_mission(thesis_mission())
            gs.set_mode(COPTER_MODE_AUTO)
        proc = subprocess.run(
            gcs_command("fly", "--connect", f"udpin:127.0.0.1:{port}", "--quiet",
                        "--tlog", str(tmp_path / "f.tlog")),
            cwd=ROOT, capture_output=True, text=True, timeout=WALL_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    events = (tmp_path / "f.events.log").read_text()
    assert "mode AUTO does not allow arming: switched to STABILIZE" in events
    assert events.index("switched to STABILIZE") < events.index("ARM       armed")


def test_rejected_mission_item(tmp_path: Path) -> None:
    mission = tmp_path / "high.toml"
    mission.write_text('[[items]]\ncommand = "takeoff"\nalt_m = 50.0\n'  # above the fence
                       '[[items]]\ncommand = "land"\n')
    proc = subprocess.run(
        gcs_command("fly", "--spawn-vehicle", "--speedup", "10", "--mission", str(mission),
                    "--param", "FENCE_ENABLE=1", "--param", "FENCE_ALT_MAX=10",
                    "--quiet", "--tlog", str(tmp_path / "f.tlog")),
        cwd=ROOT, capture_output=True, text=True, timeout=WALL_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 5, proc.stdout + proc.stderr
    line = last_line(proc.stderr)
    assert line.startswith("ftc-gcs: mission rejected: ")
    assert "take-off altitude" in line and "50" in line  # the vehicle's reason, whole
    assert "FENCE_ALT_MAX" in line  # naming the parameter that refuses


def test_refused_parameter_is_one_line_with_the_vehicles_reason(tmp_path: Path) -> None:
    proc = subprocess.run(
        gcs_command("fly", "--spawn-vehicle", "--speedup", "10", "--param", "ATT_CTRL=7",
                    "--quiet", "--tlog", str(tmp_path / "f.tlog")),
        cwd=ROOT, capture_output=True, text=True, timeout=WALL_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 4, proc.stdout + proc.stderr
    line = last_line(proc.stderr)
    assert line.startswith("ftc-gcs: command refused: parameter ATT_CTRL = 7 refused, still ")
    assert line.endswith(": ATT_CTRL: 7 outside 0..1")  # the vehicle's reason, whole


def test_vehicle_killed_mid_flight_keeps_the_records(tmp_path: Path) -> None:
    port = free_port()
    tlog = tmp_path / "f.tlog"
    events = tmp_path / "f.events.log"
    vehicle = SpawnedVehicle(VehicleSpec(speedup=10, seed=1), port,
                             log_path=tmp_path / "vehicle.log").start()
    try:
        gcs = subprocess.Popen(
            gcs_command("fly", "--connect", f"udpin:127.0.0.1:{port}", "--faults", "table7.3",
                        "--connect-timeout", f"{BOOT_S:g}", "--link-timeout", "3", "--quiet",
                        "--tlog", str(tlog)),
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            stdin=subprocess.DEVNULL)
        deadline = time.monotonic() + WALL_S
        # kill it once the first fault (mission +22 s) has taken effect
        while time.monotonic() < deadline and gcs.poll() is None:
            if events.exists() and "motor 3 took effect" in events.read_text():
                break
            time.sleep(0.05)
        vehicle.kill()
        out, err = gcs.communicate(timeout=WALL_S)
    finally:
        vehicle.stop()
    assert gcs.returncode == 6, out + err
    line = last_line(err)
    assert line.startswith("ftc-gcs: timeout: no telemetry from the vehicle for ")
    assert "(link lost)" in line
    # everything up to the kill is there, readable by pymavlink and by the report
    log = mavutil.mavlink_connection(str(tlog))
    n_sim_state = 0
    while log.recv_match(type="SIM_STATE") is not None:
        n_sim_state += 1
    log.close()
    assert n_sim_state > 2000  # 100 Hz for the 22 s flown
    report = analyze_tlog(tlog)
    assert report.vehicle_time_s is not None and report.vehicle_time_s >= 22.0
    assert [i.motor for i in report.injections] == [3]
    text = events.read_text()
    assert "motor 3 took effect" in text and "link lost" in text
