"""The one place that chooses the MAVLink dialect and wire version.

Every module of the endpoint imports the dialect from here, so the choice (ArduPilot's
``ardupilotmega`` dialect, MAVLink 2 framing) is made once, explicitly in code, and never
through pymavlink's import-time environment variables (``MAVLINK20``, ``MAVLINK_DIALECT``).

:class:`Codec` packs outgoing messages with the vehicle's system and component ids and a
rolling sequence number, and parses incoming datagrams. UDP delivers whole datagrams, so each
datagram is parsed by a fresh parser: a truncated or garbage packet can never swallow the
start of the next datagram. The parsers carry no signing key: they decode signed and unsigned
packets alike, and :mod:`fcu.mavlink.signing` checks signatures on the decoded packets (with
the key held by the packer's signing state, which signs what is sent).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

__all__ = ["Codec", "ParseResult", "heartbeat_message", "mavlink2"]

MAVLinkMessage: TypeAlias = mavlink2.MAVLink_message


def heartbeat_message(base_mode: int, custom_mode: int, system_status: int) -> MAVLinkMessage:
    """The vehicle's HEARTBEAT: an ArduCopter-style quadrotor (``MAV_TYPE_QUADROTOR``,
    ``MAV_AUTOPILOT_ARDUPILOTMEGA``, MAVLink version 3) in ``base_mode`` / ``custom_mode``
    with ``system_status`` (MAV_STATE)."""
    return mavlink2.MAVLink_heartbeat_message(
        mavlink2.MAV_TYPE_QUADROTOR, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, base_mode,
        custom_mode, system_status, 3)


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
        data = msg.pack(self._mav)
        self._mav.seq = (self._mav.seq + 1) % 256
        return data

    def parse_datagram(self, data: bytes) -> ParseResult:
        """Decode every packet in one datagram; never raises.

        Parameters
        ----------
        data : bytes
            One UDP datagram (any content, including random bytes).
        """
        parser = mavlink2.MAVLink(None)
        parser.robust_parsing = True  # no key: signatures are checked by fcu.mavlink.signing
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
