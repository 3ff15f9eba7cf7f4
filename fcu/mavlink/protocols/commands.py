"""COMMAND_LONG / COMMAND_INT dispatch, SET_MODE, and GUIDED set-points.

The request and its answer are :mod:`fcu.mavlink.protocols.command_request`'s; the handlers
of message requests and intervals, calibration and set-points are in
:mod:`fcu.mavlink.protocols.message_commands`, :mod:`fcu.mavlink.protocols.calibration_command`
and :mod:`fcu.mavlink.protocols.setpoint_commands`.

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
from dataclasses import replace

from fcu.mavlink.enums import FailureType, FailureUnit
from fcu.mavlink.port import FailureInjector, VehiclePort
from fcu.mavlink.port_records import CommandResult
from fcu.mavlink.protocols.calibration_command import CalibrationCommand
from fcu.mavlink.protocols.command_request import (
    CommandLimits,
    CommandOutcome,
    CommandRequest,
    accepted,
    denied,
    outcome_of,
    target_ned,
    unsupported,
    whole_number,
)
from fcu.mavlink.protocols.message_commands import MessageCommands
from fcu.mavlink.protocols.mission_items import RELATIVE_ALT_FRAMES, set_current_refusal
from fcu.mavlink.protocols.setpoint_commands import SetpointCommands
from fcu.mavlink.telemetry.streams import StreamScheduler
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2

__all__ = ["CommandDispatcher"]

_M = mavlink2
FORCE_MAGIC = 21196  # COMPONENT_ARM_DISARM param2 that forces arming/disarming
# DO_CHANGE_SPEED param1 -> port speed type (airspeed is taken as ground speed: no wind sensor)
_SPEED_TYPES = ("ground", "ground", "climb", "descent")


class CommandDispatcher(MessageCommands, CalibrationCommand, SetpointCommands):
    """Turns commands into port calls and one ACK result each.

    The flight, mission and system commands are handled here; message requests and
    intervals (:class:`~fcu.mavlink.protocols.message_commands.MessageCommands`), calibration
    (:class:`~fcu.mavlink.protocols.calibration_command.CalibrationCommand`) and the GUIDED
    set-points (:class:`~fcu.mavlink.protocols.setpoint_commands.SetpointCommands`) in the parts it
    is made of.

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
            _M.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda r: outcome_of(port.return_to_launch()),
            _M.MAV_CMD_NAV_LAND: lambda r: outcome_of(port.land()),
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
            return unsupported("")  # unknown: no STATUSTEXT, ground stations probe a lot
        try:
            return handler(request)
        except Exception as err:  # a port bug must not reach the receive loop
            return CommandOutcome(_M.MAV_RESULT_FAILED,
                                  f"command {request.command} failed: {type(err).__name__}")

    # ----------------------------------------------------------------------- flight
    def _takeoff(self, r: CommandRequest) -> CommandOutcome:
        alt_m = r.z
        if not (math.isfinite(alt_m) and 0.0 < alt_m <= self._limits.max_alt_m):
            return denied(f"Takeoff altitude {alt_m} m not in (0, {self._limits.max_alt_m:g}]")
        return outcome_of(self._port.takeoff(alt_m))

    def _set_mode(self, r: CommandRequest) -> CommandOutcome:
        base = whole_number(r.params[0], 0, 255)
        if base is None or not base & _M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return denied(f"Set mode: param1 = {r.params[0]} must have the custom-mode flag")
        mode = whole_number(r.params[1], 0, 255)
        if mode is None:
            return denied(f"Set mode: custom mode {r.params[1]} is not a mode number")
        return self.set_mode(mode)

    def set_mode(self, custom_mode: int) -> CommandOutcome:
        """Mode change shared by DO_SET_MODE and the legacy SET_MODE message."""
        return outcome_of(self._port.set_mode(custom_mode), heartbeat_soon=True)

    def _change_speed(self, r: CommandRequest) -> CommandOutcome:
        speed_type, speed = r.params[0], r.params[1]
        kind = whole_number(speed_type, 0, 3)
        if kind is None:
            return denied(f"Change speed: speed type {speed_type} not in 0..3")
        if speed == -1.0:
            return accepted()  # MAV_CMD: -1 = no change
        if not (math.isfinite(speed) and 0.0 < speed <= self._limits.max_speed_m_s):
            return denied(f"Change speed: {speed} m/s not in (0, {self._limits.max_speed_m_s:g}]")
        return outcome_of(self._port.change_speed(speed, _SPEED_TYPES[kind]))


    def _reposition(self, r: CommandRequest) -> CommandOutcome:
        speed, yaw_deg = r.params[0], r.params[3]
        if math.isinf(yaw_deg):
            return denied(f"Reposition: yaw {yaw_deg} is not a number")
        target = target_ned(r, self._port.snapshot(), self._limits)
        if isinstance(target, str):
            return denied(f"Reposition: {target}")
        if math.isfinite(speed) and speed > 0.0:
            if speed > self._limits.max_speed_m_s:
                return denied(f"Reposition: speed {speed} m/s above "
                               f"{self._limits.max_speed_m_s:g}")
            changed = self._port.change_speed(speed, "ground")
            if not changed.accepted:
                return outcome_of(changed)
        yaw_rad = math.radians(yaw_deg) if math.isfinite(yaw_deg) else None
        return outcome_of(self._port.goto(target, yaw_rad))

    def _orbit(self, r: CommandRequest) -> CommandOutcome:
        """DO_ORBIT (PX4's; MAVSDK's do_orbit): p1 radius m (NaN: CIRCLE_RADIUS), p2
        velocity m/s (NaN: CIRCLE_RATE; a negative radius circles counter-clockwise), p3 yaw
        behaviour (the vehicle faces the centre), p4 orbits (not counted: until told
        otherwise), centre latitude/longitude/altitude (NaN: the current one; the altitude
        is AMSL in every global frame, as PX4 reads it: MAVSDK's do_orbit sends its
        absolute altitude in MAV_FRAME_GLOBAL_RELATIVE_ALT)."""
        radius, speed = r.params[0], r.params[1]
        if math.isinf(radius) or math.isinf(speed):
            return denied(f"Orbit: radius {radius} m, velocity {speed} m/s not numbers")
        if r.frame in RELATIVE_ALT_FRAMES:  # PX4 reads DO_ORBIT's altitude as AMSL whatever
            r = replace(r, frame=_M.MAV_FRAME_GLOBAL)  # the frame (MAVSDK sends AMSL in 3)
        centre = target_ned(r, self._port.snapshot(), self._limits)
        if isinstance(centre, str):
            return denied(f"Orbit: {centre}")
        # PX4: a negative radius circles counter-clockwise; NaN velocity: the default
        signed_speed = math.copysign(abs(speed), -1.0 if radius < 0 else 1.0) \
            if math.isfinite(speed) else None
        return outcome_of(self._port.orbit(
            centre, abs(radius) if math.isfinite(radius) else None, signed_speed),
            heartbeat_soon=True)

    def _fence_enable(self, r: CommandRequest) -> CommandOutcome:
        """DO_FENCE_ENABLE (MAVProxy's ``fence enable``): p1 1 enables, 0 disables the fence
        (FENCE_ENABLE, in force at once); 2 (disable the floor only) has no floor to act on."""
        enable = whole_number(r.params[0], 0, 2)
        if enable is None:
            return denied(f"Fence enable: param1 = {r.params[0]} must be 0, 1 or 2")
        if enable == 2:
            return unsupported("Fence enable: there is no floor fence to disable")
        return outcome_of(self._set_param("FENCE_ENABLE", float(enable)))

    def _set_home(self, r: CommandRequest) -> CommandOutcome:
        use_current = r.params[0]
        if use_current == 1.0:
            return outcome_of(self._port.set_home(None))
        if use_current != 0.0:
            return denied(f"Set home: param1 = {use_current} must be 0 or 1")
        if not all(math.isfinite(v) for v in (r.x, r.y, r.z)):
            return denied(f"Set home: position ({r.x}, {r.y}, {r.z}) is not three numbers")
        target = target_ned(r, self._port.snapshot(), self._limits)
        if isinstance(target, str):
            return denied(f"Set home: {target}")
        distance_m = math.hypot(float(target[0]), float(target[1]))
        limit_m = self._limits.max_home_distance_m
        if distance_m > limit_m:
            return denied(f"Set home: {distance_m / 1000:.0f} km from the origin (limit "
                           f"{limit_m / 1000:g} km)")
        return outcome_of(self._port.set_home(target))

    # ----------------------------------------------------------------------- mission, system
    def _mission_start(self, r: CommandRequest) -> CommandOutcome:
        if self._mission_total() == 0:
            return denied("Mission start: no mission loaded")
        return outcome_of(self._port.mission_start())

    def _set_mission_current(self, r: CommandRequest) -> CommandOutcome:
        total = self._mission_total()
        seq = whole_number(r.params[0], 0, max(total, 0))
        if seq is None or total == 0:
            return denied(set_current_refusal(r.params[0], total))
        return outcome_of(self._port.mission_set_current(max(seq, 1)))

    def _reboot(self, r: CommandRequest) -> CommandOutcome:
        action = whole_number(r.params[0], 0, 3)
        if action is None:
            return denied(f"Reboot: param1 = {r.params[0]} not in 0..3")
        if action == 0:
            return accepted()
        if action != 1:
            return unsupported("Reboot: only autopilot reboot (param1 = 1) is supported")
        result = self._port.reboot()
        if result.accepted:
            return accepted(reboot=True)
        return outcome_of(result)

    def _arm_disarm(self, r: CommandRequest) -> CommandOutcome:
        arm = whole_number(r.params[0], 0, 1)
        if arm is None:
            return denied(f"Arm/disarm: param1 = {r.params[0]} must be 0 or 1")
        force = r.params[1] == FORCE_MAGIC
        result = self._port.arm(force=force) if arm else self._port.disarm(force=force)
        return outcome_of(result, heartbeat_soon=True)

    def _run_prearm_checks(self, r: CommandRequest) -> CommandOutcome:
        result = self._port.prearm_check()
        if result.accepted:
            return accepted()
        return CommandOutcome(_M.MAV_RESULT_ACCEPTED, f"PreArm: {result.reason}")

    def _inject_failure(self, r: CommandRequest) -> CommandOutcome:
        unit = whole_number(r.params[0], 0, 255)
        kind = whole_number(r.params[1], 0, 255)
        instance = whole_number(r.params[2], 0, 255)
        if unit is None or unit not in {int(u) for u in FailureUnit}:
            return denied(f"Inject failure: unknown failure unit {r.params[0]}")
        if kind is None or kind not in {int(t) for t in FailureType}:
            return denied(f"Inject failure: unknown failure type {r.params[1]}")
        if instance is None:
            return denied(f"Inject failure: instance {r.params[2]} not in 0..255")
        if self._injector is None:
            return unsupported("Inject failure: no fault injector on this vehicle")
        at = r.params[3]  # our extension: simulated time of the injection, 0/NaN = now
        at_s = float(at) if math.isfinite(at) and at > 0.0 else None
        return outcome_of(self._injector.inject_failure(unit, kind, instance, at_s))
