"""One MAVLink link to one vehicle: heartbeat, receive and record, replies, commands.

:class:`Link` owns a pymavlink connection (MAVLink 2, ardupilotmega, see :mod:`gcs.mavlink`)
and does what every exchange with the vehicle rests on: it sends its own HEARTBEAT twice per
wall-clock second (the vehicle's GCS-loss failsafe counts it), receives every packet, keeps
the vehicle's protocol replies (COMMAND_ACK, PARAM_VALUE, MISSION_REQUEST/_INT, MISSION_ACK,
STATUSTEXT, SYS_STATUS, MESSAGE_INTERVAL) until someone waits for them
(:class:`gcs.reply_inbox.ReplyInbox`), finds the vehicle and its clock, and sends COMMAND_LONG
waiting for the COMMAND_ACK. What a ground station does
over it (parameters, missions, arming, injections) is :class:`gcs.station.GroundStation`.

A bad link
----------
Two threads keep the link alive whatever the caller is busy with (drawing a live view, a
slow machine): one sends the HEARTBEAT on its own timer, one drains the socket as datagrams
arrive into a queue that :meth:`Link.pump` handles (so the operating system's buffer,
enlarged to 4 MiB, never overflows while the caller is busy). The caller's thread does all
the rest; the codec, the socket writes and the records are shared under one lock. The
heartbeat goes out every 0.5 s so that a link losing a third of its packets practically
never goes the vehicle's 5 s (``FS_GCS_TIMEOUT``) without one. Commands are retried with
back-off (:data:`ACK_TIMEOUTS_S`: 8 attempts over about 20 s; other requests are asked
again after a wait set by the measured round trips, :class:`gcs.round_trips.RoundTrips`), and
a command whose ACK was lost but whose effect the vehicle already shows (armed, a mode, a
stream interval read back) counts as done: see :meth:`Link.command`.

With a signing key (MAVLink 2 signing, :func:`gcs.mavlink.enable_signing`) everything sent is
signed and only packets that verify with the key are handled; :meth:`Link.wait_vehicle` says
at once, with :class:`gcs.errors.SigningMismatch`, when the vehicle's signing does not match
ours (it signs and we have no key, or three of its HEARTBEATs failed the signature check:
:class:`gcs.signing_check.SigningCheck`).

Every packet sent or received goes, in order, to the .tlog (:class:`gcs.records.TlogWriter`)
and to a :class:`gcs.analysis.FlightAnalyzer`, whose events go to the event log.

Clocks: socket waits and protocol time-outs are wall-clock seconds (what a person waits); the
vehicle's clock is its simulated seconds, read from its telemetry (``time_boot_ms``). The two
never mix.
"""

from __future__ import annotations

import math
import queue
import select
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Self

from flightdata.series import FlightEvent
from flightdata.signing import timestamp_from_unix
from gcs.analysis import FlightAnalyzer
from gcs.errors import CommandRefused, FlightTimeout, SigningMismatch, VehicleNotFound
from gcs.mavlink import MAVLinkMessage, decode_packet, enable_signing, mavlink2, open_link
from gcs.records import EventLog, TlogWriter
from gcs.reply_inbox import ReplyInbox
from gcs.round_trips import RoundTrips
from gcs.signing_check import SigningCheck
from gcs.telemetry import mavlink_text

__all__ = ["ACK_TIMEOUTS_S", "Link"]

_M = mavlink2
_HEARTBEAT_PERIOD_S = 0.5  # s wall, GCS heartbeat (ArduPilot FS_GCS_TIMEOUT default is 5 s)
ACK_TIMEOUTS_S = (1.0, 1.5, 2.0, 2.5, 3.0, 3.0, 3.0, 3.0)
"""Wall seconds each attempt of a command waits for its answer (8 attempts, ~19 s)."""
BOOT_PROGRESS_GAP_S = 30.0  # s wall a booting vehicle may go without a progress report
_REASON_WAIT_S = 0.3  # s wall, how long a refusal's STATUSTEXT may trail its ACK
_READ_WAIT_S = 0.1  # s wall, longest the reader thread sleeps before looking again
_PUMP_BATCH = 20_000  # messages handled per pump at most (the caller keeps control)


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
        self._signing_check = SigningCheck(url, self.signing)
        self.url = url
        self.tlog = tlog
        self.events = events if events is not None else EventLog(None)
        self.analyzer = FlightAnalyzer(on_event=self._on_analyzer_event)
        self.vehicle_ready = False  # wait_vehicle found it booted (STANDBY or later)
        self._last_heartbeat_wall = -math.inf
        self._last_rx_wall = -math.inf
        self._last_vehicle_wall = -math.inf
        self.inbox = ReplyInbox()  # protocol replies waiting for a reader
        self._clock_hooks: list[Callable[[float], None]] = []
        self._handling_wall_s: float | None = None  # receipt of the message being handled
        self.round_trips = RoundTrips()  # of requests to their replies, to time retries
        self._event_hooks: list[Callable[[FlightEvent], None]] = []
        self._sent_clock: float | None = None  # vehicle clock when the last command left
        # the last command ended with its COMMAND_ACK (False: its effect showed, the answer
        # never came)
        self.last_command_acked = True
        self.closed = False
        # the threads (started by start(), e.g. on the first pump)
        self._io = threading.RLock()  # the codec, socket writes and the records
        self._received: queue.SimpleQueue[tuple[MAVLinkMessage, float]] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self.receive_errors = 0  # socket errors seen by the reader thread

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

    def start(self) -> None:
        """Start the heartbeat and reader threads (idempotent; :meth:`pump` calls it)."""
        if self._threads or self.closed:
            return
        self._threads = [threading.Thread(target=self._heartbeat_loop, name="gcs-heartbeat",
                                          daemon=True),
                         threading.Thread(target=self._read_loop, name="gcs-reader",
                                          daemon=True)]
        for thread in self._threads:
            thread.start()

    def close(self) -> None:
        """Stop the threads, close the link and flush the records (idempotent)."""
        if self.closed:
            return
        self.closed = True
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=5.0)
        try:
            with self._io:
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
    def _record(self, packet: bytes, msg: MAVLinkMessage, stamp: float | None = None) -> None:
        """Log ``packet`` (received at UNIX time ``stamp``, s; now when None) and feed it."""
        if stamp is None:
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
        """Pack, send and record one message (the caller's thread; the heartbeat thread
        has :meth:`send_heartbeat`).

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
        with self._io:
            packets = self._pack(msgs)
            self.conn.write(b"".join(packets))
            for m, packet in zip(msgs, packets, strict=True):
                decoded = decode_packet(packet)  # what the wire (and the .tlog) carries
                self._record(packet, decoded if decoded is not None else m)

    def _pack(self, msgs: Sequence[MAVLinkMessage]) -> list[bytes]:
        mav = self.conn.mav
        if mav.signing.sign_outgoing:  # never behind the wall clock, as MAVProxy keeps it
            mav.signing.timestamp = max(mav.signing.timestamp, timestamp_from_unix(time.time()))
        packets = []
        for m in msgs:
            packets.append(bytes(m.pack(mav)))
            mav.seq = (mav.seq + 1) % 256
            mav.total_packets_sent += 1
            mav.total_bytes_sent += len(packets[-1])
        return packets

    def send_heartbeat(self) -> None:
        """Our HEARTBEAT (a ground station: type GCS, autopilot INVALID), from any thread.

        Recorded in the .tlog but not fed to the analyzer (it carries nothing the table
        uses, and the analyzer belongs to the caller's thread).
        """
        msg = _M.MAVLink_heartbeat_message(_M.MAV_TYPE_GCS, _M.MAV_AUTOPILOT_INVALID, 0, 0,
                                           _M.MAV_STATE_ACTIVE, 3)
        with self._io:
            (packet,) = self._pack([msg])
            self.conn.write(packet)
            if self.tlog is not None:
                self.tlog.write(packet, time.time())
        self._last_heartbeat_wall = time.monotonic()

    def _heartbeat_loop(self) -> None:
        while not self._stop.is_set():
            try:
                self.send_heartbeat()
            except (OSError, ValueError):
                pass  # a closed or failing socket: the caller's thread reports the link
            self._stop.wait(_HEARTBEAT_PERIOD_S)

    @property
    def target(self) -> tuple[int, int]:
        """(sysid, compid) of the vehicle (raises when none was found yet)."""
        if self.analyzer.vehicle is None:
            raise VehicleNotFound(f"no vehicle on {self.url} yet")
        return self.analyzer.vehicle

    # ------------------------------------------------------------------ receiving
    def _read_loop(self) -> None:
        """The reader thread: move every datagram's messages into the queue at once."""
        fd = getattr(self.conn, "fd", None)
        while not self._stop.is_set():
            try:
                if fd is not None:
                    select.select([fd], [], [], _READ_WAIT_S)
                else:
                    time.sleep(0.005)
            except (OSError, ValueError):
                return  # closed
            while not self._stop.is_set():
                try:
                    with self._io:
                        msg = self.conn.recv_msg()
                except (ConnectionError, OSError):
                    self.receive_errors += 1
                    break
                except Exception:  # a malformed packet pymavlink chokes on: skip it
                    self.receive_errors += 1
                    continue
                if msg is None:
                    break
                # BAD_DATA too: a packet that failed the signature check is counted
                # (SigningCheck.note_unverified)
                self._received.put((msg, time.time()))

    def pump(self, wait_s: float = 0.0) -> int:
        """Wait up to ``wait_s`` wall seconds for data, then handle all that is waiting.

        Returns
        -------
        int
            Messages handled.
        """
        self.start()
        handled = 0
        try:
            item = self._received.get(timeout=wait_s) if wait_s > 0 else \
                self._received.get_nowait()
        except queue.Empty:
            return 0
        while True:
            msg, stamp = item
            if msg.get_type() == "BAD_DATA":
                self._signing_check.note_unverified(msg)
            else:
                self._handle(msg, stamp)
            handled += 1
            if handled >= _PUMP_BATCH:
                break
            try:
                item = self._received.get_nowait()
            except queue.Empty:
                break
        self._last_rx_wall = time.monotonic()
        return handled

    @property
    def unverified(self) -> int:
        """Packets dropped by the signature check."""
        return self._signing_check.unverified

    def _handle(self, msg: MAVLinkMessage, stamp: float | None = None) -> None:
        self._signing_check.note_received(msg)
        before = self.analyzer.clock_s
        self._handling_wall_s = stamp
        with self._io:
            self._record(bytes(msg.get_msgbuf()), msg, stamp)
        vehicle = self.analyzer.vehicle
        if vehicle is not None and (msg.get_srcSystem(), msg.get_srcComponent()) == vehicle:
            self._last_vehicle_wall = time.monotonic()
            if self.conn.target_system != vehicle[0]:
                self.conn.target_system = vehicle[0]
                self.conn.target_component = vehicle[1]
            self.inbox.keep(msg)
        clock = self.analyzer.clock_s
        if clock is not None and clock != before:
            for hook in list(self._clock_hooks):
                hook(clock)

    def _wait_reply(self, kinds: Sequence[str], match: Callable[[MAVLinkMessage], bool],
                    timeout_s: float) -> MAVLinkMessage | None:
        deadline = time.monotonic() + timeout_s
        while True:
            for kind in kinds:
                msg = self.inbox.take(kind, match)
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
                     gone: Callable[[], str | None] | None = None,
                     progress_gap_s: float = BOOT_PROGRESS_GAP_S) -> tuple[int, int]:
        """Wait for an autopilot's HEARTBEAT, and while it says MAV_STATE_BOOT for one that
        does not; returns its (sysid, compid).

        A booting vehicle that reports progress (STATUSTEXT ``preparing: N of M kernels
        compiled, T s``, every few seconds while it compiles) is waited for as long as the
        reports keep coming, each shown on the log: at most ``progress_gap_s`` between two of
        them, however long the boot takes in all (minutes, on a machine that has never
        compiled the kernels).

        Parameters
        ----------
        timeout_s : float
            Wall seconds: for the first HEARTBEAT, and for a booting vehicle that reports no
            progress.
        gone : callable or None
            Polled while waiting: a text when the vehicle cannot come any more (a child
            process that exited), which ends the wait at once.
        progress_gap_s : float
            Wall seconds a booting vehicle may go without a progress report.

        Raises
        ------
        VehicleNotFound
            When none arrives in time, a booting vehicle stops reporting progress, or ``gone``
            says why.
        SigningMismatch
            When the vehicle's MAVLink 2 signing does not match ours.
        """
        self.log("LINK", f"listening on {self.url}" + (" (signing)" if self.signing else ""))
        start_s = time.monotonic()
        deadline = start_s + timeout_s
        booting_logged = False
        seen_lines = 0
        analyzer = self.analyzer
        signing_check = self._signing_check
        while analyzer.vehicle is None or analyzer.vehicle_booting or signing_check.mismatch():
            if analyzer.vehicle_booting and not booting_logged:
                self.log("LINK", "vehicle booting (HEARTBEAT says MAV_STATE_BOOT): waiting")
                booting_logged = True
            if analyzer.boot_progress_lines != seen_lines:
                seen_lines = analyzer.boot_progress_lines
                self.log("LINK", f"vehicle {analyzer.boot_progress}")
                deadline = max(deadline, time.monotonic() + progress_gap_s)
            mismatch = signing_check.mismatch()
            if mismatch:
                raise SigningMismatch(mismatch)
            left = deadline - time.monotonic()
            if left <= 0:
                waited_s = time.monotonic() - start_s
                if seen_lines:
                    raise VehicleNotFound(
                        f"the vehicle on {self.url} stopped reporting its boot progress after "
                        f"{waited_s:.0f} s; its last report: '{analyzer.boot_progress}'")
                if analyzer.vehicle_booting:
                    raise VehicleNotFound(f"the vehicle on {self.url} was still booting after "
                                          f"{timeout_s:g} s (and reported no progress)")
                raise VehicleNotFound(f"no HEARTBEAT from an autopilot on {self.url} within "
                                      f"{timeout_s:g} s" + (
                                          f" ({self.unverified} packets failed the signature "
                                          "check)" if self.unverified else ""))
            why = gone() if gone is not None else None
            if why:
                raise VehicleNotFound(why)
            self.pump(min(left, 0.1))
        assert analyzer.vehicle is not None  # (the loop above waited for it)
        sysid, compid = analyzer.vehicle
        self.vehicle_ready = True
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
                accept_temporarily_rejected: bool = False, with_timesync: bool = False,
                applied: Callable[[], bool] | None = None,
                read_back: Callable[[], None] | None = None) -> int:
        """COMMAND_LONG, waiting for its COMMAND_ACK (retried with back-off).

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
        applied : callable or None
            Whether the vehicle already shows the command's effect (armed, a mode, a stream
            interval read back...). Polled while waiting: an ACK lost on the way back then
            costs no more than the read-back, and a retry the vehicle refuses because the
            first attempt took effect counts as done.
        read_back : callable or None
            Asks the vehicle for the state ``applied`` looks at (e.g. GET_MESSAGE_INTERVAL);
            called with every attempt after the first.

        Returns
        -------
        int
            MAV_RESULT (ACCEPTED, or TEMPORARILY_REJECTED when allowed).

        Raises
        ------
        CommandRefused
            DENIED, UNSUPPORTED, FAILED..., with the vehicle's STATUSTEXT reason.
        FlightTimeout
            No answer after every attempt (:data:`ACK_TIMEOUTS_S`).
        """
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        name = what or (_M.enums["MAV_CMD"][command].name.removeprefix("MAV_CMD_")
                        if command in _M.enums["MAV_CMD"] else str(command))
        sysid, compid = self.target

        def is_ack(m: MAVLinkMessage) -> bool:
            return int(m.command) == command

        for attempt, timeout_s in enumerate(ACK_TIMEOUTS_S):
            self.inbox.take_all("COMMAND_ACK", is_ack)
            self.send(_M.MAVLink_command_long_message(sysid, compid, command, attempt, *p),
                      with_timesync=with_timesync)
            if attempt and read_back is not None:
                read_back()
            self._sent_clock = self.analyzer.clock_s
            deadline = time.monotonic() + timeout_s
            ack = None
            while ack is None:
                ack = self.inbox.take("COMMAND_ACK", is_ack)
                if ack is not None:
                    break
                if attempt and applied is not None and applied():
                    self.log("ACK", f"{name}: answer lost, the vehicle shows it done")
                    self.last_command_acked = False
                    return _M.MAV_RESULT_ACCEPTED
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self.pump(min(left, 0.05))
            if ack is None:
                continue
            result = int(ack.result)
            self.last_command_acked = True
            if result == _M.MAV_RESULT_ACCEPTED:
                return result
            if result == _M.MAV_RESULT_TEMPORARILY_REJECTED and accept_temporarily_rejected:
                return result
            if attempt and applied is not None and applied():
                self.log("ACK", f"{name}: the first attempt took effect (read back)")
                return _M.MAV_RESULT_ACCEPTED
            result_name = _M.enums["MAV_RESULT"][result].name.removeprefix("MAV_RESULT_") \
                if result in _M.enums["MAV_RESULT"] else str(result)
            reason = self._refusal_reason()
            raise CommandRefused(f"{name}: {result_name}" + (f": {reason}" if reason else ""))
        raise FlightTimeout(f"no COMMAND_ACK for {name} after {len(ACK_TIMEOUTS_S)} attempts "
                            f"over {sum(ACK_TIMEOUTS_S):g} s")

    @property
    def received_wall_s(self) -> float | None:
        """Wall time (``time.time``) the message being handled was received by the reader
        thread (None when unknown): a clock hook can tell a message that left the vehicle
        before something it sent from one that may have left after."""
        return self._handling_wall_s

    # ------------------------------------------------------------------ hooks
    def on_clock(self, hook: Callable[[float], None]) -> None:
        """Call ``hook(clock_s)`` each time the vehicle clock advances (inside :meth:`pump`)."""
        self._clock_hooks.append(hook)

    def on_event(self, hook: Callable[[FlightEvent], None]) -> None:
        """Call ``hook(event)`` for each analyzer event."""
        self._event_hooks.append(hook)

