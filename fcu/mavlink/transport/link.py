"""The small interfaces the endpoint's parts share: a datagram link and an outbox.

A :class:`Link` moves whole datagrams (UDP in the vehicle process, a list in unit tests).
An :class:`Outbox` is how a protocol part (parameters, mission, commands) sends a message
without knowing about sockets, sequence numbers or the vehicle's identity.
"""

from __future__ import annotations

from typing import Protocol

from fcu.mavlink.transport.codec import MAVLinkMessage

__all__ = ["Address", "Link", "Outbox"]

Address = tuple[str, int]
"""A peer's (host, port)."""


class Link(Protocol):
    """A non-blocking datagram link."""

    def send(self, data: bytes, to: Address | None = None) -> None:
        """Send one datagram to ``to``, or to every known peer when None; never raises."""
        ...

    def receive(self) -> list[tuple[bytes, Address]]:
        """Every datagram waiting now (bounded), with its sender; never blocks or raises."""
        ...

    def add_peer(self, peer: Address) -> None:
        """Remember ``peer`` as a destination of broadcasts (telemetry)."""
        ...


class Outbox(Protocol):
    """Where protocol parts put their messages."""

    def send(self, msg: MAVLinkMessage, to: Address | None = None) -> None:
        """Send ``msg`` to ``to`` (a reply) or to every peer when None."""
        ...

    def status(self, severity: int, text: str) -> None:
        """Send a STATUSTEXT (chunked when longer than 50 characters) to every peer."""
        ...
