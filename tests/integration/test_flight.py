"""Whole flights of the vehicle process over MAVLink: tracking against the headless runner,
the GCS-loss failsafe under a speed-up, simulator faults found by the autopilot's estimator,
and the command line.
"""

from __future__ import annotations

import math
import signal
import socket
import statistics
import subprocess
import sys
import time

import numpy as np
import pytest
from vehicle_harness import ANSWER_S, ROOT, Gcs, M, mission_item

from fcu.mavlink.geo import geo_to_ned
from fcu.mavlink.port_records import GeoPoint
from flightdata.mission import MissionItem
from flightdata.records import DetectionRecord, FaultRecord, OutcomeRecord, from_wire
from sim.runner import fly
from sim.scenario import load_scenario

GUIDED, AUTO, LAND = 4, 3, 9
ACCEPTED = M.MAV_RESULT_ACCEPTED
_SPEED_TYPES = {"ground": 1, "climb": 2, "descent": 3}


def guided_take_off(gcs: Gcs, alt_m: float) -> None:
    """GUIDED, arm, NAV_TAKEOFF to ``alt_m`` and wait for the take-off to complete."""
    assert gcs.set_mode(GUIDED).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    since = gcs.mark()
    assert gcs.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt_m).result == ACCEPTED
    gcs.wait("STATUSTEXT", lambda m: "take-off complete" in m.text, since=since)


def wire_mission(items: tuple[MissionItem, ...]) -> list:
    """Navigator mission items as MISSION_ITEM_INT, local NED (exact for these numbers)."""
    nan = math.nan
    out = [mission_item(0, M.MAV_CMD_NAV_WAYPOINT)]  # home: seq 0, ArduPilot style
    for seq, item in enumerate(items, start=1):
        if item.command == "change_speed":
            out.append(mission_item(seq, M.MAV_CMD_DO_CHANGE_SPEED, frame=M.MAV_FRAME_MISSION,
                                    params=(_SPEED_TYPES[item.speed_type], item.speed_m_s,
                                            -1, 0)))
        elif item.command == "takeoff":
            out.append(mission_item(seq, M.MAV_CMD_NAV_TAKEOFF, z=-item.alt_m,
                                    params=(0, 0, 0, nan)))
        elif item.command == "waypoint":
            assert item.pos_ned is not None
            north, east, down = item.pos_ned
            out.append(mission_item(seq, M.MAV_CMD_NAV_WAYPOINT, x=north, y=east, z=down,
                                    params=(item.hold_s, 0, 0, nan)))
        else:
            assert item.command == "land" and item.pos_ned is None
            out.append(mission_item(seq, M.MAV_CMD_NAV_LAND, frame=M.MAV_FRAME_MISSION,
                                    params=(0, 0, 0, nan)))
    return out


def truth_by_time(gcs: Gcs) -> dict[int, object]:
    """SIM_STATE (which has no time field) keyed by the simulated time it was sent at.

    The endpoint sends every message due in one tick from one snapshot, back to back, so a
    SIM_STATE carries the time of the time-stamped message just before it in the same run
    of consecutive sequence numbers (a gap in the sequence, i.e. a lost packet, breaks it).
    """
    out: dict[int, object] = {}
    time_ms: int | None = None
    last_seq: int | None = None
    for msg in gcs.messages():
        if msg.get_srcComponent() != 1:
            continue
        seq = msg.get_seq()
        if last_seq is not None and seq != (last_seq + 1) % 256:
            time_ms = None
        last_seq = seq
        if hasattr(msg, "time_boot_ms"):
            time_ms = int(msg.time_boot_ms)
        elif msg.get_type() == "SIM_STATE" and time_ms is not None:
            out[time_ms] = msg
    return out


@pytest.mark.slow
def test_thesis_mission_over_mavlink_flies_as_the_headless_runner(start_vehicle,
                                                                   gcs: Gcs) -> None:
    # SIM_STATE carries latitude/longitude as float32 degrees: 0.4 m steps at 35 deg S, but
    # 1e-7 m near (0, 0). Home there makes the truth readable to the micrometre.
    vehicle = start_vehicle("--scenario", "baseline", "--speedup", "10", "--start-paused",
                            "--home", "0,0,0", "--duration", "60", outs=[gcs.port])
    gcs.wait_heartbeat()
    scenario = load_scenario("baseline")
    # The runner's start sequence, over MAVLink, while simulated time holds at 0:
    # load the mission, arm, AUTO, start; then let time run.
    ack, _ = gcs.upload_mission(wire_mission(scenario.mission))
    assert ack.type == M.MAV_MISSION_ACCEPTED
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert gcs.set_mode(AUTO).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_MISSION_START).result == ACCEPTED
    assert gcs.param_set("SIM_PAUSE", 0).param_value == 0.0
    deadline = time.monotonic() + 180.0
    while vehicle.proc.poll() is None and time.monotonic() < deadline:
        gcs.pump(0.1)
    while gcs.pump(0.3):
        pass
    assert vehicle.proc.returncode == 0, "the vehicle did not stop after --duration 60"

    truth = truth_by_time(gcs)
    targets = {int(m.time_boot_ms): m for m in gcs.messages("POSITION_TARGET_LOCAL_NED")}
    headless = fly(scenario)
    log = headless.log
    tick_of = {int(round(t * 1000)): k for k, t in enumerate(log.time_s)}
    origin = GeoPoint(0.0, 0.0, 0.0)
    times = sorted(t for t in truth if t in tick_of)
    assert len(times) >= 550  # SIM_STATE at 10 Hz over 60 s, a few lost at most
    pos = np.array([geo_to_ned(truth[t].lat, truth[t].lon, truth[t].alt, origin)
                    for t in times])
    vel = np.array([[truth[t].vn, truth[t].ve, truth[t].vd] for t in times])
    ticks = [tick_of[t] for t in times]
    # Same seed, same configuration, same command ticks: the same trajectory, to the float32
    # resolution of SIM_STATE (positions ~0.6 m, velocities < 0.2 m/s).
    np.testing.assert_allclose(pos, log.pos_ned[ticks], rtol=0, atol=2e-6)
    headless_vel = np.gradient(log.pos_ned[:, :], log.time_s, axis=0)[ticks]
    assert np.max(np.abs(vel - headless_vel)) < 0.05  # finite differences of 10 ms ticks
    # Tracking RMS over the flight, from MAVLink alone (truth vs POSITION_TARGET_LOCAL_NED),
    # against the runner's metric (taken at 100 Hz rather than 10 Hz).
    flying = [(p, targets[t]) for p, t in zip(pos, times, strict=True)
              if t in targets and p[2] < -1e-3]
    assert len(flying) >= 450
    err = np.array([p - [m.x, m.y, m.z] for p, m in flying])
    rms = np.sqrt(np.mean(err**2, axis=0))
    expected = [headless.metrics["rms"][axis] for axis in ("x", "y", "z")]
    np.testing.assert_allclose(rms, expected, rtol=0.2)
    reached = [m.seq for m in gcs.messages("MISSION_ITEM_REACHED")]
    assert reached == list(range(1, len(scenario.mission) + 1))


@pytest.mark.slow
def test_gcs_loss_failsafe_lands_on_wall_time_only(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", "20", outs=[gcs.port])
    gcs.wait_heartbeat()
    gcs.auto_heartbeat(1.0)  # 1 Hz of wall time: 20 s of simulated time between two
    assert gcs.param_set("FS_GCS_TIMEOUT", 2.0).param_value == 2.0
    guided_take_off(gcs, 1.0)
    # Hover for 4 s of wall time (80 s simulated) with heartbeats every wall second.
    hover = gcs.collect(4.0)
    assert not [m.text for m in hover if m.get_type() == "STATUSTEXT" and "failsafe" in
                m.text.lower()]
    assert {m.custom_mode for m in hover if m.get_type() == "HEARTBEAT"} == {GUIDED}
    # Silence: the failsafe lands after FS_GCS_TIMEOUT of wall time.
    gcs.auto_heartbeat(0.0)
    since = gcs.mark()
    text = gcs.wait("STATUSTEXT", lambda m: "GCS failsafe" in m.text, timeout_s=15.0)
    silent_s = time.monotonic() - gcs.last_heartbeat_s
    assert "LAND" in text.text
    assert 2.0 <= silent_s <= 10.0  # FS_GCS_TIMEOUT of wall time (plus loop latency)
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == LAND
             and m.system_status == M.MAV_STATE_CRITICAL, since=since)
    gcs.wait("HEARTBEAT", lambda m: m.get_srcComponent() == 1
             and not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED, timeout_s=30.0, since=since)
    # landed and disarmed: the failsafe is over, and arming works again once the GCS is back
    gcs.wait("STATUSTEXT", lambda m: "GCS failsafe cleared" in m.text, since=since)
    gcs.auto_heartbeat(1.0)
    gcs.heartbeat()
    assert gcs.set_mode(GUIDED).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED


@pytest.mark.slow
def test_simulator_fault_is_found_by_the_autopilot(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", "10", outs=[gcs.port])
    gcs.wait_heartbeat()
    guided_take_off(gcs, 1.0)
    before = [m for m in gcs.collect(1.0) if m.get_type() == "SERVO_OUTPUT_RAW"]
    # ArduPilot style: motor 1 (front) at 70 % thrust
    since = gcs.mark()
    assert gcs.param_set("SIM_ENGINE_MUL", 0.7).param_value == pytest.approx(0.7)
    assert gcs.param_set("SIM_ENGINE_FAIL", 1).param_value == 1.0
    gcs.wait("STATUSTEXT", lambda m: "SIM" in m.text and "loe 30" in m.text, since=since)
    detected = gcs.wait("STATUSTEXT", lambda m: "motor 1 lost" in m.text, timeout_s=30.0,
                        since=since)
    assert detected.severity == M.MAV_SEVERITY_CRITICAL
    after = [m for m in gcs.collect(1.0) if m.get_type() == "SERVO_OUTPUT_RAW"]
    loe1 = [m.value for m in gcs.messages("NAMED_VALUE_FLOAT", since=since) if m.name == "LOE1"]

    def mean_diff(msgs: list) -> float:
        return statistics.fmean(m.servo1_raw - m.servo2_raw for m in msgs)

    # The controller asks motor 1 for 1/0.7 of its hover command: ~+170 us at 1400 us.
    assert abs(mean_diff(before)) < 40
    assert mean_diff(after) > 100
    assert loe1[-1] == pytest.approx(0.3, abs=0.1)
    sim = gcs.wait("SIM_STATE")
    assert -sim.vd == pytest.approx(0.0, abs=0.3)  # still holding altitude (truth)
    heartbeat = gcs.wait_heartbeat(ANSWER_S)
    assert heartbeat.system_status == M.MAV_STATE_CRITICAL  # a detected fault is active


def _records(messages: list) -> list:
    """The structured records (DEBUG_FLOAT_ARRAY FTC_REC) among messages, first copies."""
    seen: dict[int, object] = {}
    for msg in messages:
        if msg.get_type() == "DEBUG_FLOAT_ARRAY" and msg.name == "FTC_REC":
            seq, record = from_wire(int(msg.array_id), msg.data, int(msg.time_usec) * 1e-6)
            seen.setdefault(seq, record)
    return list(seen.values())


@pytest.mark.slow
def test_a_crash_disarms_within_3_s_and_a_lost_motor_blocks_arming(start_vehicle,
                                                                     gcs: Gcs) -> None:
    start_vehicle("--speedup", "5", outs=[gcs.port])
    gcs.auto_heartbeat(1.0)
    gcs.wait_heartbeat()
    guided_take_off(gcs, 1.0)
    # ArduPilot style: motor 1 (front) dead
    since = gcs.mark()
    assert gcs.param_set("SIM_ENGINE_MUL", 0.0).param_value == 0.0
    assert gcs.param_set("SIM_ENGINE_FAIL", 1).param_value == 1.0
    disarmed = gcs.wait("HEARTBEAT", lambda m: (m.get_srcSystem(), m.get_srcComponent())
                        == gcs.target and not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED,
                        timeout_s=120.0, since=since)
    after = gcs.messages(since=since)
    at_disarm = after.index(disarmed)
    disarm_s = max(m.time_boot_ms for m in after[:at_disarm]
                   if m.get_type() == "ATTITUDE") / 1e3
    gcs.collect(2.0)  # the records are repeated: let their copies arrive
    records = _records(gcs.messages(since=since))
    (fault,) = [r for r in records if isinstance(r, FaultRecord) and r.action == "started"]
    outcome = [r for r in records if isinstance(r, OutcomeRecord)]
    assert outcome and outcome[0].kind in ("crashed", "flyaway"), outcome
    assert fault.time_s < outcome[0].time_s <= disarm_s
    assert disarm_s - outcome[0].time_s <= 3.0, (outcome[0], disarm_s)
    motor = [r for r in records
             if isinstance(r, DetectionRecord) and r.kind in ("loe", "motor_lost")]
    assert motor and {r.motor for r in motor} == {1}, motor
    # a motor detected failed: arming is refused, with the reason
    since = gcs.mark()
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_DENIED
    reason = gcs.wait("STATUSTEXT", lambda m: "motor 1" in m.text, since=since)
    assert "arm" in reason.text.lower(), reason.text


@pytest.mark.slow
def test_guided_targets_reposition_and_rtl_under_another_sysid(start_vehicle) -> None:
    gcs = Gcs(target=(7, 1))
    try:
        start_vehicle("--speedup", "20", "--sysid", "7", outs=[gcs.port])
        heartbeat = gcs.wait_heartbeat()
        assert (heartbeat.type, heartbeat.autopilot) == (M.MAV_TYPE_QUADROTOR,
                                                         M.MAV_AUTOPILOT_ARDUPILOTMEGA)
        home = gcs.wait("HOME_POSITION")
        origin = GeoPoint(home.latitude / 1e7, home.longitude / 1e7, home.altitude / 1e3)

        def truth_ned() -> np.ndarray:
            sim = gcs.wait("SIM_STATE")
            return geo_to_ned(sim.lat_int / 1e7, sim.lon_int / 1e7, sim.alt, origin)

        since = gcs.mark()  # a command for system 1 is not for this vehicle
        gcs.send(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0,
                                                M.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0,
                                                0, 0, 0))
        assert gcs.set_mode(GUIDED).result == ACCEPTED
        assert not [m for m in gcs.messages("COMMAND_ACK", since=since)
                    if m.command == M.MAV_CMD_REQUEST_MESSAGE]
        assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
        since = gcs.mark()
        assert gcs.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 1.0).result == ACCEPTED
        gcs.wait("STATUSTEXT", lambda m: "take-off complete" in m.text, since=since)
        # SET_POSITION_TARGET_LOCAL_NED, position only
        since = gcs.mark()
        gcs.send(M.MAVLink_set_position_target_local_ned_message(
            0, 7, 1, M.MAV_FRAME_LOCAL_NED, 0b0000_1101_1111_1000, 1.5, -1.0, -1.2, 0, 0, 0,
            0, 0, 0, 0, 0))
        gcs.wait("STATUSTEXT", lambda m: "reached guided target" in m.text, timeout_s=30.0,
                 since=since)
        # 1 cm: SIM_STATE's integer latitude/longitude resolution; 0.1 m: WPNAV_RADIUS
        np.testing.assert_allclose(truth_ned(), [1.5, -1.0, -1.2], atol=0.1)
        # DO_REPOSITION as COMMAND_INT, relative altitude, ground speed 0.5 m/s
        north_deg, east_deg = geo_to_ned(origin.lat_deg + 1e-5, origin.lon_deg + 1e-5, 0,
                                         origin)[:2] / 1e-5
        lat, lon = origin.lat_deg + 0.5 / north_deg, origin.lon_deg + 0.5 / east_deg
        since = gcs.mark()
        gcs.send(M.MAVLink_command_int_message(
            7, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_DO_REPOSITION, 0, 0, 0.5, 0,
            0, math.nan, round(lat * 1e7), round(lon * 1e7), 1.0))
        ack = gcs.wait("COMMAND_ACK", lambda m: m.command == M.MAV_CMD_DO_REPOSITION,
                       since=since)
        assert ack.result == ACCEPTED
        gcs.wait("STATUSTEXT", lambda m: "reached guided target" in m.text, timeout_s=30.0,
                 since=since)
        np.testing.assert_allclose(truth_ned(), [0.5, 0.5, -1.0], atol=0.1)
        # RTL: home at 1 m (RTL_ALT 100 cm), hold, land, disarm
        since = gcs.mark()
        assert gcs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == ACCEPTED
        gcs.wait_mode(6)
        gcs.wait("STATUSTEXT", lambda m: m.text == "landed", timeout_s=60.0, since=since)
        gcs.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 7
                 and not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED, timeout_s=30.0,
                 since=since)
        np.testing.assert_allclose(truth_ned(), [0.0, 0.0, 0.0], atol=0.1)
    finally:
        gcs.close()


def test_bad_options_print_one_line_and_exit_2() -> None:
    for args in (["--speedup", "-3"], ["--bind", "localhost"], ["--home", "91,0,0"],
                 ["--scenario", "no_such_scenario"], ["--sysid", "0"], ["--frobnicate"]):
        done = subprocess.run([sys.executable, "-m", "sim", *args], cwd=ROOT, text=True,
                              capture_output=True, timeout=120)
        assert done.returncode == 2, (args, done.stderr)
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("ftc-vehicle: error:"), done.stderr
        assert "Traceback" not in done.stderr and done.stdout == ""


def test_duration_stops_the_vehicle_by_itself(start_vehicle, gcs: Gcs) -> None:
    vehicle = start_vehicle("--speedup", "20", "--duration", "3", outs=[gcs.port])
    assert vehicle.proc.wait(60) == 0
    vehicle.stop()  # joins the output readers
    assert "stopped at 3.00 s simulated" in vehicle.lines[-1], vehicle.lines


def test_ctrl_c_stops_the_vehicle_cleanly(start_vehicle, gcs: Gcs) -> None:
    vehicle = start_vehicle("--speedup", "5", outs=[gcs.port])
    gcs.wait_heartbeat()
    vehicle.proc.send_signal(signal.SIGINT)
    assert vehicle.proc.wait(30) == 0
    vehicle.stop()
    assert "stopped at" in vehicle.lines[-1] and not vehicle.stderr_text, vehicle.stderr_text
    # the socket is closed: the vehicle's port can be bound again at once
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as again:
        again.bind(vehicle.address)
