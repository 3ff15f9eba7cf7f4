"""COMMAND_LONG / COMMAND_INT dispatch, SET_MODE, and GUIDED set-points.

Every command addressed to us gets exactly one COMMAND_ACK (the endpoint sends it from the
:class:`CommandOutcome` returned here); an unknown command is answered
MAV_RESULT_UNSUPPORTED at once; a missing, non-finite or out-of-range parameter is answered
MAV_RESULT_DENIED with a STATUSTEXT naming it; a port that raises yields MAV_RESULT_FAILED.

Parameter conventions
---------------------
- COMMAND_LONG carries positions in param5/6/7 as latitude, longitude (degrees) and altitude
  AMSL (MAV_FRAME_GLOBAL, as MAV_CMD defines them); COMMAND_INT in x/y (degE7 in global
  frames, metres * 1e4 in MAV_FRAME_LOCAL_NED) and z with the frame it names.
  NAV_TAKEOFF's altitude is always above home (ArduPilot).
- Where MAV_CMD documents NaN (COMMAND_INT: INT32_MAX) as "use the current value" (yaw of
  DO_REPOSITION, its latitude/longitude/altitude) it is honoured; anywhere else it is DENIED.

Supported commands
------------------
NAV_RETURN_TO_LAUNCH 20, NAV_LAND 21, NAV_TAKEOFF 22 (p7 altitude above home, m),
DO_SET_MODE 176 (p1 with MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, p2 ArduCopter mode),
DO_CHANGE_SPEED 178 (p1 0/1 ground, 2 climb, 3 descent speed; p2 m/s, -1 = unchanged),
DO_SET_HOME 179 (p1 = 1: here; else p5..p7, at most ``max_home_distance_m`` from the origin),
DO_REPOSITION 192 (p4 yaw deg, position),
DO_SET_MISSION_CURRENT 224 (p1 seq), PREFLIGHT_REBOOT_SHUTDOWN 246 (p1 = 1 reboot; 0 no-op),
MISSION_START 300 (p1/p2 ignored: runs from the current item),
COMPONENT_ARM_DISARM 400 (p1 1/0, p2 = 21196 forces),
RUN_PREARM_CHECKS 401 (ArduPilot's: ACCEPTED, and when the vehicle would refuse to arm, a
STATUSTEXT ``PreArm: <reason>``, the reason arming would give),
GET_HOME_POSITION 410, INJECT_FAILURE 420 (p1 unit, p2 type, p3 instance, p4 simulated time
of the injection, s since boot, 0 = now),
GET_MESSAGE_INTERVAL 510 (p1 message id, at most 65535: MESSAGE_INTERVAL's field),
SET_MESSAGE_INTERVAL 511 (p1 message id, p2 interval us: -1 stop, 0 default; an interval
shorter than one autopilot tick is accepted and clamped to one message per tick, as ArduPilot
caps streams at its loop rate: GET_MESSAGE_INTERVAL reports the rate in force),
PREFLIGHT_CALIBRATION 241 (the sensors are simulated: gyro, compass, barometer, accelerometer
and level are accepted and reported started, in progress and done at once, in the ``[cal]``
STATUSTEXTs of PX4's calibration protocol that MAVSDK and QGroundControl parse; all
parameters 0 cancels), REQUEST_MESSAGE 512 (p1 message id), REQUEST_AUTOPILOT_CAPABILITIES
520. Any message the
vehicle can produce can be streamed and requested; a message it cannot produce gets
UNSUPPORTED (not DENIED, which is for bad parameters).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from fcu.mavlink.codec import MAVLinkMessage, mavlink2
from fcu.mavlink.enums import FailureType, FailureUnit, Severity
from fcu.mavlink.geo import geo_to_ned, home_alt_amsl_m
from fcu.mavlink.mission import (
    GLOBAL_FRAMES,
    LOCAL_FRAMES,
    RELATIVE_ALT_FRAMES,
    set_current_refusal,
)
from fcu.mavlink.port import FailureInjector, VehiclePort
from fcu.mavlink.port_records import CommandResult, VehicleSnapshot
from fcu.mavlink.streams import StreamScheduler

__all__ = ["CommandDispatcher", "CommandLimits", "CommandOutcome", "CommandRequest"]

_M = mavlink2
FORCE_MAGIC = 21196  # COMPONENT_ARM_DISARM param2 that forces arming/disarming
INT32_MAX = 0x7FFFFFFF
_TYPEMASK_POS = 0b000_000_111
_TYPEMASK_VEL = 0b000_111_000
_TYPEMASK_YAW_IGNORE = 1024
_TYPEMASK_YAW_RATE_IGNORE = 2048
_ATTITUDE_IGNORE = 128  # SET_ATTITUDE_TARGET type_mask: the attitude quaternion unused
_THROTTLE_IGNORE = 64  # SET_ATTITUDE_TARGET type_mask: the thrust unused
_MAX_INTERVAL_MSG_ID = 0xFFFF  # MESSAGE_INTERVAL.message_id is a uint16
# DO_CHANGE_SPEED param1 -> port speed type (airspeed is taken as ground speed: no wind sensor)
_SPEED_TYPES = ("ground", "ground", "climb", "descent")


@dataclass(frozen=True, kw_only=True)
class CommandLimits:
    """Ranges beyond which a command parameter is refused as absurd."""

    max_alt_m: float = 10_000.0  # m, take-off altitude, |altitude| of targets
    max_local_m: float = 10_000.0  # m, |north|, |east|, |down| of local targets
    max_speed_m_s: float = 50.0  # m/s, DO_CHANGE_SPEED and velocity set-points
    # m, horizontal distance of a new home from the NED origin (ArduCopter refuses a home
    # farther than EKF_ORIGIN_MAX_DIST_M = 50 km from its EKF origin)
    max_home_distance_m: float = 50_000.0


@dataclass(frozen=True, kw_only=True)
class CommandRequest:
    """A COMMAND_LONG or COMMAND_INT, normalised.

    Attributes
    ----------
    command : int
        MAV_CMD.
    params : tuple of 4 float
        param1..param4.
    x, y, z : float
        param5..7: latitude/longitude in degrees (global frames) or metres (local frame);
        NaN where COMMAND_INT sent INT32_MAX ("current").
    frame : int
        MAV_FRAME (MAV_FRAME_GLOBAL for COMMAND_LONG).
    """

    command: int
    params: tuple[float, float, float, float]
    x: float
    y: float
    z: float
    frame: int = _M.MAV_FRAME_GLOBAL

    @classmethod
    def from_message(cls, msg: MAVLinkMessage) -> CommandRequest:
        """From COMMAND_LONG or COMMAND_INT."""
        params = (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4))
        if msg.get_type() == "COMMAND_LONG":
            return cls(command=int(msg.command), params=params, x=float(msg.param5),
                       y=float(msg.param6), z=float(msg.param7))
        frame = int(msg.frame)
        scale = 1e7 if frame in GLOBAL_FRAMES else 1e4 if frame in LOCAL_FRAMES else 1.0

        def unscale(v: int) -> float:
            return math.nan if v == INT32_MAX else v / scale

        return cls(command=int(msg.command), params=params, x=unscale(int(msg.x)),
                   y=unscale(int(msg.y)), z=float(msg.z), frame=frame)


@dataclass(frozen=True)
class CommandOutcome:
    """The single COMMAND_ACK result, why, and what to send after the ACK."""

    result: int
    reason: str = ""
    follow_up: list[MAVLinkMessage] = field(default_factory=list)
    heartbeat_soon: bool = False  # mode/arming changed: confirm with a HEARTBEAT at once
    reboot: bool = False  # the vehicle accepted a reboot: reset the endpoint after the ACK


def _accepted(follow_up: list[MAVLinkMessage] | None = None, *,
              reboot: bool = False) -> CommandOutcome:
    return CommandOutcome(_M.MAV_RESULT_ACCEPTED, follow_up=follow_up or [], reboot=reboot)


def _denied(reason: str) -> CommandOutcome:
    return CommandOutcome(_M.MAV_RESULT_DENIED, reason)


def _unsupported(reason: str) -> CommandOutcome:
    return CommandOutcome(_M.MAV_RESULT_UNSUPPORTED, reason)


def _from_result(result: CommandResult, *, heartbeat_soon: bool = False) -> CommandOutcome:
    if result.accepted:
        return CommandOutcome(_M.MAV_RESULT_ACCEPTED, heartbeat_soon=heartbeat_soon)
    if result.unsupported:
        return CommandOutcome(_M.MAV_RESULT_UNSUPPORTED, result.reason)
    return CommandOutcome(_M.MAV_RESULT_DENIED, result.reason)


def _cal_texts(*texts: str) -> list[MAVLinkMessage]:
    """Calibration progress as STATUSTEXTs (each under 50 characters: one packet)."""
    return [_M.MAVLink_statustext_message(Severity.INFO, text.encode("ascii"), 0, 0)
            for text in texts]


def _whole(value: float, lo: int, hi: int) -> int | None:
    """``value`` as an int when it is a whole number in [lo, hi], else None."""
    if not math.isfinite(value) or value != round(value) or not lo <= value <= hi:
        return None
    return int(value)


class CommandDispatcher:
    """Turns commands into port calls and one ACK result each.

    Parameters
    ----------
    port : VehiclePort
    injector : FailureInjector or None
        Fault-injection port; None answers INJECT_FAILURE with UNSUPPORTED.
    streams : StreamScheduler
        For SET/GET_MESSAGE_INTERVAL.
    build_message : callable
        ``build_message(msg_id)`` -> the message(s) to send for REQUEST_MESSAGE; None when the
        id cannot be produced, empty when it has nothing to report now.
    mission_total : callable
        Number of mission items excluding home.
    limits : CommandLimits
    set_param : callable, optional
        ``set_param(name, value)`` for commands that change a parameter (DO_FENCE_ENABLE);
        the endpoint passes its parameter table's, so reads report the change (default: the
        port's).
    """

    def __init__(self, port: VehiclePort, injector: FailureInjector | None,
                 streams: StreamScheduler,
                 build_message: Callable[[int], list[MAVLinkMessage] | None],
                 mission_total: Callable[[], int], limits: CommandLimits, *,
                 set_param: Callable[[str, float], CommandResult] | None = None) -> None:
        self._port = port
        self._set_param = set_param if set_param is not None else (
            lambda name, value: port.set_param(name, value))
        self._injector = injector
        self._streams = streams
        self._build_message = build_message
        self._mission_total = mission_total
        self._limits = limits
        self._handlers: dict[int, Callable[[CommandRequest], CommandOutcome]] = {
            _M.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda r: _from_result(port.return_to_launch()),
            _M.MAV_CMD_NAV_LAND: lambda r: _from_result(port.land()),
            _M.MAV_CMD_NAV_TAKEOFF: self._takeoff,
            _M.MAV_CMD_DO_SET_MODE: self._set_mode,
            _M.MAV_CMD_DO_CHANGE_SPEED: self._change_speed,
            _M.MAV_CMD_DO_SET_HOME: self._set_home,
            _M.MAV_CMD_DO_REPOSITION: self._reposition,
            _M.MAV_CMD_DO_SET_MISSION_CURRENT: self._set_mission_current,
            _M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: self._reboot,
            _M.MAV_CMD_MISSION_START: self._mission_start,
            _M.MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm,
            _M.MAV_CMD_RUN_PREARM_CHECKS: self._run_prearm_checks,
            _M.MAV_CMD_GET_HOME_POSITION: lambda r: self._send_message(
                _M.MAVLINK_MSG_ID_HOME_POSITION),
            _M.MAV_CMD_INJECT_FAILURE: self._inject_failure,
            _M.MAV_CMD_GET_MESSAGE_INTERVAL: self._get_message_interval,
            _M.MAV_CMD_SET_MESSAGE_INTERVAL: self._set_message_interval,
            _M.MAV_CMD_REQUEST_MESSAGE: self._request_message,
            _M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._capabilities,
            _M.MAV_CMD_PREFLIGHT_CALIBRATION: self._calibrate,
            _M.MAV_CMD_DO_ORBIT: self._orbit,
            _M.MAV_CMD_DO_FENCE_ENABLE: self._fence_enable,
        }

    @property
    def supported(self) -> frozenset[int]:
        """MAV_CMD numbers that are handled."""
        return frozenset(self._handlers)

    def dispatch(self, request: CommandRequest) -> CommandOutcome:
        """Run ``request``; never raises (a port that raises gives MAV_RESULT_FAILED)."""
        handler = self._handlers.get(request.command)
        if handler is None:
            return _unsupported("")  # unknown: no STATUSTEXT, ground stations probe a lot
        try:
            return handler(request)
        except Exception as err:  # a port bug must not reach the receive loop
            return CommandOutcome(_M.MAV_RESULT_FAILED,
                                  f"command {request.command} failed: {type(err).__name__}")

    # ----------------------------------------------------------------------- flight
    def _takeoff(self, r: CommandRequest) -> CommandOutcome:
        alt_m = r.z
        if not (math.isfinite(alt_m) and 0.0 < alt_m <= self._limits.max_alt_m):
            return _denied(f"Takeoff altitude {alt_m} m not in (0, {self._limits.max_alt_m:g}]")
        return _from_result(self._port.takeoff(alt_m))

    def _set_mode(self, r: CommandRequest) -> CommandOutcome:
        base = _whole(r.params[0], 0, 255)
        if base is None or not base & _M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return _denied(f"Set mode: param1 = {r.params[0]} must have the custom-mode flag")
        mode = _whole(r.params[1], 0, 255)
        if mode is None:
            return _denied(f"Set mode: custom mode {r.params[1]} is not a mode number")
        return self.set_mode(mode)

    def set_mode(self, custom_mode: int) -> CommandOutcome:
        """Mode change shared by DO_SET_MODE and the legacy SET_MODE message."""
        return _from_result(self._port.set_mode(custom_mode), heartbeat_soon=True)

    def _change_speed(self, r: CommandRequest) -> CommandOutcome:
        speed_type, speed = r.params[0], r.params[1]
        kind = _whole(speed_type, 0, 3)
        if kind is None:
            return _denied(f"Change speed: speed type {speed_type} not in 0..3")
        if speed == -1.0:
            return _accepted()  # MAV_CMD: -1 = no change
        if not (math.isfinite(speed) and 0.0 < speed <= self._limits.max_speed_m_s):
            return _denied(f"Change speed: {speed} m/s not in (0, {self._limits.max_speed_m_s:g}]")
        return _from_result(self._port.change_speed(speed, _SPEED_TYPES[kind]))

    def _target_geo(self, r: CommandRequest, snap: VehicleSnapshot) -> np.ndarray | str:
        """Target NED (m) of a positional command, NaN fields -> current; or a refusal."""
        current = np.asarray(snap.pos_ned, dtype=float)
        if r.frame in GLOBAL_FRAMES:
            lat, lon, alt = r.x, r.y, r.z
            if math.isinf(lat) or (math.isfinite(lat) and abs(lat) > 90.0):
                return f"latitude {lat} outside -90..90"
            if math.isinf(lon) or (math.isfinite(lon) and abs(lon) > 180.0):
                return f"longitude {lon} outside -180..180"
            if math.isinf(alt) or (math.isfinite(alt) and abs(alt) > self._limits.max_alt_m):
                return f"altitude {alt} m beyond +-{self._limits.max_alt_m:g} m"
            base = home_alt_amsl_m(snap.origin, snap.home_pos_ned)
            alt_amsl = alt + base if r.frame in RELATIVE_ALT_FRAMES else alt
            target = geo_to_ned(lat if math.isfinite(lat) else snap.origin.lat_deg,
                                lon if math.isfinite(lon) else snap.origin.lon_deg,
                                alt_amsl if math.isfinite(alt) else snap.origin.alt_m,
                                snap.origin)
        elif r.frame in LOCAL_FRAMES:
            target = np.array([r.x, r.y, r.z])
            if np.any(np.isinf(target)) or np.any(np.abs(target) > self._limits.max_local_m):
                return f"local target {target} m beyond +-{self._limits.max_local_m:g} m"
        else:
            return f"frame {r.frame} not supported"
        # NaN (COMMAND_INT: INT32_MAX) latitude/longitude or altitude: keep the current one.
        keep_horizontal = not (math.isfinite(r.x) and math.isfinite(r.y))
        keep_vertical = not math.isfinite(r.z)
        return np.where([keep_horizontal, keep_horizontal, keep_vertical], current, target)

    def _reposition(self, r: CommandRequest) -> CommandOutcome:
        speed, yaw_deg = r.params[0], r.params[3]
        if math.isinf(yaw_deg):
            return _denied(f"Reposition: yaw {yaw_deg} is not a number")
        target = self._target_geo(r, self._port.snapshot())
        if isinstance(target, str):
            return _denied(f"Reposition: {target}")
        if math.isfinite(speed) and speed > 0.0:
            if speed > self._limits.max_speed_m_s:
                return _denied(f"Reposition: speed {speed} m/s above "
                               f"{self._limits.max_speed_m_s:g}")
            changed = self._port.change_speed(speed, "ground")
            if not changed.accepted:
                return _from_result(changed)
        yaw_rad = math.radians(yaw_deg) if math.isfinite(yaw_deg) else None
        return _from_result(self._port.goto(target, yaw_rad))

    def _orbit(self, r: CommandRequest) -> CommandOutcome:
        """DO_ORBIT (PX4's; MAVSDK's do_orbit): p1 radius m (NaN: CIRCLE_RADIUS), p2
        velocity m/s (NaN: CIRCLE_RATE; a negative radius circles counter-clockwise), p3 yaw
        behaviour (the vehicle faces the centre), p4 orbits (not counted: until told
        otherwise), centre latitude/longitude/altitude (NaN: the current one; the altitude
        is AMSL in every global frame, as PX4 reads it: MAVSDK's do_orbit sends its
        absolute altitude in MAV_FRAME_GLOBAL_RELATIVE_ALT)."""
        radius, speed = r.params[0], r.params[1]
        if math.isinf(radius) or math.isinf(speed):
            return _denied(f"Orbit: radius {radius} m, velocity {speed} m/s not numbers")
        if r.frame in RELATIVE_ALT_FRAMES:  # PX4 reads DO_ORBIT's altitude as AMSL whatever
            r = replace(r, frame=_M.MAV_FRAME_GLOBAL)  # the frame (MAVSDK sends AMSL in 3)
        centre = self._target_geo(r, self._port.snapshot())
        if isinstance(centre, str):
            return _denied(f"Orbit: {centre}")
        # PX4: a negative radius circles counter-clockwise; NaN velocity: the default
        signed_speed = math.copysign(abs(speed), -1.0 if radius < 0 else 1.0) \
            if math.isfinite(speed) else None
        return _from_result(self._port.orbit(
            centre, abs(radius) if math.isfinite(radius) else None, signed_speed),
            heartbeat_soon=True)

    def _fence_enable(self, r: CommandRequest) -> CommandOutcome:
        """DO_FENCE_ENABLE (MAVProxy's ``fence enable``): p1 1 enables, 0 disables the fence
        (FENCE_ENABLE, in force at once); 2 (disable the floor only) has no floor to act on."""
        enable = _whole(r.params[0], 0, 2)
        if enable is None:
            return _denied(f"Fence enable: param1 = {r.params[0]} must be 0, 1 or 2")
        if enable == 2:
            return _unsupported("Fence enable: there is no floor fence to disable")
        return _from_result(self._set_param("FENCE_ENABLE", float(enable)))

    def _set_home(self, r: CommandRequest) -> CommandOutcome:
        use_current = r.params[0]
        if use_current == 1.0:
            return _from_result(self._port.set_home(None))
        if use_current != 0.0:
            return _denied(f"Set home: param1 = {use_current} must be 0 or 1")
        if not all(math.isfinite(v) for v in (r.x, r.y, r.z)):
            return _denied(f"Set home: position ({r.x}, {r.y}, {r.z}) is not three numbers")
        target = self._target_geo(r, self._port.snapshot())
        if isinstance(target, str):
            return _denied(f"Set home: {target}")
        distance_m = math.hypot(float(target[0]), float(target[1]))
        limit_m = self._limits.max_home_distance_m
        if distance_m > limit_m:
            return _denied(f"Set home: {distance_m / 1000:.0f} km from the origin (limit "
                           f"{limit_m / 1000:g} km)")
        return _from_result(self._port.set_home(target))

    # ----------------------------------------------------------------------- mission, system
    def _mission_start(self, r: CommandRequest) -> CommandOutcome:
        if self._mission_total() == 0:
            return _denied("Mission start: no mission loaded")
        return _from_result(self._port.mission_start())

    def _set_mission_current(self, r: CommandRequest) -> CommandOutcome:
        total = self._mission_total()
        seq = _whole(r.params[0], 0, max(total, 0))
        if seq is None or total == 0:
            return _denied(set_current_refusal(r.params[0], total))
        return _from_result(self._port.mission_set_current(max(seq, 1)))

    def _reboot(self, r: CommandRequest) -> CommandOutcome:
        action = _whole(r.params[0], 0, 3)
        if action is None:
            return _denied(f"Reboot: param1 = {r.params[0]} not in 0..3")
        if action == 0:
            return _accepted()
        if action != 1:
            return _unsupported("Reboot: only autopilot reboot (param1 = 1) is supported")
        result = self._port.reboot()
        if result.accepted:
            return _accepted(reboot=True)
        return _from_result(result)

    def _arm_disarm(self, r: CommandRequest) -> CommandOutcome:
        arm = _whole(r.params[0], 0, 1)
        if arm is None:
            return _denied(f"Arm/disarm: param1 = {r.params[0]} must be 0 or 1")
        force = r.params[1] == FORCE_MAGIC
        result = self._port.arm(force=force) if arm else self._port.disarm(force=force)
        return _from_result(result, heartbeat_soon=True)

    def _run_prearm_checks(self, r: CommandRequest) -> CommandOutcome:
        result = self._port.prearm_check()
        if result.accepted:
            return _accepted()
        return CommandOutcome(_M.MAV_RESULT_ACCEPTED, f"PreArm: {result.reason}")

    def _inject_failure(self, r: CommandRequest) -> CommandOutcome:
        unit = _whole(r.params[0], 0, 255)
        kind = _whole(r.params[1], 0, 255)
        instance = _whole(r.params[2], 0, 255)
        if unit is None or unit not in {int(u) for u in FailureUnit}:
            return _denied(f"Inject failure: unknown failure unit {r.params[0]}")
        if kind is None or kind not in {int(t) for t in FailureType}:
            return _denied(f"Inject failure: unknown failure type {r.params[1]}")
        if instance is None:
            return _denied(f"Inject failure: instance {r.params[2]} not in 0..255")
        if self._injector is None:
            return _unsupported("Inject failure: no fault injector on this vehicle")
        at = r.params[3]  # our extension: simulated time of the injection, 0/NaN = now
        at_s = float(at) if math.isfinite(at) and at > 0.0 else None
        return _from_result(self._injector.inject_failure(unit, kind, instance, at_s))

    # ----------------------------------------------------------------------- calibration
    def _calibrate(self, r: CommandRequest) -> CommandOutcome:
        """PREFLIGHT_CALIBRATION on simulated sensors: accepted, then the progress texts
        ground stations parse (PX4's ``[cal]`` protocol, version 2: started, progress,
        done), at once; all parameters 0 cancels (nothing runs long enough to cancel)."""
        values = (r.params[0], r.params[1], r.params[2], r.params[3], r.x, r.y, r.z)
        codes = [_whole(v, 0, 255) if math.isfinite(v) else 0 for v in values]
        if any(c is None for c in codes):
            return _denied(f"Calibration: parameters {values} must be whole numbers")
        if not any(codes):
            return _accepted(follow_up=_cal_texts("[cal] calibration cancelled"))
        which = [name for name, on in (
            ("gyro", codes[0] == 1), ("mag", codes[1] == 1), ("baro", codes[2] == 1),
            ("accel", codes[4] in (1, 4)), ("level", codes[4] == 2)) if on]
        others = [i + 1 for i, c in enumerate(codes) if c and i not in (0, 1, 2, 4)]
        if others or not which or codes[4] not in (0, 1, 2, 4):
            return _unsupported(f"Calibration {values}: only gyro (p1), compass (p2), "
                                "barometer (p3), accelerometer and level (p5 1, 2, 4)")
        if self._port.snapshot().armed:
            return _denied("Calibration refused: disarm first")
        texts: list[str] = []
        for name in which:
            texts += [f"[cal] calibration started: 2 {name}", "[cal] progress <50>",
                      "[cal] progress <100>", f"[cal] calibration done: {name}"]
        return _accepted(follow_up=_cal_texts(*texts))

    # ----------------------------------------------------------------------- messages
    def _send_message(self, msg_id: int) -> CommandOutcome:
        messages = self._build_message(msg_id)
        if messages is None:
            return _unsupported(f"Message {msg_id} not supported")
        if not messages:
            return CommandOutcome(_M.MAV_RESULT_TEMPORARILY_REJECTED,
                                  f"Message {msg_id} not available yet")
        return _accepted(follow_up=messages)

    def _request_message(self, r: CommandRequest) -> CommandOutcome:
        msg_id = _whole(r.params[0], 0, 0xFFFFFF)
        if msg_id is None:
            return _denied(f"Request message: param1 = {r.params[0]} is not a message id")
        return self._send_message(msg_id)

    def _capabilities(self, r: CommandRequest) -> CommandOutcome:
        flag = _whole(r.params[0], 0, 1)
        if flag is None:
            return _denied(f"Request capabilities: param1 = {r.params[0]} must be 0 or 1")
        if flag == 0:
            return _accepted()
        return self._send_message(_M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)

    def _set_message_interval(self, r: CommandRequest) -> CommandOutcome:
        msg_id = _whole(r.params[0], 0, 0xFFFFFF)
        interval_us = r.params[1]
        if msg_id is None:
            return _denied(f"Set interval: param1 = {r.params[0]} is not a message id")
        if not self._streams.has(msg_id):  # a message id, but one we cannot produce
            return _unsupported(f"Set interval: message {msg_id} cannot be streamed")
        if not math.isfinite(interval_us) or (interval_us < 0 and interval_us != -1.0):
            return _denied(f"Set interval: interval {interval_us} us invalid")
        if interval_us == -1.0:
            rate: float | None = 0.0
        elif interval_us == 0.0:
            rate = None
        else:
            rate = 1e6 / interval_us
        try:
            self._streams.set_rate(msg_id, rate)
        except ValueError as err:
            return _denied(f"Set interval: {err}")
        return _accepted()

    def _get_message_interval(self, r: CommandRequest) -> CommandOutcome:
        msg_id = _whole(r.params[0], 0, 0xFFFFFF)
        if msg_id is None:
            return _denied(f"Get interval: param1 = {r.params[0]} is not a message id")
        if msg_id > _MAX_INTERVAL_MSG_ID:
            return _denied(f"Get interval: message id {msg_id} above {_MAX_INTERVAL_MSG_ID} "
                           "(MESSAGE_INTERVAL cannot carry it)")
        if not self._streams.has(msg_id):
            interval_us = 0  # MESSAGE_INTERVAL: 0 = not available
        else:
            rate = self._streams.rate_hz(msg_id)
            interval_us = -1 if rate <= 0 else min(round(1e6 / rate), INT32_MAX)
        return _accepted(follow_up=[_M.MAVLink_message_interval_message(msg_id, interval_us)])

    # ----------------------------------------------------------------------- set-points
    def position_target_local(self, msg: MAVLinkMessage) -> CommandResult:
        """SET_POSITION_TARGET_LOCAL_NED: GUIDED go-to (position) or velocity set-point.

        Frames LOCAL_NED (absolute), LOCAL_OFFSET_NED (offset from the current position) and
        BODY_NED / BODY_OFFSET_NED (offset and velocity rotated by the current heading).
        Position is used when none of x, y, z is masked; else velocity when none of vx, vy,
        vz is masked; other masks are refused. Yaw unless YAW_IGNORE is set.
        """
        frame = int(msg.coordinate_frame)
        frames = (_M.MAV_FRAME_LOCAL_NED, _M.MAV_FRAME_LOCAL_OFFSET_NED, _M.MAV_FRAME_BODY_NED,
                  _M.MAV_FRAME_BODY_OFFSET_NED)
        if frame not in frames:
            return CommandResult.denied(f"Position target: frame {frame} not supported")
        snap = self._port.snapshot()
        yaw_now = float(snap.euler_rad[2])
        c, s = math.cos(yaw_now), math.sin(yaw_now)
        body = frame in (_M.MAV_FRAME_BODY_NED, _M.MAV_FRAME_BODY_OFFSET_NED)

        def rotate(v: np.ndarray) -> np.ndarray:
            return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]) if body else v

        return self._set_point(msg, snap, rotate,
                               np.array([msg.x, msg.y, msg.z], dtype=float),
                               offset=frame != _M.MAV_FRAME_LOCAL_NED, body=body)

    def position_target_global(self, msg: MAVLinkMessage) -> CommandResult:
        """SET_POSITION_TARGET_GLOBAL_INT: as the local form, position in degE7 and m."""
        frame = int(msg.coordinate_frame)
        if frame not in GLOBAL_FRAMES:
            return CommandResult.denied(f"Position target: frame {frame} not supported")
        snap = self._port.snapshot()
        pos = np.array([math.nan, math.nan, math.nan])
        if not int(msg.type_mask) & _TYPEMASK_POS:
            r = CommandRequest(command=0, params=(0.0, 0.0, 0.0, 0.0),
                               x=int(msg.lat_int) / 1e7, y=int(msg.lon_int) / 1e7,
                               z=float(msg.alt), frame=frame)
            if not all(math.isfinite(v) for v in (r.x, r.y, r.z)):
                return CommandResult.denied("Position target: position is not a number")
            target = self._target_geo(r, snap)
            if isinstance(target, str):
                return CommandResult.denied(f"Position target: {target}")
            pos = target
        return self._set_point(msg, snap, lambda v: v, pos, offset=False, body=False)

    def _set_point(self, msg: MAVLinkMessage, snap: VehicleSnapshot,
                   rotate: Callable[[np.ndarray], np.ndarray], pos: np.ndarray,
                   offset: bool, body: bool) -> CommandResult:
        mask = int(msg.type_mask)
        yaw: float | None = None
        yaw_rate: float | None = None
        if not mask & _TYPEMASK_YAW_IGNORE:
            yaw = float(msg.yaw)
            if not math.isfinite(yaw):
                return CommandResult.denied("Position target: yaw is not a number")
        elif not mask & _TYPEMASK_YAW_RATE_IGNORE:
            yaw_rate = float(msg.yaw_rate)
            if not math.isfinite(yaw_rate):
                return CommandResult.denied("Position target: yaw rate is not a number")
        if not mask & _TYPEMASK_POS:
            if not np.all(np.isfinite(pos)):
                return CommandResult.denied("Position target: position is not a number")
            target = rotate(pos)
            if offset:
                target = np.asarray(snap.pos_ned, dtype=float) + target
            if np.any(np.abs(target) > self._limits.max_local_m):
                return CommandResult.denied(
                    f"Position target beyond +-{self._limits.max_local_m:g} m")
            return self._port.goto(target, yaw)
        if (mask & _TYPEMASK_POS) == _TYPEMASK_POS and not mask & _TYPEMASK_VEL:
            vel = np.array([msg.vx, msg.vy, msg.vz], dtype=float)
            if not np.all(np.isfinite(vel)):
                return CommandResult.denied("Velocity target is not a number")
            if float(np.linalg.norm(vel)) > self._limits.max_speed_m_s:
                return CommandResult.denied(
                    f"Velocity target above {self._limits.max_speed_m_s:g} m/s")
            # a body-frame velocity stays in the heading frame (it turns with the vehicle)
            return self._port.set_velocity(vel, yaw, yaw_rate, heading_frame=body)
        return CommandResult.not_supported(f"Position target: type_mask 0x{mask:x} not supported")

    def attitude_target(self, msg: MAVLinkMessage) -> CommandResult:
        """SET_ATTITUDE_TARGET in GUIDED: the quaternion's roll, pitch and yaw, and the thrust
        (0..1; ignored: 0.5, hold the altitude), which the vehicle reads as ArduCopter does
        (:meth:`fcu.navigation.guided_setpoints.GuidedSetpoints.set_attitude`). Body rates
        alone are not flown."""
        mask = int(msg.type_mask)
        if mask & _ATTITUDE_IGNORE:
            return CommandResult.not_supported(
                "Attitude target: body rates alone not supported: send a quaternion")
        q = np.array(msg.q, dtype=float)
        norm = float(np.linalg.norm(q)) if np.all(np.isfinite(q)) else math.nan
        if not math.isfinite(norm) or abs(norm - 1.0) > 0.1:
            return CommandResult.denied(f"Attitude target: quaternion {list(q)} is not a "
                                        "unit quaternion")
        w, x, y, z = q / norm
        roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
        pitch = math.asin(min(max(2.0 * (w * y - z * x), -1.0), 1.0))
        yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        thrust = 0.5
        if not mask & _THROTTLE_IGNORE:
            thrust = float(msg.thrust)
            if not math.isfinite(thrust) or not 0.0 <= thrust <= 1.0:
                return CommandResult.denied(f"Attitude target: thrust {thrust} outside [0, 1]")
        return self._port.set_attitude(roll, pitch, yaw, thrust)
