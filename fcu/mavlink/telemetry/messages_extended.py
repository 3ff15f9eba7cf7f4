"""Build the extended telemetry messages, as ArduPilot SITL sends them, from a snapshot.

The quantities come from ``snapshot.extended`` (:mod:`fcu.mavlink.telemetry.extended`),
computed when one of these messages is built; WIND comes from simulator truth
(``snapshot.truth``, like SIM_STATE: the wind at the vehicle is what the simulator blows, not
an estimate). Units on the wire, as ArduPilot's:

====================  =======================================================================
RAW_IMU, SCALED_IMU   accelerations in mG (``1000 a / 9.80665``), rates in mrad/s, magnetic
                      field 0 (no magnetometer), temperature in cdegC (RAW_IMU ``id`` 0)
SCALED_PRESSURE       press_abs in hPa, press_diff 0 hPa (no airspeed sensor), cdegC
VIBRATION             m/s^2 per axis, clip counts of IMUs 0..2 (one IMU)
EKF_STATUS_REPORT     variances as :class:`fcu.mavlink.telemetry.extended.EkfReport`, flags
AHRS2                 rad, altitude m AMSL, degE7 (the estimator that is not flying)
NAV_CONTROLLER_OUTPUT deg (float roll/pitch, int16 bearings 0..359), wp_dist in whole metres
                      (uint16, as ArduPilot), alt_error m, aspd_error 0 (no airspeed), m
WIND                  direction the wind blows from, deg 0..360; horizontal speed m/s;
                      speed_z: the wind's vertical velocity, m/s (NED, down positive)
RC_CHANNELS           no receiver: chancount 0, every channel UINT16_MAX ("unused"), rssi
                      UINT8_MAX ("unknown"), as the MAVLink spec defines them
====================  =======================================================================

Each builder fills its message's fields by name (records of
:func:`fcu.mavlink.transport.codec.fields_of`) and returns None when there is nothing to report
yet (no sample, no second estimator, no truth): the message is then skipped.
"""

from __future__ import annotations

import math
import sys

from fcu.mavlink.geo import ned_to_geo
from fcu.mavlink.port_records import VehicleSnapshot
from fcu.mavlink.telemetry.messages import (
    INT16_MAX,
    UINT16_MAX,
    UINT32_MAX,
    Fields,
    TelemetryContext,
    builder_table,
    clamp_int,
    time_boot_ms,
    time_usec,
)
from fcu.mavlink.telemetry.messages import (
    finite_float as _f,
)
from fcu.mavlink.transport.codec import fields_of, mavlink2

__all__ = ["EXTENDED_BUILDERS", "G0_M_S2"]

_M = mavlink2
G0_M_S2 = 9.80665  # m/s^2, the g of mG

RawImu = fields_of(_M.MAVLink_raw_imu_message)
ScaledImu = fields_of(_M.MAVLink_scaled_imu_message)
ScaledPressure = fields_of(_M.MAVLink_scaled_pressure_message)
Vibration = fields_of(_M.MAVLink_vibration_message)
EkfStatusReport = fields_of(_M.MAVLink_ekf_status_report_message)
Ahrs2 = fields_of(_M.MAVLink_ahrs2_message)
NavControllerOutput = fields_of(_M.MAVLink_nav_controller_output_message)
Wind = fields_of(_M.MAVLink_wind_message)
RcChannels = fields_of(_M.MAVLink_rc_channels_message)


def _cdeg_c(temperature_c: float) -> int:
    """Temperature in cdegC; 0 means "no sensor" on the wire, so a true 0 is sent as 1."""
    value = clamp_int(temperature_c * 100.0, -INT16_MAX, INT16_MAX, 0)
    return 1 if value == 0 and math.isfinite(temperature_c) else value


def _imu_ints(snap: VehicleSnapshot) -> tuple[int, dict[str, int], int] | None:
    """(time in us, the IMU fields by name, temperature in cdegC) of the latest IMU sample."""
    reading = snap.extended.imu() if snap.extended is not None else None
    if reading is None:
        return None
    ax, ay, az = (clamp_int(1000.0 * float(a) / G0_M_S2, -INT16_MAX, INT16_MAX, 0)
                  for a in reading.accel_frd[:3])
    gx, gy, gz = (clamp_int(1000.0 * float(w), -INT16_MAX, INT16_MAX, 0)
                  for w in reading.gyro_frd[:3])
    imu = {"xacc": ax, "yacc": ay, "zacc": az, "xgyro": gx, "ygyro": gy, "zgyro": gz,
           "xmag": 0, "ymag": 0, "zmag": 0}
    return time_usec(reading.time_s), imu, _cdeg_c(reading.temperature_c)


def raw_imu(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """RAW_IMU: the latest IMU sample (ArduPilot's scaling: mG, mrad/s)."""
    ints = _imu_ints(snap)
    if ints is None:
        return None
    time_us, imu, temperature = ints
    return RawImu(time_usec=time_us, **imu, id=0, temperature=temperature)


def scaled_imu(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """SCALED_IMU: the same sample, time since boot in ms."""
    ints = _imu_ints(snap)
    if ints is None:
        return None
    time_us, imu, temperature = ints
    return ScaledImu(time_boot_ms=(time_us // 1000) & UINT32_MAX, **imu,
                     temperature=temperature)


def scaled_pressure(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """SCALED_PRESSURE: the barometer's pressure (hPa) and temperature (cdegC)."""
    reading = snap.extended.pressure() if snap.extended is not None else None
    if reading is None:
        return None
    return ScaledPressure(
        time_boot_ms=time_boot_ms(reading.time_s), press_abs=_f(reading.pressure_pa / 100.0),
        press_diff=0.0, temperature=_cdeg_c(reading.temperature_c), temperature_press_diff=0)


def vibration(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """VIBRATION: ArduPilot's vibration levels (m/s^2) and clip counts."""
    levels = snap.extended.vibration() if snap.extended is not None else None
    if levels is None:
        return None
    v = levels.vibration_m_s2
    clip0, clip1, clip2 = (clamp_int(float(c), 0, UINT32_MAX, 0) for c in levels.clipping)
    return Vibration(
        time_usec=time_usec(levels.time_s), vibration_x=_f(v[0]), vibration_y=_f(v[1]),
        vibration_z=_f(v[2]), clipping_0=clip0, clipping_1=clip1, clipping_2=clip2)


def ekf_status_report(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """EKF_STATUS_REPORT: the flying estimator's variances and flags."""
    report = snap.extended.ekf() if snap.extended is not None else None
    if report is None:
        return None
    return EkfStatusReport(
        flags=clamp_int(report.flags, 0, UINT16_MAX, 0),
        velocity_variance=_f(report.velocity_variance),
        pos_horiz_variance=_f(report.pos_horiz_variance),
        pos_vert_variance=_f(report.pos_vert_variance),
        compass_variance=_f(report.compass_variance),
        terrain_alt_variance=_f(report.terrain_alt_variance), airspeed_variance=0.0)


def ahrs2(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """AHRS2: the second estimator's attitude (rad) and position (degE7, m AMSL)."""
    second = snap.extended.secondary() if snap.extended is not None else None
    if second is None:
        return None
    e = second.euler_rad
    lat, lon, alt = ned_to_geo(second.pos_ned, snap.origin)
    e7 = 2**31 - 1
    return Ahrs2(roll=_f(e[0]), pitch=_f(e[1]), yaw=_f(e[2]), altitude=_f(alt),
                 lat=clamp_int(lat * 1e7, -e7, e7, 0), lng=clamp_int(lon * 1e7, -e7, e7, 0))


def _deg360(angle_rad: float) -> int:
    """Bearing in whole degrees 0..359 (0 when unknown)."""
    if not math.isfinite(angle_rad):
        return 0
    return clamp_int(math.degrees(angle_rad) % 360.0, 0, 360, 0) % 360


def nav_controller_output(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """NAV_CONTROLLER_OUTPUT: desired attitude and heading, distance and errors."""
    nav = snap.extended.nav_controller() if snap.extended is not None else None
    if nav is None:
        return None
    return NavControllerOutput(
        nav_roll=_f(math.degrees(nav.roll_rad)), nav_pitch=_f(math.degrees(nav.pitch_rad)),
        nav_bearing=_deg360(nav.bearing_rad), target_bearing=_deg360(nav.target_bearing_rad),
        wp_dist=clamp_int(nav.wp_dist_m, 0, UINT16_MAX, 0), alt_error=_f(nav.alt_error_m),
        aspd_error=0.0, xtrack_error=_f(nav.xtrack_error_m))


def wind(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """WIND (ardupilotmega): the simulator's wind at the vehicle (truth, like SIM_STATE)."""
    truth = snap.truth
    if truth is None or truth.wind_ned is None:
        return None
    wn, we, wd = (float(v) for v in truth.wind_ned[:3])
    speed = math.hypot(wn, we)
    # the air moves towards atan2(we, wn); it comes from the opposite direction
    direction = math.degrees(math.atan2(-we, -wn)) % 360.0 if speed > 0.0 else 0.0
    return Wind(direction=_f(direction), speed=_f(speed), speed_z=_f(wd))


# interned names: a call matches keywords by identity first (an f-string's would be 2x slower)
_UNUSED_CHANNELS = {sys.intern(f"chan{k}_raw"): UINT16_MAX for k in range(1, 19)}


def rc_channels(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """RC_CHANNELS: no receiver (module docstring)."""
    return RcChannels(time_boot_ms=time_boot_ms(snap.time_s), chancount=0, **_UNUSED_CHANNELS,
                      rssi=0xFF)


EXTENDED_BUILDERS = builder_table(
    (_M.MAVLink_raw_imu_message, raw_imu),
    (_M.MAVLink_scaled_imu_message, scaled_imu),
    (_M.MAVLink_scaled_pressure_message, scaled_pressure),
    (_M.MAVLink_vibration_message, vibration),
    (_M.MAVLink_ekf_status_report_message, ekf_status_report),
    (_M.MAVLink_ahrs2_message, ahrs2),
    (_M.MAVLink_nav_controller_output_message, nav_controller_output),
    (_M.MAVLink_wind_message, wind),
    (_M.MAVLink_rc_channels_message, rc_channels),
)
"""Message id -> (its message class, its builder), as
:data:`fcu.mavlink.telemetry.messages.BUILDERS`."""
