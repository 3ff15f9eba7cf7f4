"""The vehicle's peer table: configured destinations always served, learned peers first come,
first served, a full table refusing newcomers (with one logged notice each) until a peer has
been silent for ``peer_timeout_s``."""

from __future__ import annotations

import logging
import socket

import pytest

from fcu.mavlink.transport.udp import UdpLink

OUT = ("127.0.0.1", 14550)
WAIT_S = 5.0  # s, generous bound for a datagram over loopback


class Clock:
    """A wall clock the test moves by hand, s."""

    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def test_forty_chattering_peers_never_displace_the_first_sixteen(
        caplog: pytest.LogCaptureFixture) -> None:
    clock = Clock()
    link = UdpLink("127.0.0.1", 0, default_peers=[OUT], clock=clock)
    first = [("127.0.0.1", 30000 + k) for k in range(16)]
    chatter = [("127.0.0.1", 31000 + k) for k in range(40)]
    with caplog.at_level(logging.INFO, logger="fcu.mavlink.transport.udp"):
        for peer in first:
            link.add_peer(peer)
        for _ in range(10):  # each chatters ten times
            for peer in chatter:
                clock.now_s += 0.01
                link.add_peer(peer)
            for peer in first:  # the first ones keep talking (a heartbeat a second)
                link.add_peer(peer)
    assert link.peers == [OUT, *first]
    assert link.refused_peers == 400
    notices = [r.getMessage() for r in caplog.records]
    assert len(notices) == 40  # one notice per refused peer, not per datagram
    assert all("refused" in n and "16" in n for n in notices)
    assert any("127.0.0.1:31039" in n for n in notices)
    link.close()


def test_a_silent_learned_peer_gives_its_place_to_a_newcomer() -> None:
    clock = Clock()
    link = UdpLink("127.0.0.1", 0, default_peers=[OUT], max_peers=2, peer_timeout_s=30.0,
                   clock=clock)
    a, b, c = ("127.0.0.1", 1001), ("127.0.0.1", 1002), ("127.0.0.1", 1003)
    link.add_peer(a)
    link.add_peer(b)
    clock.now_s += 20.0
    link.add_peer(b)  # b keeps talking, a falls silent
    link.add_peer(c)
    assert link.peers == [OUT, a, b]  # a has been silent 20 s only: c is refused
    clock.now_s += 15.0  # a silent 35 s, b 15 s
    link.add_peer(c)
    assert link.peers == [OUT, b, c]
    link.close()


def test_a_configured_destination_is_never_a_learned_peer() -> None:
    link = UdpLink("127.0.0.1", 0, default_peers=[OUT], max_peers=1)
    for _ in range(3):
        link.add_peer(OUT)  # the --out ground station writes to us
    link.add_peer(("127.0.0.1", 1001))
    assert link.peers == [OUT, ("127.0.0.1", 1001)]
    assert link.refused_peers == 0
    link.close()


def test_broadcasts_reach_the_destinations_and_the_admitted_peers_only() -> None:
    socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(4)]
    try:
        for s in socks:
            s.bind(("127.0.0.1", 0))
            s.settimeout(WAIT_S)
        out, first, second, refused = [("127.0.0.1", s.getsockname()[1]) for s in socks]
        with UdpLink("127.0.0.1", 0, default_peers=[out], max_peers=2) as link:
            for peer in (first, second, refused):
                link.add_peer(peer)
            link.send(b"telemetry")
            for s in socks[:3]:
                assert s.recvfrom(64)[0] == b"telemetry"
            socks[3].settimeout(0.2)
            with pytest.raises(TimeoutError):
                socks[3].recvfrom(64)
            link.send(b"reply", refused)  # replies still reach whoever asked
            socks[3].settimeout(WAIT_S)
            assert socks[3].recvfrom(64)[0] == b"reply"
    finally:
        for s in socks:
            s.close()
