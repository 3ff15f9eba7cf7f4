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
  command uses (:data:`~fcu.mavlink.protocols.mission_items.USED_PARAMS`) -> INVALID_PARAMn, except
  param4 (yaw) of NAV_WAYPOINT/LOITER/LAND/TAKEOFF where the MAVLink spec defines NaN as
  "keep the heading mode" (MAVSDK sends it); NaN in a parameter the command does not use is
  accepted (ArduPilot ignores it; MAVSDK's Mission plugin sends NaN in RTL's param1);
  non-finite or absurd coordinates (|lat| > 90, |lon| > 180, |alt| > ``max_alt_m``, local
  |x|, |y|, |z| > ``max_local_m``) -> INVALID_PARAM5_X / 6_Y / 7. Fields the frame does not
  use (x, y, z of MAV_FRAME_MISSION) are not judged.
- A mission the vehicle boots with (``ftc-vehicle --load-mission``) is loaded through
  :meth:`MissionProtocol.load`, in the form a ground station would upload it
  (:func:`flightdata.mission.mavlink_form`), so a download and MISSION_CURRENT report it.
- The fence (MAV_MISSION_TYPE_FENCE: polygon vertices and circles, inclusion and exclusion,
  a return point) and the rally points (MAV_MISSION_TYPE_RALLY) are uploaded, downloaded and
  cleared by the same protocol, without a home item (seq 0 is their first item), each item
  checked (:func:`~fcu.mavlink.protocols.mission_items.validate_plan_item`), and stored as
  uploaded (:meth:`plan_items`); the fence also goes to the vehicle as local areas
  (:func:`~fcu.mavlink.protocols.mission_items.fence_areas`), which it enforces while
  FENCE_ENABLE is 1 and FENCE_TYPE has bit 2. Other mission types are answered
  MAV_MISSION_UNSUPPORTED.
- Time-outs are judged on the clock passed in (the vehicle process passes the wall-clock
  monotonic time, so a simulation speed-up does not shorten them).
- MISSION_ITEM_INT carries latitude/longitude in degE7 and local x/y in metres * 1e4.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from fcu.mavlink.enums import Severity
from fcu.mavlink.geo import ned_to_geo
from fcu.mavlink.port_records import CommandResult, MissionItem, VehicleSnapshot
from fcu.mavlink.protocols.mission_items import (
    PLAN_COMMANDS,
    PLAN_NAMES,
    MissionConfig,
    WireItem,
    fence_areas,
    to_mission_item,
    validate_item,
    validate_plan_item,
)
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2
from fcu.mavlink.transport.link import Address, Outbox
from fcu.navigation.fence import FenceAreas
from flightdata.mission import MissionItem as PlannedItem

__all__ = ["MissionProtocol"]

_M = mavlink2


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
            self._outbox.status(Severity.INFO, f"{PLAN_NAMES[up.mission_type]}: "
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
