"""GUIDED set-points: SET_POSITION_TARGET_LOCAL_NED, SET_POSITION_TARGET_GLOBAL_INT and
SET_ATTITUDE_TARGET, checked and handed to the vehicle port as a go-to, a velocity or an
attitude.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from fcu.mavlink.port import VehiclePort
from fcu.mavlink.port_records import CommandResult, VehicleSnapshot
from fcu.mavlink.protocols.command_request import CommandLimits, CommandRequest, target_ned
from fcu.mavlink.protocols.mission_items import GLOBAL_FRAMES
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2

__all__ = ["SetpointCommands"]

_M = mavlink2
_TYPEMASK_POS = 0b000_000_111
_TYPEMASK_VEL = 0b000_111_000
_TYPEMASK_YAW_IGNORE = 1024
_TYPEMASK_YAW_RATE_IGNORE = 2048
_ATTITUDE_IGNORE = 128  # SET_ATTITUDE_TARGET type_mask: the attitude quaternion unused
_THROTTLE_IGNORE = 64  # SET_ATTITUDE_TARGET type_mask: the thrust unused


class SetpointCommands:
    """GUIDED set-points (module docstring); a part of
    :class:`fcu.mavlink.protocols.commands.CommandDispatcher`, whose port and limits it uses."""

    _port: VehiclePort
    _limits: CommandLimits

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
            target = target_ned(r, snap, self._limits)
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
