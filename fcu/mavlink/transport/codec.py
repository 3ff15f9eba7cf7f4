"""The one place that chooses the MAVLink dialect and wire version.

Every module of the endpoint imports the dialect from here, so the choice (ArduPilot's
``ardupilotmega`` dialect, MAVLink 2 framing) is made once, explicitly in code, and never
through pymavlink's import-time environment variables (``MAVLINK20``, ``MAVLINK_DIALECT``).

:class:`Codec` packs outgoing messages with the vehicle's system and component ids and a
rolling sequence number, and parses incoming datagrams. UDP delivers whole datagrams, so each
datagram is parsed by a fresh parser: a truncated or garbage packet can never swallow the
start of the next datagram. The parsers carry no signing key: they decode signed and unsigned
packets alike, and :mod:`fcu.mavlink.transport.signing` checks signatures on the decoded
packets (with the key held by the packer's signing state, which signs what is sent).

Packing writes the packet pymavlink's ``MAVLink_message.pack`` writes, byte for byte, without
its per-packet objects: per message type, the payload struct and the field order are looked up
once (:class:`_Layout`), then each packet is one ``struct`` call for the header and payload,
the CRC (CRC-16/MCRF4XX over everything after the magic byte, then the type's CRC_EXTRA) and,
with a key, the signature block (link id, 48-bit timestamp, the first 6 bytes of
``sha256(key + packet)``; the timestamp then grows by one). MAVLink 2 drops the payload's
trailing zero bytes (at least one byte stays). :meth:`Codec.pack_fields` packs the same packet
from a message type and its constructor arguments, without the message object (the telemetry
streams' path: most of what the vehicle sends). tests/fcu/mavlink/transport/test_codec.py
compares both with pymavlink for every message type of the dialect, signed and unsigned.

The builders fill those arguments by name: :func:`fields_of` gives each message type a record
type (a named tuple of ``cls.fieldnames``, made once per type), built with keywords, so a
misspelt or missing field raises at once; the record is a tuple in the constructor's order,
and :class:`_Layout` maps that order to the wire's once per type.
"""

from __future__ import annotations

import collections
import hashlib
import operator
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

__all__ = ["Codec", "Fields", "ParseResult", "fields_of", "heartbeat_fields",
           "heartbeat_message", "mavlink2"]

MAVLinkMessage: TypeAlias = mavlink2.MAVLink_message

Fields: TypeAlias = tuple[Any, ...]
"""A message's constructor arguments in ``cls.fieldnames`` order, as :meth:`Codec.pack_fields`
packs them: what the telemetry builders return, as records of :func:`fields_of`."""

_MAGIC = bytes([mavlink2.PROTOCOL_MARKER_V2])  # 0xFD
_HEADER = struct.Struct("<BBBBBBHB")  # after the magic: len, incompat, compat, seq, sys, comp, id
_CRC = struct.Struct("<H")
_SIGNATURE_LINK_STAMP = struct.Struct("<BQ")  # link id, timestamp: the first 7 bytes are sent
_IFLAG_SIGNED = mavlink2.MAVLINK_IFLAG_SIGNED


def _crc16(data: bytes) -> int:
    """CRC-16/MCRF4XX of ``data`` from 0xFFFF (pymavlink's ``x25crc``: its compiled
    ``fastcrc`` when installed, else its Python loop)."""
    return int(mavlink2.x25crc(data).crc)


_mcrf4xx: Callable[[bytes, int], int] | None = getattr(mavlink2, "mcrf4xx", None)
_crc: Callable[[bytes], int] = (
    _crc16 if _mcrf4xx is None else lambda data: _mcrf4xx(data, 0xFFFF))  # type: ignore[misc]


class _Layout:
    """How one message type is laid out on the wire (from pymavlink's class attributes).

    ``values(msg)`` gives the payload's struct arguments in wire order: character arrays as
    their raw bytes (pymavlink's ``_<name>_raw``), other arrays spread element by element.
    ``wire(fields)`` gives the same from the constructor's arguments (``fields``, in
    ``cls.fieldnames`` order, character arrays as bytes), without a message object.
    """

    def __init__(self, cls: type[MAVLinkMessage]) -> None:
        self.msg_id_low = cls.id & 0xFFFF
        self.msg_id_high = cls.id >> 16
        self.crc_extra = bytes([cls.crc_extra])
        self.payload = cls.unpacker
        names: list[str] = []
        self.arrays: list[tuple[int, int]] = []  # (index in names, length) of spread arrays
        order: list[int] = []  # wire field -> its index among the constructor's arguments
        for name, length in zip(cls.ordered_fieldnames, cls.array_lengths, strict=True):
            index = cls.fieldnames.index(name)
            order.append(index)
            if cls.fieldtypes[index] == "char":
                names.append(f"_{name}_raw")  # bytes as given to the constructor
            else:
                if length > 0:
                    self.arrays.append((len(names), length))
                names.append(name)
        get = operator.attrgetter(*names)
        self.get: Callable[[MAVLinkMessage], Any] = (
            (lambda m: (get(m),)) if len(names) == 1 else get)
        self.values: Callable[[MAVLinkMessage], Sequence[Any]] = (
            self._spread if self.arrays else self.get)
        pick = operator.itemgetter(*order)
        self.pick: Callable[[Sequence[Any]], Any] = (
            (lambda f: (pick(f),)) if len(order) == 1 else pick)
        # None: the constructor's order is the wire order and there is no array to spread
        self.wire: Callable[[Sequence[Any]], Sequence[Any]] | None = (
            self._spread_fields if self.arrays
            else None if order == list(range(len(order))) else self.pick)

    def _spread(self, msg: MAVLinkMessage) -> list[Any]:
        return self._spread_values(self.get(msg))

    def _spread_fields(self, fields: Sequence[Any]) -> list[Any]:
        return self._spread_values(self.pick(fields))

    def _spread_values(self, fields: Sequence[Any]) -> list[Any]:
        out: list[Any] = []
        start = 0
        for index, length in self.arrays:
            out += fields[start:index]
            out += fields[index][:length]
            start = index + 1
        out += fields[start:]
        return out


_LAYOUTS: dict[type, _Layout] = {}


def _layout(cls: type[MAVLinkMessage]) -> _Layout:
    layout = _LAYOUTS.get(cls)
    if layout is None:
        layout = _LAYOUTS[cls] = _Layout(cls)
    return layout


_RECORDS: dict[type, Callable[..., Fields]] = {}


def fields_of(cls: type[MAVLinkMessage]) -> Callable[..., Fields]:
    """The record type of ``cls``'s constructor arguments, made once per message type: a
    :func:`collections.namedtuple` named after the message (``Attitude`` for ATTITUDE) whose
    fields are ``cls.fieldnames`` in order, arrays and character arrays one field each.

    Built with keywords (``fields_of(MAVLink_attitude_message)(time_boot_ms=..., roll=...,
    ...)``), a misspelt or missing field raises TypeError at once; the record is a tuple in
    the constructor's order, which :meth:`Codec.pack_fields` packs as it is, and
    ``cls(**record._asdict())`` is the same message.
    """
    record = _RECORDS.get(cls)
    if record is None:
        name = "".join(part.capitalize() for part in cls.msgname.split("_"))
        record = _RECORDS[cls] = collections.namedtuple(
            name, cls.fieldnames, module=__name__)
    return record


_HEARTBEAT = fields_of(mavlink2.MAVLink_heartbeat_message)


def heartbeat_fields(base_mode: int, custom_mode: int, system_status: int) -> Fields:
    """The vehicle's HEARTBEAT as its constructor arguments: an ArduCopter-style quadrotor
    (``MAV_TYPE_QUADROTOR``, ``MAV_AUTOPILOT_ARDUPILOTMEGA``, MAVLink version 3) in
    ``base_mode`` / ``custom_mode`` with ``system_status`` (MAV_STATE)."""
    return _HEARTBEAT(type=mavlink2.MAV_TYPE_QUADROTOR,
                      autopilot=mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, base_mode=base_mode,
                      custom_mode=custom_mode, system_status=system_status, mavlink_version=3)


def heartbeat_message(base_mode: int, custom_mode: int, system_status: int) -> MAVLinkMessage:
    """The vehicle's HEARTBEAT (:func:`heartbeat_fields`) as a message."""
    return mavlink2.MAVLink_heartbeat_message(
        *heartbeat_fields(base_mode, custom_mode, system_status))


@dataclass(frozen=True, slots=True)
class ParseResult:
    """What one datagram contained.

    Attributes
    ----------
    messages : list of MAVLink_message
        The valid, decoded messages in arrival order.
    malformed : int
        Packets rejected by the parser (bad CRC, bad length, bad prefix, bad flags).
    unknown : int
        Well-formed packets whose message id the dialect does not define.
    """

    messages: list[MAVLinkMessage]
    malformed: int
    unknown: int


class Codec:
    """MAVLink 2 packer and per-datagram parser for one vehicle identity.

    Parameters
    ----------
    sysid : int
        MAVLink system id of the vehicle, 1..255.
    compid : int
        MAVLink component id, 1 (MAV_COMP_ID_AUTOPILOT1) for the autopilot.
    """

    def __init__(self, sysid: int, compid: int) -> None:
        self._mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        self._mav.robust_parsing = True

    @property
    def sysid(self) -> int:
        """The system id written into outgoing packets."""
        return int(self._mav.srcSystem)

    @sysid.setter
    def sysid(self, value: int) -> None:
        self._mav.srcSystem = int(value)

    @property
    def compid(self) -> int:
        """The component id written into outgoing packets."""
        return int(self._mav.srcComponent)

    @property
    def signing(self) -> mavlink2.MAVLinkSigning:
        """The packer's signing state (key, timestamp): set, outgoing packets are signed."""
        return self._mav.signing

    def pack(self, msg: MAVLinkMessage) -> bytes:
        """Serialise ``msg`` as a MAVLink 2 packet and advance the sequence number.

        Raises
        ------
        struct.error
            When a field does not fit its wire type (the builders clamp, so this is a bug).
        """
        layout = _layout(type(msg))
        return self._frame(layout, layout.payload.pack(*layout.values(msg)))

    def pack_fields(self, cls: type[MAVLinkMessage], fields: Sequence[Any]) -> bytes:
        """:meth:`pack` of ``cls(*fields)``, without making the message object (the
        telemetry streams' path: ``fields`` in ``cls.fieldnames`` order, as the constructor
        takes them: a record of :func:`fields_of(cls) <fields_of>`).

        Raises
        ------
        struct.error
            As :meth:`pack`.
        """
        layout = _layout(cls)
        wire = layout.wire
        return self._frame(layout, layout.payload.pack(*(fields if wire is None
                                                         else wire(fields))))

    def _frame(self, layout: _Layout, payload: bytes) -> bytes:
        """The MAVLink 2 packet around ``payload`` (signed when a key is set); the sequence
        number moves on."""
        mav = self._mav
        # MAVLink 2 does not send the payload's trailing zeros (one byte at least stays)
        payload = payload.rstrip(b"\0") or payload[:1]
        signing = mav.signing
        signed = signing.sign_outgoing
        body = _HEADER.pack(len(payload), _IFLAG_SIGNED if signed else 0, 0, mav.seq,
                            mav.srcSystem, mav.srcComponent, layout.msg_id_low,
                            layout.msg_id_high) + payload
        packet = _MAGIC + body + _CRC.pack(_crc(body + layout.crc_extra))
        if signed:
            packet += _SIGNATURE_LINK_STAMP.pack(signing.link_id, signing.timestamp)[:7]
            packet += hashlib.sha256(signing.secret_key + packet).digest()[:6]
            signing.timestamp += 1
        mav.seq = (mav.seq + 1) % 256
        return packet

    def parse_datagram(self, data: bytes) -> ParseResult:
        """Decode every packet in one datagram; never raises.

        Parameters
        ----------
        data : bytes
            One UDP datagram (any content, including random bytes).
        """
        parser = mavlink2.MAVLink(None)
        parser.robust_parsing = True  # no key: fcu.mavlink.transport.signing checks signatures
        messages: list[MAVLinkMessage] = []
        malformed = 0
        unknown = 0
        try:
            decoded = parser.parse_buffer(data) or []
        except Exception:  # a parser bug must never reach the receive loop
            return ParseResult(messages=[], malformed=1, unknown=0)
        for msg in decoded:
            kind = msg.get_type()
            if kind == "BAD_DATA":
                malformed += 1
            elif isinstance(msg, mavlink2.MAVLink_unknown):
                unknown += 1
            else:
                messages.append(msg)
        if parser.buf_len() > 0:
            # A datagram that ends inside a packet carries a truncated packet.
            malformed += 1
        return ParseResult(messages=messages, malformed=malformed, unknown=unknown)
