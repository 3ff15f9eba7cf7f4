"""MAVLink 2 message signing on the vehicle's link, as ArduPilot does it.

Rules (https://mavlink.io/en/guide/message_signing.html; ArduPilot's
``libraries/GCS_MAVLink/GCS_Signing.cpp``):

- SETUP_SIGNING (256), addressed to the vehicle, installs a 32-byte key and the initial
  timestamp; an all-zero key switches signing off. While a key is installed SETUP_SIGNING
  itself must be signed with it (like every other message), so only a holder of the key can
  change or remove it. There is no secure channel here (ArduPilot trusts its USB port, a UDP
  vehicle has none).
- With a key, every packet the vehicle sends is signed (link id 0, the one link).
- Incoming packets are accepted when their signature verifies with the key and their
  timestamp is newer than the last one accepted on the same stream (source system,
  component, link id); a stream's first packet may be at most one minute behind the
  vehicle's own timestamp, and at most :data:`MAX_STREAMS` streams are tracked. The
  signature is checked first, then the timestamp, as the C library does, so a forged packet
  can never move a stream's timestamp (pymavlink's ``check_signature`` records the timestamp
  before it checks the signature, which is why the endpoint's parsers carry no key and this
  module does the checking).
- Unsigned packets are dropped, except RADIO_STATUS and RADIO, which radios inject without
  the key (:data:`flightdata.signing.UNSIGNED_ALLOWED_IDS`). A dropped packet is never
  answered and never makes its sender a telemetry peer; an unsigned HEARTBEAT does not count
  for the GCS-loss failsafe.

Visibility: every rejection is counted (:class:`SigningStats`); the first one after a key is
installed is announced by a STATUSTEXT (WARNING); while a key is installed the count of
rejected packets goes out as NAMED_VALUE_INT ``SIGN_REJ`` once per wall-clock second.

Timestamps (10 us since 2015-01-01 UTC) of outgoing packets grow by one per packet and never
fall behind the wall clock (this vehicle runs on a computer with a real-time clock) nor behind
the newest accepted incoming timestamp.

Keys live in memory: one installed by SETUP_SIGNING lasts until the vehicle process ends (it
survives MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, which restarts the endpoint's state, as
ArduPilot keeps its key in storage); a key given at start-up (``EndpointConfig.signing_key``,
``ftc-vehicle --signing-key``) is installed again at every start.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from fcu.mavlink.enums import Severity
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2
from fcu.mavlink.transport.link import Outbox
from flightdata.signing import (
    KEY_BYTES,
    MAX_TIMESTAMP,
    UNSIGNED_ALLOWED_IDS,
    timestamp_from_unix,
)

__all__ = ["MAX_STREAMS", "REPORT_NAME", "MessageSigning", "SigningStats", "check_key",
           "start_signing"]

_M = mavlink2
MAX_STREAMS = 16  # MAVLINK_MAX_SIGNING_STREAMS of the C library
REPORT_NAME = "SIGN_REJ"  # NAMED_VALUE_INT carrying the count of rejected packets
NEW_STREAM_WINDOW = 6_000_000  # 10 us units: a new stream may be one minute behind us
_REPORT_PERIOD_S = 1.0  # s wall between SIGN_REJ reports
_LINK_ID = 0
_SIGNATURE_BYTES = _M.MAVLINK_SIGNATURE_BLOCK_LEN  # 13: link id, timestamp, signature


def check_key(key: bytes) -> bytes:
    """``key`` if it can be installed (32 bytes, not all zero); else ValueError."""
    if len(key) != KEY_BYTES:
        raise ValueError(f"signing key of {len(key)} bytes: must be {KEY_BYTES}")
    if not any(key):
        raise ValueError("signing key all zero: that means no signing")
    return bytes(key)


@dataclass
class SigningStats:
    """What the signing check did with incoming packets (reset when a key is installed)."""

    verified: int = 0  # signed packets accepted
    unsigned_allowed: int = 0  # RADIO_STATUS / RADIO accepted without a signature
    unsigned: int = 0  # rejected: no signature (or MAVLink 1)
    bad_signature: int = 0  # rejected: the signature does not verify with the key
    replayed: int = 0  # rejected: timestamp not newer than its stream's last one
    stale: int = 0  # rejected: a new stream more than a minute behind our timestamp
    too_many_streams: int = 0  # rejected: MAX_STREAMS streams already tracked

    @property
    def rejected(self) -> int:
        """Packets dropped by the signing check."""
        return (self.unsigned + self.bad_signature + self.replayed + self.stale
                + self.too_many_streams)


def start_signing(state: mavlink2.MAVLinkSigning, key: bytes, initial_timestamp: int = 0,
                  unix_clock: Callable[[], float] = time.time) -> None:
    """Sign what ``state``'s packer sends with ``key`` (32 bytes, not all zero) on the
    vehicle's link id, from ``initial_timestamp`` (10 us units since 2015) or the wall clock
    when that is later."""
    state.secret_key = check_key(key)
    state.sign_outgoing = True
    state.link_id = _LINK_ID
    state.allow_unsigned_callback = None
    now = timestamp_from_unix(unix_clock())
    state.timestamp = min(max(int(initial_timestamp), now), MAX_TIMESTAMP)


class MessageSigning:
    """Signing state of one endpoint: the key, outgoing timestamps, incoming checks.

    Parameters
    ----------
    state : pymavlink MAVLinkSigning
        The signing state of the packer that signs outgoing packets
        (:attr:`fcu.mavlink.transport.codec.Codec.signing`).
    outbox : Outbox
        Where STATUSTEXT and SIGN_REJ go.
    key : bytes or None
        Key installed at start (32 bytes, not all zero); None: signing off.
    unix_clock : callable
        UNIX time in seconds (``time.time``): signature timestamps follow it.
    """

    def __init__(self, state: mavlink2.MAVLinkSigning, outbox: Outbox, *, key: bytes | None = None,
                 unix_clock: Callable[[], float] = time.time) -> None:
        self._state = state
        self._outbox = outbox
        self._clock = unix_clock
        self._streams: dict[tuple[int, int, int], int] = {}
        self._announced = False
        self._last_report_wall_s = -math.inf
        self.stats = SigningStats()
        self._disable_state()
        if key is not None:
            self.install(check_key(key), 0)

    @property
    def active(self) -> bool:
        """A key is installed: outgoing packets are signed, incoming ones checked."""
        return self._state.secret_key is not None

    @property
    def timestamp(self) -> int:
        """The timestamp the next outgoing packet carries, 10 us units since 2015."""
        return int(self._state.timestamp)

    # ------------------------------------------------------------------ key
    def install(self, key: bytes, initial_timestamp: int) -> None:
        """Start signing with ``key`` (32 bytes, not all zero) from ``initial_timestamp``
        (10 us units since 2015; the wall clock when that is later)."""
        start_signing(self._state, key, initial_timestamp, self._clock)
        self._streams.clear()
        self._announced = False
        self.stats = SigningStats()

    def disable(self) -> None:
        """Stop signing: packets go out unsigned and every incoming packet is accepted."""
        self._disable_state()
        self._streams.clear()

    def _disable_state(self) -> None:
        self._state.secret_key = None
        self._state.sign_outgoing = False
        self._state.allow_unsigned_callback = None

    def handle_setup(self, msg: MAVLinkMessage) -> None:
        """SETUP_SIGNING (already addressed to us and, with a key, verified by :meth:`accept`).

        An all-zero key disables signing; an initial timestamp beyond 48 bits is refused with
        a STATUSTEXT and changes nothing.
        """
        key = bytes(int(b) & 0xFF for b in msg.secret_key)[:KEY_BYTES].ljust(KEY_BYTES, b"\0")
        initial = int(msg.initial_timestamp)
        if not any(key):
            was_active = self.active
            self.disable()
            if was_active:
                self._outbox.status(Severity.NOTICE, "Signing disabled")
            return
        if initial > MAX_TIMESTAMP:
            self._outbox.status(Severity.WARNING, f"Setup signing refused: initial_timestamp "
                                f"{initial} does not fit 48 bits")
            return
        self.install(key, initial)
        self._outbox.status(Severity.NOTICE, "Signing enabled: unsigned packets are dropped")

    # ------------------------------------------------------------------ incoming
    def accept(self, msg: MAVLinkMessage) -> bool:
        """Whether ``msg`` (decoded without a key) may be handled; counts the rejections."""
        if self._state.secret_key is None:
            return True
        buf = bytes(msg.get_msgbuf())
        signed = (len(buf) > 2 + _SIGNATURE_BYTES and buf[0] == _M.PROTOCOL_MARKER_V2
                  and buf[2] & _M.MAVLINK_IFLAG_SIGNED)
        if not signed:
            if msg.get_msgId() in UNSIGNED_ALLOWED_IDS:
                self.stats.unsigned_allowed += 1
                return True
            return self._reject(msg, "unsigned")
        # signature = sha256(key + header + payload + CRC + link id + timestamp)[:6]
        expected = hashlib.sha256(self._state.secret_key + buf[:-6]).digest()[:6]
        if not hmac.compare_digest(expected, buf[-6:]):
            return self._reject(msg, "bad_signature")
        link_id = buf[-_SIGNATURE_BYTES]
        stamp = int.from_bytes(buf[-12:-6], "little")
        stream = (link_id, msg.get_srcSystem(), msg.get_srcComponent())
        last = self._streams.get(stream)
        if last is None:
            if len(self._streams) >= MAX_STREAMS:
                return self._reject(msg, "too_many_streams")
            if stamp + NEW_STREAM_WINDOW < self._state.timestamp:
                return self._reject(msg, "stale")
        elif stamp <= last:
            return self._reject(msg, "replayed")
        self._streams[stream] = stamp
        self._state.timestamp = max(int(self._state.timestamp), stamp)
        self.stats.verified += 1
        return True

    def _reject(self, msg: MAVLinkMessage, why: str) -> bool:
        setattr(self.stats, why, getattr(self.stats, why) + 1)
        if not self._announced:
            self._announced = True
            words = why.replace("_", " ")
            self._outbox.status(
                Severity.WARNING, f"Signing: dropped {msg.get_type()} from "
                f"{msg.get_srcSystem()}/{msg.get_srcComponent()} ({words}); "
                f"NAMED_VALUE_INT {REPORT_NAME} counts rejections")
        return False

    # ------------------------------------------------------------------ periodic
    def tick(self, time_s: float, wall_s: float) -> None:
        """Keep the outgoing timestamp up with the wall clock; send SIGN_REJ when due.

        Parameters
        ----------
        time_s : float
            Simulated time since boot, s (the report's ``time_boot_ms``).
        wall_s : float
            Monotonic wall-clock time, s.
        """
        if self._state.secret_key is None:
            return
        self._state.timestamp = min(max(int(self._state.timestamp), self._now()),
                                    MAX_TIMESTAMP)
        if wall_s - self._last_report_wall_s < _REPORT_PERIOD_S:
            return
        self._last_report_wall_s = wall_s
        time_ms = min(max(int(time_s * 1000.0), 0), 0xFFFFFFFF)
        self._outbox.send(_M.MAVLink_named_value_int_message(
            time_ms, REPORT_NAME.encode(), min(self.stats.rejected, 0x7FFFFFFF)))

    def _now(self) -> int:
        return timestamp_from_unix(self._clock())
