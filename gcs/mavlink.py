"""The one place where the ground station chooses its MAVLink dialect and wire version.

Every module of ``gcs`` takes the dialect from here: ArduPilot's ``ardupilotmega`` dialect
with MAVLink 2 framing, imported explicitly as ``pymavlink.dialects.v20.ardupilotmega``.

pymavlink's ``mavutil`` picks its dialect module from the ``MAVLINK20`` environment variable
(read in ``mavutil.set_dialect``) and, when it first sees a MAVLink 2 packet, sets that
variable for the whole process and swaps parsers. We never rely on that: after
``mavutil.mavlink_connection(url, dialect="ardupilotmega")`` opens the socket,
:func:`use_mavlink2` replaces the connection's codec by an explicit MAVLink 2 one and turns
the auto-switch off, so the wire version does not depend on the environment or on what the
vehicle happened to send first. The environment is never read or written here.

MAVLink 2 signing: :func:`enable_signing` makes a connection sign everything it sends with a
key (:mod:`flightdata.signing` for the KEY format) and accept only packets that verify with
it, plus unsigned RADIO_STATUS and RADIO, as MAVProxy's ``signing key`` does.

Recorded flights (.tlog) are read by :func:`read_tlog`, a small reader of MAVProxy's format
(``[uint64 big-endian UNIX time in microseconds][one MAVLink packet]`` repeated) on the same
explicit MAVLink 2 codec; pymavlink's own ``mavutil.mavlink_connection("x.tlog")``,
``mavlogdump.py`` and MAVExplorer read the same files.
"""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeAlias

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from flightdata.signing import UNSIGNED_ALLOWED_IDS, timestamp_from_unix

__all__ = [
    "DIALECT",
    "GCS_COMPID",
    "GCS_SYSID",
    "LogRecord",
    "MAVLinkMessage",
    "decode_packet",
    "enable_signing",
    "is_signed",
    "mavlink2",
    "check_url",
    "open_link",
    "read_tlog",
    "use_mavlink2",
]

MAVLinkMessage: TypeAlias = mavlink2.MAVLink_message

DIALECT = "ardupilotmega"
GCS_SYSID = 255  # SYSID_MYGCS default of ArduPilot: the vehicle's GCS failsafe counts us
GCS_COMPID = mavlink2.MAV_COMP_ID_MISSIONPLANNER  # 190, what ground stations use
_RCVBUF_BYTES = 4 * 1024 * 1024  # 100 Hz streams at speed-up 10 must not overflow the socket
_TLOG_TIME = struct.Struct(">Q")


def use_mavlink2(conn: Any) -> None:
    """Make a ``mavutil`` connection pack and parse MAVLink 2 with the ardupilotmega dialect.

    Parameters
    ----------
    conn : pymavlink.mavutil.mavfile
        A freshly opened connection (nothing received yet).
    """
    mav = mavlink2.MAVLink(conn, srcSystem=conn.source_system,
                           srcComponent=conn.source_component)
    mav.robust_parsing = True
    conn.mav = mav
    conn.WIRE_PROTOCOL_VERSION = mavlink2.WIRE_PROTOCOL_VERSION  # "2.0"
    conn.first_byte = False  # mavutil's auto-switch would set os.environ["MAVLINK20"]


_NETWORK_KINDS = ("udpin", "udpout", "udp", "udpbcast", "tcp", "tcpin")
_LISTENING_KINDS = ("udpin", "udp", "tcpin")  # port 0 = any free port


def check_url(url: str) -> None:
    """Check a connection string before opening it.

    Network forms are ``KIND:HOST:PORT`` with KIND one of udpin, udpout, udp, udpbcast, tcp,
    tcpin (``HOST:PORT`` alone is pymavlink's udpin); anything starting with ``/`` or ``COM``
    is a serial device (``DEVICE[,BAUD]``), opened as it is.

    Raises
    ------
    ValueError
        One line saying what is wrong with ``url``.
    """
    if url.startswith("/") or url.upper().startswith("COM"):
        return
    parts = url.split(":")
    if len(parts) == 2 and parts[0] not in _NETWORK_KINDS:
        parts = ["udpin", *parts]
    if len(parts) != 3 or not parts[1]:
        raise ValueError("expected KIND:HOST:PORT (udpin:0.0.0.0:14550, "
                         "udpout:127.0.0.1:14555, tcp:HOST:PORT) or a serial device")
    kind, _, port_text = parts
    if kind not in _NETWORK_KINDS:
        raise ValueError(f"{kind!r} is not one of {', '.join(_NETWORK_KINDS)} (or a serial "
                         "device)")
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"port {port_text!r} is not a number") from None
    low = 0 if kind in _LISTENING_KINDS else 1
    if not low <= port <= 65535:
        raise ValueError(f"port {port} not in {low}..65535")


def open_link(url: str, *, source_system: int = GCS_SYSID,
              source_component: int = GCS_COMPID) -> Any:
    """Open a MAVLink 2 ground-station connection.

    Parameters
    ----------
    url : str
        A ``mavutil`` connection string: ``udpin:HOST:PORT`` (listen, the ground-station
        convention: the vehicle sends to us), ``udpout:HOST:PORT`` (send to a vehicle bound
        there), ``tcp:HOST:PORT``...
    source_system, source_component : int
        Our MAVLink identity.

    Returns
    -------
    pymavlink.mavutil.mavfile
        Non-blocking for UDP.

    Raises
    ------
    ValueError
        A malformed connection string (:func:`check_url`).
    OSError
        When the socket cannot be opened (port in use, bad address, unknown host).
    """
    check_url(url)
    try:
        conn = mavutil.mavlink_connection(url, dialect=DIALECT, source_system=source_system,
                                          source_component=source_component,
                                          autoreconnect=False)
    except (ValueError, OverflowError) as err:  # what pymavlink lets through unparsed
        raise ValueError(str(err)) from None
    use_mavlink2(conn)
    sock = getattr(conn, "port", None)
    if isinstance(sock, socket.socket):
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _RCVBUF_BYTES)
        except OSError:
            pass  # the kernel keeps its default; a slow reader then drops, as a radio would
    return conn


def _radio_only(mav: Any, msg_id: int) -> bool:
    return msg_id in UNSIGNED_ALLOWED_IDS


def enable_signing(conn: Any, key: bytes, unix_s: float) -> None:
    """Sign what ``conn`` sends with ``key`` and drop received packets that do not verify.

    Parameters
    ----------
    conn : pymavlink.mavutil.mavfile
        An open MAVLink 2 connection (:func:`open_link`).
    key : bytes
        32-byte secret key (:func:`flightdata.signing.key_from_text`).
    unix_s : float
        UNIX time now, s: the first signature timestamp (link id 0).

    Notes
    -----
    A dropped packet comes out of ``recv_msg`` as BAD_DATA with the reason
    ``"Invalid signature"`` (unsigned, or signed with another key, or replayed).
    """
    conn.setup_signing(bytes(key), sign_outgoing=True, allow_unsigned_callback=_radio_only,
                       initial_timestamp=timestamp_from_unix(unix_s), link_id=0)


def is_signed(packet: bytes | bytearray) -> bool:
    """Whether a raw MAVLink packet carries a signature (MAVLink 2, signed flag)."""
    return (len(packet) > 2 and packet[0] == mavlink2.PROTOCOL_MARKER_V2
            and bool(packet[2] & mavlink2.MAVLINK_IFLAG_SIGNED))


def decode_packet(data: bytes) -> MAVLinkMessage | None:
    """Decode one raw MAVLink packet; None when it is not a valid packet of the dialect."""
    parser = mavlink2.MAVLink(None)
    parser.robust_parsing = True
    try:
        msgs = parser.parse_buffer(bytes(data)) or []
    except Exception:
        return None
    for msg in msgs:
        if msg.get_type() != "BAD_DATA" and not isinstance(msg, mavlink2.MAVLink_unknown):
            return msg
    return None


@dataclass(frozen=True, slots=True)
class LogRecord:
    """One record of a .tlog: when it was written and the packet.

    Attributes
    ----------
    unix_time_us : int
        Wall-clock time the ground station logged the packet, microseconds since 1970.
    message : MAVLink_message
        The decoded packet (sender in ``get_srcSystem()`` / ``get_srcComponent()``).
    """

    unix_time_us: int
    message: MAVLinkMessage


def _packet_length(buf: bytes, pos: int) -> int | None:
    """Length of the MAVLink packet starting at ``buf[pos]`` (None: not a packet start)."""
    if pos + 2 > len(buf):
        return None
    magic = buf[pos]
    payload_len = buf[pos + 1]
    if magic == mavlink2.PROTOCOL_MARKER_V2:
        if pos + 3 > len(buf):
            return None
        signed = buf[pos + 2] & mavlink2.MAVLINK_IFLAG_SIGNED
        return 10 + payload_len + 2 + (mavlink2.MAVLINK_SIGNATURE_BLOCK_LEN if signed else 0)
    if magic == mavlink2.PROTOCOL_MARKER_V1:
        return 6 + payload_len + 2
    return None


def read_tlog(path: str | Path) -> Iterator[LogRecord]:
    """Records of a MAVProxy-format telemetry log, in file order.

    A truncated last record (a flight interrupted while writing) ends the iteration; a
    record that does not decode is skipped by scanning for the next packet start.

    Parameters
    ----------
    path : str or Path
        The .tlog file.
    """
    buf = Path(path).read_bytes()
    pos = 0
    n = len(buf)
    while pos + 8 < n:
        length = _packet_length(buf, pos + 8)
        if length is None or pos + 8 + length > n:
            if length is not None:
                return  # truncated tail
            pos += 1  # resynchronise: scan for the next timestamp + packet start
            continue
        (stamp,) = _TLOG_TIME.unpack_from(buf, pos)
        msg = decode_packet(buf[pos + 8:pos + 8 + length])
        if msg is None:
            pos += 1
            continue
        yield LogRecord(stamp, msg)
        pos += 8 + length
