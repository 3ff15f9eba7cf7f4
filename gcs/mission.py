"""Missions as a ground station uploads them: MAVLink mission items, the thesis mission, files.

A :class:`WireItem` is one MISSION_ITEM_INT as it goes on the wire (ArduPilot flavour: seq 0
is home, the first real item is seq 1). :func:`thesis_mission` is the chapter-7 flight in
those terms; :func:`load_mission` reads a mission file:

- QGC WPL 110 text (what MAVProxy's ``wp save`` and Mission Planner write; ``.txt`` or
  ``.waypoints``): a ``QGC WPL 110`` line, then one tab- or space-separated line per item
  ``seq current frame command p1 p2 p3 p4 x y z autocontinue`` with x/y in degrees
  (global frames) or metres (local frame). Its seq 0 is home.
- TOML (``.toml``), an array of tables ``[[items]]`` without home, each either a named
  command like the scenario files' missions::

      [[items]]
      command = "takeoff"        # waypoint | takeoff | land | rtl | change_speed
      alt_m = 0.6                # takeoff: m above home
      [[items]]
      command = "waypoint"
      pos_ned = [1.0, 0.0, -0.6] # m, NED about the vehicle's origin (home at boot)
      hold_s = 1.0               # s
      [[items]]
      command = "change_speed"
      speed_type = "ground"      # ground | climb | descent
      speed_m_s = 0.15

  or a raw item ``{ mav_cmd = 16, frame = 1, params = [0, 0, 0, 0], x = 0, y = 0, z = 0 }``
  (frame numbers of MAV_FRAME; x/y in degrees or metres as above).
- QGroundControl plans (``.plan``, JSON; :func:`load_plan`), as QGC saves them: the
  ``mission`` section's ``SimpleItem`` entries (``command``, ``frame``, ``params`` of seven
  values: param1..4, latitude, longitude, altitude; ``null`` for NaN; ``autoContinue``), its
  ``geoFence`` (``polygons`` of ``[lat, lon]`` vertices, ``circles`` with a ``center`` and a
  ``radius``, each ``inclusion`` or not) and its ``rallyPoints`` (``[lat, lon, alt]``), the
  last two turned into the fence and rally items QGC uploads (NAV_FENCE_POLYGON_VERTEX_*,
  NAV_FENCE_CIRCLE_*, NAV_RALLY_POINT). ``plannedHomePosition`` is not used (home is the
  vehicle's). Complex items (survey, corridor and structure scans), whose waypoints QGC
  computes, are refused by name.

Home (seq 0) is replaced by the vehicle's HOME_POSITION when the upload happens, as MAVProxy
and QGroundControl do.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from flightdata.mission import MavlinkForm, MissionItem, mavlink_form
from flightdata.mission import thesis_mission as shared_thesis_mission
from gcs.mavlink import MAVLinkMessage, mavlink2

__all__ = [
    "MissionFileError",
    "PlanSections",
    "WireItem",
    "home_item",
    "load_mission",
    "load_plan",
    "thesis_mission",
    "wire_item",
]

_M = mavlink2
_GLOBAL_FRAMES = frozenset({_M.MAV_FRAME_GLOBAL, _M.MAV_FRAME_GLOBAL_INT,
                            _M.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                            _M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                            _M.MAV_FRAME_GLOBAL_TERRAIN_ALT, _M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
_LOCAL_FRAMES = frozenset({_M.MAV_FRAME_LOCAL_NED, _M.MAV_FRAME_LOCAL_ENU,
                           _M.MAV_FRAME_LOCAL_OFFSET_NED})
_NAMED_COMMANDS = {"waypoint": _M.MAV_CMD_NAV_WAYPOINT, "takeoff": _M.MAV_CMD_NAV_TAKEOFF,
                   "land": _M.MAV_CMD_NAV_LAND, "rtl": _M.MAV_CMD_NAV_RETURN_TO_LAUNCH,
                   "change_speed": _M.MAV_CMD_DO_CHANGE_SPEED}


class MissionFileError(ValueError):
    """A mission file that cannot be used; the message names the file, the item and the key."""


@dataclass(frozen=True, kw_only=True)
class WireItem(MavlinkForm):
    """One mission item as MISSION_ITEM_INT carries it: a
    :class:`flightdata.mission.MavlinkForm` (command, frame, params, x, y, z; x, y in
    degrees in global frames) and its autocontinue flag."""

    autocontinue: bool = True

    def _int_scale(self) -> float:
        if self.frame in _GLOBAL_FRAMES:
            return 1e7
        if self.frame in _LOCAL_FRAMES:
            return 1e4
        return 1.0

    def to_message(self, seq: int, target_system: int, target_component: int, *,
                   current: bool = False,
                   mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> MAVLinkMessage:
        """MISSION_ITEM_INT for this item at ``seq``."""
        scale = self._int_scale()

        def scaled(value: float) -> int:
            if not math.isfinite(value):
                return 0x7FFFFFFF  # INT32_MAX: "unset" in MISSION_ITEM_INT
            return max(-0x7FFFFFFF, min(0x7FFFFFFF, int(round(value * scale))))

        p1, p2, p3, p4 = self.params
        return _M.MAVLink_mission_item_int_message(
            target_system, target_component, seq, self.frame, self.command, int(current),
            int(self.autocontinue), p1, p2, p3, p4, scaled(self.x), scaled(self.y),
            float(self.z), mission_type)

    def describe(self) -> str:
        """A short readable form, e.g. ``NAV_WAYPOINT LOCAL_NED (1, 0, -0.6) p1=1``."""
        name = _M.enums["MAV_CMD"][self.command].name if self.command in _M.enums[
            "MAV_CMD"] else str(self.command)
        frame = _M.enums["MAV_FRAME"][self.frame].name if self.frame in _M.enums[
            "MAV_FRAME"] else str(self.frame)
        params = " ".join(f"p{i + 1}={v:g}" for i, v in enumerate(self.params)
                          if v != 0 and not math.isnan(v))
        where = "" if self.frame == _M.MAV_FRAME_MISSION else \
            f" ({self.x:g}, {self.y:g}, {self.z:g})"
        return f"{name.removeprefix('MAV_CMD_')} {frame.removeprefix('MAV_FRAME_')}{where}" \
            + (f" {params}" if params else "")


def home_item(lat_deg: float = 0.0, lon_deg: float = 0.0, alt_amsl_m: float = 0.0) -> WireItem:
    """Seq 0: home, as ArduPilot expects it (NAV_WAYPOINT, MAV_FRAME_GLOBAL, AMSL)."""
    return WireItem(command=_M.MAV_CMD_NAV_WAYPOINT, frame=_M.MAV_FRAME_GLOBAL,
                    x=lat_deg, y=lon_deg, z=alt_amsl_m)


def wire_item(item: MissionItem) -> WireItem:
    """The MISSION_ITEM_INT of one mission item (:func:`flightdata.mission.mavlink_form`)."""
    return WireItem(**asdict(mavlink_form(item)))


def thesis_mission(**plan: float) -> list[WireItem]:
    """The chapter-7 flight (:func:`flightdata.mission.thesis_mission`, same keyword
    arguments) as items seq 1..10; home is added at upload."""
    return [wire_item(item) for item in shared_thesis_mission(**plan)]


# ------------------------------------------------------------------------------ files


def _fail(path: Path, where: str, why: str) -> MissionFileError:
    return MissionFileError(f"{path}: {where}: {why}")


def _number(path: Path, where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _fail(path, where, f"{value!r} is not a number")
    return float(value)


def _vector3(path: Path, where: str, value: Any) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise _fail(path, where, f"{value!r} must be three numbers [north, east, down] in m")
    a, b, c = (_number(path, where, v) for v in value)
    return a, b, c


_NAMED_KEYS = {"waypoint": {"pos_ned", "hold_s", "yaw_deg"}, "takeoff": {"alt_m"},
               "land": {"pos_ned"}, "rtl": set(), "change_speed": {"speed_type", "speed_m_s"}}
_RAW_KEYS = {"mav_cmd", "frame", "params", "x", "y", "z", "autocontinue"}


def _item_from_table(path: Path, index: int, table: Mapping[str, Any]) -> WireItem:
    where = f"items[{index}]"
    if "mav_cmd" in table:
        extra = sorted(set(table) - _RAW_KEYS)
        if extra:
            raise _fail(path, where, f"unknown key {extra[0]} (raw items take "
                        f"{', '.join(sorted(_RAW_KEYS))})")
        params = table.get("params", [0.0, 0.0, 0.0, 0.0])
        if not isinstance(params, list) or len(params) != 4:
            raise _fail(path, f"{where}.params", f"{params!r} must be four numbers")
        p = tuple(_number(path, f"{where}.params", v) for v in params)
        return WireItem(command=int(_number(path, f"{where}.mav_cmd", table["mav_cmd"])),
                        frame=int(_number(path, f"{where}.frame",
                                          table.get("frame", _M.MAV_FRAME_MISSION))),
                        params=(p[0], p[1], p[2], p[3]),
                        x=_number(path, f"{where}.x", table.get("x", 0.0)),
                        y=_number(path, f"{where}.y", table.get("y", 0.0)),
                        z=_number(path, f"{where}.z", table.get("z", 0.0)),
                        autocontinue=bool(table.get("autocontinue", True)))
    command = table.get("command")
    if command not in _NAMED_COMMANDS:
        raise _fail(path, f"{where}.command", f"{command!r} must be one of "
                    f"{', '.join(_NAMED_COMMANDS)} (or give a raw mav_cmd)")
    extra = sorted(set(table) - _NAMED_KEYS[command] - {"command"})
    if extra:
        raise _fail(path, where, f"unknown key {extra[0]} for {command} (allowed: "
                    f"{', '.join(sorted(_NAMED_KEYS[command])) or 'none'})")
    try:
        if command == "waypoint":
            if "pos_ned" not in table:
                raise _fail(path, where, "a waypoint needs pos_ned = [north, east, down] (m)")
            yaw = table.get("yaw_deg")
            item = MissionItem(
                command="waypoint", pos_ned=_vector3(path, f"{where}.pos_ned", table["pos_ned"]),
                hold_s=_number(path, f"{where}.hold_s", table.get("hold_s", 0.0)),
                yaw_rad=None if yaw is None else math.radians(
                    _number(path, f"{where}.yaw_deg", yaw)))
        elif command == "takeoff":
            item = MissionItem(command="takeoff",
                               alt_m=_number(path, f"{where}.alt_m", table.get("alt_m", 0.0)))
        elif command == "land":
            pos = table.get("pos_ned")
            item = MissionItem(command="land", pos_ned=None if pos is None else
                               _vector3(path, f"{where}.pos_ned", pos))
        elif command == "rtl":
            item = MissionItem(command="rtl")
        else:
            item = MissionItem(command="change_speed",
                               speed_type=table.get("speed_type", "ground"),
                               speed_m_s=_number(path, f"{where}.speed_m_s",
                                                 table.get("speed_m_s", 0.0)))
    except ValueError as err:  # ConfigError: "<key> = <value>: <allowed>"
        if isinstance(err, MissionFileError):
            raise
        raise _fail(path, where, str(err)) from None
    return wire_item(item)


def _load_toml(path: Path) -> list[WireItem]:
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise MissionFileError(f"{path}: not valid TOML: {err}") from None
    if "mission" in data and "items" not in data:  # a scenario file's [mission] table
        data = data["mission"]
    items = data.get("items")
    if not isinstance(items, list) or not items:
        raise _fail(path, "items", "must be a non-empty array of tables [[items]]")
    return [_item_from_table(path, i, t) for i, t in enumerate(items)]


def _load_wpl(path: Path) -> list[WireItem]:
    lines = [ln.strip() for ln in path.read_text(encoding="utf-8").splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("#")]
    if not lines or not lines[0].startswith("QGC WPL"):
        raise _fail(path, "line 1", "a waypoint file starts with 'QGC WPL 110'")
    items: list[WireItem] = []
    for number, line in enumerate(lines[1:], start=2):
        fields = line.split()
        if len(fields) != 12:
            raise _fail(path, f"line {number}", f"{len(fields)} fields, expected 12 (seq "
                        "current frame command p1 p2 p3 p4 x y z autocontinue)")
        try:
            values = [float(f) for f in fields]
        except ValueError:
            raise _fail(path, f"line {number}", "a field is not a number") from None
        items.append(WireItem(command=int(values[3]), frame=int(values[2]),
                              params=(values[4], values[5], values[6], values[7]),
                              x=values[8], y=values[9], z=values[10],
                              autocontinue=bool(values[11])))
    if len(items) < 2:
        raise _fail(path, "items", "needs home (seq 0) and at least one item")
    return items[1:]  # seq 0 is home, replaced by the vehicle's at upload


@dataclass(frozen=True)
class PlanSections:
    """The three sections of a QGroundControl ``.plan`` file as the items uploaded for them.

    Attributes
    ----------
    mission : list of WireItem
        Items seq 1..n (home is added at upload).
    fence : list of WireItem
        MAV_MISSION_TYPE_FENCE items (polygon vertices and circles), seq 0..
    rally : list of WireItem
        MAV_MISSION_TYPE_RALLY items, seq 0..
    """

    mission: list[WireItem]
    fence: list[WireItem]
    rally: list[WireItem]


def _plan_number(path: Path, where: str, value: Any, *, nullable: bool = False) -> float:
    if value is None and nullable:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(
            float(value)):
        raise _fail(path, where, f"{json.dumps(value)} is not a number"
                    + (" (or null)" if nullable else ""))
    return float(value)


def _plan_section(path: Path, data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    section = data.get(key, {})
    if not isinstance(section, dict):
        raise _fail(path, key, "must be a JSON object")
    return section


def _plan_list(path: Path, section: Mapping[str, Any], where: str, key: str) -> list[Any]:
    value = section.get(key, [])
    if not isinstance(value, list):
        raise _fail(path, f"{where}.{key}", "must be a JSON array")
    return value


def _latlon(path: Path, where: str, value: Any, n: int = 2) -> list[float]:
    if not isinstance(value, list) or len(value) != n:
        shape = "[latitude, longitude]" if n == 2 else "[latitude, longitude, altitude]"
        raise _fail(path, where, f"{json.dumps(value)} must be {shape}")
    out = [_plan_number(path, where, v) for v in value]
    if not (-90.0 <= out[0] <= 90.0 and -180.0 <= out[1] <= 180.0):
        raise _fail(path, where, f"latitude {out[0]:g}, longitude {out[1]:g} out of range")
    return out


def _plan_item(path: Path, where: str, item: Any) -> WireItem:
    if not isinstance(item, dict):
        raise _fail(path, where, "must be a JSON object")
    kind = item.get("type")
    if kind == "ComplexItem":
        raise _fail(path, where, f"complex item {item.get('complexItemType', '?')!r}: not "
                    "supported (only SimpleItem; QGC computes a survey's or a scan's "
                    "waypoints itself)")
    if kind != "SimpleItem":
        raise _fail(path, f"{where}.type", f"{json.dumps(kind)} must be \"SimpleItem\"")
    for key in ("command", "frame", "params"):
        if key not in item:
            raise _fail(path, where, f"no {key!r}")
    command = _plan_number(path, f"{where}.command", item["command"])
    frame = _plan_number(path, f"{where}.frame", item["frame"])
    if not (command.is_integer() and 0 <= command <= 65535):
        raise _fail(path, f"{where}.command", f"{command:g} is not a MAV_CMD number")
    if not (frame.is_integer() and 0 <= frame <= 255):
        raise _fail(path, f"{where}.frame", f"{frame:g} is not a MAV_FRAME number")
    params = item["params"]
    if not isinstance(params, list) or len(params) != 7:
        got = f"{len(params)} values" if isinstance(params, list) else json.dumps(params)
        raise _fail(path, f"{where}.params", f"{got}: expected 7 (param1..4, latitude, "
                    "longitude, altitude; null for none)")
    p = [_plan_number(path, f"{where}.params[{i}]", v, nullable=True)
         for i, v in enumerate(params)]
    auto = item.get("autoContinue", True)
    if not isinstance(auto, bool):
        raise _fail(path, f"{where}.autoContinue", f"{json.dumps(auto)} must be true or false")
    return WireItem(command=int(command), frame=int(frame), params=(p[0], p[1], p[2], p[3]),
                    x=p[4], y=p[5], z=p[6], autocontinue=auto)


def _fence_items(path: Path, fence: Mapping[str, Any]) -> list[WireItem]:
    items: list[WireItem] = []
    frame = _M.MAV_FRAME_GLOBAL
    for i, poly in enumerate(_plan_list(path, fence, "geoFence", "polygons")):
        where = f"geoFence.polygons[{i}]"
        if not isinstance(poly, dict):
            raise _fail(path, where, "must be a JSON object")
        vertices = poly.get("polygon")
        if not isinstance(vertices, list) or len(vertices) < 3:
            raise _fail(path, f"{where}.polygon", "must be at least 3 [latitude, longitude]")
        command = (_M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION if poly.get("inclusion", True)
                   else _M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
        for j, vertex in enumerate(vertices):
            lat, lon = _latlon(path, f"{where}.polygon[{j}]", vertex)
            items.append(WireItem(command=command, frame=frame,
                                  params=(float(len(vertices)), 0.0, 0.0, 0.0), x=lat, y=lon))
    for i, circle in enumerate(_plan_list(path, fence, "geoFence", "circles")):
        where = f"geoFence.circles[{i}]"
        spec = circle.get("circle") if isinstance(circle, dict) else None
        if not isinstance(spec, dict):
            raise _fail(path, where, "must hold a \"circle\" with a center and a radius")
        lat, lon = _latlon(path, f"{where}.circle.center", spec.get("center"))
        radius = _plan_number(path, f"{where}.circle.radius", spec.get("radius"))
        if radius <= 0:
            raise _fail(path, f"{where}.circle.radius", f"{radius:g} m must be > 0")
        command = (_M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION if circle.get("inclusion", True)
                   else _M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION)
        items.append(WireItem(command=command, frame=frame, params=(radius, 0.0, 0.0, 0.0),
                              x=lat, y=lon))
    return items


def _rally_items(path: Path, rally: Mapping[str, Any]) -> list[WireItem]:
    items = []
    for i, point in enumerate(_plan_list(path, rally, "rallyPoints", "points")):
        lat, lon, alt = _latlon(path, f"rallyPoints.points[{i}]", point, n=3)
        items.append(WireItem(command=_M.MAV_CMD_NAV_RALLY_POINT,
                              frame=_M.MAV_FRAME_GLOBAL_RELATIVE_ALT, x=lat, y=lon, z=alt))
    return items


def load_plan(path: str | Path) -> PlanSections:
    """The mission, geofence and rally points of a QGroundControl ``.plan`` file (module
    docstring).

    Raises
    ------
    MissionFileError
        Missing or unreadable file, not JSON, not a plan, or a bad item (named by its place
        in the file, e.g. ``mission.items[2].params``).
    """
    p = Path(path)
    if not p.is_file():
        raise MissionFileError(f"{p}: no such mission file")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise MissionFileError(f"{p}: not valid JSON: {err}") from None
    if not isinstance(data, dict) or data.get("fileType") != "Plan":
        raise _fail(p, "fileType", "not a QGroundControl plan (no \"fileType\": \"Plan\")")
    mission = _plan_section(p, data, "mission")
    version = mission.get("version", 2)
    if version != 2:
        raise _fail(p, "mission.version", f"{json.dumps(version)}: only version 2 (QGC 3.2 "
                    "and later) is read")
    raw = _plan_list(p, mission, "mission", "items")
    items = [_plan_item(p, f"mission.items[{i}]", item) for i, item in enumerate(raw)]
    if not items:
        raise _fail(p, "mission.items", "no mission items")
    return PlanSections(mission=items, fence=_fence_items(p, _plan_section(p, data, "geoFence")),
                        rally=_rally_items(p, _plan_section(p, data, "rallyPoints")))


def load_mission(path: str | Path) -> list[WireItem]:
    """Mission items (without home) from a QGC WPL 110, TOML or QGC ``.plan`` file (see the
    module docstring; a plan's geofence and rally points: :func:`load_plan`).

    Raises
    ------
    MissionFileError
        Missing or unreadable file, bad syntax, unknown key, bad value.
    """
    p = Path(path)
    if not p.is_file():
        raise MissionFileError(f"{p}: no such mission file")
    if p.suffix.lower() == ".toml":
        return _load_toml(p)
    if p.suffix.lower() == ".plan":
        return load_plan(p).mission
    return _load_wpl(p)


def with_home(items: Sequence[WireItem], home: WireItem) -> list[WireItem]:
    """``home`` as seq 0 followed by ``items`` (seq 1..n)."""
    return [replace(home), *items]
