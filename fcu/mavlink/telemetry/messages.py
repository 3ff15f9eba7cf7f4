"""Build MAVLink messages from a :class:`~fcu.mavlink.port_records.VehicleSnapshot`.

This is the unit-conversion edge: SI/NED inside, MAVLink units on the wire. Every integer
field is clamped into its wire type (a NaN becomes the field's "unknown" value), so a
diverged estimate can never make packing fail. A builder returns its message's constructor
arguments (:data:`Fields`; :data:`BUILDERS` pairs it with the message class) as a record of
:func:`~fcu.mavlink.transport.codec.fields_of` filled by name (``Attitude(time_boot_ms=...,
roll=..., ...)``: a misspelt or missing field raises), which the endpoint packs without making
a pymavlink message object.

Conventions worth knowing on the ground-station side
----------------------------------------------------
- Times: ``time_boot_ms`` / ``time_usec`` are **simulated** time since boot.
- Positions: LOCAL_POSITION_NED is about the NED origin (home at boot, on the ground);
  GLOBAL_POSITION_INT.alt and GPS_RAW_INT.alt are AMSL, ``relative_alt`` is above the
  current home.
- GPS_RAW_INT carries the estimated position from the lab's motion-capture system (the
  Qball-X4 has no GPS): fix 3D and 12 synthetic satellites while the position source is
  healthy, NO_FIX and 0 otherwise.
- VFR_HUD airspeed equals ground speed (no airspeed sensor); throttle is the mean motor
  command in percent of ``pwm_max``.
- SERVO_OUTPUT_RAW servo1..servo4 carry motors 1..4 in the thesis numbering of
  docs/design.md (1 front, 2 back, 3 left, 4 right), as
  ``PWM_us = 1000 + 1000 * u / pwm_max`` clamped to 1000..2000; servo5..16 are 0 (unused).
- SIM_STATE is simulator truth; NAMED_VALUE_FLOAT ``LOE1``..``LOE4`` are the estimated loss
  of effectiveness of motors 1..4 (0 healthy, 1 no thrust).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fcu.floats import wrap_pi
from fcu.mavlink.enums import MavState, Severity
from fcu.mavlink.geo import home_alt_amsl_m, ned_to_geo
from fcu.mavlink.port_records import LandedState, VehicleSnapshot
from fcu.mavlink.transport.codec import (
    Fields,
    MAVLinkMessage,
    fields_of,
    heartbeat_fields,
    mavlink2,
)
from fcu.navigation.modes import Mode
from flightdata.geometry import euler_from_wxyz, quat_from_euler

__all__ = [
    "AUTOPILOT_CAPABILITIES",
    "STATUSTEXT_CHUNK_LEN",
    "TelemetryContext",
    "BUILDERS",
    "Builder",
    "BuilderTable",
    "Fields",
    "autopilot_version",
    "builder_table",
    "command_ack",
    "pwm_to_us",
    "statustext_chunks",
]

_M = mavlink2
UINT8_MAX = 0xFF
UINT16_MAX = 0xFFFF
INT16_MAX = 0x7FFF
UINT32_MAX = 0xFFFFFFFF
INT32_MAX = 0x7FFFFFFF
UINT64_MAX = 0xFFFFFFFFFFFFFFFF
STATUSTEXT_CHUNK_LEN = 50  # characters per STATUSTEXT packet
STATUSTEXT_MAX_CHUNKS = 20  # longer texts are truncated (1000 characters)

AUTOPILOT_CAPABILITIES = (
    _M.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | _M.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | _M.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | _M.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | _M.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
    | _M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | _M.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
    | _M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | _M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
)
"""What AUTOPILOT_VERSION advertises (each one implemented by this endpoint)."""

# the record types the builders fill (fields_of: the message's constructor arguments by name)
SysStatus = fields_of(_M.MAVLink_sys_status_message)
GpsRawInt = fields_of(_M.MAVLink_gps_raw_int_message)
Attitude = fields_of(_M.MAVLink_attitude_message)
AttitudeQuaternion = fields_of(_M.MAVLink_attitude_quaternion_message)
LocalPositionNed = fields_of(_M.MAVLink_local_position_ned_message)
GlobalPositionInt = fields_of(_M.MAVLink_global_position_int_message)
VfrHud = fields_of(_M.MAVLink_vfr_hud_message)
ServoOutputRaw = fields_of(_M.MAVLink_servo_output_raw_message)
BatteryStatus = fields_of(_M.MAVLink_battery_status_message)
HomePosition = fields_of(_M.MAVLink_home_position_message)
ExtendedSysState = fields_of(_M.MAVLink_extended_sys_state_message)
MissionCurrent = fields_of(_M.MAVLink_mission_current_message)
SystemTime = fields_of(_M.MAVLink_system_time_message)
PositionTargetLocalNed = fields_of(_M.MAVLink_position_target_local_ned_message)
AttitudeTarget = fields_of(_M.MAVLink_attitude_target_message)
SimState = fields_of(_M.MAVLink_sim_state_message)
NamedValueFloat = fields_of(_M.MAVLink_named_value_float_message)
AutopilotVersion = fields_of(_M.MAVLink_autopilot_version_message)
CommandAck = fields_of(_M.MAVLink_command_ack_message)
Statustext = fields_of(_M.MAVLink_statustext_message)

# ArduCopter sets GUIDED_ENABLED for the modes under position control (GCS_Copter::base_mode).
_GUIDED_MODES = frozenset({Mode.AUTO, Mode.GUIDED, Mode.LOITER, Mode.RTL, Mode.BRAKE})


@dataclass(frozen=True, slots=True)
class TelemetryContext:
    """What the builders need besides the snapshot.

    Attributes
    ----------
    pwm_max : float
        Motor command at full power (SERVO_OUTPUT_RAW, VFR_HUD throttle).
    mission_total : int
        Mission items excluding home (MISSION_CURRENT.total); 0 when there is no mission.
    errors_comm : int
        Malformed packets received so far (SYS_STATUS.errors_comm).
    gcs_failsafe_active : bool
        The endpoint's GCS-loss failsafe is acting (HEARTBEAT shows CRITICAL).
    boot_unix_time_s : float or None
        UNIX time at boot for SYSTEM_TIME (unix = boot + simulated time); None sends 0.
    """

    pwm_max: float = 0.05
    mission_total: int = 0
    errors_comm: int = 0
    gcs_failsafe_active: bool = False
    boot_unix_time_s: float | None = None


# ---------------------------------------------------------------------------------------------
# small conversions


def clamp_int(value: float, lo: int, hi: int, unknown: int) -> int:
    """``round(value)`` clamped to [lo, hi]; ``unknown`` for NaN."""
    if math.isnan(value):
        return unknown
    if value >= hi:
        return hi
    if value <= lo:
        return lo
    return int(round(value))


def time_boot_ms(time_s: float) -> int:
    """Simulated time as uint32 milliseconds (wraps after 49.7 days like the firmware)."""
    return clamp_int(time_s * 1e3, 0, UINT64_MAX, 0) & UINT32_MAX


def time_usec(time_s: float) -> int:
    """Simulated time as uint64 microseconds."""
    return clamp_int(time_s * 1e6, 0, UINT64_MAX, 0)


def cdeg_heading(yaw_rad: float) -> int:
    """Heading in centidegrees 0..35999 (UINT16_MAX when unknown)."""
    if not math.isfinite(yaw_rad):
        return UINT16_MAX
    return clamp_int(math.degrees(yaw_rad) % 360.0 * 100.0, 0, 35999, UINT16_MAX)


def pwm_to_us(u: float, pwm_max: float) -> int:
    """Motor command ``u`` (0..pwm_max) as a PWM pulse width, 1000..2000 microseconds."""
    return clamp_int(1000.0 + 1000.0 * u / pwm_max, 1000, 2000, 1000)


def _e7(deg: float) -> int:
    return clamp_int(deg * 1e7, -INT32_MAX, INT32_MAX, 0)


def _mm(m: float) -> int:
    return clamp_int(m * 1e3, -INT32_MAX, INT32_MAX, 0)


def _f(value: float) -> float:
    return float(value)


def finite_float(value: float) -> float:
    """A finite float for a float field (NaN and inf become 0)."""
    value = float(value)
    return value if math.isfinite(value) else 0.0


_F64 = np.dtype(np.float64)


def _floats(v: np.ndarray | Sequence[float]) -> list[float]:
    """``[float(x) for x in v]``; a float64 array in one call."""
    if type(v) is np.ndarray and v.dtype == _F64:
        return v.tolist()
    return [float(x) for x in v]


def _xyz(v: np.ndarray | Sequence[float]) -> list[float]:
    """``[float(v[0]), float(v[1]), float(v[2])]``; a float64 array of 3 in one call."""
    if type(v) is np.ndarray and v.dtype == _F64 and v.shape == (3,):
        return v.tolist()
    return [float(v[0]), float(v[1]), float(v[2])]


def _cms(x: float) -> int:
    """m/s as int16 cm/s."""
    return clamp_int(x * 100.0, -INT16_MAX, INT16_MAX, 0)


# ---------------------------------------------------------------------------------------------
# streamed messages


def heartbeat(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """HEARTBEAT: ArduCopter quad, custom mode, armed flag, system status."""
    base_mode = _M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | _M.MAV_MODE_FLAG_STABILIZE_ENABLED
    if snap.armed:
        base_mode |= _M.MAV_MODE_FLAG_SAFETY_ARMED
    if snap.custom_mode in _GUIDED_MODES:
        base_mode |= _M.MAV_MODE_FLAG_GUIDED_ENABLED
    status = int(snap.system_status)
    if (ctx.gcs_failsafe_active or snap.failsafe_active) and status != MavState.BOOT:
        status = max(status, int(MavState.CRITICAL))
    return heartbeat_fields(base_mode, clamp_int(snap.custom_mode, 0, UINT32_MAX, 0),
                            clamp_int(status, 0, UINT8_MAX, 0))


def sensor_bits(snap: VehicleSnapshot) -> tuple[int, int, int]:
    """SYS_STATUS (present, enabled, health) bitmasks."""
    h = snap.health
    sensors = {
        _M.MAV_SYS_STATUS_SENSOR_3D_GYRO: h.gyro,
        _M.MAV_SYS_STATUS_SENSOR_3D_ACCEL: h.accel,
        _M.MAV_SYS_STATUS_SENSOR_3D_MAG: h.mag,
        _M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE: h.baro,
        _M.MAV_SYS_STATUS_SENSOR_GPS: h.gps,
        _M.MAV_SYS_STATUS_SENSOR_VISION_POSITION: h.gps,
        _M.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL: True,
        _M.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION: True,
        _M.MAV_SYS_STATUS_SENSOR_YAW_POSITION: True,
        _M.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL: True,
        _M.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL: True,
        _M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS: h.motors,
        _M.MAV_SYS_STATUS_AHRS: h.ahrs,
        _M.MAV_SYS_STATUS_SENSOR_BATTERY: snap.battery.healthy,
        _M.MAV_SYS_STATUS_PREARM_CHECK: h.prearm,
    }
    present = 0
    health = _M.MAV_SYS_STATUS_GEOFENCE  # no fence: never breached (MAVProxy reads this bit)
    for bit, ok in sensors.items():
        present |= bit
        if ok:
            health |= bit
    return present, present, health


def _battery_ints(snap: VehicleSnapshot) -> tuple[int, int]:
    """(current in cA, remaining in %), -1 where unknown."""
    bat = snap.battery
    current_ca = -1 if bat.current_a is None else clamp_int(bat.current_a * 100.0, -1,
                                                            INT16_MAX, -1)
    remaining = -1 if bat.remaining is None else clamp_int(bat.remaining * 100.0, 0, 100, -1)
    return current_ca, remaining


def sys_status(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """SYS_STATUS: sensor bits, battery, receive-error count."""
    present, enabled, health = sensor_bits(snap)
    bat = snap.battery
    current_ca, remaining = _battery_ints(snap)
    return SysStatus(
        onboard_control_sensors_present=present, onboard_control_sensors_enabled=enabled,
        onboard_control_sensors_health=health, load=0,
        voltage_battery=clamp_int(bat.voltage_v * 1e3, 0, UINT16_MAX - 1, UINT16_MAX),
        current_battery=current_ca, battery_remaining=remaining, drop_rate_comm=0,
        errors_comm=clamp_int(ctx.errors_comm, 0, UINT16_MAX, 0), errors_count1=0,
        errors_count2=0, errors_count3=0, errors_count4=0,
        onboard_control_sensors_present_extended=0, onboard_control_sensors_enabled_extended=0,
        onboard_control_sensors_health_extended=0)


def gps_raw_int(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """GPS_RAW_INT from the estimated position (mocap in the lab)."""
    lat, lon, alt = ned_to_geo(snap.pos_ned, snap.origin)
    vn, ve = float(snap.vel_ned[0]), float(snap.vel_ned[1])
    speed = math.hypot(vn, ve)
    ok = snap.health.gps
    dop = 100 if ok else UINT16_MAX
    return GpsRawInt(
        time_usec=time_usec(snap.time_s),
        fix_type=_M.GPS_FIX_TYPE_3D_FIX if ok else _M.GPS_FIX_TYPE_NO_FIX,
        lat=_e7(lat), lon=_e7(lon), alt=_mm(alt), eph=dop, epv=dop,
        vel=clamp_int(speed * 100.0, 0, UINT16_MAX - 1, UINT16_MAX),
        cog=cdeg_heading(math.atan2(ve, vn)) if speed > 0.1 else UINT16_MAX,
        satellites_visible=12 if ok else 0, alt_ellipsoid=0, h_acc=10, v_acc=10, vel_acc=10,
        hdg_acc=0, yaw=0)


def attitude(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """ATTITUDE: ZYX Euler angles (yaw wrapped to [-pi, pi)) and body rates."""
    roll, pitch, yaw = _xyz(snap.euler_rad)
    p, q, r = _xyz(snap.rate_frd)
    return Attitude(time_boot_ms=time_boot_ms(snap.time_s), roll=roll, pitch=pitch,
                    yaw=wrap_pi(yaw), rollspeed=p, pitchspeed=q, yawspeed=r)


def attitude_quaternion(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """ATTITUDE_QUATERNION: [w, x, y, z] and body rates."""
    qw, qx, qy, qz = quat_from_euler(snap.euler_rad).tolist()
    p, q, r = _xyz(snap.rate_frd)
    return AttitudeQuaternion(
        time_boot_ms=time_boot_ms(snap.time_s), q1=qw, q2=qx, q3=qy, q4=qz, rollspeed=p,
        pitchspeed=q, yawspeed=r, repr_offset_q=[0.0, 0.0, 0.0, 0.0])


def local_position_ned(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """LOCAL_POSITION_NED about the origin."""
    n, e, d = _xyz(snap.pos_ned)
    vn, ve, vd = _xyz(snap.vel_ned)
    return LocalPositionNed(time_boot_ms=time_boot_ms(snap.time_s), x=n, y=e, z=d, vx=vn,
                            vy=ve, vz=vd)


def relative_alt_m(snap: VehicleSnapshot, alt_amsl_m: float) -> float:
    """Altitude above the current home (above the origin while home is unset)."""
    return alt_amsl_m - home_alt_amsl_m(snap.origin, snap.home_pos_ned)


def global_position_int(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """GLOBAL_POSITION_INT: degE7, AMSL and relative altitude in mm, velocity in cm/s."""
    lat, lon, alt = ned_to_geo(snap.pos_ned, snap.origin)
    vn, ve, vd = _xyz(snap.vel_ned)
    return GlobalPositionInt(
        time_boot_ms=time_boot_ms(snap.time_s), lat=_e7(lat), lon=_e7(lon), alt=_mm(alt),
        relative_alt=_mm(relative_alt_m(snap, alt)), vx=_cms(vn), vy=_cms(ve), vz=_cms(vd),
        hdg=cdeg_heading(_f(snap.euler_rad[2])))


def vfr_hud(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """VFR_HUD: ground speed (also as airspeed), heading, throttle %, AMSL altitude, climb."""
    _, _, alt = ned_to_geo(snap.pos_ned, snap.origin)
    speed = math.hypot(_f(snap.vel_ned[0]), _f(snap.vel_ned[1]))
    heading = cdeg_heading(_f(snap.euler_rad[2]))
    throttle = float(np.mean(snap.pwm)) / ctx.pwm_max * 100.0
    return VfrHud(
        airspeed=speed, groundspeed=speed, heading=0 if heading == UINT16_MAX else heading // 100,
        throttle=clamp_int(throttle, 0, 100, 0), alt=alt, climb=-_f(snap.vel_ned[2]))


# interned names: a call matches keywords by identity first (an f-string's would be 2x slower)
_UNUSED_SERVOS = {sys.intern(f"servo{k}_raw"): 0 for k in range(5, 17)}


def servo_output_raw(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """SERVO_OUTPUT_RAW: motors 1..4 (thesis numbering) on servo1..servo4."""
    us = [pwm_to_us(u, ctx.pwm_max) for u in _floats(snap.pwm[:4])]
    us += [0] * (4 - len(us))
    return ServoOutputRaw(
        time_usec=time_usec(snap.time_s) & UINT32_MAX, port=0, servo1_raw=us[0],
        servo2_raw=us[1], servo3_raw=us[2], servo4_raw=us[3], **_UNUSED_SERVOS)


def battery_status(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """BATTERY_STATUS: pack voltage in cell 0 (cells unknown, as ArduPilot without cell
    monitoring), current, charge (mAh) and energy (hJ) used, remaining %, time to empty,
    charge state (CRITICAL, LOW from the monitor's levels or under 20 %, else OK)."""
    bat = snap.battery
    voltages = [clamp_int(bat.voltage_v * 1e3, 0, UINT16_MAX - 1, UINT16_MAX)]
    voltages += [UINT16_MAX] * 9
    current_ca, remaining = _battery_ints(snap)
    if not bat.healthy:
        charge = _M.MAV_BATTERY_CHARGE_STATE_CRITICAL
    elif bat.low or 0 <= remaining < 20:
        charge = _M.MAV_BATTERY_CHARGE_STATE_LOW
    else:
        charge = _M.MAV_BATTERY_CHARGE_STATE_OK
    consumed_mah = -1 if bat.consumed_mah is None else clamp_int(bat.consumed_mah, 0,
                                                                  INT32_MAX, -1)
    consumed_hj = -1 if bat.consumed_j is None else clamp_int(bat.consumed_j / 100.0, 0,
                                                               INT32_MAX, -1)
    time_left_s = 0 if bat.time_remaining_s is None else clamp_int(bat.time_remaining_s, 0,
                                                                    INT32_MAX, 0)
    return BatteryStatus(
        id=0, battery_function=_M.MAV_BATTERY_FUNCTION_ALL, type=_M.MAV_BATTERY_TYPE_LIPO,
        temperature=INT16_MAX, voltages=voltages, current_battery=current_ca,
        current_consumed=consumed_mah, energy_consumed=consumed_hj, battery_remaining=remaining,
        time_remaining=time_left_s, charge_state=charge, voltages_ext=[0, 0, 0, 0], mode=0,
        fault_bitmask=0)


def home_position(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """HOME_POSITION (None while home is unset): geodetic and in the local NED frame."""
    ned = snap.home_pos_ned
    if ned is None:
        return None
    lat, lon, alt = ned_to_geo(ned, snap.origin)
    return HomePosition(
        latitude=_e7(lat), longitude=_e7(lon), altitude=_mm(alt), x=_f(ned[0]), y=_f(ned[1]),
        z=_f(ned[2]), q=[1.0, 0.0, 0.0, 0.0], approach_x=0.0, approach_y=0.0, approach_z=0.0,
        time_usec=time_usec(snap.time_s))


def extended_sys_state(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """EXTENDED_SYS_STATE: multicopter, landed state."""
    landed = clamp_int(snap.landed_state, 0, LandedState.LANDING, LandedState.UNDEFINED)
    return ExtendedSysState(vtol_state=_M.MAV_VTOL_STATE_MC, landed_state=landed)


def mission_current(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """MISSION_CURRENT with ``total`` (items without home; UINT16_MAX: no mission) and state."""
    total = ctx.mission_total if ctx.mission_total > 0 else UINT16_MAX
    mode = 1 if snap.custom_mode == Mode.AUTO else 2
    return MissionCurrent(
        seq=clamp_int(snap.mission_seq, 0, UINT16_MAX, 0), total=total,
        mission_state=clamp_int(snap.mission_state, 0, UINT8_MAX, 0), mission_mode=mode)


def system_time(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields:
    """SYSTEM_TIME: UNIX time (boot time + simulated time; 0 when unknown), time since boot."""
    unix_us = 0 if ctx.boot_unix_time_s is None else time_usec(ctx.boot_unix_time_s + snap.time_s)
    return SystemTime(time_unix_usec=unix_us, time_boot_ms=time_boot_ms(snap.time_s))


def position_target_local_ned(snap: VehicleSnapshot,
                              ctx: TelemetryContext) -> Fields | None:
    """POSITION_TARGET_LOCAL_NED: the position controller's reference (None when idle)."""
    t = snap.position_target
    if t is None:
        return None
    p, v, a = t.pos_ned, t.vel_ned, t.acc_ned
    return PositionTargetLocalNed(
        time_boot_ms=time_boot_ms(snap.time_s), coordinate_frame=_M.MAV_FRAME_LOCAL_NED,
        type_mask=_M.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE,
        x=_f(p[0]), y=_f(p[1]), z=_f(p[2]), vx=_f(v[0]), vy=_f(v[1]), vz=_f(v[2]),
        afx=_f(a[0]), afy=_f(a[1]), afz=_f(a[2]), yaw=wrap_pi(_f(t.yaw_rad)), yaw_rate=0.0)


def attitude_target(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """ATTITUDE_TARGET: the attitude controller's reference (None when idle)."""
    t = snap.attitude_target
    if t is None:
        return None
    q, w = quat_from_euler(t.euler_rad), t.rate_frd
    return AttitudeTarget(
        time_boot_ms=time_boot_ms(snap.time_s), type_mask=0, q=[_f(x) for x in q],
        body_roll_rate=_f(w[0]), body_pitch_rate=_f(w[1]), body_yaw_rate=_f(w[2]),
        thrust=_f(t.thrust))


def sim_state(snap: VehicleSnapshot, ctx: TelemetryContext) -> Fields | None:
    """SIM_STATE: simulator truth (None outside simulation)."""
    t = snap.truth
    if t is None:
        return None
    qf = _floats(t.quat_wxyz)
    roll, pitch, yaw = euler_from_wxyz(qf[0], qf[1], qf[2], qf[3])
    ax, ay, az = _xyz(t.accel_frd)
    p, q_rate, r = _xyz(t.rate_frd)
    vn, ve, vd = _xyz(t.vel_ned)
    lat, lon, alt = ned_to_geo(t.pos_ned, snap.origin)
    return SimState(
        q1=qf[0], q2=qf[1], q3=qf[2], q4=qf[3], roll=roll, pitch=pitch, yaw=yaw, xacc=ax,
        yacc=ay, zacc=az, xgyro=p, ygyro=q_rate, zgyro=r, lat=lat, lon=lon, alt=alt,
        std_dev_horz=0.0, std_dev_vert=0.0, vn=vn, ve=ve, vd=vd, lat_int=_e7(lat),
        lon_int=_e7(lon))


_LOE_NAMES = (b"LOE1", b"LOE2", b"LOE3", b"LOE4")


def named_value_floats(snap: VehicleSnapshot, ctx: TelemetryContext) -> list[Fields]:
    """NAMED_VALUE_FLOAT ``LOE1``..``LOE4`` (none when no estimate is available)."""
    if snap.loe is None:
        return []
    t_ms = time_boot_ms(snap.time_s)
    return [NamedValueFloat(time_boot_ms=t_ms, name=name, value=v)
            for name, v in zip(_LOE_NAMES, _floats(snap.loe[:4]), strict=False)]


Builder = Callable[[VehicleSnapshot, TelemetryContext], Fields | list[Fields] | None]
"""A message's builder: the constructor arguments of its one message (a record of
:func:`~fcu.mavlink.transport.codec.fields_of` its class), of several (a list of records; may
be empty) or None (nothing to report)."""

BuilderTable = dict[int, tuple[type[MAVLinkMessage], Builder]]
"""Message id -> (its message class, its builder)."""


def builder_table(*entries: tuple[type[MAVLinkMessage], Builder]) -> BuilderTable:
    """A :data:`BuilderTable` of (message class, builder) pairs, keyed by each class's id."""
    return {cls.id: (cls, builder) for cls, builder in entries}


BUILDERS = builder_table(
    (_M.MAVLink_heartbeat_message, heartbeat),
    (_M.MAVLink_sys_status_message, sys_status),
    (_M.MAVLink_gps_raw_int_message, gps_raw_int),
    (_M.MAVLink_attitude_message, attitude),
    (_M.MAVLink_attitude_quaternion_message, attitude_quaternion),
    (_M.MAVLink_local_position_ned_message, local_position_ned),
    (_M.MAVLink_global_position_int_message, global_position_int),
    (_M.MAVLink_vfr_hud_message, vfr_hud),
    (_M.MAVLink_servo_output_raw_message, servo_output_raw),
    (_M.MAVLink_battery_status_message, battery_status),
    (_M.MAVLink_home_position_message, home_position),
    (_M.MAVLink_extended_sys_state_message, extended_sys_state),
    (_M.MAVLink_mission_current_message, mission_current),
    (_M.MAVLink_system_time_message, system_time),
    (_M.MAVLink_position_target_local_ned_message, position_target_local_ned),
    (_M.MAVLink_attitude_target_message, attitude_target),
    (_M.MAVLink_sim_state_message, sim_state),
    (_M.MAVLink_named_value_float_message, named_value_floats),
)


# ---------------------------------------------------------------------------------------------
# replies and events


def autopilot_version(sysid: int, version: tuple[int, int, int]) -> Fields:
    """AUTOPILOT_VERSION: capabilities and the ArduCopter version we speak like.

    Parameters
    ----------
    sysid : int
        Vehicle system id (also used as the board uid).
    version : tuple of 3 int
        (major, minor, patch), packed as ArduPilot does with type OFFICIAL.
    """
    major, minor, patch = version
    sw = (major << 24) | (minor << 16) | (patch << 8) | _M.FIRMWARE_VERSION_TYPE_OFFICIAL
    return AutopilotVersion(
        capabilities=AUTOPILOT_CAPABILITIES, flight_sw_version=sw, middleware_sw_version=0,
        os_sw_version=0, board_version=0, flight_custom_version=[0] * 8,
        middleware_custom_version=[0] * 8, os_custom_version=[0] * 8, vendor_id=0,
        product_id=0, uid=sysid, uid2=[0] * 18)


def command_ack(command: int, result: int, target_system: int,
                target_component: int) -> Fields:
    """COMMAND_ACK addressed to the sender of the command."""
    return CommandAck(
        command=clamp_int(command, 0, UINT16_MAX, 0), result=result, progress=0,
        result_param2=0, target_system=clamp_int(target_system, 0, UINT8_MAX, 0),
        target_component=clamp_int(target_component, 0, UINT8_MAX, 0))


def _ascii(text: str) -> str:
    return "".join(c if 32 <= ord(c) < 127 else "?" for c in text)


def statustext_chunks(severity: int, text: str, chunk_id: int) -> list[Fields]:
    """STATUSTEXT packets for ``text`` (their constructor arguments), split into 50-character
    chunks.

    A text of at most 50 characters is one packet with ``id`` 0. A longer one is sent as
    chunks sharing ``id = chunk_id`` (1..65535) with ``chunk_seq`` 0, 1, ...; the last chunk
    is shorter than 50 characters (an empty chunk follows an exact multiple of 50), which is
    how a receiver knows the text is complete. Non-printable and non-ASCII characters become
    '?'; texts beyond 20 chunks are truncated.
    """
    sev = clamp_int(severity, Severity.EMERGENCY, Severity.DEBUG, Severity.INFO)
    clean = _ascii(text)
    n = STATUSTEXT_CHUNK_LEN
    if len(clean) <= n:
        return [Statustext(severity=sev, text=clean.encode("ascii"), id=0, chunk_seq=0)]
    if not 1 <= chunk_id <= UINT16_MAX:
        raise ValueError(f"chunk_id = {chunk_id!r}: must be in 1..65535")
    clean = clean[: n * STATUSTEXT_MAX_CHUNKS - 1]
    parts = [clean[i:i + n] for i in range(0, len(clean), n)]
    if len(parts[-1]) == n:
        parts.append("")
    return [Statustext(severity=sev, text=part.encode("ascii"), id=chunk_id, chunk_seq=seq)
            for seq, part in enumerate(parts)]
