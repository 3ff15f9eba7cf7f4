"""A MAVLink command as the dispatcher sees it: the request, its answer and its limits.

:class:`CommandRequest` normalises COMMAND_LONG and COMMAND_INT (positions in degrees or
metres, NaN for "current"); :class:`CommandOutcome` is the one COMMAND_ACK result with what
follows it, built by :func:`accepted`, :func:`denied`, :func:`unsupported` and
:func:`outcome_of` (from the vehicle's :class:`~fcu.mavlink.port_records.CommandResult`);
:class:`CommandLimits` bounds the parameters; :func:`whole_number` and :func:`target_ned`
read parameters (a whole number in range; a positional command's target in local NED).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fcu.mavlink.geo import geo_to_ned, home_alt_amsl_m
from fcu.mavlink.port_records import CommandResult, VehicleSnapshot
from fcu.mavlink.protocols.mission_items import GLOBAL_FRAMES, LOCAL_FRAMES, RELATIVE_ALT_FRAMES
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2

__all__ = ["INT32_MAX", "CommandLimits", "CommandOutcome", "CommandRequest", "accepted",
           "denied", "outcome_of", "target_ned", "unsupported", "whole_number"]

_M = mavlink2
INT32_MAX = 0x7FFFFFFF


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


def accepted(follow_up: list[MAVLinkMessage] | None = None, *,
             reboot: bool = False) -> CommandOutcome:
    """MAV_RESULT_ACCEPTED, with what to send after the ACK."""
    return CommandOutcome(_M.MAV_RESULT_ACCEPTED, follow_up=follow_up or [], reboot=reboot)


def denied(reason: str) -> CommandOutcome:
    """MAV_RESULT_DENIED (a bad parameter), saying why."""
    return CommandOutcome(_M.MAV_RESULT_DENIED, reason)


def unsupported(reason: str) -> CommandOutcome:
    """MAV_RESULT_UNSUPPORTED, saying why."""
    return CommandOutcome(_M.MAV_RESULT_UNSUPPORTED, reason)


def outcome_of(result: CommandResult, *, heartbeat_soon: bool = False) -> CommandOutcome:
    """The ACK result of the vehicle's answer ``result``."""
    if result.accepted:
        return CommandOutcome(_M.MAV_RESULT_ACCEPTED, heartbeat_soon=heartbeat_soon)
    if result.unsupported:
        return CommandOutcome(_M.MAV_RESULT_UNSUPPORTED, result.reason)
    return CommandOutcome(_M.MAV_RESULT_DENIED, result.reason)


def whole_number(value: float, lo: int, hi: int) -> int | None:
    """``value`` as an int when it is a whole number in [lo, hi], else None."""
    if not math.isfinite(value) or value != round(value) or not lo <= value <= hi:
        return None
    return int(value)


def target_ned(r: CommandRequest, snap: VehicleSnapshot, limits: CommandLimits
               ) -> np.ndarray | str:
    """Target NED (m) of a positional command, NaN fields -> current; or a refusal."""
    current = np.asarray(snap.pos_ned, dtype=float)
    if r.frame in GLOBAL_FRAMES:
        lat, lon, alt = r.x, r.y, r.z
        if math.isinf(lat) or (math.isfinite(lat) and abs(lat) > 90.0):
            return f"latitude {lat} outside -90..90"
        if math.isinf(lon) or (math.isfinite(lon) and abs(lon) > 180.0):
            return f"longitude {lon} outside -180..180"
        if math.isinf(alt) or (math.isfinite(alt) and abs(alt) > limits.max_alt_m):
            return f"altitude {alt} m beyond +-{limits.max_alt_m:g} m"
        base = home_alt_amsl_m(snap.origin, snap.home_pos_ned)
        alt_amsl = alt + base if r.frame in RELATIVE_ALT_FRAMES else alt
        target = geo_to_ned(lat if math.isfinite(lat) else snap.origin.lat_deg,
                            lon if math.isfinite(lon) else snap.origin.lon_deg,
                            alt_amsl if math.isfinite(alt) else snap.origin.alt_m,
                            snap.origin)
    elif r.frame in LOCAL_FRAMES:
        target = np.array([r.x, r.y, r.z])
        if np.any(np.isinf(target)) or np.any(np.abs(target) > limits.max_local_m):
            return f"local target {target} m beyond +-{limits.max_local_m:g} m"
    else:
        return f"frame {r.frame} not supported"
    # NaN (COMMAND_INT: INT32_MAX) latitude/longitude or altitude: keep the current one.
    keep_horizontal = not (math.isfinite(r.x) and math.isfinite(r.y))
    keep_vertical = not math.isfinite(r.z)
    return np.where([keep_horizontal, keep_horizontal, keep_vertical], current, target)
