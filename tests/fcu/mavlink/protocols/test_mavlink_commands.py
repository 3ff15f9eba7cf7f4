"""COMMAND_LONG / COMMAND_INT / SET_MODE / set-points over loopback UDP with pymavlink."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from mavlink_testkit import ORIGIN, WAIT_S, Gcs, VehicleThread, linked, started
from numpy.testing import assert_allclose

from fcu.mavlink.geo import ned_to_geo
from fcu.mavlink.transport.codec import mavlink2
from fcu.navigation.modes import Mode

M = mavlink2
NAN = math.nan
ACCEPTED, DENIED, UNSUPPORTED = M.MAV_RESULT_ACCEPTED, M.MAV_RESULT_DENIED, M.MAV_RESULT_UNSUPPORTED


@pytest.fixture
def fly() -> Iterator[tuple[Gcs, VehicleThread]]:
    with linked(speedup=5.0) as pair:
        yield pair


def calls(vehicle: VehicleThread, name: str) -> list[tuple[Any, ...]]:
    with vehicle.lock:
        return [c for c in vehicle.vehicle.calls if c[0] == name]


def called(vehicle: VehicleThread, name: str, n: int) -> tuple[Any, ...]:
    """The ``n``-th call (1-based) of ``name``, waited for: a set-point gets no answer."""
    deadline = time.monotonic() + WAIT_S
    while len(made := calls(vehicle, name)) < n:
        assert time.monotonic() < deadline, f"no call {n} of {name}"
        time.sleep(0.01)
    return made[n - 1]


# (command, params, result) from a fresh vehicle: disarmed, STABILIZE, home set, no mission.
FRESH_CASES = [
    (M.MAV_CMD_COMPONENT_ARM_DISARM, (1,), ACCEPTED),
    (M.MAV_CMD_COMPONENT_ARM_DISARM, (0,), ACCEPTED),
    (M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, 2.0), DENIED),  # not GUIDED and armed
    (M.MAV_CMD_NAV_LAND, (), ACCEPTED),
    (M.MAV_CMD_NAV_RETURN_TO_LAUNCH, (), ACCEPTED),
    (M.MAV_CMD_DO_SET_MODE, (1, 4), ACCEPTED),
    (M.MAV_CMD_DO_SET_MODE, (1, 13), DENIED),  # SPORT: not implemented by the vehicle
    (M.MAV_CMD_MISSION_START, (0, 0), DENIED),  # no mission
    (M.MAV_CMD_SET_MESSAGE_INTERVAL, (M.MAVLINK_MSG_ID_ATTITUDE, 100_000), ACCEPTED),
    (M.MAV_CMD_REQUEST_MESSAGE, (M.MAVLINK_MSG_ID_AUTOPILOT_VERSION,), ACCEPTED),
    (M.MAV_CMD_REQUEST_MESSAGE, (300,), UNSUPPORTED),  # PROTOCOL_VERSION,
    (M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, (1,), ACCEPTED),
    (M.MAV_CMD_DO_REPOSITION, (-1, 0, 0, NAN, ORIGIN.lat_deg, ORIGIN.lon_deg, 110), DENIED),
    (M.MAV_CMD_DO_CHANGE_SPEED, (1, 3.0, -1), ACCEPTED),
    (M.MAV_CMD_DO_SET_HOME, (1,), ACCEPTED),
    (M.MAV_CMD_DO_SET_MISSION_CURRENT, (1,), DENIED),  # no mission
    (M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (1,), ACCEPTED),
    (M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (2,), UNSUPPORTED),  # shutdown
    (M.MAV_CMD_INJECT_FAILURE, (M.FAILURE_UNIT_SYSTEM_MOTOR, M.FAILURE_TYPE_OFF, 2),
     ACCEPTED),
    (M.MAV_CMD_INJECT_FAILURE, (M.FAILURE_UNIT_SENSOR_BARO, 8, 0),  # 8 DRIFT
     UNSUPPORTED),  # the injector does not simulate it
    (M.MAV_CMD_GET_HOME_POSITION, (), ACCEPTED),
    (M.MAV_CMD_GET_MESSAGE_INTERVAL, (M.MAVLINK_MSG_ID_ATTITUDE,), ACCEPTED),
    (M.MAV_CMD_SET_MESSAGE_INTERVAL, (291, 100_000), UNSUPPORTED),  # ESC_STATUS: not ours
    (M.MAV_CMD_PREFLIGHT_CALIBRATION, (1,), ACCEPTED),  # gyro, simulated
    (31337, (), UNSUPPORTED),  # unknown command
    (M.MAV_CMD_DO_FLIGHTTERMINATION, (1,), UNSUPPORTED),  # known to MAVLink, not to us
]


@pytest.mark.parametrize("command, params, result", FRESH_CASES,
                         ids=[f"{c}-{p}" for c, p, _ in FRESH_CASES])
def test_every_command_gets_exactly_one_ack(fly: tuple[Gcs, VehicleThread], command: int,
                                            params: tuple[float, ...], result: int) -> None:
    gcs, _ = fly
    ack = gcs.ack(command, *params)  # asserts there is exactly one
    assert ack.result == result
    assert (ack.target_system, ack.target_component) == (gcs.sysid, gcs.compid)


NAN_CASES = [
    (M.MAV_CMD_COMPONENT_ARM_DISARM, (NAN,)),
    (M.MAV_CMD_COMPONENT_ARM_DISARM, (2,)),
    (M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, NAN)),
    (M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, -5.0)),
    (M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, 1e9)),
    (M.MAV_CMD_DO_SET_MODE, (1, NAN)),
    (M.MAV_CMD_DO_SET_MODE, (NAN, 4)),
    (M.MAV_CMD_DO_SET_MODE, (0, 4)),  # no custom-mode flag
    (M.MAV_CMD_DO_SET_MODE, (1, 4.5)),
    (M.MAV_CMD_SET_MESSAGE_INTERVAL, (NAN, 1000)),
    (M.MAV_CMD_SET_MESSAGE_INTERVAL, (M.MAVLINK_MSG_ID_ATTITUDE, NAN)),
    (M.MAV_CMD_SET_MESSAGE_INTERVAL, (M.MAVLINK_MSG_ID_HEARTBEAT, -1)),  # never stopped
    (M.MAV_CMD_REQUEST_MESSAGE, (NAN,)),
    (M.MAV_CMD_DO_CHANGE_SPEED, (1, NAN)),
    (M.MAV_CMD_DO_CHANGE_SPEED, (1, 500.0)),
    (M.MAV_CMD_DO_SET_HOME, (0, 0, 0, 0, NAN, 29.0, 100.0)),
    (M.MAV_CMD_DO_SET_HOME, (0, 0, 0, 0, 95.0, 29.0, 100.0)),
    (M.MAV_CMD_DO_REPOSITION, (-1, 0, 0, 0, 200.0, 29.0, 100.0)),
    (M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (NAN,)),
    (M.MAV_CMD_INJECT_FAILURE, (NAN, 1, 0)),
    (M.MAV_CMD_INJECT_FAILURE, (77, 1, 0)),  # no such failure unit
    (M.MAV_CMD_INJECT_FAILURE, (101, 9, 0)),  # no such failure type
    (M.MAV_CMD_INJECT_FAILURE, (101, 1, -1)),
]


@pytest.mark.parametrize("command, params", NAN_CASES,
                         ids=[f"{c}-{p}" for c, p in NAN_CASES])
def test_bad_parameters_are_denied_with_a_reason(fly: tuple[Gcs, VehicleThread], command: int,
                                                 params: tuple[float, ...]) -> None:
    gcs, vehicle = fly
    gcs.command_long(command, *params)
    got = gcs.gather({"COMMAND_ACK": lambda m: m.command == command,
                      "STATUSTEXT": lambda m: True})
    assert got["COMMAND_ACK"].result == DENIED
    assert got["STATUSTEXT"].severity <= M.MAV_SEVERITY_WARNING
    assert vehicle.endpoint.stats.handler_errors == 0


def test_commands_for_another_system_are_not_answered(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    gcs.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, target_system=7)
    assert gcs.acks(M.MAV_CMD_COMPONENT_ARM_DISARM, timeout_s=1.0) == []
    assert not calls(vehicle, "arm")


def test_guided_takeoff_goto_land(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    assert gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    hb = gcs.recv("HEARTBEAT", condition=lambda m: m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
    assert hb is not None and hb.custom_mode == Mode.GUIDED
    assert hb.base_mode & M.MAV_MODE_FLAG_GUIDED_ENABLED
    assert gcs.ack(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 2.0).result == ACCEPTED
    # 2 m at 2 m/s and 5x: well under a wall second; relative_alt in mm.
    up = gcs.recv("GLOBAL_POSITION_INT", 2 * WAIT_S, lambda m: m.relative_alt > 1990)
    assert up is not None
    in_air = gcs.recv("EXTENDED_SYS_STATE",
                      condition=lambda m: m.landed_state == M.MAV_LANDED_STATE_IN_AIR)
    assert in_air is not None and in_air.vtol_state == M.MAV_VTOL_STATE_MC
    # DO_REPOSITION as MAVSDK sends it: COMMAND_INT, degE7, AMSL altitude.
    lat, lon, alt = ned_to_geo(np.array([4.0, -3.0, -2.0]), ORIGIN)
    gcs.command_int(M.MAV_CMD_DO_REPOSITION, M.MAV_FRAME_GLOBAL_INT, (-1, 1, 0, 90.0),
                    round(lat * 1e7), round(lon * 1e7), alt)
    acks = gcs.acks(M.MAV_CMD_DO_REPOSITION)
    assert [a.result for a in acks] == [ACCEPTED]
    (goto,) = calls(vehicle, "goto")
    assert_allclose(goto[1], [4.0, -3.0, -2.0], atol=0.02)  # degE7 quantisation ~1 cm
    assert goto[2] == pytest.approx(math.pi / 2)
    there = gcs.recv("LOCAL_POSITION_NED", 2 * WAIT_S,
                     lambda m: abs(m.x - 4.0) < 0.05 and abs(m.y + 3.0) < 0.05)
    assert there is not None
    assert gcs.ack(M.MAV_CMD_NAV_LAND).result == ACCEPTED
    landed = gcs.recv("HEARTBEAT", 2 * WAIT_S, lambda m: m.custom_mode == Mode.LAND
                      and not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
    assert landed is not None


def test_arm_refused_in_land_then_forced(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    assert gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.LAND).result == ACCEPTED
    gcs.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    got = gcs.gather({"COMMAND_ACK": lambda m: m.command == M.MAV_CMD_COMPONENT_ARM_DISARM,
                      "STATUSTEXT": lambda m: "armable" in m.text})
    assert got["COMMAND_ACK"].result == DENIED and "STATUSTEXT" in got
    assert gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196).result == ACCEPTED
    assert calls(vehicle, "arm") == [("arm", False), ("arm", True)]


def test_run_prearm_checks_says_why_arming_would_be_refused(
        fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    assert gcs.ack(M.MAV_CMD_RUN_PREARM_CHECKS).result == ACCEPTED  # armable: no text
    assert gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.LAND).result == ACCEPTED
    gcs.command_long(M.MAV_CMD_RUN_PREARM_CHECKS)
    got = gcs.gather({"COMMAND_ACK": lambda m: m.command == M.MAV_CMD_RUN_PREARM_CHECKS,
                      "STATUSTEXT": lambda m: m.text.startswith("PreArm: ")})
    assert got["COMMAND_ACK"].result == ACCEPTED  # as ArduPilot: the checks ran
    assert "not armable" in got["STATUSTEXT"].text  # the reason arming would give
    assert calls(vehicle, "arm") == []  # nothing armed


def test_legacy_set_mode_is_acknowledged_and_confirmed_by_heartbeat(
        fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, _ = fly
    gcs.mav.set_mode_send(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, Mode.LOITER)
    acks = gcs.acks(M.MAVLINK_MSG_ID_SET_MODE)
    assert [a.result for a in acks] == [ACCEPTED]
    assert gcs.recv("HEARTBEAT", condition=lambda m: m.custom_mode == Mode.LOITER)
    gcs.mav.set_mode_send(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 13)  # SPORT: refused
    assert [a.result for a in gcs.acks(M.MAVLINK_MSG_ID_SET_MODE)] == [DENIED]


def test_request_message_autopilot_version_and_home(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, _ = fly
    gcs.command_long(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    got = gcs.gather({"COMMAND_ACK": lambda m: m.command == M.MAV_CMD_REQUEST_MESSAGE,
                      "AUTOPILOT_VERSION": lambda m: True})
    assert got["COMMAND_ACK"].result == ACCEPTED
    caps = got["AUTOPILOT_VERSION"].capabilities
    assert caps & M.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    assert caps & M.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    gcs.command_long(M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1)
    assert gcs.recv("AUTOPILOT_VERSION") is not None
    gcs.command_long(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
    got = gcs.gather({"COMMAND_ACK": lambda m: m.command == M.MAV_CMD_REQUEST_MESSAGE,
                      "HOME_POSITION": lambda m: True})
    assert got["COMMAND_ACK"].result == ACCEPTED
    assert got["HOME_POSITION"].latitude == round(ORIGIN.lat_deg * 1e7)


def test_home_not_set_is_temporarily_rejected(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    with vehicle.lock:
        vehicle.vehicle.home_pos_ned = None
    ack = gcs.ack(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
    assert ack.result == M.MAV_RESULT_TEMPORARILY_REJECTED


def test_inject_failure_reaches_the_injector(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    assert gcs.ack(M.MAV_CMD_INJECT_FAILURE, 101, 4, 3).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_INJECT_FAILURE, 101, 0, 0).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_INJECT_FAILURE, 101, 1, 9).result == DENIED  # no motor 9
    assert vehicle.injector is not None
    assert vehicle.injector.calls == [(101, 4, 3), (101, 0, 0), (101, 1, 9)]
    assert vehicle.injector.times == [None, None, None]  # param4 = 0: now


def test_inject_failure_param4_is_the_simulated_time_of_the_injection(
        fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    assert gcs.ack(M.MAV_CMD_INJECT_FAILURE, 101, 4, 3, 22.5).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_INJECT_FAILURE, 101, 4, 3, NAN).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_INJECT_FAILURE, 101, 4, 3, -1.0).result == ACCEPTED
    assert vehicle.injector is not None
    assert vehicle.injector.times == [22.5, None, None]  # NaN and negative: now


def test_inject_failure_without_an_injector_is_unsupported() -> None:
    with Gcs() as gcs:
        vehicle = started(gcs, injector=False)
        try:
            assert gcs.ack(M.MAV_CMD_INJECT_FAILURE, 101, 1, 1).result == UNSUPPORTED
        finally:
            vehicle.stop()


def test_reboot_refused_when_armed(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    assert gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1).result == DENIED
    assert gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1).result == ACCEPTED
    assert vehicle.vehicle.reboots == 1
    assert gcs.recv("HEARTBEAT") is not None  # still talking after the reboot


def test_set_home_here_and_elsewhere(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    lat, lon, alt = ned_to_geo(np.array([10.0, 20.0, -1.0]), ORIGIN)
    # COMMAND_INT: degE7, exact to about a centimetre.
    gcs.command_int(M.MAV_CMD_DO_SET_HOME, M.MAV_FRAME_GLOBAL_INT, (0,), round(lat * 1e7),
                    round(lon * 1e7), alt)
    assert [a.result for a in gcs.acks(M.MAV_CMD_DO_SET_HOME)] == [ACCEPTED]
    home = gcs.recv("HOME_POSITION", 3 * WAIT_S, lambda m: abs(m.x - 10.0) < 0.02)
    assert home is not None and home.y == pytest.approx(20.0, abs=0.02)
    assert home.z == pytest.approx(-1.0, abs=1e-3)
    # COMMAND_LONG carries degrees as float32: ~4e-6 deg, i.e. within half a metre.
    lat, lon, alt = ned_to_geo(np.array([-30.0, 5.0, 0.0]), ORIGIN)
    assert gcs.ack(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat, lon, alt).result == ACCEPTED
    assert_allclose(calls(vehicle, "set_home")[-1][1], [-30.0, 5.0, 0.0], atol=0.5)
    assert gcs.ack(M.MAV_CMD_DO_SET_HOME, 1).result == ACCEPTED
    assert calls(vehicle, "set_home")[-1] == ("set_home", None)


def test_change_speed_types(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    assert gcs.ack(M.MAV_CMD_DO_CHANGE_SPEED, 1, 3.5, -1).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_DO_CHANGE_SPEED, 2, 1.0, -1).result == ACCEPTED
    assert gcs.ack(M.MAV_CMD_DO_CHANGE_SPEED, 1, -1, -1).result == ACCEPTED  # no change
    assert calls(vehicle, "change_speed") == [("change_speed", 3.5, "ground"),
                                              ("change_speed", 1.0, "climb")]


def test_set_position_target_local_ned(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED)
    gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    use_pos_yaw = 0b0000_1001_1111_1000  # ignore vel, acc, yaw rate: position + yaw
    gcs.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, use_pos_yaw,
                                               1.0, 2.0, -3.0, 0, 0, 0, 0, 0, 0, 0.5, 0)
    target = gcs.recv("POSITION_TARGET_LOCAL_NED", condition=lambda m: abs(m.x - 1.0) < 1e-6)
    assert target is not None and (target.y, target.z) == (2.0, -3.0)
    goto = calls(vehicle, "goto")[-1]
    assert_allclose(goto[1], [1.0, 2.0, -3.0])
    assert goto[2] == pytest.approx(0.5)
    # velocity only (position ignored), with a yaw rate: handed to set_velocity
    use_vel_rate = 0b0000_0101_1100_0111
    gcs.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, use_vel_rate,
                                               0, 0, 0, 1.0, 0, 0, 0, 0, 0, 0, 0.25)
    _, vel, yaw, yaw_rate, heading_frame = called(vehicle, "set_velocity", 1)
    assert_allclose(vel, [1.0, 0.0, 0.0])
    assert (yaw, yaw_rate, heading_frame) == (None, pytest.approx(0.25), False)
    # in the body frame: kept in the heading frame (it turns with the vehicle)
    gcs.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_BODY_NED, use_vel_rate,
                                               0, 0, 0, 0, 2.0, 0, 0, 0, 0, 0, 0)
    _, vel, _, _, heading_frame = called(vehicle, "set_velocity", 2)
    assert_allclose(vel, [0.0, 2.0, 0.0])
    assert heading_frame
    # NaN position: refused without reaching the vehicle
    n_goto = len(calls(vehicle, "goto"))
    gcs.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, use_pos_yaw,
                                               NAN, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    assert gcs.text(lambda t: "not a number" in t) is not None
    assert len(calls(vehicle, "goto")) == n_goto


def test_set_attitude_target_hands_euler_angles_and_thrust_over(
        fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    roll, yaw = math.radians(30.0), math.radians(90.0)
    q = [math.cos(yaw / 2) * math.cos(roll / 2), math.cos(yaw / 2) * math.sin(roll / 2),
         math.sin(yaw / 2) * math.sin(roll / 2), math.sin(yaw / 2) * math.cos(roll / 2)]
    attitude_and_thrust = 0b0000_0111  # body rates ignored
    gcs.mav.set_attitude_target_send(0, 1, 1, attitude_and_thrust, q, 0, 0, 0, 0.7)
    _, roll_rad, pitch_rad, yaw_rad, thrust = called(vehicle, "set_attitude", 1)
    assert (roll_rad, pitch_rad, yaw_rad) == (pytest.approx(roll), pytest.approx(0.0, abs=1e-9),
                                              pytest.approx(yaw))
    assert thrust == pytest.approx(0.7)
    # body rates alone, a thrust outside [0, 1]: refused, said, not handed over
    gcs.mav.set_attitude_target_send(0, 1, 1, 128, [1, 0, 0, 0], 0.1, 0, 0, 0.5)
    assert gcs.text(lambda t: "body rates alone not supported" in t) is not None
    gcs.mav.set_attitude_target_send(0, 1, 1, attitude_and_thrust, [1, 0, 0, 0], 0, 0, 0, 1.5)
    assert gcs.text(lambda t: "thrust 1.5 outside [0, 1]" in t) is not None
    assert len(calls(vehicle, "set_attitude")) == 1


def test_set_position_target_body_offset(fly: tuple[Gcs, VehicleThread]) -> None:
    gcs, vehicle = fly
    gcs.ack(M.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED)
    gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    with vehicle.lock:
        vehicle.vehicle.yaw_rad = math.pi / 2  # nose east
        vehicle.vehicle.speed_m_s = 0.0  # stay put so the offset is from a known position
    pos_only = 0b0000_1101_1111_1000  # position, no yaw
    gcs.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_BODY_OFFSET_NED, pos_only,
                                               2.0, 0.0, 0.0, 0, 0, 0, 0, 0, 0, 0, 0)
    assert gcs.recv("POSITION_TARGET_LOCAL_NED", condition=lambda m: abs(m.y - 2.0) < 1e-6)
    goto = calls(vehicle, "goto")[-1]
    assert_allclose(goto[1], [0.0, 2.0, 0.0], atol=1e-9)  # 2 m forward = 2 m east
    assert goto[2] is None
