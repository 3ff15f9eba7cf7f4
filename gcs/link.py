"""One MAVLink link to one vehicle: heartbeat, receive and record, replies, commands.

:class:`Link` owns a pymavlink connection (MAVLink 2, ardupilotmega, see :mod:`gcs.mavlink`)
and does what every exchange with the vehicle rests on: it sends its own HEARTBEAT once per
wall-clock second (the vehicle's GCS-loss failsafe counts it), receives every packet, keeps
the vehicle's protocol replies (COMMAND_ACK, PARAM_VALUE, MISSION_REQUEST/_INT, MISSION_ACK,
STATUSTEXT, SYS_STATUS) until someone waits for them, finds the vehicle and its clock, and
sends COMMAND_LONG waiting for the COMMAND_ACK (retrying as MAVSDK does). What a ground
station does over it (parameters, missions, arming, injections) is
:class:`gcs.station.GroundStation`.

With a signing key (MAVLink 2 signing, :func:`gcs.mavlink.enable_signing`) everything sent is
signed and only packets that verify with the key are handled; :meth:`Link.wait_vehicle` says
at once, with :class:`gcs.errors.SigningMismatch`, when the vehicle's signing does not match
ours (it signs and we have no key, or three of its HEARTBEATs failed the signature check).

Every packet sent or received goes, in order, to the .tlog (:class:`gcs.records.TlogWriter`)
and to a :class:`gcs.analysis.FlightAnalyzer`, whose events go to the event log.

Clocks: socket waits and protocol time-outs are wall-clock seconds (what a person waits); the
vehicle's clock is its simulated seconds, read from its telemetry (``time_boot_ms``). The two
never mix.
"""

from __future__ import annotations

import math
import select
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Self

from flightdata.series import FlightEvent
from flightdata.signing import timestamp_from_unix
from gcs.analysis import FlightAnalyzer
from gcs.errors import CommandRefused, FlightTimeout, SigningMismatch, VehicleNotFound
from gcs.mavlink import (
    MAVLinkMessage,
    decode_packet,
    enable_signing,
    is_signed,
    mavlink2,
    open_link,
)
from gcs.records import EventLog, TlogWriter
from gcs.telemetry import mavlink_text

__all__ = ["ACK_TIMEOUT_S", "Link"]

_M = mavlink2
_HEARTBEAT_PERIOD_S = 1.0  # s wall, GCS heartbeat (ArduPilot FS_GCS_TIMEOUT default is 5 s)
ACK_TIMEOUT_S = 1.0  # s wall, per attempt
_ACK_ATTEMPTS = 3
_REASON_WAIT_S = 0.3  # s wall, how long a refusal's STATUSTEXT may trail its ACK
_UNVERIFIED_HEARTBEATS = 3  # autopilot HEARTBEATs failing the signature check: a mismatch


class Link:
    """One MAVLink link to one vehicle (see the module docstring).

    Parameters
    ----------
    conn : pymavlink.mavutil.mavfile
        An open MAVLink 2 connection (:func:`gcs.mavlink.open_link`).
    url : str
        What ``conn`` was opened with (for messages).
    tlog : TlogWriter or None
        Where every packet is recorded.
    events : EventLog or None
        Where events are written.
    signing_key : bytes or None
        MAVLink 2 signing key (32 bytes); None: unsigned.
    """

    def __init__(self, conn: Any, url: str, *, tlog: TlogWriter | None = None,
                 events: EventLog | None = None, signing_key: bytes | None = None) -> None:
        self.conn = conn
        self.signing = signing_key is not None
        if signing_key is not None:
            enable_signing(conn, signing_key, time.time())
        self.unverified = 0  # packets dropped by the signature check
        self._unverified_heartbeats: list[bytes] = []  # raw autopilot HEARTBEATs dropped
        self._vehicle_signs = False  # a signed autopilot HEARTBEAT was seen
        self.url = url
        self.tlog = tlog
        self.events = events if events is not None else EventLog(None)
        self.analyzer = FlightAnalyzer(on_event=self._on_analyzer_event)
        self._last_heartbeat_wall = -math.inf
        self._last_rx_wall = -math.inf
        self._last_vehicle_wall = -math.inf
        self._inbox: list[MAVLinkMessage] = []  # protocol replies waiting for a reader
        self._clock_hooks: list[Callable[[float], None]] = []
        self._event_hooks: list[Callable[[FlightEvent], None]] = []
        self._sent_clock: float | None = None  # vehicle clock when the last command left
        self.closed = False

    # ------------------------------------------------------------------ lifecycle
    @classmethod
    def open(cls, url: str, *, tlog: str | Path | None = None,
             event_log: str | Path | None = None, echo: Any = None,
             signing_key: bytes | None = None) -> Self:
        """Open ``url`` and the records.

        Parameters
        ----------
        url : str
            pymavlink connection string, e.g. ``udpin:0.0.0.0:14550``.
        tlog : path or None
            .tlog to write.
        event_log : path or None
            Event log to write.
        echo : text stream or None
            Also print events there (e.g. ``sys.stderr``).
        signing_key : bytes or None
            MAVLink 2 signing key (32 bytes); None: unsigned.
        """
        conn = open_link(url)
        return cls(conn, url, tlog=None if tlog is None else TlogWriter(tlog),
                   events=EventLog(event_log, echo), signing_key=signing_key)

    def close(self) -> None:
        """Close the link and flush the records (idempotent)."""
        if self.closed:
            return
        self.closed = True
        try:
            self.conn.close()
        finally:
            if self.tlog is not None:
                self.tlog.close()
            self.events.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ recording
    def _record(self, packet: bytes, msg: MAVLinkMessage) -> None:
        stamp = time.time()
        if self.tlog is not None:
            self.tlog.write(packet, stamp)
        self.analyzer.feed(msg, int(stamp * 1e6))

    def _on_analyzer_event(self, event: FlightEvent) -> None:
        self.events.write(event.kind, event.text, event.time_s)
        self._note_event(event)
        for hook in list(self._event_hooks):
            hook(event)

    def _note_event(self, event: FlightEvent) -> None:
        """Called with each analyzer event before the :meth:`on_event` hooks (a subclass's
        own bookkeeping)."""

    def log(self, kind: str, text: str) -> None:
        """Write an event of our own, dated with the vehicle clock."""
        self.events.write(kind, text, self.analyzer.clock_s)

    # ------------------------------------------------------------------ sending
    def send(self, msg: MAVLinkMessage, *, with_timesync: bool = False) -> None:
        """Pack, send and record one message.

        Parameters
        ----------
        msg : MAVLink_message
        with_timesync : bool
            Append a TIMESYNC request in the same datagram: the vehicle handles both in the
            same tick and answers the TIMESYNC with that tick's simulated time, which dates
            the command exactly (see :mod:`gcs.analysis`).
        """
        msgs = [msg]
        if with_timesync:
            sysid, compid = self.target
            msgs.append(_M.MAVLink_timesync_message(0, time.time_ns()))
        mav = self.conn.mav
        if mav.signing.sign_outgoing:  # never behind the wall clock, as MAVProxy keeps it
            mav.signing.timestamp = max(mav.signing.timestamp, timestamp_from_unix(time.time()))
        packets = []
        for m in msgs:
            packets.append(bytes(m.pack(mav)))
            mav.seq = (mav.seq + 1) % 256
            mav.total_packets_sent += 1
            mav.total_bytes_sent += len(packets[-1])
        self.conn.write(b"".join(packets))
        for m, packet in zip(msgs, packets, strict=True):
            decoded = decode_packet(packet)  # what the wire (and the .tlog) carries: float32
            self._record(packet, decoded if decoded is not None else m)

    def send_heartbeat(self) -> None:
        """Our HEARTBEAT (a ground station: type GCS, autopilot INVALID)."""
        self.send(_M.MAVLink_heartbeat_message(_M.MAV_TYPE_GCS, _M.MAV_AUTOPILOT_INVALID, 0,
                                               0, _M.MAV_STATE_ACTIVE, 3))
        self._last_heartbeat_wall = time.monotonic()

    @property
    def target(self) -> tuple[int, int]:
        """(sysid, compid) of the vehicle (raises when none was found yet)."""
        if self.analyzer.vehicle is None:
            raise VehicleNotFound(f"no vehicle on {self.url} yet")
        return self.analyzer.vehicle

    # ------------------------------------------------------------------ receiving
    def pump(self, wait_s: float = 0.0) -> int:
        """Wait up to ``wait_s`` wall seconds for data, then handle all that is waiting.

        Returns
        -------
        int
            Messages handled.
        """
        now = time.monotonic()
        if now - self._last_heartbeat_wall >= _HEARTBEAT_PERIOD_S:
            self.send_heartbeat()
        fd = getattr(self.conn, "fd", None)
        if wait_s > 0 and fd is not None:
            try:
                select.select([fd], [], [], wait_s)
            except (OSError, ValueError):
                pass
        elif wait_s > 0:
            time.sleep(wait_s)
        handled = 0
        while True:
            try:
                msg = self.conn.recv_msg()
            except (ConnectionError, OSError):
                break
            if msg is None:
                break
            if msg.get_type() == "BAD_DATA":
                self._note_unverified(msg)
                continue
            handled += 1
            self._handle(msg)
        if handled:
            self._last_rx_wall = time.monotonic()
        return handled

    def _note_unverified(self, bad: MAVLinkMessage) -> None:
        """Count a packet the signature check dropped; keep the autopilot HEARTBEATs."""
        if getattr(bad, "reason", "") != "Invalid signature":
            return
        self.unverified += 1
        packet = bytes(bad.data)
        msg = decode_packet(packet)
        if (msg is not None and msg.get_type() == "HEARTBEAT"
                and int(msg.autopilot) != _M.MAV_AUTOPILOT_INVALID
                and len(self._unverified_heartbeats) < _UNVERIFIED_HEARTBEATS):
            self._unverified_heartbeats.append(packet)

    def _signing_mismatch(self) -> str | None:
        """Why the vehicle's signing cannot match ours (None: no sign of a mismatch yet)."""
        if not self.signing and self._vehicle_signs:
            return (f"the autopilot on {self.url} signs its packets (MAVLink 2 signing) and "
                    "drops unsigned ones: give its key with --signing-key")
        if len(self._unverified_heartbeats) < _UNVERIFIED_HEARTBEATS:
            return None
        if not any(is_signed(p) for p in self._unverified_heartbeats):
            return (f"the autopilot on {self.url} does not sign its packets (no signing key "
                    "on the vehicle?), so none verifies with --signing-key")
        return (f"the autopilot on {self.url} signs with another key than --signing-key "
                f"({self.unverified} of its packets failed the signature check)")

    def _handle(self, msg: MAVLinkMessage) -> None:
        if (not self.signing and not self._vehicle_signs and msg.get_type() == "HEARTBEAT"
                and int(msg.autopilot) != _M.MAV_AUTOPILOT_INVALID
                and is_signed(msg.get_msgbuf())):
            self._vehicle_signs = True
        before = self.analyzer.clock_s
        self._record(bytes(msg.get_msgbuf()), msg)
        vehicle = self.analyzer.vehicle
        if vehicle is not None and (msg.get_srcSystem(), msg.get_srcComponent()) == vehicle:
            self._last_vehicle_wall = time.monotonic()
            if self.conn.target_system != vehicle[0]:
                self.conn.target_system = vehicle[0]
                self.conn.target_component = vehicle[1]
            if msg.get_type() in _REPLY_TYPES:
                self._inbox.append(msg)
                if len(self._inbox) > 10_000:
                    del self._inbox[:5_000]
        clock = self.analyzer.clock_s
        if clock is not None and clock != before:
            for hook in list(self._clock_hooks):
                hook(clock)

    def _take(self, kind: str, match: Callable[[MAVLinkMessage], bool]) -> MAVLinkMessage | None:
        for i, msg in enumerate(self._inbox):
            if msg.get_type() == kind and match(msg):
                del self._inbox[i]
                return msg
        return None

    def _wait_reply(self, kinds: Sequence[str], match: Callable[[MAVLinkMessage], bool],
                    timeout_s: float) -> MAVLinkMessage | None:
        deadline = time.monotonic() + timeout_s
        while True:
            for kind in kinds:
                msg = self._take(kind, match)
                if msg is not None:
                    return msg
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            self.pump(min(left, 0.05))

    def _refusal_reason(self, default: str = "") -> str:
        """The STATUSTEXT a refusal carries (it follows the answer within a tick or two).

        Chunked texts (longer than 50 characters) are put back together.
        """
        deadline = time.monotonic() + _REASON_WAIT_S
        parts: list[str] = []
        chunk_id: int | None = None
        while time.monotonic() < deadline:
            def wanted(m: MAVLinkMessage, chunk: int | None = chunk_id) -> bool:
                return int(m.severity) <= _M.MAV_SEVERITY_WARNING and (
                    chunk is None or int(getattr(m, "id", 0)) == chunk)

            msg = self._wait_reply(["STATUSTEXT"], wanted, max(0.0, deadline - time.monotonic()))
            if msg is None:
                break
            text = mavlink_text(msg.text)
            parts.append(text)
            chunk_id = int(getattr(msg, "id", 0))
            if chunk_id == 0 or len(text) < 50:
                break
        return "".join(parts) or default

    def wall_since_vehicle_s(self) -> float:
        """Wall seconds since the vehicle was last heard."""
        return time.monotonic() - self._last_vehicle_wall

    # ------------------------------------------------------------------ connecting
    def wait_vehicle(self, timeout_s: float = 10.0,
                     gone: Callable[[], str | None] | None = None) -> tuple[int, int]:
        """Wait for an autopilot's HEARTBEAT; returns its (sysid, compid).

        Parameters
        ----------
        timeout_s : float
            Wall seconds.
        gone : callable or None
            Polled while waiting: a text when the vehicle cannot come any more (a child
            process that exited), which ends the wait at once.

        Raises
        ------
        VehicleNotFound
            When none arrives within ``timeout_s`` wall seconds, or ``gone`` says why.
        SigningMismatch
            When the vehicle's MAVLink 2 signing does not match ours.
        """
        self.log("LINK", f"listening on {self.url}" + (" (signing)" if self.signing else ""))
        deadline = time.monotonic() + timeout_s
        while self.analyzer.vehicle is None or self._signing_mismatch():
            mismatch = self._signing_mismatch()
            if mismatch:
                raise SigningMismatch(mismatch)
            left = deadline - time.monotonic()
            if left <= 0:
                raise VehicleNotFound(f"no HEARTBEAT from an autopilot on {self.url} within "
                                      f"{timeout_s:g} s" + (
                                          f" ({self.unverified} packets failed the signature "
                                          "check)" if self.unverified else ""))
            why = gone() if gone is not None else None
            if why:
                raise VehicleNotFound(why)
            self.pump(min(left, 0.1))
        sysid, compid = self.analyzer.vehicle
        self.conn.target_system, self.conn.target_component = sysid, compid
        self.send_heartbeat()  # let a vehicle we reach through udpout learn our address now
        self.log("LINK", f"vehicle sysid {sysid} compid {compid} found")
        return sysid, compid

    def wait_clock(self, timeout_s: float = 10.0) -> float:
        """Wait until the vehicle's simulated clock is known; returns it (s).

        A TIMESYNC request goes out once per wall second meanwhile: a paused simulation
        streams nothing time-stamped, but answers TIMESYNC with its (held) time.
        """
        deadline = time.monotonic() + timeout_s
        last_request = -math.inf
        while self.analyzer.clock_s is None:
            now = time.monotonic()
            if now >= deadline:
                raise FlightTimeout(f"no time-stamped telemetry within {timeout_s:g} s")
            if now - last_request >= 1.0:
                sysid, compid = self.target
                self.send(_M.MAVLink_timesync_message(0, time.time_ns()))
                last_request = now
            self.pump(0.05)
        return self.analyzer.clock_s

    # ------------------------------------------------------------------ commands
    def command(self, command: int, params: Sequence[float] = (), *, what: str = "",
                accept_temporarily_rejected: bool = False, with_timesync: bool = False) -> int:
        """COMMAND_LONG, waiting for its COMMAND_ACK (3 attempts, 1 s apart).

        Parameters
        ----------
        command : int
            MAV_CMD.
        params : sequence of up to 7 float
            param1..param7 (missing ones are 0).
        what : str
            Words for messages (default: the command's name).
        accept_temporarily_rejected : bool
            Return TEMPORARILY_REJECTED instead of raising.
        with_timesync : bool
            Date the command exactly (see :meth:`send`).

        Returns
        -------
        int
            MAV_RESULT (ACCEPTED, or TEMPORARILY_REJECTED when allowed).

        Raises
        ------
        CommandRefused
            DENIED, UNSUPPORTED, FAILED..., with the vehicle's STATUSTEXT reason.
        FlightTimeout
            No ACK after three attempts.
        """
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        name = what or (_M.enums["MAV_CMD"][command].name.removeprefix("MAV_CMD_")
                        if command in _M.enums["MAV_CMD"] else str(command))
        sysid, compid = self.target
        for attempt in range(_ACK_ATTEMPTS):
            self._take_all("COMMAND_ACK", lambda m: int(m.command) == command)
            self.send(_M.MAVLink_command_long_message(sysid, compid, command, attempt, *p),
                      with_timesync=with_timesync)
            self._sent_clock = self.analyzer.clock_s
            ack = self._wait_reply(["COMMAND_ACK"], lambda m: int(m.command) == command,
                                   ACK_TIMEOUT_S)
            if ack is None:
                continue
            result = int(ack.result)
            if result == _M.MAV_RESULT_ACCEPTED:
                return result
            if result == _M.MAV_RESULT_TEMPORARILY_REJECTED and accept_temporarily_rejected:
                return result
            result_name = _M.enums["MAV_RESULT"][result].name.removeprefix("MAV_RESULT_") \
                if result in _M.enums["MAV_RESULT"] else str(result)
            reason = self._refusal_reason()
            raise CommandRefused(f"{name}: {result_name}" + (f": {reason}" if reason else ""))
        raise FlightTimeout(f"no COMMAND_ACK for {name} after {_ACK_ATTEMPTS} attempts "
                            f"({ACK_TIMEOUT_S:g} s apart)")

    def _take_all(self, kind: str, match: Callable[[MAVLinkMessage], bool]) -> None:
        while self._take(kind, match) is not None:
            pass

    # ------------------------------------------------------------------ hooks
    def on_clock(self, hook: Callable[[float], None]) -> None:
        """Call ``hook(clock_s)`` each time the vehicle clock advances (inside :meth:`pump`)."""
        self._clock_hooks.append(hook)

    def on_event(self, hook: Callable[[FlightEvent], None]) -> None:
        """Call ``hook(event)`` for each analyzer event."""
        self._event_hooks.append(hook)


_REPLY_TYPES = frozenset({"COMMAND_ACK", "PARAM_VALUE", "MISSION_REQUEST_INT",
                          "MISSION_REQUEST", "MISSION_ACK", "STATUSTEXT", "SYS_STATUS"})
