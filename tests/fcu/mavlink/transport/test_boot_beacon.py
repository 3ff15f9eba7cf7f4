"""The boot beacon: a HEARTBEAT saying MAV_STATE_BOOT at once, signed with the vehicle's key,
and the endpoint carrying on with the same socket and sequence numbers."""

from __future__ import annotations

import hashlib
import socket

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from fcu.mavlink.transport.boot_beacon import BootBeacon
from fcu.mavlink.transport.codec import Codec
from fcu.mavlink.transport.udp import UdpLink

LOOPBACK = "127.0.0.1"
KEY = hashlib.sha256(b"boot beacon").digest()


def _receive(sock: socket.socket, timeout_s: float = 30.0) -> list[mav.MAVLink_message]:
    sock.settimeout(timeout_s)
    data = sock.recv(65535)
    parser = mav.MAVLink(None)
    parser.robust_parsing = True
    return parser.parse_buffer(data) or []


@pytest.fixture
def ground() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((LOOPBACK, 0))
    yield sock
    sock.close()


def test_first_heartbeat_says_booting_and_later_ones_follow_at_the_period(ground):
    link = UdpLink(LOOPBACK, 0, default_peers=[ground.getsockname()])
    beacon = BootBeacon(link, Codec(7, 1), period_s=0.05)
    beacon.start()
    try:
        first = _receive(ground)[0]
        second = _receive(ground)[0]
    finally:
        beacon.handover()
        link.close()
    for msg in (first, second):
        assert msg.get_type() == "HEARTBEAT"
        assert msg.system_status == mav.MAV_STATE_BOOT
        assert msg.type == mav.MAV_TYPE_QUADROTOR
        assert msg.autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA
        assert not msg.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED
        assert msg.get_srcSystem() == 7
    assert second.get_seq() == (first.get_seq() + 1) % 256


def test_handover_stops_the_beats_and_the_packer_carries_on(ground):
    link = UdpLink(LOOPBACK, 0, default_peers=[ground.getsockname()])
    codec = Codec(1, 1)
    beacon = BootBeacon(link, codec, period_s=3600.0)
    beacon.start()
    first = _receive(ground)[0]
    beacon.handover()
    assert beacon.sent == 1
    link.send(codec.pack(mav.MAVLink_system_time_message(0, 0)))
    after = _receive(ground)[0]
    link.close()
    assert after.get_type() == "SYSTEM_TIME"
    assert after.get_seq() == first.get_seq() + 1


def test_boot_heartbeats_are_signed_with_the_vehicle_key(ground):
    link = UdpLink(LOOPBACK, 0, default_peers=[ground.getsockname()])
    beacon = BootBeacon(link, Codec(1, 1), signing_key=KEY, period_s=3600.0)
    beacon.start()
    ground.settimeout(30.0)
    data = ground.recv(65535)
    beacon.handover()
    link.close()
    assert data[2] & mav.MAVLINK_IFLAG_SIGNED
    assert hashlib.sha256(KEY + data[:-6]).digest()[:6] == data[-6:]
    checked = mav.MAVLink(None)
    checked.signing.secret_key = KEY
    assert checked.parse_buffer(data)[0].get_type() == "HEARTBEAT"


def test_an_address_in_use_is_reported_at_start(ground):
    beacon = BootBeacon(UdpLink(*ground.getsockname()), Codec(1, 1))
    with pytest.raises(OSError):
        beacon.start()


def _messages(sock: socket.socket, count: int) -> list[mav.MAVLink_message]:
    """The next ``count`` messages (each datagram holds one)."""
    out: list[mav.MAVLink_message] = []
    while len(out) < count:
        out += _receive(sock)
    return out


def test_a_progress_line_follows_the_next_heartbeat_once(ground):
    link = UdpLink(LOOPBACK, 0, default_peers=[ground.getsockname()])
    beacon = BootBeacon(link, Codec(1, 1), period_s=0.05)
    beacon.progress_line = "preparing: 3 of 130 kernels compiled, 12 s"
    beacon.start()
    try:
        first = _messages(ground, 4)  # HEARTBEAT, STATUSTEXT, HEARTBEAT, HEARTBEAT
        beacon.progress_line = "preparing: 9 of 130 kernels compiled, 17 s"
        later = _messages(ground, 6)
    finally:
        beacon.handover()
        link.close()
    assert [m.get_type() for m in first] == ["HEARTBEAT", "STATUSTEXT", "HEARTBEAT",
                                             "HEARTBEAT"]
    assert first[1].text == "preparing: 3 of 130 kernels compiled, 12 s"
    assert first[1].severity == mav.MAV_SEVERITY_INFO
    texts = [m.text for m in later if m.get_type() == "STATUSTEXT"]
    assert texts == ["preparing: 9 of 130 kernels compiled, 17 s"]  # sent once, not repeated
    seqs = [m.get_seq() for m in first + later]
    assert seqs == [(seqs[0] + k) % 256 for k in range(len(seqs))]  # one packer, in order
