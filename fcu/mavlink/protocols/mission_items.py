"""Mission items as the mission protocol carries them (:mod:`fcu.mavlink.protocols.mission`): the
frames, :class:`WireItem` (MISSION_ITEM_INT and the legacy MISSION_ITEM), the per-item checks
(:func:`validate_item`, :func:`validate_plan_item`; the rules are in the protocol's module
docstring), and the conversions to what the vehicle flies (:func:`to_mission_item`) and
enforces (:func:`fence_areas`); :class:`MissionConfig` holds the protocol's limits and
time-outs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fcu.mavlink.geo import geo_to_ned, home_alt_amsl_m
from fcu.mavlink.port_records import GeoPoint, MissionItem
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2
from fcu.navigation.fence import FenceAreas
from flightdata.mission import MissionItem as PlannedItem
from flightdata.mission import mavlink_form

__all__ = [
    "FLOAT32_MAX",
    "GLOBAL_FRAMES",
    "INT32_MAX",
    "LOCAL_FRAMES",
    "NAV_YAW_COMMANDS",
    "PLAN_COMMANDS",
    "PLAN_NAMES",
    "RELATIVE_ALT_FRAMES",
    "SUPPORTED_FRAMES",
    "USED_PARAMS",
    "MissionConfig",
    "WireItem",
    "fence_areas",
    "set_current_refusal",
    "to_mission_item",
    "validate_item",
    "validate_plan_item",
]

_M = mavlink2
GLOBAL_FRAMES = frozenset({_M.MAV_FRAME_GLOBAL, _M.MAV_FRAME_GLOBAL_INT,
                           _M.MAV_FRAME_GLOBAL_RELATIVE_ALT, _M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
RELATIVE_ALT_FRAMES = frozenset({_M.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                                 _M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
LOCAL_FRAMES = frozenset({_M.MAV_FRAME_LOCAL_NED})
SUPPORTED_FRAMES = GLOBAL_FRAMES | LOCAL_FRAMES | {_M.MAV_FRAME_MISSION}
# NAV commands whose param4 is a yaw angle in degrees, NaN meaning "keep the heading mode".
NAV_YAW_COMMANDS = frozenset({_M.MAV_CMD_NAV_WAYPOINT, _M.MAV_CMD_NAV_LOITER_UNLIM,
                              _M.MAV_CMD_NAV_LOITER_TIME, _M.MAV_CMD_NAV_LAND,
                              _M.MAV_CMD_NAV_TAKEOFF})
# param1..4 (indices 0..3) each NAV command flies with, as ArduCopter reads them; NaN in
# the others is accepted (ArduPilot ignores them, and MAVSDK's Mission plugin fills them
# with NaN). Commands not listed here have NaN refused in all four.
USED_PARAMS: dict[int, frozenset[int]] = {
    _M.MAV_CMD_NAV_WAYPOINT: frozenset({0, 3}),  # hold time, yaw
    _M.MAV_CMD_NAV_RETURN_TO_LAUNCH: frozenset(),
    _M.MAV_CMD_NAV_LAND: frozenset({3}),  # yaw
    _M.MAV_CMD_NAV_TAKEOFF: frozenset({3}),  # yaw (param1, pitch, is for planes)
    _M.MAV_CMD_NAV_FENCE_RETURN_POINT: frozenset(),
    _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION: frozenset({0}),  # vertex count
    _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION: frozenset({0}),
    _M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION: frozenset({0}),  # radius, m
    _M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION: frozenset({0}),
    _M.MAV_CMD_NAV_RALLY_POINT: frozenset(),
}
#: The commands a fence or rally upload may hold (the plan types beside the mission).
PLAN_COMMANDS: dict[int, frozenset[int]] = {
    _M.MAV_MISSION_TYPE_FENCE: frozenset({
        _M.MAV_CMD_NAV_FENCE_RETURN_POINT, _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
        _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, _M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
        _M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION}),
    _M.MAV_MISSION_TYPE_RALLY: frozenset({_M.MAV_CMD_NAV_RALLY_POINT}),
}
PLAN_NAMES = {_M.MAV_MISSION_TYPE_FENCE: "Fence", _M.MAV_MISSION_TYPE_RALLY: "Rally"}
_INVALID_PARAM = (_M.MAV_MISSION_INVALID_PARAM1, _M.MAV_MISSION_INVALID_PARAM2,
                  _M.MAV_MISSION_INVALID_PARAM3, _M.MAV_MISSION_INVALID_PARAM4)
INT32_MAX = 0x7FFFFFFF
FLOAT32_MAX = 3.4028234663852886e38


@dataclass(frozen=True, kw_only=True)
class MissionConfig:
    """Mission-protocol limits and time-outs."""

    retry_interval_s: float = 0.5  # s, re-request a missing item after this long
    upload_timeout_s: float = 8.0  # s without an item before an upload is cancelled
    max_items: int = 700  # including home
    max_alt_m: float = 10_000.0  # m, |altitude| accepted in global frames
    max_local_m: float = 10_000.0  # m, |x|, |y|, |z| accepted in the local frame

    def __post_init__(self) -> None:
        if not self.retry_interval_s > 0:
            raise ValueError(f"retry_interval_s = {self.retry_interval_s!r}: must be > 0")
        if not self.upload_timeout_s > 0:
            raise ValueError(f"upload_timeout_s = {self.upload_timeout_s!r}: must be > 0")
        if not 1 <= self.max_items <= 65535:
            raise ValueError(f"max_items = {self.max_items!r}: must be in 1..65535")


@dataclass(frozen=True, kw_only=True)
class WireItem:
    """A mission item as received, independent of the message used to carry it.

    ``x``/``y`` are degrees in global frames and metres in the local frame; ``z`` is metres
    (AMSL, above home, or down, by frame).
    """

    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    params: tuple[float, float, float, float]
    x: float
    y: float
    z: float
    mission_type: int = _M.MAV_MISSION_TYPE_MISSION

    @staticmethod
    def _int_scale(frame: int) -> float:
        if frame in GLOBAL_FRAMES:
            return 1e7
        if frame in LOCAL_FRAMES:
            return 1e4
        return 1.0

    @classmethod
    def from_planned(cls, seq: int, item: PlannedItem) -> WireItem:
        """A mission item from a scenario file, as a ground station would upload it."""
        form = mavlink_form(item)
        return cls(seq=seq, frame=form.frame, command=form.command, current=0,
                   autocontinue=1, params=form.params, x=form.x, y=form.y, z=form.z)

    @classmethod
    def from_message(cls, msg: MAVLinkMessage) -> WireItem:
        """From MISSION_ITEM_INT (scaled integers) or MISSION_ITEM (floats)."""
        frame = int(msg.frame)
        scale = cls._int_scale(frame) if msg.get_type() == "MISSION_ITEM_INT" else 1.0
        return cls(seq=int(msg.seq), frame=frame, command=int(msg.command),
                   current=int(msg.current), autocontinue=int(msg.autocontinue),
                   params=(float(msg.param1), float(msg.param2), float(msg.param3),
                           float(msg.param4)),
                   x=float(msg.x) / scale, y=float(msg.y) / scale, z=float(msg.z),
                   mission_type=int(msg.mission_type))

    def to_message(self, use_int: bool, target_system: int,
                   target_component: int) -> MAVLinkMessage:
        """As MISSION_ITEM_INT (``use_int``) or MISSION_ITEM, for a download."""
        p1, p2, p3, p4 = self.params
        if use_int:
            scale = self._int_scale(self.frame)

            def scaled(v: float) -> int:
                if not math.isfinite(v):
                    return 0
                return max(-INT32_MAX, min(INT32_MAX, round(v * scale)))

            return _M.MAVLink_mission_item_int_message(
                target_system, target_component, self.seq, self.frame, self.command,
                self.current, self.autocontinue, p1, p2, p3, p4, scaled(self.x),
                scaled(self.y), self.z, self.mission_type)
        return _M.MAVLink_mission_item_message(
            target_system, target_component, self.seq, self.frame, self.command, self.current,
            self.autocontinue, p1, p2, p3, p4, self.x, self.y, self.z, self.mission_type)


def validate_item(item: WireItem, config: MissionConfig) -> tuple[int, str]:
    """(MAV_MISSION_RESULT, reason) for one item; (MAV_MISSION_ACCEPTED, "") when valid."""
    where = f"Mission item {item.seq}"
    if item.frame not in SUPPORTED_FRAMES:
        return _M.MAV_MISSION_UNSUPPORTED_FRAME, f"{where}: frame {item.frame} not supported"
    used = USED_PARAMS.get(item.command, frozenset(range(4)))
    for i, value in enumerate(item.params):
        nan_ok = i not in used or (i == 3 and item.command in NAV_YAW_COMMANDS)
        if math.isinf(value) or (math.isnan(value) and not nan_ok):
            return _INVALID_PARAM[i], f"{where}: param{i + 1} = {value} is not a number"
        if abs(value) > FLOAT32_MAX:  # (only a boot mission can hold one: the wire is float32)
            return _INVALID_PARAM[i], f"{where}: param{i + 1} = {value:g} beyond float32"
    if item.frame == _M.MAV_FRAME_MISSION:
        return _M.MAV_MISSION_ACCEPTED, ""
    codes = (_M.MAV_MISSION_INVALID_PARAM5_X, _M.MAV_MISSION_INVALID_PARAM6_Y,
             _M.MAV_MISSION_INVALID_PARAM7)
    for code, name, value in zip(codes, ("x", "y", "z"), (item.x, item.y, item.z), strict=True):
        if not math.isfinite(value):
            return code, f"{where}: {name} = {value} is not a number"
    if item.frame in GLOBAL_FRAMES:
        if abs(item.x) > 90.0:
            return codes[0], f"{where}: latitude {item.x:g} outside -90..90"
        if abs(item.y) > 180.0:
            return codes[1], f"{where}: longitude {item.y:g} outside -180..180"
        if abs(item.z) > config.max_alt_m:
            return codes[2], f"{where}: altitude {item.z:g} m beyond +-{config.max_alt_m:g} m"
    else:
        for code, name, value in zip(codes, ("x", "y", "z"), (item.x, item.y, item.z),
                                     strict=True):
            if abs(value) > config.max_local_m:
                return code, f"{where}: {name} {value:g} m beyond +-{config.max_local_m:g} m"
    return _M.MAV_MISSION_ACCEPTED, ""


def validate_plan_item(item: WireItem, mission_type: int, config: MissionConfig
                       ) -> tuple[int, str]:
    """(MAV_MISSION_RESULT, reason) for one fence or rally item: a command of its type, in a
    global frame, valid coordinates; a polygon vertex with a vertex count of at least 3, a
    circle with a radius > 0."""
    name = PLAN_NAMES[mission_type]
    where = f"{name} item {item.seq}"
    if item.command not in PLAN_COMMANDS[mission_type]:
        return _M.MAV_MISSION_UNSUPPORTED, f"{where}: command {item.command} not a {name} item"
    if item.frame not in GLOBAL_FRAMES:
        return _M.MAV_MISSION_UNSUPPORTED_FRAME, f"{where}: frame {item.frame} not global"
    code, reason = validate_item(item, config)
    if code != _M.MAV_MISSION_ACCEPTED:
        return code, reason.replace("Mission item", where, 1)
    p1 = item.params[0]
    if item.command in (_M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                        _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION) and \
            not (p1 >= 3 and p1 == round(p1)):
        return _M.MAV_MISSION_INVALID_PARAM1, f"{where}: vertex count {p1} is not 3 or more"
    if item.command in (_M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
                        _M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION) and not p1 > 0:
        return _M.MAV_MISSION_INVALID_PARAM1, f"{where}: radius {p1} m is not > 0"
    return _M.MAV_MISSION_ACCEPTED, ""


def fence_areas(items: Sequence[WireItem], origin: GeoPoint) -> FenceAreas:
    """The stored fence plan as local areas about ``origin``: each run of ``param1``
    polygon vertices of one kind is a polygon; each circle item a circle (radius param1)."""
    polygons: dict[int, list[np.ndarray]] = {
        _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION: [],
        _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION: []}
    circles: dict[int, list[tuple[float, float, float]]] = {
        _M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION: [], _M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION: []}
    k = 0
    while k < len(items):
        item = items[k]
        ned = geo_to_ned(item.x, item.y, origin.alt_m, origin)
        if item.command in circles:
            circles[item.command].append((float(ned[0]), float(ned[1]), item.params[0]))
        elif item.command in polygons:
            n = int(item.params[0])
            run = items[k:k + n]
            polygons[item.command].append(np.array(
                [geo_to_ned(v.x, v.y, origin.alt_m, origin)[:2] for v in run]))
            k += n
            continue
        k += 1
    return FenceAreas(
        inclusion_polygons=tuple(polygons[_M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION]),
        exclusion_polygons=tuple(polygons[_M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION]),
        inclusion_circles=tuple(circles[_M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION]),
        exclusion_circles=tuple(circles[_M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION]))


def to_mission_item(item: WireItem, origin: GeoPoint,
                    home_pos_ned: np.ndarray | None) -> MissionItem:
    """Convert a validated item to the vehicle's SI/NED form (about ``origin``).

    Relative altitudes are taken above home (above the origin while home is unset). In a
    global frame, latitude = longitude = 0 means "the current horizontal position".

    Raises
    ------
    ValueError
        When the origin does not admit a local tangent plane (near a pole).
    """
    north_east: tuple[float, float] | None = None
    down: float | None = None
    home_alt = home_alt_amsl_m(origin, home_pos_ned)
    if item.frame in GLOBAL_FRAMES:
        alt_amsl = item.z + home_alt if item.frame in RELATIVE_ALT_FRAMES else item.z
        down = origin.alt_m - alt_amsl
        if not (item.x == 0.0 and item.y == 0.0):
            ned = geo_to_ned(item.x, item.y, alt_amsl, origin)
            north_east = (float(ned[0]), float(ned[1]))
    elif item.frame in LOCAL_FRAMES:
        north_east, down = (item.x, item.y), item.z
    alt_m = None if down is None else (origin.alt_m - down) - home_alt
    yaw = item.params[3]
    yaw_rad = (math.radians(yaw) if item.command in NAV_YAW_COMMANDS and math.isfinite(yaw)
               else None)
    return MissionItem(seq=item.seq, command=item.command, autocontinue=bool(item.autocontinue),
                       params=item.params, north_east_m=north_east, down_m=down, alt_m=alt_m,
                       yaw_rad=yaw_rad)


def set_current_refusal(seq: object, total: int) -> str:
    """Why MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT ``seq`` is refused by a vehicle
    holding ``total`` items (seq is out of range, or there is no mission)."""
    if total == 0:
        return "Set mission current: no mission loaded"
    return f"Set mission current: {seq} not in 1..{total}"
