"""Non-blocking UDP link for the vehicle's MAVLink endpoint.

The vehicle binds one local port (by default on 127.0.0.1, port 0 = any free port, so two
vehicles or parallel tests never collide; pass ``bind_port=14555`` for a well-known port that
``udpout:127.0.0.1:14555`` clients can reach). Telemetry goes to the default peers, the
conventional ground-station port 14550 (QGroundControl, MAVProxy ``udpin:0.0.0.0:14550``)
and API port 14540 (MAVSDK ``udpin://0.0.0.0:14540``), plus every peer that has sent us a
valid MAVLink packet (ground stations answer to the address a packet came from). Replies go
only to the peer that asked.

Peers: the configured destinations (``--out``) are always sent to, first, and are never
counted among the learned peers. Learned peers are first come, first served: up to
``max_peers`` of them (16) keep their place as long as they keep talking; when the table is
full a newcomer is refused (it still gets replies to what it asks, but no telemetry), with
one logged notice per refused address, unless a learned peer has been silent for
``peer_timeout_s`` (30 s of wall time), whose place it then takes. So a crowd of chattering
clients can never push out a ground station that connected earlier (``udpout``) or starve a
configured one.

Nothing here blocks or raises: ICMP port-unreachable errors (a ground station not running
yet surfaces as ConnectionRefusedError on Linux, ConnectionResetError on Windows) and other
socket errors are counted and ignored.
"""

from __future__ import annotations

import errno
import logging
import select
import socket
import time
from collections.abc import Callable, Iterable

from fcu.mavlink.transport.link import Address

__all__ = ["DEFAULT_PEERS", "UdpLink"]

DEFAULT_PEERS: tuple[Address, ...] = (("127.0.0.1", 14550), ("127.0.0.1", 14540))
_log = logging.getLogger(__name__)
_MAX_DATAGRAM = 65535  # bytes
_MAX_NOTICED = 4096  # refused addresses remembered so that each is logged once
_SOFT_ERRNOS = {errno.ECONNREFUSED, errno.ECONNRESET, errno.EHOSTUNREACH, errno.ENETUNREACH,
                errno.EMSGSIZE}


class UdpLink:
    """A bound, non-blocking UDP socket with a bounded set of peers.

    Parameters
    ----------
    bind_host : str
        Local address to bind ("127.0.0.1" keeps the vehicle off the network; "0.0.0.0"
        exposes it).
    bind_port : int
        Local port; 0 picks a free one (see :attr:`local_address`).
    default_peers : iterable of (host, port)
        Always sent to (telemetry), and never forgotten.
    max_peers : int
        Most learned peers besides the defaults; newcomers beyond it are refused.
    max_datagrams_per_receive : int
        Bound on the datagrams :meth:`receive` returns per call (the rest wait).
    peer_timeout_s : float
        Wall seconds of silence after which a learned peer may give its place to a newcomer
        (only when the table is full).
    clock : callable
        Monotonic wall clock, s (``time.monotonic``; injectable for tests).

    Notes
    -----
    The socket is created by :meth:`open` (also called by the first use), not by the
    constructor; :meth:`close` releases it. Usable as a context manager.
    """

    def __init__(self, bind_host: str = "127.0.0.1", bind_port: int = 0,
                 default_peers: Iterable[Address] = DEFAULT_PEERS, max_peers: int = 16,
                 max_datagrams_per_receive: int = 256, peer_timeout_s: float = 30.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not 0 <= bind_port <= 65535:
            raise ValueError(f"bind_port = {bind_port!r}: must be in 0..65535")
        if max_peers < 1:
            raise ValueError(f"max_peers = {max_peers!r}: must be >= 1")
        if not peer_timeout_s > 0:
            raise ValueError(f"peer_timeout_s = {peer_timeout_s!r}: must be > 0 s")
        self._bind = (bind_host, bind_port)
        self._defaults = [(h, int(p)) for h, p in default_peers]
        self._max_peers = max_peers
        self._max_rx = max_datagrams_per_receive
        self._peer_timeout_s = peer_timeout_s
        self._clock = clock
        self._peers: dict[Address, float] = {}  # learned peer -> wall time last heard, s
        self._broadcast: list[Address] = list(self._defaults)  # peers, kept with _peers
        self._noticed: set[Address] = set()
        self._sock: socket.socket | None = None
        self._poller: select.poll | None = None  # readable or in error: receive() reads
        self.send_errors = 0
        self.receive_errors = 0
        self.refused_peers = 0  # datagrams from peers refused a place (table full)

    # ------------------------------------------------------------------ lifecycle
    def open(self) -> None:
        """Create and bind the socket (idempotent)."""
        if self._sock is not None:
            return
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.setblocking(False)
            sock.bind(self._bind)
        except OSError:
            sock.close()
            raise
        self._sock = sock
        if hasattr(select, "poll"):
            self._poller = select.poll()
            self._poller.register(sock, select.POLLIN)

    def close(self) -> None:
        """Release the socket."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None
            self._poller = None

    def __enter__(self) -> UdpLink:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def local_address(self) -> Address:
        """The bound (host, port)."""
        self.open()
        assert self._sock is not None
        host, port = self._sock.getsockname()[:2]
        return str(host), int(port)

    @property
    def peers(self) -> list[Address]:
        """Default peers, then learned peers (in the order they were admitted)."""
        return self._defaults + list(self._peers)

    # ------------------------------------------------------------------ Link protocol
    def add_peer(self, peer: Address) -> None:
        """Note that ``peer`` was heard: admit it for broadcasts if there is room.

        A full table admits it only in place of a learned peer silent for
        ``peer_timeout_s``; otherwise it is refused (logged once per address).
        """
        if peer in self._defaults:
            return
        now = self._clock()
        if peer in self._peers:
            self._peers[peer] = now  # known: its place in the order stays
            return
        if len(self._peers) < self._max_peers:
            self._peers[peer] = now
            self._broadcast = self.peers
            return
        quietest = min(self._peers, key=self._peers.__getitem__)
        silent_s = now - self._peers[quietest]
        if silent_s >= self._peer_timeout_s:
            del self._peers[quietest]
            self._peers[peer] = now
            self._broadcast = self.peers
            self._noticed.discard(peer)
            _log.info("peer %s:%d silent for %.0f s gave its place to %s:%d", *quietest,
                      silent_s, *peer)
            return
        self.refused_peers += 1
        if peer not in self._noticed and len(self._noticed) < _MAX_NOTICED:
            self._noticed.add(peer)
            _log.warning("peer %s:%d refused: %d peers already (besides %d --out), none "
                         "silent for %g s; it gets replies, not telemetry", *peer,
                         self._max_peers, len(self._defaults), self._peer_timeout_s)

    def send(self, data: bytes, to: Address | None = None) -> None:
        """Send to ``to``, or to every peer; errors are counted, never raised."""
        sock = self._sock
        if sock is None:
            self.open()
            sock = self._sock
            assert sock is not None
        for peer in (self._broadcast if to is None else (to,)):
            try:
                sock.sendto(data, peer)
            except BlockingIOError:
                self.send_errors += 1  # socket buffer full: drop, like a radio would
            except OSError:
                self.send_errors += 1

    def receive(self) -> list[tuple[bytes, Address]]:
        """Datagrams waiting now (at most ``max_datagrams_per_receive``)."""
        sock = self._sock
        if sock is None:
            self.open()
            sock = self._sock
            assert sock is not None
        if self._poller is not None and not self._poller.poll(0):
            return []  # nothing waiting, no error pending: one cheap system call per tick
        out: list[tuple[bytes, Address]] = []
        soft_errors = 0
        while len(out) < self._max_rx and soft_errors < self._max_rx:
            try:
                data, addr = sock.recvfrom(_MAX_DATAGRAM)
            except BlockingIOError:
                break
            except OSError as err:
                # ICMP port unreachable from an earlier send, reported on this socket.
                self.receive_errors += 1
                soft_errors += 1
                if err.errno in _SOFT_ERRNOS or isinstance(err, ConnectionError):
                    continue
                break
            out.append((data, (str(addr[0]), int(addr[1]))))
        return out
