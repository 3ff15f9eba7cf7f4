"""Messages built from a snapshot, checked after a real pack/parse round trip."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest
from mavlink_testkit import ORIGIN, FakeVehicle
from numpy.testing import assert_allclose

from fcu.mavlink.enums import MavState
from fcu.mavlink.geo import metres_per_degree
from fcu.mavlink.port_records import BatteryState, SensorHealth, VehicleSnapshot
from fcu.mavlink.telemetry import messages as build
from fcu.mavlink.telemetry import streamed
from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ
from fcu.mavlink.transport.codec import Codec, mavlink2
from fcu.navigation.modes import Mode
from flightdata.geometry import euler_from_quat

M = mavlink2


def wire(msg: Any) -> Any:
    """``msg`` after packing with the vehicle codec and parsing it back."""
    codec = Codec(1, 1)
    parsed = codec.parse_datagram(codec.pack(msg))
    assert parsed.malformed == 0 and len(parsed.messages) == 1
    return parsed.messages[0]


def statustext(fields: Any) -> Any:
    """The STATUSTEXT message of a :func:`build.statustext_chunks` record."""
    return M.MAVLink_statustext_message(**fields._asdict())


def snap(**changes: Any) -> VehicleSnapshot:
    vehicle = FakeVehicle()
    vehicle.pos_ned = np.array([3.0, -4.0, -2.0])
    vehicle.vel_ned = np.array([1.0, 0.5, -0.25])
    vehicle.yaw_rad = 1.0
    return dataclasses.replace(vehicle.snapshot(), **changes)


def one(msg_id: int, s: VehicleSnapshot, ctx: build.TelemetryContext | None = None) -> Any:
    msgs = streamed.build_stream(msg_id, s, ctx or build.TelemetryContext())
    assert len(msgs) == 1
    return wire(msgs[0])


def test_heartbeat_identity_and_flags() -> None:
    hb = one(M.MAVLINK_MSG_ID_HEARTBEAT, snap(armed=True, custom_mode=Mode.GUIDED))
    assert (hb.type, hb.autopilot) == (M.MAV_TYPE_QUADROTOR, M.MAV_AUTOPILOT_ARDUPILOTMEGA)
    assert hb.custom_mode == 4
    assert hb.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert hb.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED
    assert hb.base_mode & M.MAV_MODE_FLAG_GUIDED_ENABLED
    hb = one(M.MAVLINK_MSG_ID_HEARTBEAT, snap(armed=False, custom_mode=Mode.STABILIZE,
                                              system_status=MavState.BOOT))
    assert not hb.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED
    assert not hb.base_mode & M.MAV_MODE_FLAG_GUIDED_ENABLED
    assert hb.system_status == MavState.BOOT  # the vehicle's own status, passed through


def test_heartbeat_is_critical_during_a_failsafe() -> None:
    hb = one(M.MAVLINK_MSG_ID_HEARTBEAT, snap(system_status=MavState.ACTIVE),
             build.TelemetryContext(gcs_failsafe_active=True))
    assert hb.system_status == MavState.CRITICAL
    hb = one(M.MAVLINK_MSG_ID_HEARTBEAT, snap(system_status=MavState.ACTIVE,
                                              failsafe_active=True))
    assert hb.system_status == MavState.CRITICAL


def test_sys_status_bits_follow_health() -> None:
    ok = one(M.MAVLINK_MSG_ID_SYS_STATUS, snap())
    for bit in (M.MAV_SYS_STATUS_SENSOR_3D_GYRO, M.MAV_SYS_STATUS_SENSOR_3D_ACCEL,
                M.MAV_SYS_STATUS_SENSOR_3D_MAG, M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE,
                M.MAV_SYS_STATUS_SENSOR_GPS, M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS,
                M.MAV_SYS_STATUS_AHRS, M.MAV_SYS_STATUS_PREARM_CHECK):
        assert ok.onboard_control_sensors_present & bit
        assert ok.onboard_control_sensors_enabled & bit
        assert ok.onboard_control_sensors_health & bit
    assert ok.onboard_control_sensors_health & M.MAV_SYS_STATUS_GEOFENCE  # MAVProxy: no breach
    sick = one(M.MAVLINK_MSG_ID_SYS_STATUS,
               snap(health=SensorHealth(gps=False, prearm=False, motors=False)))
    assert sick.onboard_control_sensors_present & M.MAV_SYS_STATUS_SENSOR_GPS
    assert not sick.onboard_control_sensors_health & M.MAV_SYS_STATUS_SENSOR_GPS
    assert not sick.onboard_control_sensors_health & M.MAV_SYS_STATUS_PREARM_CHECK
    assert not sick.onboard_control_sensors_health & M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    assert sick.onboard_control_sensors_health & M.MAV_SYS_STATUS_SENSOR_3D_GYRO
    assert ok.voltage_battery == 12600


def test_errors_comm_reports_malformed_packets() -> None:
    msg = one(M.MAVLINK_MSG_ID_SYS_STATUS, snap(), build.TelemetryContext(errors_comm=70000))
    assert msg.errors_comm == 65535  # clamped to uint16


def test_global_position_int_units_and_relative_alt() -> None:
    s = snap(home_pos_ned=np.array([0.0, 0.0, -0.5]))  # home 0.5 m above the origin
    msg = one(M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, s)
    north_per_deg, east_per_deg = metres_per_degree(ORIGIN.lat_deg)
    assert msg.lat == round((ORIGIN.lat_deg + 3.0 / north_per_deg) * 1e7)
    assert msg.lon == round((ORIGIN.lon_deg - 4.0 / east_per_deg) * 1e7)
    assert msg.alt == 102_000  # mm AMSL: origin 100 m + 2 m up
    assert msg.relative_alt == 1500  # mm above home
    assert (msg.vx, msg.vy, msg.vz) == (100, 50, -25)  # cm/s NED
    assert msg.hdg == round(math.degrees(1.0) * 100)


def test_local_position_and_attitude_quaternion() -> None:
    s = snap(euler_rad=np.array([0.1, -0.2, 3.0]))
    lp = one(M.MAVLINK_MSG_ID_LOCAL_POSITION_NED, s)
    assert_allclose([lp.x, lp.y, lp.z], [3.0, -4.0, -2.0], atol=1e-6)  # float32 on the wire
    aq = one(M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, s)
    euler = euler_from_quat(np.array([aq.q1, aq.q2, aq.q3, aq.q4]))
    assert_allclose(euler, [0.1, -0.2, 3.0], atol=1e-6)  # float32 quaternion


def test_servo_output_raw_maps_motors_in_thesis_order() -> None:
    msg = one(M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, snap(pwm=np.array([0.0, 0.0125, 0.05, 0.07])),
              build.TelemetryContext(pwm_max=0.05))
    # PWM_us = 1000 + 1000 u / pwm_max, clamped to 1000..2000
    assert [msg.servo1_raw, msg.servo2_raw, msg.servo3_raw, msg.servo4_raw] == \
        [1000, 1250, 2000, 2000]
    assert msg.servo5_raw == 0


def test_vfr_hud_and_battery() -> None:
    s = snap(pwm=np.full(4, 0.025), battery=BatteryState(voltage_v=11.1, remaining=0.1))
    hud = one(M.MAVLINK_MSG_ID_VFR_HUD, s, build.TelemetryContext(pwm_max=0.05))
    assert hud.throttle == 50
    assert hud.groundspeed == pytest.approx(math.hypot(1.0, 0.5), rel=1e-6)
    assert hud.climb == pytest.approx(0.25)
    assert hud.alt == pytest.approx(102.0)
    bat = one(M.MAVLINK_MSG_ID_BATTERY_STATUS, s)
    assert bat.voltages[0] == 11100 and bat.voltages[1] == 65535
    assert bat.battery_remaining == 10
    assert bat.charge_state == M.MAV_BATTERY_CHARGE_STATE_LOW


def test_home_position_only_when_home_is_set() -> None:
    assert streamed.build_stream(M.MAVLINK_MSG_ID_HOME_POSITION, snap(home_pos_ned=None),
                              build.TelemetryContext()) == []
    home = one(M.MAVLINK_MSG_ID_HOME_POSITION, snap(home_pos_ned=np.array([0.0, 0.0, 0.0])))
    assert home.latitude == round(ORIGIN.lat_deg * 1e7)
    assert home.altitude == 100_000


def test_mission_current_total_and_state() -> None:
    msg = one(M.MAVLINK_MSG_ID_MISSION_CURRENT, snap(mission_seq=2, mission_state=3,
                                                    custom_mode=Mode.AUTO),
              build.TelemetryContext(mission_total=4))
    assert (msg.seq, msg.total, msg.mission_state, msg.mission_mode) == (2, 4, 3, 1)
    msg = one(M.MAVLINK_MSG_ID_MISSION_CURRENT, snap())
    assert msg.total == 65535  # no mission on the vehicle


def test_named_value_floats_carry_loe_per_motor() -> None:
    msgs = [wire(m) for m in streamed.build_stream(
        M.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT, snap(loe=np.array([0.0, 0.5, 1.0, 0.25])),
        build.TelemetryContext())]
    assert [(m.name, m.value) for m in msgs] == [("LOE1", 0.0), ("LOE2", 0.5), ("LOE3", 1.0),
                                                 ("LOE4", 0.25)]


def test_sim_state_carries_truth() -> None:
    msg = one(M.MAVLINK_MSG_ID_SIM_STATE, snap())
    assert msg.yaw == pytest.approx(1.0, abs=1e-6)
    assert msg.zacc == pytest.approx(-9.81, abs=1e-5)
    assert msg.alt == pytest.approx(102.0, abs=1e-4)


def test_nan_everywhere_still_packs() -> None:
    nan3 = np.full(3, np.nan)
    s = snap(pos_ned=nan3, vel_ned=nan3, euler_rad=nan3, rate_frd=nan3, pwm=np.full(4, np.nan),
             battery=BatteryState(voltage_v=math.nan, remaining=math.nan,
                                  current_a=math.nan))
    for msg_id in DEFAULT_RATES_HZ:
        for msg in streamed.build_stream(msg_id, s, build.TelemetryContext()):
            wire(msg)


def test_statustext_short_is_one_packet() -> None:
    msgs = [wire(statustext(f)) for f in build.statustext_chunks(4, "Arm: pre-arm checks failed",
                                                                  9)]
    assert [(m.text, m.id, m.chunk_seq) for m in msgs] == [("Arm: pre-arm checks failed", 0, 0)]


@pytest.mark.parametrize("length", [51, 100, 149])
def test_statustext_long_is_chunked_and_reassembles(length: int) -> None:
    text = "".join(chr(ord("a") + i % 26) for i in range(length))
    msgs = [wire(statustext(f)) for f in build.statustext_chunks(2, text, 77)]
    assert all(m.id == 77 and m.severity == 2 for m in msgs)
    assert [m.chunk_seq for m in msgs] == list(range(len(msgs)))
    assert all(len(m.text) <= 50 for m in msgs)
    assert "".join(m.text for m in msgs) == text
    assert len(msgs[-1].text) < 50  # a short (possibly empty) last chunk ends the text


def test_statustext_non_ascii_is_replaced() -> None:
    (msg,) = [wire(statustext(f)) for f in build.statustext_chunks(6, "Höhe\n", 1)]
    assert msg.text == "H?he?"


def test_autopilot_version_capabilities() -> None:
    msg = wire(M.MAVLink_autopilot_version_message(*build.autopilot_version(1, (4, 5, 0))))
    for cap in (M.MAV_PROTOCOL_CAPABILITY_MAVLINK2, M.MAV_PROTOCOL_CAPABILITY_MISSION_INT,
                M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
                M.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST,
                M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED):
        assert msg.capabilities & cap
    assert not msg.capabilities & M.MAV_PROTOCOL_CAPABILITY_FTP  # not implemented
    assert msg.flight_sw_version >> 24 == 4
