"""Harness for the integration tests: the vehicle in a subprocess and a pymavlink ground station.

Everything runs on loopback (127.0.0.1). The vehicle binds port 0 (a free port chosen by the
OS, read back from its startup line) and sends its telemetry only to the ports the test's own
sockets are bound to, so tests run in parallel without hearing each other. Every wait is
bounded by a generous wall-clock limit (a loaded two-core machine); nothing here retries.

The ground station is a bare UDP socket plus pymavlink's ``ardupilotmega`` MAVLink 2 codec
(chosen explicitly, no environment variables), so a test controls every byte it sends: it can
drop a packet on purpose, send NaN fields, or send random bytes. With ``signing_key`` it signs
what it sends (MAVLink 2 signing); it always decodes what it receives without a key, so a test
sees signed and unsigned packets alike and checks signatures itself (``raw`` keeps every
datagram when asked).
"""

from __future__ import annotations

import math
import os
import re
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from flightdata.signing import timestamp_from_unix

M = mavlink2
ROOT = Path(__file__).resolve().parents[2]
STARTUP_S = 60.0  # s wall: imports, numba cache, LQR design on a loaded machine
ANSWER_S = 10.0  # s wall: any single answer over loopback
STOP_S = 20.0  # s wall: clean stop after SIGTERM
_LISTEN = re.compile(r"listening on udp ([\d.]+):(\d+)")

Message = Any  # a pymavlink MAVLink_message


# ``python -m sim`` that first asks for SIGTERM when the test process dies (Linux: prctl
# PR_SET_PDEATHSIG), so no vehicle outlives a killed test run. The vehicle asks it itself,
# after exec: a preexec_fn would make subprocess fork the test process and run Python in the
# child, which aborts at random when gRPC's threads are live (the MAVSDK tests: "epoll_wait
# error: Bad file descriptor", SIGABRT); without one, subprocess spawns with vfork.
_VEHICLE_MAIN = (
    "import sys\n"
    "if sys.platform.startswith('linux'):\n"
    f"    import ctypes; ctypes.CDLL(None).prctl(1, {int(signal.SIGTERM)})\n"
    "from sim.vehicle_cli import main\n"
    "sys.exit(main())\n")


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    """A port free right now on 127.0.0.1 (for tools that must be told a port to bind)."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class VehicleProcess:
    """``python -m sim`` in a subprocess, stopped with SIGTERM (then killed) at teardown.

    Parameters
    ----------
    args : sequence of str
        Extra command-line options (``--speedup``, ``--out`` ...). ``--bind 127.0.0.1:0``
        is added unless ``any_port`` is False.
    any_port : bool
        Bind a free port (False: the vehicle's own default, e.g. from ``--instance``).
    """

    def __init__(self, args: Sequence[str], any_port: bool = True) -> None:
        self.args = [*(["--bind", "127.0.0.1:0"] if any_port else []), *args]
        env = dict(os.environ)
        env["PYTHONUNBUFFERED"] = "1"
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _VEHICLE_MAIN, *self.args], cwd=ROOT, env=env,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.lines: list[str] = []
        self.stderr_text = ""
        self._reader = threading.Thread(target=self._read_stdout, daemon=True)
        self._err_reader = threading.Thread(target=self._read_stderr, daemon=True)
        self._reader.start()
        self._err_reader.start()
        self.address = self._wait_listening()

    def _read_stdout(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def _read_stderr(self) -> None:
        assert self.proc.stderr is not None
        self.stderr_text = self.proc.stderr.read()

    def _wait_listening(self) -> tuple[str, int]:
        deadline = time.monotonic() + STARTUP_S
        while time.monotonic() < deadline:
            for line in list(self.lines):
                match = _LISTEN.search(line)
                if match:
                    return match.group(1), int(match.group(2))
            if self.proc.poll() is not None:
                self._reader.join(5)
                self._err_reader.join(5)
                raise RuntimeError(f"vehicle exited with {self.proc.returncode}: "
                                   f"{self.lines} {self.stderr_text[-3000:]}")
            time.sleep(0.05)
        self.kill()
        raise TimeoutError(f"vehicle did not start within {STARTUP_S} s: {self.lines}")

    def stop(self) -> int:
        """SIGTERM, wait for a clean exit (kill after :data:`STOP_S`); returns the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(STOP_S)
            except subprocess.TimeoutExpired:
                self.kill()
        self._reader.join(5)
        self._err_reader.join(5)
        return int(self.proc.returncode)

    def kill(self) -> None:
        """Kill the vehicle (only ever this process, by its id)."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(STOP_S)


@dataclass
class Received:
    """One message and the wall-clock time (monotonic, s) it was received."""

    wall_s: float
    msg: Message


class Gcs:
    """A pymavlink ground station on its own UDP socket.

    Parameters
    ----------
    sysid, compid : int
        Our MAVLink identity (255/190: a GCS, as MAVProxy and QGroundControl are).
    signing_key : bytes or None
        Sign what we send with this 32-byte key (see :meth:`sign_with`).
    keep_raw : bool
        Keep every received datagram in :attr:`raw`.
    """

    def __init__(self, sysid: int = 255, compid: int = 190,
                 target: tuple[int, int] = (1, 1), signing_key: bytes | None = None,
                 keep_raw: bool = False) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        self.target = target  # (sysid, compid) of the vehicle the protocol helpers address
        self.vehicle: tuple[str, int] | None = None
        self.log: list[Received] = []
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._heartbeat_s = 0.0  # wall period of automatic GCS heartbeats (0 = none)
        self._last_hb = -math.inf
        self.raw: list[bytes] | None = [] if keep_raw else None
        self.sign_with(signing_key)

    def sign_with(self, key: bytes | None, link_id: int = 0) -> None:
        """Sign what we send with ``key`` from now on (None: unsigned); timestamps start at
        the wall clock (10 us since 2015) and grow by one per packet."""
        signing = self.mav.signing
        signing.secret_key = key
        signing.sign_outgoing = key is not None
        signing.link_id = link_id
        signing.timestamp = max(signing.timestamp, timestamp_from_unix(time.time()))

    @property
    def port(self) -> int:
        """Our bound UDP port (pass it to the vehicle's ``--out``)."""
        return int(self.sock.getsockname()[1])

    def close(self) -> None:
        """Stop the reader and close the socket."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)
        self.sock.close()

    # ------------------------------------------------------------------ sending
    def send(self, msg: Message) -> None:
        """Pack ``msg`` (MAVLink 2, our ids) and send it to the vehicle."""
        assert self.vehicle is not None, "no vehicle address yet"
        data = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        self.sock.sendto(data, self.vehicle)

    def send_raw(self, data: bytes) -> None:
        """Send bytes as one datagram, unparsed."""
        assert self.vehicle is not None
        self.sock.sendto(data, self.vehicle)

    def heartbeat(self) -> None:
        """One GCS HEARTBEAT."""
        self.send(M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                              M.MAV_STATE_ACTIVE, 3))

    @property
    def last_heartbeat_s(self) -> float:
        """Wall-clock time (monotonic) of the last automatic HEARTBEAT sent."""
        return self._last_hb

    def auto_heartbeat(self, period_s: float) -> None:
        """Send a GCS HEARTBEAT every ``period_s`` of wall time while receiving (0 stops)."""
        self._heartbeat_s = period_s

    # ------------------------------------------------------------------ receiving
    def _parse(self, data: bytes) -> list[Message]:
        parser = mavlink2.MAVLink(None)
        parser.robust_parsing = True
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:
            return []
        return [m for m in msgs if m.get_type() != "BAD_DATA"]

    def pump(self, timeout_s: float) -> int:
        """Receive for up to ``timeout_s`` (returns after the first datagram batch)."""
        readable, _, _ = select.select([self.sock], [], [], max(timeout_s, 0.0))
        count = 0
        if readable:
            while True:
                try:
                    data, addr = self.sock.recvfrom(65535)
                except BlockingIOError:
                    break
                now = time.monotonic()
                if self.vehicle is None:
                    self.vehicle = (addr[0], addr[1])
                with self._lock:
                    if self.raw is not None:
                        self.raw.append(data)
                    for msg in self._parse(data):
                        self.log.append(Received(now, msg))
                        count += 1
        if self._heartbeat_s > 0 and self.vehicle is not None:
            now = time.monotonic()
            if now - self._last_hb >= self._heartbeat_s:
                self._last_hb = now
                self.heartbeat()
        return count

    def start_reader(self) -> None:
        """Receive on a background thread from now on (for tests driven by asyncio tools)."""
        def loop() -> None:
            while not self._stop.is_set():
                try:
                    self.pump(0.05)
                except OSError:
                    return

        self._thread = threading.Thread(target=loop, daemon=True)
        self._thread.start()

    def _receive_for(self, left_s: float) -> None:
        """Let a little of the ``left_s`` wall seconds pass while messages come in: received
        here, or by the reader thread when it runs."""
        if self._thread is None:
            self.pump(min(left_s, 0.1))
        else:
            time.sleep(min(left_s, 0.02))

    def messages(self, kind: str | Iterable[str] | None = None, since: int = 0) -> list[Message]:
        """Messages received so far (from log index ``since``), optionally of some types."""
        kinds = {kind} if isinstance(kind, str) else set(kind) if kind is not None else None
        with self._lock:
            entries = self.log[since:]
        return [e.msg for e in entries if kinds is None or e.msg.get_type() in kinds]

    def texts(self, since: int = 0) -> list[str]:
        """STATUSTEXTs received (from log index ``since``), chunks joined: a text longer than
        50 characters arrives as chunks sharing an id, the last one shorter than 50."""
        out: list[str] = []
        partial: dict[int, list[str]] = {}
        for msg in self.messages("STATUSTEXT", since):
            if msg.id == 0:
                out.append(msg.text)
                continue
            chunks = partial.setdefault(msg.id, [])
            chunks.append(msg.text)
            if len(msg.text) < 50:
                out.append("".join(partial.pop(msg.id)))
        return out

    def wait_text(self, part: str, since: int, timeout_s: float = ANSWER_S) -> str:
        """The first STATUSTEXT (chunks joined) after log index ``since`` containing ``part``.

        Raises
        ------
        TimeoutError
            None arrived within ``timeout_s`` wall seconds.
        """
        deadline = time.monotonic() + timeout_s
        while True:
            found = [text for text in self.texts(since) if part in text]
            if found:
                return found[0]
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no STATUSTEXT with {part!r} within {timeout_s} s")
            self._receive_for(left)

    def mark(self) -> int:
        """Index of the next message to arrive (for :meth:`messages` / :meth:`wait`)."""
        with self._lock:
            return len(self.log)

    def wait(self, kind: str | Iterable[str], predicate: Callable[[Message], bool] | None = None,
             timeout_s: float = ANSWER_S, since: int | None = None) -> Message:
        """The first message of ``kind`` (after ``since``; default: from now) matching.

        Raises
        ------
        TimeoutError
            None arrived within ``timeout_s`` wall seconds.
        """
        kinds = {kind} if isinstance(kind, str) else set(kind)
        index = self.mark() if since is None else since
        deadline = time.monotonic() + timeout_s
        while True:
            with self._lock:
                entries = self.log[index:]
            for entry in entries:
                index += 1
                msg = entry.msg
                if msg.get_type() in kinds and (predicate is None or predicate(msg)):
                    return msg
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no {sorted(kinds)} within {timeout_s} s")
            self._receive_for(left)

    def collect(self, duration_s: float) -> list[Message]:
        """Everything received during the next ``duration_s`` wall seconds."""
        start = self.mark()
        deadline = time.monotonic() + duration_s
        while (left := deadline - time.monotonic()) > 0:
            self._receive_for(left)
        return self.messages(since=start)

    def wait_heartbeat(self, timeout_s: float = STARTUP_S) -> Message:
        """The vehicle's next HEARTBEAT (learning its address if needed)."""
        return self.wait("HEARTBEAT", lambda m: (m.get_srcSystem(), m.get_srcComponent())
                         == self.target, timeout_s)

    # ------------------------------------------------------------------ protocols
    def command(self, command: int, *params: float, timeout_s: float = ANSWER_S) -> Message:
        """COMMAND_LONG ``command`` with up to 7 params; returns its COMMAND_ACK."""
        p = list(params) + [0.0] * (7 - len(params))
        target = self.target
        since = self.mark()
        self.send(M.MAVLink_command_long_message(target[0], target[1], command, 0, *p))
        return self.wait("COMMAND_ACK", lambda m: m.command == command, timeout_s, since)

    def set_mode(self, custom_mode: int) -> Message:
        """DO_SET_MODE to an ArduCopter mode; returns the ACK."""
        return self.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                            custom_mode)

    def take_off(self, alt_m: float, timeout_s: float = 60.0) -> Message:
        """GUIDED, arm, NAV_TAKEOFF to ``alt_m`` (each ACCEPTED); returns the first
        GLOBAL_POSITION_INT within 5 cm of that height."""
        guided = 4  # ArduCopter's GUIDED
        for what, ack in (("GUIDED", self.set_mode(guided)),
                          ("arming", self.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)),
                          ("take-off", self.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0,
                                                    alt_m))):
            assert ack.result == M.MAV_RESULT_ACCEPTED, f"{what}: result {ack.result}"
        return self.wait("GLOBAL_POSITION_INT",
                         lambda m: m.relative_alt > 1000.0 * alt_m - 50.0, timeout_s)

    def wait_mode(self, custom_mode: int, timeout_s: float = ANSWER_S) -> Message:
        """The first HEARTBEAT showing ``custom_mode``."""
        return self.wait("HEARTBEAT", lambda m: m.get_srcComponent() == self.target[1]
                         and m.custom_mode == custom_mode, timeout_s)

    def param_set(self, name: str, value: float) -> Message:
        """PARAM_SET; returns the PARAM_VALUE echoed for ``name``."""
        since = self.mark()
        self.send(M.MAVLink_param_set_message(*self.target, name.encode(), value,
                                              M.MAV_PARAM_TYPE_REAL32))
        return self.wait("PARAM_VALUE", lambda m: m.param_id == name, since=since)

    def param_get(self, name: str) -> float:
        """PARAM_REQUEST_READ by name."""
        since = self.mark()
        self.send(M.MAVLink_param_request_read_message(*self.target, name.encode(), -1))
        return float(self.wait("PARAM_VALUE", lambda m: m.param_id == name,
                               since=since).param_value)

    def upload_mission(self, items: Sequence[Message], drop_seqs: Iterable[int] = (),
                       timeout_s: float = 30.0) -> tuple[Message, dict[int, int]]:
        """Mission upload (MISSION_COUNT, then answer MISSION_REQUEST_INTs).

        The first request of each seq in ``drop_seqs`` goes unanswered (a lost packet).

        Returns
        -------
        (MISSION_ACK, {seq: number of requests received})
        """
        drop = set(drop_seqs)
        requests: dict[int, int] = {}
        since = self.mark()
        self.send(M.MAVLink_mission_count_message(*self.target, len(items),
                                                  M.MAV_MISSION_TYPE_MISSION))
        deadline = time.monotonic() + timeout_s
        while True:
            msg = self.wait(["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"],
                            timeout_s=max(deadline - time.monotonic(), 0.1), since=since)
            since = self.mark()
            if msg.get_type() == "MISSION_ACK":
                return msg, requests
            seq = int(msg.seq)
            requests[seq] = requests.get(seq, 0) + 1
            if seq in drop and requests[seq] == 1:
                continue
            self.send(items[seq])


def mission_item(seq: int, command: int, *, params: Sequence[float] = (0, 0, 0, 0),
                 x: float = 0.0, y: float = 0.0, z: float = 0.0,
                 frame: int = M.MAV_FRAME_LOCAL_NED, current: int = 0,
                 target: tuple[int, int] = (1, 1)) -> Message:
    """MISSION_ITEM_INT; ``x``/``y`` in metres (local) or degrees (global), ``z`` in metres."""
    scale = 1e4 if frame == M.MAV_FRAME_LOCAL_NED else 1e7
    p = list(params) + [0.0] * (4 - len(params))
    return M.MAVLink_mission_item_int_message(*target, seq, frame, command, current, 1, *p,
                                              round(x * scale), round(y * scale), z,
                                              M.MAV_MISSION_TYPE_MISSION)


def write_hover_mission(path: Path, alt_m: float = 0.6) -> Path:
    """Write an ``ftc-gcs`` mission file to ``path``: climb at 0.3 m/s to ``alt_m`` (m), hold
    4 s, land; about 15 s of simulated time for the default height."""
    path.write_text(f"""\
[[items]]
command = "change_speed"
speed_type = "climb"
speed_m_s = 0.3
[[items]]
command = "takeoff"
alt_m = {alt_m}
[[items]]
command = "waypoint"
pos_ned = [0.0, 0.0, {-alt_m}]
hold_s = 4.0
[[items]]
command = "land"
""")
    return path
