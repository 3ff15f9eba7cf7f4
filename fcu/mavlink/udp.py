"""Non-blocking UDP link for the vehicle's MAVLink endpoint.

The vehicle binds one local port (by default on 127.0.0.1, port 0 = any free port, so two
vehicles or parallel tests never collide; pass ``bind_port=14555`` for a well-known port that
``udpout:127.0.0.1:14555`` clients can reach). Telemetry goes to the default peers, the
conventional ground-station port 14550 (QGroundControl, MAVProxy ``udpin:0.0.0.0:14550``)
and API port 14540 (MAVSDK ``udpin://0.0.0.0:14540``), plus every peer that has sent us a
valid MAVLink packet (ground stations answer to the address a packet came from). Replies go
only to the peer that asked.

Nothing here blocks or raises: ICMP port-unreachable errors (a ground station not running
yet surfaces as ConnectionRefusedError on Linux, ConnectionResetError on Windows) and other
socket errors are counted and ignored.
"""

from __future__ import annotations

import errno
import socket
from collections import OrderedDict
from collections.abc import Iterable

from fcu.mavlink.link import Address

__all__ = ["DEFAULT_PEERS", "UdpLink"]

DEFAULT_PEERS: tuple[Address, ...] = (("127.0.0.1", 14550), ("127.0.0.1", 14540))
_MAX_DATAGRAM = 65535  # bytes
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
        Most remembered peers besides the defaults; the least recently heard is dropped.
    max_datagrams_per_receive : int
        Bound on the datagrams :meth:`receive` returns per call (the rest wait).

    Notes
    -----
    The socket is created by :meth:`open` (also called by the first use), not by the
    constructor; :meth:`close` releases it. Usable as a context manager.
    """

    def __init__(self, bind_host: str = "127.0.0.1", bind_port: int = 0,
                 default_peers: Iterable[Address] = DEFAULT_PEERS, max_peers: int = 16,
                 max_datagrams_per_receive: int = 256) -> None:
        if not 0 <= bind_port <= 65535:
            raise ValueError(f"bind_port = {bind_port!r}: must be in 0..65535")
        if max_peers < 1:
            raise ValueError(f"max_peers = {max_peers!r}: must be >= 1")
        self._bind = (bind_host, bind_port)
        self._defaults = [(h, int(p)) for h, p in default_peers]
        self._max_peers = max_peers
        self._max_rx = max_datagrams_per_receive
        self._peers: OrderedDict[Address, None] = OrderedDict()
        self._sock: socket.socket | None = None
        self.send_errors = 0
        self.receive_errors = 0

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

    def close(self) -> None:
        """Release the socket."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None

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
        """Default peers, then learnt peers (most recent last)."""
        learnt = [p for p in self._peers if p not in self._defaults]
        return self._defaults + learnt

    # ------------------------------------------------------------------ Link protocol
    def add_peer(self, peer: Address) -> None:
        """Remember ``peer`` for broadcasts (bounded, least recently heard dropped)."""
        if peer in self._defaults:
            return
        self._peers[peer] = None
        self._peers.move_to_end(peer)
        while len(self._peers) > self._max_peers:
            self._peers.popitem(last=False)

    def send(self, data: bytes, to: Address | None = None) -> None:
        """Send to ``to``, or to every peer; errors are counted, never raised."""
        self.open()
        assert self._sock is not None
        for peer in (self.peers if to is None else [to]):
            try:
                self._sock.sendto(data, peer)
            except BlockingIOError:
                self.send_errors += 1  # socket buffer full: drop, like a radio would
            except OSError:
                self.send_errors += 1

    def receive(self) -> list[tuple[bytes, Address]]:
        """Datagrams waiting now (at most ``max_datagrams_per_receive``)."""
        self.open()
        assert self._sock is not None
        out: list[tuple[bytes, Address]] = []
        soft_errors = 0
        while len(out) < self._max_rx and soft_errors < self._max_rx:
            try:
                data, addr = self._sock.recvfrom(_MAX_DATAGRAM)
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
