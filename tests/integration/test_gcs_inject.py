"""Both injection routes, parameter faults and a crash, on a short hover mission.

``--inject-via command`` sends MAV_CMD_INJECT_FAILURE (unit MOTOR, type WRONG, instance =
motor) after setting SIM_FI_LOE, as MAVSDK's Failure plugin would, with param4 = the simulated
time it is due (the vehicle schedules it); ``param`` sets SIM_MOTn_LOE when due; a parameter
fault sets a SIM_* parameter at its time; a total loss of one motor in flight ends in a crash
(exit 1).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from gcs.faults import FaultSpec
from gcs.mavlink import mavlink2
from gcs.mission import WireItem

M = mavlink2
ROOT = Path(__file__).resolve().parents[2]
WALL_S = 300.0  # s: one short flight on a loaded two-core machine

pytestmark = pytest.mark.slow

HOVER = [  # climb to 0.6 m, hold 8 s, land: about 20 s of simulated time
    WireItem(command=M.MAV_CMD_DO_CHANGE_SPEED, params=(2.0, 0.3, -1.0, 0.0)),
    WireItem(command=M.MAV_CMD_NAV_TAKEOFF, frame=M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
             params=(0.0, 0.0, 0.0, float("nan")), z=0.6),
    WireItem(command=M.MAV_CMD_NAV_WAYPOINT, frame=M.MAV_FRAME_LOCAL_NED,
             params=(8.0, 0.0, 0.0, float("nan")), z=-0.6),
    WireItem(command=M.MAV_CMD_NAV_LAND, frame=M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
             params=(0.0, 0.0, 0.0, float("nan"))),
]


# the parameter fault travels as a PARAM_SET sent when due: at 2x a loaded machine's delay
# costs a fifth of the simulated time, and the mass change is still seen before the landing
@pytest.mark.vehicle(speedup=2, seed=2)
def test_inject_failure_command_and_a_parameter_fault(vehicle_link) -> None:  # type: ignore[no-untyped-def]
    outcome = vehicle_link.fly(
        mission=HOVER, inject_via="command",
        faults=[FaultSpec(motor=2, loe=0.25, at_s=6.0),
                FaultSpec(param="SIM_MASS_DROP", value=0.3, at_s=8.0)])
    assert outcome.error is None, outcome.error
    motor_fault, mass_drop = outcome.timing
    assert motor_fault.error_s is not None and abs(motor_fault.error_s) <= 0.1  # s simulated
    assert mass_drop.fault.param == "SIM_MASS_DROP"
    report = outcome.report
    injections = [(i.motor, i.loe) for i in report.injections]
    assert injections == [(2, 0.25)]
    # scheduled on the vehicle's clock: announced when it starts, on the planned tick
    assert report.injections[0].text == "fault started: motor 2: loe 25 % (step)"
    assert motor_fault.error_s == pytest.approx(0.0, abs=1e-9)
    assert [d.motor for d in report.detections if d.kind in ("loe", "motor_lost")] == [2]
    # the 0.3 kg drop is reported as a mass change (kg, negative: lighter), not a motor fault
    (mass,) = [d for d in report.detections if d.kind == "mass_change"]
    assert mass.record.magnitude == pytest.approx(-0.3, abs=0.05)
    assert report.params["SIM_MASS_DROP"] == pytest.approx(0.3)


# at 2x a loaded machine's delay costs a fifth of the simulated time it costs at 10x
@pytest.mark.vehicle(speedup=2, seed=2)
def test_a_parameter_injection_takes_effect_on_arrival(vehicle_link) -> None:  # type: ignore[no-untyped-def]
    outcome = vehicle_link.fly(mission=HOVER, inject_via="param",
                               faults=[FaultSpec(motor=2, loe=0.25, at_s=6.0)])
    assert outcome.error is None, outcome.error
    (timing,) = outcome.timing
    # sent ahead by the measured lag: lands within a few ticks of its target, load permitting
    assert timing.error_s is not None and abs(timing.error_s) <= 1.0  # s simulated
    assert outcome.report.injections[0].text == "fault started: motor 2: loe 25 % (step)"


def test_total_loss_of_a_motor_is_a_crash(tmp_path: Path) -> None:
    mission = tmp_path / "high.toml"
    # 3 m up: a fall from there lands at ~7 m/s, beyond the airframe's 3 m/s crash speed
    mission.write_text('[[items]]\ncommand = "change_speed"\nspeed_type = "climb"\n'
                       'speed_m_s = 1.0\n'
                       '[[items]]\ncommand = "takeoff"\nalt_m = 3.0\n'
                       '[[items]]\ncommand = "waypoint"\npos_ned = [0, 0, -3.0]\nhold_s = 10\n'
                       '[[items]]\ncommand = "land"\n')
    proc = subprocess.run(
        [sys.executable, "-m", "gcs", "fly", "--spawn-vehicle", "--speedup", "10",
         "--mission", str(mission), "--fault", "1:1.0@8", "--max-flight-s", "60", "--quiet",
         "--tlog", str(tmp_path / "f.tlog"), "--json", str(tmp_path / "f.json")],
        cwd=ROOT, capture_output=True, text=True, timeout=WALL_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("ftc-gcs: crash: outcome: crashed at ")
    assert "CRASHED" in proc.stdout  # the table of what was flown is still printed


def test_a_lost_parameter_injection_is_sent_again(tmp_path: Path) -> None:
    # the first two PARAM_SETs of SIM_MOT2_LOE never reach the vehicle: without a resend the
    # fault would never be injected and the vehicle would hover healthy
    from lossy_proxy import LossyProxy
    from vehicle_harness import VehicleProcess, write_hover_mission

    mission = write_hover_mission(tmp_path / "hover.toml")  # climb 2 s, hold 4 s, land
    with LossyProxy(0.0, 1, drop_first=b"SIM_MOT2_LOE", drop_times=2) as proxy:
        vehicle = VehicleProcess(["--speedup", "10", "--seed", "2", "--start-paused",
                                  "--out", f"127.0.0.1:{proxy.vehicle_port}"])
        try:
            proc = subprocess.run(
                [sys.executable, "-m", "gcs", "fly", "--connect",
                 f"udpout:127.0.0.1:{proxy.gcs_port}", "--mission", str(mission),
                 "--inject-via", "param", "--fault", "2:0.25@3", "--quiet",
                 "--tlog", str(tmp_path / "f.tlog"), "--json", str(tmp_path / "f.json")],
                cwd=ROOT, capture_output=True, text=True, timeout=WALL_S,
                stdin=subprocess.DEVNULL)
        finally:
            vehicle.stop()
    assert proc.returncode == 0, proc.stdout + proc.stderr[-3000:]
    assert proxy.targeted_left == 0  # both were dropped
    events = (tmp_path / "f.events.log").read_text()
    assert events.count("sending it again") == 2, events
    assert "fault started: motor 2: loe 25 %" in events
