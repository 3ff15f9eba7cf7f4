"""A seeded lossy UDP relay between a vehicle and a ground station, on loopback only.

::

    vehicle --out 127.0.0.1:<vehicle_port> ---> proxy ---> ground station (udpout:...)
    vehicle <--------------------------------- proxy <--- udpout:127.0.0.1:<gcs_port>

The proxy binds two ports on 127.0.0.1 (chosen by the OS). The vehicle is told to send its
telemetry to :attr:`LossyProxy.vehicle_port`; the ground station connects with
``udpout:127.0.0.1:<gcs_port>``. Each side's address is learned from its first datagram, so
nothing needs a port number guessed in advance. Every datagram is dropped with probability
``loss``, decided by a ``random.Random`` per direction seeded from ``seed``: the same seed gives
the same sequence of decisions (which packets they hit depends on the traffic, which depends
on timing; the rate does not).
"""

from __future__ import annotations

import random
import select
import socket
import threading
from dataclasses import dataclass

__all__ = ["LossyProxy"]

_RCVBUF_BYTES = 4 << 20  # keep up with 100 Hz streams at a speed-up of 10
_MAX_DATAGRAM = 65535


@dataclass
class Direction:
    """Counters of one direction."""

    forwarded: int = 0
    dropped: int = 0

    @property
    def loss(self) -> float:
        """Fraction of datagrams dropped so far."""
        total = self.forwarded + self.dropped
        return self.dropped / total if total else 0.0


class LossyProxy:
    """Relay UDP between a vehicle and a ground station, dropping a fraction of datagrams.

    Parameters
    ----------
    loss : float
        Probability that any one datagram is dropped, each way (0..1).
    seed : int
        Seed of the two drop decision streams.
    drop_first : bytes or None
        Also drop the first ``drop_times`` datagrams to the vehicle that contain these bytes
        (a parameter's name: that PARAM_SET is lost for certain), whatever ``loss`` says.
    drop_times : int
    """

    def __init__(self, loss: float, seed: int, drop_first: bytes | None = None,
                 drop_times: int = 1) -> None:
        if not 0.0 <= loss < 1.0:
            raise ValueError(f"loss = {loss!r}: must be in [0, 1)")
        self.loss = loss
        self._drop_first = drop_first
        self.targeted_left = drop_times if drop_first is not None else 0
        self._rng_down = random.Random(f"{seed}-to-gcs")
        self._rng_up = random.Random(f"{seed}-to-vehicle")
        self.to_gcs = Direction()
        self.to_vehicle = Direction()
        self._vehicle_side = self._socket()
        self._gcs_side = self._socket()
        self._vehicle: tuple[str, int] | None = None
        self._gcs: tuple[str, int] | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def _socket() -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _RCVBUF_BYTES)
        sock.bind(("127.0.0.1", 0))
        sock.setblocking(False)
        return sock

    @property
    def vehicle_port(self) -> int:
        """Where the vehicle sends (its ``--out``)."""
        return int(self._vehicle_side.getsockname()[1])

    @property
    def gcs_port(self) -> int:
        """Where the ground station sends (``udpout:127.0.0.1:<gcs_port>``)."""
        return int(self._gcs_side.getsockname()[1])

    def start(self) -> LossyProxy:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(10.0)
        self._vehicle_side.close()
        self._gcs_side.close()

    def __enter__(self) -> LossyProxy:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _run(self) -> None:
        sides = [self._vehicle_side, self._gcs_side]
        while not self._stop.is_set():
            try:
                readable, _, _ = select.select(sides, [], [], 0.1)
            except (OSError, ValueError):
                return
            for sock in readable:
                self._drain(sock)

    def _drain(self, sock: socket.socket) -> None:
        from_vehicle = sock is self._vehicle_side
        while True:
            try:
                data, addr = sock.recvfrom(_MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return  # an ICMP error from an earlier send: nothing to relay
            if from_vehicle:
                self._vehicle = addr
                self._relay(data, self._gcs_side, self._gcs, self._rng_down, self.to_gcs)
            else:
                self._gcs = addr
                if self.targeted_left and self._drop_first in data:
                    self.targeted_left -= 1
                    self.to_vehicle.dropped += 1
                    continue
                self._relay(data, self._vehicle_side, self._vehicle, self._rng_up,
                            self.to_vehicle)

    def _relay(self, data: bytes, out: socket.socket, to: tuple[str, int] | None,
               rng: random.Random, counts: Direction) -> None:
        if to is None:
            return  # the other side has not spoken yet: nowhere to send
        if rng.random() < self.loss:
            counts.dropped += 1
            return
        try:
            out.sendto(data, to)
        except OSError:
            return
        counts.forwarded += 1
