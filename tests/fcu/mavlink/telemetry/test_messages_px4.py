"""PX4's telemetry beside ArduPilot's: HIGHRES_IMU, ODOMETRY, ACTUATOR_OUTPUT_STATUS, and
ArduPilot's ESC_TELEMETRY_1_TO_4 from the simulated ESCs; all requestable, none streamed by
default."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_mavlink_messages import one, snap
from test_messages_extended import IMU, Extended

from fcu.mavlink.port_records import SimTruth
from fcu.mavlink.telemetry import messages as build
from fcu.mavlink.telemetry import streamed
from fcu.mavlink.telemetry.extended import PressureReading
from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ, STREAM_GROUPS
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
PX4_IDS = (M.MAVLINK_MSG_ID_HIGHRES_IMU, M.MAVLINK_MSG_ID_ODOMETRY,
           M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4)


def test_requestable_but_not_streamed_by_default() -> None:
    for msg_id in PX4_IDS:
        assert streamed.can_build(msg_id)
        assert DEFAULT_RATES_HZ[msg_id] == 0.0
    # ArduPilot sends its ESC report in EXTRA3
    assert M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4 in STREAM_GROUPS[M.MAV_DATA_STREAM_EXTRA3]


def test_highres_imu_is_the_sample_in_si() -> None:
    pressure = PressureReading(time_s=12.5, pressure_pa=95_000.0, temperature_c=20.0)
    msg = one(M.MAVLINK_MSG_ID_HIGHRES_IMU,
              snap(extended=Extended(imu_reading=IMU, pressure_reading=pressure)))
    assert msg.time_usec == 12_500_000
    np.testing.assert_allclose([msg.xacc, msg.yacc, msg.zacc], IMU.accel_frd, rtol=1e-6)
    np.testing.assert_allclose([msg.xgyro, msg.ygyro, msg.zgyro], IMU.gyro_frd, rtol=1e-6)
    assert msg.abs_pressure == pytest.approx(950.0)  # hPa
    assert msg.temperature == pytest.approx(21.37, abs=1e-4)
    assert msg.fields_updated == 0x3F | 0x200 | 0x1000  # acc, gyro, pressure, temperature
    assert not streamed.build_stream(M.MAVLINK_MSG_ID_HIGHRES_IMU, snap(extended=Extended()),
                                     build.TelemetryContext())  # no sample yet


def test_odometry_velocity_is_in_the_body_frame() -> None:
    s = snap(euler_rad=np.array([0.0, 0.0, math.pi / 2]), vel_ned=np.array([1.0, 0.0, 0.5]))
    msg = one(M.MAVLINK_MSG_ID_ODOMETRY, s)
    assert (msg.frame_id, msg.child_frame_id) == (M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_BODY_FRD)
    np.testing.assert_allclose([msg.x, msg.y, msg.z], s.pos_ned, rtol=1e-6)
    # facing east, moving north: the velocity is to the left (-right) in FRD
    np.testing.assert_allclose([msg.vx, msg.vy, msg.vz], [0.0, -1.0, 0.5], atol=1e-6)
    np.testing.assert_allclose(msg.q, [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-6)
    assert math.isnan(msg.pose_covariance[0])  # unknown


def test_actuator_outputs_are_the_motor_pwm() -> None:
    ctx = build.TelemetryContext()
    s = snap(pwm=np.array([0.0, ctx.pwm_max, 0.5 * ctx.pwm_max, 0.25 * ctx.pwm_max]))
    msg = one(M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, s, ctx)
    servo = one(M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, s, ctx)
    assert msg.active == 0b1111
    assert list(msg.actuator[:4]) == [servo.servo1_raw, servo.servo2_raw, servo.servo3_raw,
                                      servo.servo4_raw]
    assert not any(msg.actuator[4:])


def test_esc_report_shows_a_lost_rotor() -> None:
    truth = SimTruth(pos_ned=np.zeros(3), vel_ned=np.zeros(3), quat_wxyz=np.array([1.0, 0, 0, 0]),
                     rate_frd=np.zeros(3), accel_frd=np.zeros(3),
                     esc_rpm=np.array([4957.4, 4957.4, 0.0, 5200.0]),
                     esc_current_a=np.array([3.3, 3.3, 0.0, 3.5]), esc_voltage_v=11.1)
    msg = one(M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4, snap(truth=truth))
    assert list(msg.rpm) == [4957, 4957, 0, 5200]
    assert list(msg.current) == [330, 330, 0, 350]  # cA
    assert list(msg.voltage) == [1110] * 4  # cV
    assert not streamed.build_stream(M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4, snap(truth=None),
                                     build.TelemetryContext())
