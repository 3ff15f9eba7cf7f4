"""Mission upload as a ground station does it: the MISSION_COUNT / MISSION_REQUEST_INT /
MISSION_ITEM_INT / MISSION_ACK exchange, made to survive a lossy link.

:class:`MissionUploader` is the mission half of :class:`gcs.station.GroundStation`: it uploads
a mission (home added as seq 0), a geofence or rally points, nudges an upload the vehicle
stopped asking for, starts a stalled one over, and raises
:class:`gcs.errors.MissionRejected` with the vehicle's reason when it refuses. Times are
wall-clock seconds.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import NoReturn

from gcs.errors import FlightTimeout, MissionRejected
from gcs.link import Link
from gcs.mavlink import mavlink2
from gcs.mission import WireItem, home_item

__all__ = ["MissionUploader"]

_M = mavlink2
_MISSION_NUDGE_S = 1.0  # s wall without a MISSION_REQUEST before we nudge the upload, at most
_MISSION_STALL_S = 15.0  # s wall without progress before an upload starts over
_MISSION_UPLOADS = 3  # uploads started before giving up
_MISSION_TYPE_WORDS = {_M.MAV_MISSION_TYPE_MISSION: "mission",
                       _M.MAV_MISSION_TYPE_FENCE: "geofence",
                       _M.MAV_MISSION_TYPE_RALLY: "rally points"}


class MissionUploader(Link):
    """Uploads missions, geofences and rally points over one link (module docstring);
    arguments as :class:`gcs.link.Link`."""

    def upload_mission(self, items: Sequence[WireItem], *, timeout_s: float = 120.0,
                       mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> None:
        """Upload ``items`` (seq 1..n; home from HOME_POSITION is added as seq 0); with
        ``mission_type`` FENCE or RALLY, a geofence or rally points (seq 0..n-1, no home).

        Over a lossy link: when no request comes for a while
        (:meth:`gcs.round_trips.RoundTrips.retry_wait_s`, 1 s at most), the upload is nudged
        (MISSION_COUNT again before the first request; else the item after the last one asked
        for, which the vehicle either wanted or answers by asking again for the one it misses; after
        the last item, that item again, which a vehicle that finished answers with its
        MISSION_ACK again); an upload the vehicle cancelled (it timed out) or that made no
        progress for :data:`_MISSION_STALL_S` starts over, up to :data:`_MISSION_UPLOADS`
        times.

        Raises
        ------
        MissionRejected
            A MISSION_ACK other than ACCEPTED (with the vehicle's reason; ``result`` holds
            the MAV_MISSION_RESULT).
        FlightTimeout
            The vehicle stopped asking for items.
        """
        sysid, compid = self.target
        what = _MISSION_TYPE_WORDS.get(mission_type, f"mission type {mission_type}")
        if mission_type == _M.MAV_MISSION_TYPE_MISSION:
            home = home_item()
            if self.analyzer.home is not None:
                lat_e7, lon_e7, alt_mm = self.analyzer.home[:3]
                home = home_item(lat_e7 * 1e-7, lon_e7 * 1e-7, alt_mm * 1e-3)
            wire = [home, *items]
            self.log("MISSION", f"uploading {len(items)} items (+ home)")
        else:
            wire = list(items)
            self.log("MISSION", f"uploading {what}: {len(items)} items")
        count = len(wire)
        deadline = time.monotonic() + timeout_s
        last_seq = -1
        for upload in range(_MISSION_UPLOADS):
            if upload:
                self.log("MISSION", f"upload stalled after item {last_seq}: starting over")
            last_seq = self._upload_once(wire, deadline, mission_type)
            if last_seq == count:
                self.log("MISSION", f"upload of {len(items)} items accepted" if what == "mission"
                         else f"upload of {what}: {len(items)} items accepted")
                return
        raise FlightTimeout(f"{what} upload stalled after item {last_seq} of {count - 1} "
                            f"({_MISSION_UPLOADS} uploads)")

    def _upload_once(self, wire: Sequence[WireItem], deadline: float,
                     mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> int:
        """One upload; returns ``len(wire)`` when accepted, else the last seq asked for."""
        sysid, compid = self.target
        count = len(wire)
        home_first = mission_type == _M.MAV_MISSION_TYPE_MISSION
        for kind in ("MISSION_ACK", "MISSION_REQUEST_INT", "MISSION_REQUEST", "STATUSTEXT"):
            self.inbox.take_all(kind, lambda m: True)

        # time.monotonic() of the last send and of the last progress; whether the last send
        # was a nudge (a round trip is measured only from an answer to a request, never from a
        # nudge, which an answer to an earlier send may follow)
        sent_at = progress_at = 0.0
        nudged = False

        def send_count() -> None:
            nonlocal sent_at
            self.send(_M.MAVLink_mission_count_message(sysid, compid, count, mission_type))
            sent_at = time.monotonic()

        def send_item(seq: int) -> None:
            nonlocal sent_at
            self.send(wire[seq].to_message(seq, sysid, compid, current=home_first and seq == 0,
                                           mission_type=mission_type))
            sent_at = time.monotonic()

        send_count()
        progress_at = sent_at
        last_seq = -1
        while (now := time.monotonic()) < deadline and now - progress_at < _MISSION_STALL_S:
            reply = self._wait_reply(["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"],
                                     lambda m: int(getattr(m, "mission_type", 0)) == mission_type,
                                     self.round_trips.retry_wait_s(_MISSION_NUDGE_S))
            if reply is None:
                nudged = True
                if last_seq < 0:
                    send_count()
                else:
                    send_item(min(last_seq + 1, count - 1))
                continue
            if reply.get_type() == "MISSION_ACK":
                result = int(reply.type)
                if result == _M.MAV_MISSION_ACCEPTED:
                    return count
                if result == _M.MAV_MISSION_OPERATION_CANCELLED:
                    return last_seq  # the vehicle timed out: start over
                self._mission_rejected(wire, result, last_seq, mission_type)
            seq = int(reply.seq)
            if not 0 <= seq < count:
                continue
            if seq > last_seq:
                progress_at = time.monotonic()
                if not nudged:
                    self.round_trips.note(sent_at)
            last_seq = seq
            send_item(seq)
            nudged = False
        return last_seq

    def _mission_rejected(self, wire: Sequence[WireItem], result: int, last_seq: int,
                          mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> NoReturn:
        name = _M.enums["MAV_MISSION_RESULT"][result].name.removeprefix(
            "MAV_MISSION_") if result in _M.enums["MAV_MISSION_RESULT"] else str(result)
        reason = self._refusal_reason()
        if last_seq == len(wire) - 1:
            where = " after the last item"  # the vehicle judged the whole mission
        elif last_seq >= 0:
            where = f" at item {last_seq} ({wire[last_seq].describe()})"
        else:
            where = ""
        what = "" if mission_type == _M.MAV_MISSION_TYPE_MISSION else \
            f"{_MISSION_TYPE_WORDS.get(mission_type, str(mission_type))}: "
        raise MissionRejected(f"{what}{name}{where}" + (f": {reason}" if reason else ""),
                              result=result)
