"""Faults, detections and outcomes as MAVLink: DEBUG_FLOAT_ARRAY ``FTC_REC``, each sent
several times.

The wire form of a record is :func:`flightdata.records.to_wire` (its module docstring gives
the layout): one DEBUG_FLOAT_ARRAY (id 350, common.xml) named ``FTC_REC``, ``array_id`` the
record type, ``data`` the fields with a sequence number first, ``time_usec`` the simulated
time of the record. Datagrams get lost (a loaded machine's socket buffer, a lossy radio): each
record goes out when it happens and again :data:`REPEATS_AFTER_S` later (simulated time); a
receiver keeps the first copy of each sequence number. STATUSTEXT carries the same news for
people, in words derived from the record.
"""

from __future__ import annotations

from dataclasses import dataclass

from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2
from flightdata.records import WIRE_NAME, Record, to_wire

__all__ = ["REPEATS_AFTER_S", "RecordRelay", "record_message"]

_M = mavlink2
_DATA_LEN = 58  # DEBUG_FLOAT_ARRAY.data
REPEATS_AFTER_S = (0.1, 0.3, 0.7, 1.5)
"""s simulated after a record's first transmission when it is sent again."""


def record_message(record: Record, seq: int, time_s: float) -> MAVLinkMessage:
    """The DEBUG_FLOAT_ARRAY carrying ``record`` as number ``seq`` at ``time_s`` (s)."""
    array_id, data = to_wire(record, seq)
    return _M.MAVLink_debug_float_array_message(
        max(0, int(round(time_s * 1e6))), WIRE_NAME.encode("ascii"), array_id,
        data + [0.0] * (_DATA_LEN - len(data)))


@dataclass
class _Pending:
    message: MAVLinkMessage
    due_s: list[float]  # simulated times of the repeats still to send


class RecordRelay:
    """Numbers the records and says which messages are due at each tick."""

    def __init__(self) -> None:
        self._seq = 0
        self._pending: list[_Pending] = []

    def add(self, record: Record, now_s: float) -> MAVLinkMessage:
        """The first transmission of ``record`` (its repeats are scheduled)."""
        self._seq += 1
        msg = record_message(record, self._seq, getattr(record, "time_s", now_s))
        self._pending.append(_Pending(msg, [now_s + d for d in REPEATS_AFTER_S]))
        return msg

    def due(self, now_s: float) -> list[MAVLinkMessage]:
        """The repeats due at ``now_s`` (simulated s)."""
        if not self._pending:
            return []  # the common tick
        out = []
        for p in self._pending:
            while p.due_s and p.due_s[0] <= now_s + 1e-9:
                p.due_s.pop(0)
                out.append(p.message)
        self._pending = [p for p in self._pending if p.due_s]
        return out
