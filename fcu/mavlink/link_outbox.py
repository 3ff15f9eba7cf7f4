"""The endpoint's outbox: packs messages and sends them on the link, chunking STATUSTEXT.

Every protocol part of the endpoint (parameters, mission, signing, commands, telemetry) sends
through one :class:`LinkOutbox` (the :class:`fcu.mavlink.transport.link.Outbox` it is given); a
message that cannot be packed is counted in the endpoint's statistics and logged, never
raised.
"""

from __future__ import annotations

import logging

from fcu.mavlink.endpoint_config import EndpointStats
from fcu.mavlink.telemetry import messages as build
from fcu.mavlink.transport.codec import Codec, Fields, MAVLinkMessage, mavlink2
from fcu.mavlink.transport.link import Address, Link

__all__ = ["LinkOutbox"]

_log = logging.getLogger("fcu.mavlink.endpoint")  # the endpoint's log, as before
_STATUSTEXT = mavlink2.MAVLink_statustext_message


class LinkOutbox:
    """Packs and sends for every protocol part; STATUSTEXT chunking lives here."""

    def __init__(self, codec: Codec, link: Link, stats: EndpointStats) -> None:
        self._codec = codec
        self._link = link
        self._stats = stats
        self._chunk_id = 0

    def send(self, msg: MAVLinkMessage, to: Address | None = None) -> None:
        try:
            data = self._codec.pack(msg)
        except Exception:  # a field out of its wire range is a bug; keep flying
            self._stats.build_errors += 1
            _log.exception("cannot pack %s", msg.get_type())
            return
        self._link.send(data, to)

    def send_fields(self, cls: type[MAVLinkMessage], fields: Fields,
                    to: Address | None = None) -> None:
        """:meth:`send` of ``cls(*fields)``, packed without the message object: what the
        builders of :mod:`fcu.mavlink.telemetry.messages` return, records of
        :func:`~fcu.mavlink.transport.codec.fields_of` ``cls`` (the telemetry streams are most
        of what is sent)."""
        try:
            data = self._codec.pack_fields(cls, fields)
        except Exception:  # a field out of its wire range is a bug; keep flying
            self._stats.build_errors += 1
            _log.exception("cannot pack %s", cls.msgname)
            return
        self._link.send(data, to)

    def status(self, severity: int, text: str) -> None:
        self._chunk_id = self._chunk_id % 0xFFFF + 1
        for fields in build.statustext_chunks(severity, text, self._chunk_id):
            self.send_fields(_STATUSTEXT, fields)
