"""The vehicle's protocol replies, kept until someone waits for them.

A ground station sends a request and waits for its answer, but the answer may come while it
waits for something else (the heartbeat and telemetry never stop). :class:`ReplyInbox` keeps
every message of the reply kinds (:data:`REPLY_TYPES`: COMMAND_ACK, PARAM_VALUE,
MISSION_REQUEST/_INT, MISSION_ACK, STATUSTEXT, SYS_STATUS, MESSAGE_INTERVAL) that came from
the vehicle, oldest first, until :meth:`ReplyInbox.take` hands one out; the oldest half is
dropped when ten thousand are waiting (replies nobody asked for).
"""

from __future__ import annotations

from collections.abc import Callable

from gcs.mavlink import MAVLinkMessage

__all__ = ["REPLY_TYPES", "ReplyInbox"]

REPLY_TYPES = frozenset({"COMMAND_ACK", "PARAM_VALUE", "MISSION_REQUEST_INT",
                         "MISSION_REQUEST", "MISSION_ACK", "STATUSTEXT", "SYS_STATUS",
                         "MESSAGE_INTERVAL"})
"""The message kinds kept for a reader."""
_MAX_WAITING = 10_000  # replies kept at the most (then the oldest half goes)


class ReplyInbox:
    """The vehicle's replies waiting for a reader (module docstring)."""

    def __init__(self) -> None:
        self._waiting: list[MAVLinkMessage] = []

    def keep(self, msg: MAVLinkMessage) -> None:
        """Keep ``msg`` (a message from the vehicle) when it is of a reply kind."""
        if msg.get_type() in REPLY_TYPES:
            self._waiting.append(msg)
            if len(self._waiting) > _MAX_WAITING:
                del self._waiting[:_MAX_WAITING // 2]

    def take(self, kind: str, match: Callable[[MAVLinkMessage], bool]) -> MAVLinkMessage | None:
        """The oldest waiting reply of type ``kind`` that ``match`` accepts, taken out (None
        when there is none)."""
        for i, msg in enumerate(self._waiting):
            if msg.get_type() == kind and match(msg):
                del self._waiting[i]
                return msg
        return None

    def take_all(self, kind: str, match: Callable[[MAVLinkMessage], bool]) -> None:
        """Drop every waiting reply of type ``kind`` that ``match`` accepts."""
        while self.take(kind, match) is not None:
            pass
