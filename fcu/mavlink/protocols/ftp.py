"""MAVLink FTP (https://mavlink.io/en/services/ftp.html): this vehicle has no file server.

Every request is answered with a NAK (``FileNotFound`` for opening or listing,
``UnknownCommand`` otherwise; TerminateSession and ResetSessions are ACKed), so a ground
station that tries FTP first (MAVProxy fetches parameters over FTP) falls back to the
parameter protocol immediately instead of after its time-out.
"""

from __future__ import annotations

from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2

__all__ = ["ftp_reply"]

# opcodes and error codes used here
_FTP_ACK, _FTP_NAK = 128, 129
_FTP_ACKED = frozenset({1, 2})  # TerminateSession, ResetSessions
_FTP_FILE_OPS = frozenset({3, 4, 6, 7, 11, 12, 14, 15})  # list, open, create, remove, CRC, ...
_FTP_ERR_UNKNOWN_COMMAND, _FTP_ERR_FILE_NOT_FOUND = 7, 10


def ftp_reply(msg: MAVLinkMessage, src: tuple[int, int]) -> MAVLinkMessage | None:
    """The answer to FILE_TRANSFER_PROTOCOL ``msg`` from ``src`` (sysid, compid), or None
    for another network than 0."""
    if int(msg.target_network) != 0:
        return None
    request = bytes(msg.payload)
    seq, session, opcode = int.from_bytes(request[0:2], "little"), request[2], request[3]
    if opcode in _FTP_ACKED:
        reply_opcode, data = _FTP_ACK, b""
    else:
        error = _FTP_ERR_FILE_NOT_FOUND if opcode in _FTP_FILE_OPS else \
            _FTP_ERR_UNKNOWN_COMMAND
        reply_opcode, data = _FTP_NAK, bytes([error])
    header = ((seq + 1) % 0x10000).to_bytes(2, "little") + bytes(
        [session, reply_opcode, len(data), opcode, 0, 0]) + bytes(4)
    payload = (header + data).ljust(251, b"\0")
    return mavlink2.MAVLink_file_transfer_protocol_message(0, src[0], src[1], list(payload))
