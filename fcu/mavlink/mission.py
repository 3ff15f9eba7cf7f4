"""Mission protocol, ArduPilot flavour (https://mavlink.io/en/services/mission.html).

Upload:   GCS MISSION_COUNT(n) -> vehicle MISSION_REQUEST_INT(0) -> GCS MISSION_ITEM_INT(0)
          -> ... -> vehicle MISSION_ACK(ACCEPTED). A peer that answers with the legacy float
          MISSION_ITEM is asked with the legacy MISSION_REQUEST from then on.
Download: GCS MISSION_REQUEST_LIST -> vehicle MISSION_COUNT(n) -> GCS MISSION_REQUEST_INT(i)
          (or MISSION_REQUEST) -> vehicle MISSION_ITEM_INT(i) (or MISSION_ITEM) ... -> GCS ACK.

ArduPilot conventions kept here:
- seq 0 is home. It is uploaded like any item but, as in ArduPilot, neither judged nor
  handed to the vehicle (MAVSDK's import of a QGC ``.plan`` sends it with altitude NaN); a
  download always returns the current home as seq 0 (MAV_FRAME_GLOBAL, AMSL).
  With no mission the vehicle reports a count of 1 (home only).
- The whole mission is handed to the vehicle (:meth:`VehiclePort.mission_set`) only when the
  last item has arrived and been validated: an aborted upload leaves the old mission intact.
- Re-requests are idempotent: a duplicate item or one from the future makes the vehicle
  re-request at once the one it is waiting for (the uploader is there, and missed that
  request), and a missing item is re-requested every ``retry_interval_s``. The upload is
  cancelled (MISSION_ACK OPERATION_CANCELLED and a STATUSTEXT) only after
  ``upload_timeout_s`` without an item from the uploader, ArduPilot's 8 s
  (``MissionItemProtocol::upload_timeout_ms``), so a partial upload outlives a bad patch of
  link. ArduPilot re-requests every 1 s; this vehicle every 0.5 s, so that an upload through
  30 % loss each way practically never goes 8 s without a request-and-item round trip (with
  1 s, about 0.5 ** 8: 3 % of 10-item uploads cancelled). A repeated last item after
  completion is answered with the ACK again.
- Validation, per item, answered with a MISSION_ACK error that ends the upload (and a
  STATUSTEXT saying why): frames other than GLOBAL(_INT), GLOBAL_RELATIVE_ALT(_INT),
  LOCAL_NED and MISSION -> UNSUPPORTED_FRAME; inf anywhere, or NaN in a param1..4 the
  command uses (:data:`USED_PARAMS`) -> INVALID_PARAMn, except param4 (yaw) of
  NAV_WAYPOINT/LOITER/LAND/TAKEOFF where the MAVLink spec defines NaN as "keep the heading
  mode" (MAVSDK sends it); NaN in a parameter the command does not use is accepted
  (ArduPilot ignores it; MAVSDK's Mission plugin sends NaN in RTL's param1); non-finite or absurd
  coordinates (|lat| > 90, |lon| > 180, |alt| > ``max_alt_m``, local |x|, |y|, |z| >
  ``max_local_m``) -> INVALID_PARAM5_X / 6_Y / 7. Fields the frame does not use (x, y, z of
  MAV_FRAME_MISSION) are not judged.
- A mission the vehicle boots with (``ftc-vehicle --load-mission``) is loaded through
  :meth:`MissionProtocol.load`, in the form a ground station would upload it
  (:func:`flightdata.mission.mavlink_form`), so a download and MISSION_CURRENT report it.
- The fence (MAV_MISSION_TYPE_FENCE: polygon vertices and circles, inclusion and exclusion,
  a return point) and the rally points (MAV_MISSION_TYPE_RALLY) are uploaded, downloaded
  and cleared by the same protocol, without a home item (seq 0 is their first item), each
  item checked (:func:`validate_plan_item`), and stored as uploaded (:meth:`plan_items`);
  the fence also goes to the vehicle as local areas (:func:`fence_areas`), which it enforces
  while FENCE_ENABLE is 1 and FENCE_TYPE has bit 2. Other mission types are answered
  MAV_MISSION_UNSUPPORTED.
- Time-outs are judged on the clock passed in (the vehicle process passes the wall-clock
  monotonic time, so a simulation speed-up does not shorten them).
- MISSION_ITEM_INT carries latitude/longitude in degE7 and local x/y in metres * 1e4.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fcu.mavlink.codec import MAVLinkMessage, mavlink2
from fcu.mavlink.enums import Severity
from fcu.mavlink.geo import geo_to_ned, home_alt_amsl_m, ned_to_geo
from fcu.mavlink.link import Address, Outbox
from fcu.mavlink.port_records import CommandResult, GeoPoint, MissionItem, VehicleSnapshot
from fcu.navigation.fence import FenceAreas
from flightdata.mission import MissionItem as PlannedItem
from flightdata.mission import mavlink_form

__all__ = [
    "MissionConfig",
    "set_current_refusal",
    "MissionProtocol",
    "WireItem",
    "to_mission_item",
    "validate_item",
    "validate_plan_item",
    "fence_areas",
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
_PLAN_NAMES = {_M.MAV_MISSION_TYPE_FENCE: "Fence", _M.MAV_MISSION_TYPE_RALLY: "Rally"}
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
    name = _PLAN_NAMES[mission_type]
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


@dataclass
class _Upload:
    peer: tuple[int, int]  # (sysid, compid) of the uploader
    addr: Address
    count: int
    items: list[WireItem]
    use_int: bool
    last_item_s: float  # when an item (or the count) last came from the uploader
    last_request_s: float  # when the item waited for was last requested
    mission_type: int = _M.MAV_MISSION_TYPE_MISSION


class MissionProtocol:
    """The vehicle side of the mission protocol.

    Parameters
    ----------
    outbox : Outbox
        Where replies go.
    snapshot : callable
        Returns the vehicle's :class:`VehicleSnapshot` (home and origin are read from it).
    commit : callable
        Hands a complete, validated mission (items seq 1..) to the vehicle
        (:meth:`VehiclePort.mission_set`).
    config : MissionConfig
    """

    def __init__(self, outbox: Outbox, snapshot: Callable[[], VehicleSnapshot],
                 commit: Callable[[list[MissionItem]], CommandResult],
                 config: MissionConfig,
                 commit_fence: Callable[[FenceAreas], CommandResult] | None = None) -> None:
        self._outbox = outbox
        self._commit_fence = commit_fence
        self._snapshot = snapshot
        self._commit = commit
        self._config = config
        self._items: list[WireItem] = []  # seq 1..n-1 (home is not stored)
        # the fence and the rally points, seq 0.. (no home item), as uploaded
        self._plans: dict[int, list[WireItem]] = {t: [] for t in PLAN_COMMANDS}
        self._upload: _Upload | None = None
        self._completed: tuple[tuple[int, int], int] | None = None  # (peer, last seq)

    # ----------------------------------------------------------------- state
    @property
    def count(self) -> int:
        """Items on the vehicle including home (what a download reports)."""
        return 1 + len(self._items)

    @property
    def total(self) -> int:
        """Items excluding home (MISSION_CURRENT.total); 0 when there is no mission."""
        return len(self._items)

    @property
    def uploading(self) -> bool:
        """An upload is in progress."""
        return self._upload is not None

    @property
    def items(self) -> list[WireItem]:
        """The stored mission (seq 1..), as received."""
        return list(self._items)

    def plan_items(self, mission_type: int) -> list[WireItem]:
        """The stored fence (MAV_MISSION_TYPE_FENCE) or rally points (RALLY), as received."""
        return list(self._plans[mission_type])

    def reset(self) -> None:
        """Forget any transfer in progress (reboot); the stored mission is kept."""
        self._upload = None
        self._completed = None

    # ----------------------------------------------------------------- helpers
    def _ack(self, code: int, peer: tuple[int, int], to: Address,
             mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> None:
        self._outbox.send(_M.MAVLink_mission_ack_message(peer[0], peer[1], code, mission_type), to)

    def _request(self, up: _Upload) -> None:
        seq = len(up.items)
        if up.use_int:
            msg = _M.MAVLink_mission_request_int_message(up.peer[0], up.peer[1], seq,
                                                         up.mission_type)
        else:
            msg = _M.MAVLink_mission_request_message(up.peer[0], up.peer[1], seq,
                                                     up.mission_type)
        self._outbox.send(msg, up.addr)

    def _fail(self, up: _Upload, code: int, reason: str) -> None:
        self._upload = None
        self._ack(code, up.peer, up.addr, up.mission_type)
        self._outbox.status(Severity.WARNING, reason)

    def _home_item(self) -> WireItem:
        snap = self._snapshot()
        home = snap.home_pos_ned
        lat, lon, alt = ned_to_geo(home, snap.origin) if home is not None else (0.0, 0.0, 0.0)
        return WireItem(seq=0, frame=_M.MAV_FRAME_GLOBAL, command=_M.MAV_CMD_NAV_WAYPOINT,
                        current=0, autocontinue=1, params=(0.0, 0.0, 0.0, 0.0), x=lat, y=lon,
                        z=alt)

    def _store(self, items: list[WireItem]) -> CommandResult:
        """Hand ``items`` (seq 1..) to the vehicle; keep them when it accepts."""
        snap = self._snapshot()
        try:
            converted = [to_mission_item(i, snap.origin, snap.home_pos_ned) for i in items]
        except ValueError as err:
            return CommandResult.denied(str(err))
        result = self._commit(converted)
        if result.accepted:
            self._items = list(items)
        return result

    def _set_plan(self, mission_type: int, items: list[WireItem]) -> None:
        """Store a fence or rally plan; a fence goes to the vehicle to be enforced."""
        self._plans[mission_type] = items
        if mission_type == _M.MAV_MISSION_TYPE_FENCE and self._commit_fence is not None:
            self._commit_fence(fence_areas(items, self._snapshot().origin))

    def load(self, items: Sequence[PlannedItem]) -> CommandResult:
        """Replace the mission by ``items`` (seq 1..) without a ground station: the boot
        mission. Validated and handed to the vehicle as an upload would be."""
        if len(items) + 1 > self._config.max_items:
            return CommandResult.denied(f"Mission of {len(items) + 1} items exceeds "
                                        f"{self._config.max_items}")
        wire = [WireItem.from_planned(seq, item) for seq, item in enumerate(items, 1)]
        for item in wire:
            code, reason = validate_item(item, self._config)
            if code != _M.MAV_MISSION_ACCEPTED:
                return CommandResult.denied(reason)
        return self._store(wire)

    # ----------------------------------------------------------------- upload
    def handle_count(self, msg: MAVLinkMessage, peer: tuple[int, int], to: Address,
                     now_s: float) -> None:
        """MISSION_COUNT: start an upload (or clear the mission when the count is 0)."""
        mission_type = int(msg.mission_type)
        plan = mission_type in PLAN_COMMANDS
        if mission_type != _M.MAV_MISSION_TYPE_MISSION and not plan:
            self._ack(_M.MAV_MISSION_UNSUPPORTED, peer, to, mission_type)
            return
        count = int(msg.count)
        self._upload = None
        self._completed = None
        if count == 0:  # MAVLink: an empty upload clears
            if plan:
                self._set_plan(mission_type, [])
                self._ack(_M.MAV_MISSION_ACCEPTED, peer, to, mission_type)
            else:
                self._finish_commit([], peer, to)
            return
        if count > self._config.max_items:
            self._ack(_M.MAV_MISSION_NO_SPACE, peer, to, mission_type)
            self._outbox.status(Severity.WARNING, f"Mission of {count} items exceeds "
                                f"{self._config.max_items}")
            return
        self._upload = _Upload(peer=peer, addr=to, count=count, items=[], use_int=True,
                               last_item_s=now_s, last_request_s=now_s,
                               mission_type=mission_type)
        self._request(self._upload)

    def _finish_commit(self, items: list[WireItem], peer: tuple[int, int], to: Address) -> bool:
        result = self._store(items)
        if result.accepted:
            self._ack(_M.MAV_MISSION_ACCEPTED, peer, to)
            return True
        code = _M.MAV_MISSION_UNSUPPORTED if result.unsupported else _M.MAV_MISSION_ERROR
        self._ack(code, peer, to)
        self._outbox.status(Severity.WARNING, f"Mission rejected: {result.reason}")
        return False

    def handle_item(self, msg: MAVLinkMessage, peer: tuple[int, int], to: Address,
                    now_s: float) -> None:
        """MISSION_ITEM_INT or MISSION_ITEM during an upload."""
        mission_type = int(msg.mission_type)
        up = self._upload
        seq = int(msg.seq)
        if up is None:
            if self._completed == (peer, seq):  # our ACK was lost: say it again
                self._ack(_M.MAV_MISSION_ACCEPTED, peer, to, mission_type)
            elif mission_type != _M.MAV_MISSION_TYPE_MISSION and \
                    mission_type not in PLAN_COMMANDS:
                self._ack(_M.MAV_MISSION_UNSUPPORTED, peer, to, mission_type)
            return
        if peer != up.peer:
            self._ack(_M.MAV_MISSION_DENIED, peer, to, mission_type)
            return
        if mission_type != up.mission_type:
            return
        expected = len(up.items)
        up.last_item_s = now_s  # the uploader is still there
        if seq != expected:  # a duplicate (our request was lost) or one missed: ask again
            up.last_request_s = now_s
            self._request(up)
            return
        up.use_int = msg.get_type() == "MISSION_ITEM_INT"
        item = WireItem.from_message(msg)
        # seq 0 of a mission is home, never flown nor stored: as ArduPilot, not judged
        # (MAVSDK's import of a QGC .plan sends it with altitude NaN)
        if up.mission_type in PLAN_COMMANDS:
            code, reason = validate_plan_item(item, up.mission_type, self._config)
        elif seq > 0:
            code, reason = validate_item(item, self._config)
        else:
            code, reason = _M.MAV_MISSION_ACCEPTED, ""
        if code != _M.MAV_MISSION_ACCEPTED:
            self._fail(up, code, reason)
            return
        up.items.append(item)
        if len(up.items) < up.count:
            up.last_request_s = now_s
            self._request(up)
            return
        self._upload = None
        if up.mission_type in PLAN_COMMANDS:
            self._set_plan(up.mission_type, list(up.items))
            self._ack(_M.MAV_MISSION_ACCEPTED, peer, to, up.mission_type)
            self._outbox.status(Severity.INFO, f"{_PLAN_NAMES[up.mission_type]}: "
                                f"{len(up.items)} items stored")
            self._completed = (peer, up.count - 1)
        elif self._finish_commit(up.items[1:], peer, to):
            self._completed = (peer, up.count - 1)

    def tick(self, now_s: float) -> None:
        """Re-request a missing item, or cancel a stalled upload."""
        up = self._upload
        if up is None:
            return
        if now_s - up.last_item_s > self._config.upload_timeout_s:
            self._fail(up, _M.MAV_MISSION_OPERATION_CANCELLED,
                       f"Mission upload timed out waiting for item {len(up.items)}")
            return
        if now_s - up.last_request_s >= self._config.retry_interval_s:
            up.last_request_s = now_s
            self._request(up)

    # ----------------------------------------------------------------- download & others
    def handle_request_list(self, msg: MAVLinkMessage, peer: tuple[int, int],
                            to: Address) -> None:
        """MISSION_REQUEST_LIST: announce the count (home included)."""
        mission_type = int(msg.mission_type)
        if mission_type in PLAN_COMMANDS:
            self._outbox.send(_M.MAVLink_mission_count_message(
                peer[0], peer[1], len(self._plans[mission_type]), mission_type), to)
            return
        if mission_type != _M.MAV_MISSION_TYPE_MISSION:
            self._ack(_M.MAV_MISSION_UNSUPPORTED, peer, to, mission_type)
            return
        self._outbox.send(_M.MAVLink_mission_count_message(
            peer[0], peer[1], self.count, _M.MAV_MISSION_TYPE_MISSION), to)

    def handle_request(self, msg: MAVLinkMessage, peer: tuple[int, int], to: Address) -> None:
        """MISSION_REQUEST_INT / MISSION_REQUEST: send one item (idempotent, any order)."""
        mission_type = int(msg.mission_type)
        seq = int(msg.seq)
        use_int = msg.get_type() == "MISSION_REQUEST_INT"
        if mission_type in PLAN_COMMANDS:
            stored = self._plans[mission_type]
            if not 0 <= seq < len(stored):
                self._ack(_M.MAV_MISSION_INVALID_SEQUENCE, peer, to, mission_type)
                return
            self._outbox.send(stored[seq].to_message(use_int, peer[0], peer[1]), to)
            return
        if mission_type != _M.MAV_MISSION_TYPE_MISSION:
            self._ack(_M.MAV_MISSION_UNSUPPORTED, peer, to, mission_type)
            return
        if not 0 <= seq < self.count:
            self._ack(_M.MAV_MISSION_INVALID_SEQUENCE, peer, to)
            return
        item = self._home_item() if seq == 0 else self._items[seq - 1]
        self._outbox.send(item.to_message(use_int, peer[0], peer[1]), to)

    def handle_clear_all(self, msg: MAVLinkMessage, peer: tuple[int, int], to: Address) -> None:
        """MISSION_CLEAR_ALL: clear the mission, the fence or the rally points (ALL: all)."""
        mission_type = int(msg.mission_type)
        if mission_type in PLAN_COMMANDS or mission_type == _M.MAV_MISSION_TYPE_ALL:
            for plan in PLAN_COMMANDS:
                if mission_type in (plan, _M.MAV_MISSION_TYPE_ALL):
                    self._set_plan(plan, [])
            if mission_type != _M.MAV_MISSION_TYPE_ALL:
                self._ack(_M.MAV_MISSION_ACCEPTED, peer, to, mission_type)
                return
        if mission_type not in (_M.MAV_MISSION_TYPE_MISSION, _M.MAV_MISSION_TYPE_ALL):
            self._ack(_M.MAV_MISSION_UNSUPPORTED, peer, to, mission_type)
            return
        self._upload = None
        self._completed = None
        result = self._store([])
        code = _M.MAV_MISSION_ACCEPTED if result.accepted else _M.MAV_MISSION_ERROR
        if not result.accepted:
            self._outbox.status(Severity.WARNING, f"Mission clear refused: {result.reason}")
        self._ack(code, peer, to, mission_type)
