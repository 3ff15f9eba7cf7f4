"""Telemetry PX4 sends beside ArduPilot's, built from a snapshot, for tools written for PX4.

Streamed only when asked for (SET_MESSAGE_INTERVAL, REQUEST_MESSAGE; default rate 0), except
where ArduPilot has a message in a stream group (:mod:`fcu.mavlink.telemetry.streams`). Units on the
wire, as the MAVLink spec gives them:

=======================  =====================================================================
HIGHRES_IMU              the latest IMU sample in SI (m/s^2, rad/s), the barometer's pressure
                         (hPa) and the IMU temperature (degC); ``fields_updated`` flags what
                         is filled (no magnetometer, no airspeed sensor: not flagged)
ODOMETRY                 the flying estimate: position NED about the origin (m), attitude
                         quaternion, velocity in the body frame FRD (m/s, ``child_frame_id``
                         BODY_FRD), body rates (rad/s); covariances unknown (NaN first)
ACTUATOR_OUTPUT_STATUS   the motor commands as PWM in microseconds, motors 1..4 active
ESC_TELEMETRY_1_TO_4     ArduPilot's ESC report (EXTRA3 group, as ArduPilot): rpm, voltage
                         (cV), current (cA), charge used (mAh), temperature unknown (0);
                         from what the simulated ESCs measure (:class:`SimTruth` ``esc_*``)
=======================  =====================================================================

ESC_STATUS and ESC_INFO (PX4's) are not in the pymavlink dialect the vehicle speaks
(``ardupilotmega`` of pymavlink 2.4), so they cannot be produced: asked for, they get
UNSUPPORTED like any message the vehicle cannot produce.
"""

from __future__ import annotations

import math

import numpy as np

from fcu.mavlink.port_records import VehicleSnapshot
from fcu.mavlink.telemetry.messages import (
    UINT16_MAX,
    Fields,
    TelemetryContext,
    builder_table,
    clamp_int,
    pwm_to_us,
    time_usec,
)
from fcu.mavlink.telemetry.messages import (
    finite_float as _f,
)
from fcu.mavlink.transport.codec import fields_of, mavlink2
from flightdata.geometry import quat_from_euler

__all__ = ["PX4_BUILDERS"]

_M = mavlink2
# HIGHRES_IMU.fields_updated (HIGHRES_IMU_UPDATED_FLAGS): accelerometer x/y/z (bits 0-2),
# gyroscope x/y/z (3-5), absolute pressure (9), temperature (12)
HIGHRES_IMU_FIELDS = 0x3F | 0x200 | 0x1000
HIGHRES_IMU_NO_PRESSURE = HIGHRES_IMU_FIELDS & ~0x200
_UNKNOWN_COVARIANCE = [math.nan] + [0.0] * 20  # MAVLink: NaN first = unknown
ESC_REPORT_HZ = 10.0  # Hz, the ESCs' own report rate (ESC_TELEMETRY's packet count)

# the record types the builders fill by name (fcu.mavlink.transport.codec.fields_of)
HighresImu = fields_of(_M.MAVLink_highres_imu_message)
Odometry = fields_of(_M.MAVLink_odometry_message)
ActuatorOutputStatus = fields_of(_M.MAVLink_actuator_output_status_message)
EscTelemetry1To4 = fields_of(_M.MAVLink_esc_telemetry_1_to_4_message)


def highres_imu(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """HIGHRES_IMU: the latest IMU sample and barometer pressure, SI units."""
    reading = snap.extended.imu() if snap.extended is not None else None
    if reading is None:
        return None
    pressure = snap.extended.pressure() if snap.extended is not None else None
    ax, ay, az = (_f(a) for a in reading.accel_frd[:3])
    gx, gy, gz = (_f(w) for w in reading.gyro_frd[:3])
    hpa = _f(pressure.pressure_pa / 100.0) if pressure is not None else 0.0
    fields = HIGHRES_IMU_FIELDS if pressure is not None else HIGHRES_IMU_NO_PRESSURE
    return HighresImu(
        time_usec=time_usec(reading.time_s), xacc=ax, yacc=ay, zacc=az, xgyro=gx, ygyro=gy,
        zgyro=gz, xmag=0.0, ymag=0.0, zmag=0.0, abs_pressure=hpa, diff_pressure=0.0,
        pressure_alt=0.0, temperature=_f(reading.temperature_c), fields_updated=fields, id=0)


def odometry(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """ODOMETRY: the flying estimate (module docstring)."""
    q = quat_from_euler(snap.euler_rad)
    w, x, y, z = (float(v) for v in q)
    # R (body FRD -> NED) of the quaternion; v_body = R' v_ned
    rot = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    vel_body = rot.T @ np.asarray(snap.vel_ned, dtype=float)
    n, e, d = (_f(v) for v in snap.pos_ned[:3])
    vx, vy, vz = (_f(v) for v in vel_body)
    p, qr, r = (_f(v) for v in snap.rate_frd[:3])
    return Odometry(
        time_usec=time_usec(snap.time_s), frame_id=_M.MAV_FRAME_LOCAL_NED,
        child_frame_id=_M.MAV_FRAME_BODY_FRD, x=n, y=e, z=d, q=[w, x, y, z], vx=vx, vy=vy,
        vz=vz, rollspeed=p, pitchspeed=qr, yawspeed=r, pose_covariance=_UNKNOWN_COVARIANCE,
        velocity_covariance=_UNKNOWN_COVARIANCE, reset_counter=0,
        estimator_type=_M.MAV_ESTIMATOR_TYPE_AUTOPILOT, quality=0)


def actuator_output_status(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """ACTUATOR_OUTPUT_STATUS: motors 1..4 as PWM (us), the other 28 outputs unused."""
    us = [float(pwm_to_us(float(u), ctx.pwm_max)) for u in snap.pwm[:4]]
    active = (1 << len(us)) - 1
    return ActuatorOutputStatus(time_usec=time_usec(snap.time_s), active=active,
                                actuator=us + [0.0] * (32 - len(us)))


def esc_telemetry_1_to_4(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """ESC_TELEMETRY_1_TO_4: what the simulated ESCs measure (module docstring)."""
    truth = snap.truth
    if truth is None or truth.esc_rpm is None or truth.esc_current_a is None:
        return None
    volts = truth.esc_voltage_v if truth.esc_voltage_v is not None else 0.0
    rpm = [clamp_int(v, 0, UINT16_MAX, 0) for v in truth.esc_rpm[:4]]
    current_ca = [clamp_int(100.0 * a, 0, UINT16_MAX, 0) for a in truth.esc_current_a[:4]]
    voltage_cv = [clamp_int(100.0 * volts, 0, UINT16_MAX, 0)] * 4
    count = int(ESC_REPORT_HZ * max(snap.time_s, 0.0)) & UINT16_MAX  # reports so far
    return EscTelemetry1To4(temperature=[0] * 4, voltage=voltage_cv, current=current_ca,
                            totalcurrent=[0] * 4, rpm=rpm, count=[count] * 4)


PX4_BUILDERS = builder_table(
    (_M.MAVLink_highres_imu_message, highres_imu),
    (_M.MAVLink_odometry_message, odometry),
    (_M.MAVLink_actuator_output_status_message, actuator_output_status),
    (_M.MAVLink_esc_telemetry_1_to_4_message, esc_telemetry_1_to_4),
)
"""Message id -> (its message class, its builder), as
:data:`fcu.mavlink.telemetry.messages.BUILDERS`."""
