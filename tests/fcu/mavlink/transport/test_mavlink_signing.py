"""MAVLink 2 signing on the endpoint: SETUP_SIGNING, signed output that pymavlink verifies,
unsigned / forged / replayed input dropped and counted, the timestamp rules of the spec."""

from __future__ import annotations

import hashlib
import random
import time
from typing import Any

import pytest
from mavlink_testkit import GCS_ADDR, MemoryGcs, MemoryLink, memory_endpoint

from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.endpoint_config import EndpointConfig
from fcu.mavlink.transport.codec import mavlink2
from fcu.mavlink.transport.signing import MAX_STREAMS, REPORT_NAME, MessageSigning, SigningStats
from fcu.navigation.modes import Mode
from flightdata.signing import MAX_TIMESTAMP, timestamp_from_unix

M = mavlink2
KEY = hashlib.sha256(b"quadftc-test").digest()  # MAVProxy's passphrase -> key
OTHER_KEY = hashlib.sha256(b"not-the-key").digest()
MINUTE = 6_000_000  # signature timestamp units (10 us) in one minute


def signer(gcs: MemoryGcs, key: bytes | None, timestamp: int | None = None,
           link_id: int = 0) -> None:
    """Make ``gcs`` sign what it puts (None: unsigned)."""
    s = gcs.mav.signing
    s.secret_key = key
    s.sign_outgoing = key is not None
    s.link_id = link_id
    s.timestamp = timestamp_from_unix(time.time()) if timestamp is None else timestamp


def keyed_parser(key: bytes) -> Any:
    parser = M.MAVLink(None)
    parser.robust_parsing = True
    parser.signing.secret_key = key
    return parser


def setup_signing(key: bytes, timestamp: int = 0) -> Any:
    return M.MAVLink_setup_signing_message(1, 1, list(key), timestamp)


def set_mode(mode: int) -> Any:
    return M.MAVLink_command_long_message(1, 1, M.MAV_CMD_DO_SET_MODE, 0,
                                          M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode,
                                          0, 0, 0, 0, 0)


def signed_endpoint() -> tuple[MavlinkEndpoint, Any, MemoryLink, MemoryGcs]:
    """An endpoint whose key was installed by SETUP_SIGNING, and a GCS signing with it."""
    endpoint, vehicle, link, gcs = memory_endpoint()
    gcs.put(setup_signing(KEY))
    endpoint.tick(0.0, 0.0)
    assert endpoint.signing.active
    link.take()
    signer(gcs, KEY)
    return endpoint, vehicle, link, gcs


class Outbox:
    def __init__(self) -> None:
        self.sent: list[Any] = []
        self.texts: list[str] = []

    def send(self, msg: Any, to: Any = None) -> None:
        self.sent.append(msg)

    def status(self, severity: int, text: str) -> None:
        self.texts.append(text)


def packet(msg: Any, key: bytes | None, timestamp: int, src: tuple[int, int] = (255, 190),
           link_id: int = 0) -> Any:
    """``msg`` as it arrives: packed (signed with ``key`` at ``timestamp``), then decoded
    without a key as the endpoint's codec does."""
    mav = M.MAVLink(None, srcSystem=src[0], srcComponent=src[1])
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = key is not None
    mav.signing.timestamp = timestamp
    mav.signing.link_id = link_id
    (decoded,) = M.MAVLink(None).parse_buffer(msg.pack(mav))
    return decoded


HB = M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)


def test_setup_signing_installs_the_key_and_everything_sent_verifies_with_it() -> None:
    endpoint, _, link, gcs = memory_endpoint()
    endpoint.tick(0.0, 0.0)
    assert not endpoint.signing.active
    assert {data[2] & M.MAVLINK_IFLAG_SIGNED for data, _ in link.sent} == {0}
    link.take()
    gcs.put(setup_signing(KEY))  # unsigned: no key is installed yet
    for k in range(1, 201):  # 2 s of telemetry
        endpoint.tick(k * 0.01, k * 0.01)
    raw = [data for data, _ in link.sent]
    assert len(raw) > 100
    good = [m for data in raw for m in keyed_parser(KEY).parse_buffer(data) or []]
    assert len(good) == len(raw) and all(m.get_type() != "BAD_DATA" for m in good)
    assert all(m._signed for m in good)  # pymavlink verified each signature with the key
    assert "Signing enabled: unsigned packets are dropped" in [
        m.text for m in good if m.get_type() == "STATUSTEXT"]
    wrong = [m for data in raw for m in keyed_parser(OTHER_KEY).parse_buffer(data) or []]
    assert {m.get_type() for m in wrong} == {"BAD_DATA"}
    stamps = [int.from_bytes(data[-12:-6], "little") for data in raw]
    assert all(b > a for a, b in zip(stamps, stamps[1:], strict=False))  # one per packet


def test_a_key_given_at_start_signs_from_the_first_packet() -> None:
    endpoint, _, link, _ = memory_endpoint(EndpointConfig(signing_key=KEY))
    endpoint.tick(0.0, 0.0)
    raw = [data for data, _ in link.sent]
    assert raw and all(data[2] & M.MAVLINK_IFLAG_SIGNED for data in raw)
    decoded = [m for data in raw for m in keyed_parser(KEY).parse_buffer(data) or []]
    assert [m.get_type() for m in decoded].count("BAD_DATA") == 0
    assert endpoint.signing.timestamp >= timestamp_from_unix(time.time()) - MINUTE


@pytest.mark.parametrize("key", [b"short", bytes(32)])
def test_a_bad_start_key_is_refused(key: bytes) -> None:
    with pytest.raises(ValueError, match="signing key"):
        EndpointConfig(signing_key=key)


def test_a_thousand_unsigned_forged_and_replayed_commands_are_never_obeyed() -> None:
    endpoint, vehicle, link, gcs = signed_endpoint()
    # one genuine command, captured to be replayed later
    gcs.put(M.MAVLink_param_set_message(1, 1, b"WPNAV_SPEED", 3.0, M.MAV_PARAM_TYPE_REAL32))
    captured = link.inbox[-1][0]
    endpoint.tick(0.1, 0.1)
    assert vehicle.param_values["WPNAV_SPEED"] == 3.0
    link.take()
    rng = random.Random(5)
    now = endpoint.signing.timestamp
    sent = {"unsigned": 0, "wrong key": 0, "bad signature": 0, "replayed": 0, "stale": 0}
    for k in range(1000):
        kind = rng.choice(sorted(sent))
        sent[kind] += 1
        cmd = set_mode(Mode.GUIDED) if k % 2 else M.MAVLink_param_set_message(
            1, 1, b"WPNAV_SPEED", 9.0, M.MAV_PARAM_TYPE_REAL32)
        attacker = M.MAVLink(None, srcSystem=255, srcComponent=190)
        if kind == "unsigned":
            data = cmd.pack(attacker)
        elif kind == "wrong key":
            attacker.signing.secret_key, attacker.signing.sign_outgoing = OTHER_KEY, True
            attacker.signing.timestamp = now + 1000 + k
            data = cmd.pack(attacker)
        elif kind == "bad signature":
            attacker.signing.secret_key, attacker.signing.sign_outgoing = KEY, True
            attacker.signing.timestamp = now + 1000 + k
            good = bytearray(cmd.pack(attacker))
            good[-1 - rng.randrange(6)] ^= 1 << rng.randrange(8)  # one bit of the signature
            data = bytes(good)
        elif kind == "replayed":
            data = captured  # the genuine packet again, byte for byte
        else:  # a correctly signed packet of a new stream, two minutes old
            attacker.signing.secret_key, attacker.signing.sign_outgoing = KEY, True
            attacker.signing.timestamp = now - 2 * MINUTE
            attacker.signing.link_id = 1 + k % 200
            data = cmd.pack(attacker)
        link.inbox.append((data, GCS_ADDR))
        if k % 50 == 49:
            endpoint.tick(0.1 + k * 1e-4, 0.1 + k * 1e-4)
    endpoint.tick(0.3, 0.3)
    assert min(sent.values()) > 150  # every kind well represented
    assert vehicle.mode == Mode.STABILIZE  # no DO_SET_MODE obeyed
    assert vehicle.param_values["WPNAV_SPEED"] == 3.0  # no PARAM_SET obeyed
    replies = link.take()
    assert [m for m in replies if m.get_type() in ("COMMAND_ACK", "PARAM_VALUE")] == []
    stats = endpoint.signing.stats
    assert stats.rejected == 1000
    assert stats.unsigned == sent["unsigned"]
    assert stats.bad_signature == sent["wrong key"] + sent["bad signature"]
    assert stats.replayed == sent["replayed"]
    assert stats.stale == sent["stale"]
    warnings = [m.text for m in replies if m.get_type() == "STATUSTEXT"]
    assert len([t for t in warnings if t.startswith("Signing: dropped")]) == 1  # once
    # ... and the key holder is still obeyed
    gcs.put(set_mode(Mode.GUIDED))
    endpoint.tick(0.4, 0.4)
    (ack,) = link.take("COMMAND_ACK")
    assert ack.result == M.MAV_RESULT_ACCEPTED and vehicle.mode == Mode.GUIDED


def test_rejections_are_reported_as_named_value_int_each_wall_second() -> None:
    endpoint, _, link, gcs = signed_endpoint()
    for _ in range(7):
        link.inbox.append((set_mode(Mode.GUIDED).pack(M.MAVLink(None, 255, 190)), GCS_ADDR))
    endpoint.tick(0.5, 10.0)
    endpoint.tick(0.6, 10.5)  # within the second: no second report
    endpoint.tick(0.7, 11.0)
    reports = [m for m in link.take("NAMED_VALUE_INT") if m.name == REPORT_NAME]
    assert [(r.value, r.time_boot_ms) for r in reports] == [(7, 500), (7, 700)]


def test_radio_status_is_accepted_unsigned_and_the_gcs_heartbeat_is_not() -> None:
    endpoint, _, link, _ = signed_endpoint()
    radio = M.MAVLink(None, srcSystem=51, srcComponent=68)  # a SiK radio's ids
    radio_addr, unsigned_gcs = ("127.0.0.1", 50001), ("127.0.0.1", 50002)
    link.inbox.append((M.MAVLink_radio_status_message(200, 190, 100, 90, 80, 0, 0).pack(radio),
                       radio_addr))
    link.inbox.append((HB.pack(M.MAVLink(None, srcSystem=255, srcComponent=190)),
                       unsigned_gcs))
    endpoint.tick(0.1, 0.1)
    assert endpoint.signing.stats.unsigned_allowed == 1
    assert endpoint.signing.stats.unsigned == 1
    # the radio's packet was handled (its sender became a peer); the unsigned HEARTBEAT not
    assert link.peers == [GCS_ADDR, radio_addr]


def test_setup_signing_needs_the_current_key_to_change_or_remove_it() -> None:
    endpoint, _, link, gcs = signed_endpoint()
    intruder = MemoryGcs(link)
    intruder.put(setup_signing(bytes(32)))  # unsigned "remove": dropped
    intruder.put(setup_signing(OTHER_KEY))  # unsigned "replace": dropped
    endpoint.tick(0.1, 0.1)
    assert endpoint.signing.active and endpoint.signing.stats.unsigned == 2
    gcs.put(setup_signing(bytes(32)))  # signed with the key: signing off
    endpoint.tick(0.2, 0.2)
    assert not endpoint.signing.active
    assert "Signing disabled" in [m.text for m in link.take("STATUSTEXT")]
    intruder.put(set_mode(Mode.GUIDED))
    endpoint.tick(0.3, 0.3)
    (ack,) = link.take("COMMAND_ACK")
    assert ack.result == M.MAV_RESULT_ACCEPTED  # unsigned commands are obeyed again
    endpoint.tick(0.4, 0.4)
    assert {data[2] & M.MAVLINK_IFLAG_SIGNED for data, _ in link.sent} == {0}


def test_a_timestamp_beyond_48_bits_is_refused() -> None:
    endpoint, _, link, gcs = memory_endpoint()
    gcs.put(setup_signing(KEY, MAX_TIMESTAMP + 1))
    endpoint.tick(0.0, 0.0)
    assert not endpoint.signing.active
    assert any("does not fit 48 bits" in m.text for m in link.take("STATUSTEXT"))


def test_the_key_survives_a_reboot_command() -> None:
    endpoint, _, link, gcs = signed_endpoint()
    gcs.put(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0,
                                           0, 0, 0, 0, 0))
    endpoint.tick(0.1, 0.1)
    assert link.take("COMMAND_ACK")[0].result == M.MAV_RESULT_ACCEPTED
    endpoint.tick(0.0, 0.2)
    assert endpoint.signing.active
    assert all(data[2] & M.MAVLINK_IFLAG_SIGNED for data, _ in link.sent)


# ---------------------------------------------------------------- the rules, one by one
def gate(unix_s: float = 1.7e9) -> tuple[MessageSigning, Outbox, list[float]]:
    clock = [unix_s]
    outbox = Outbox()
    signing = MessageSigning(M.MAVLink(None).signing, outbox, key=KEY,
                             unix_clock=lambda: clock[0])
    return signing, outbox, clock


def test_each_stream_must_move_forward() -> None:
    signing, _, _ = gate()
    t = signing.timestamp
    assert signing.accept(packet(HB, KEY, t + 10))
    assert not signing.accept(packet(HB, KEY, t + 10))  # the same timestamp again
    assert not signing.accept(packet(HB, KEY, t + 5))  # older
    assert signing.accept(packet(HB, KEY, t + 11))
    assert signing.accept(packet(HB, KEY, t + 5, link_id=3))  # another link: its own stream
    assert signing.accept(packet(HB, KEY, t + 5, src=(255, 191)))  # another component
    assert signing.stats == SigningStats(verified=4, replayed=2)


def test_a_new_stream_may_be_at_most_a_minute_behind() -> None:
    signing, _, _ = gate()
    t = signing.timestamp
    assert not signing.accept(packet(HB, KEY, t - MINUTE - 1, src=(250, 1)))
    assert signing.accept(packet(HB, KEY, t - MINUTE, src=(251, 1)))
    assert signing.stats.stale == 1


def test_a_forged_packet_cannot_move_a_stream_forward() -> None:
    # pymavlink's own check_signature records the timestamp before checking the signature,
    # so one forged packet from the future would lock the genuine sender out
    signing, _, _ = gate()
    t = signing.timestamp
    assert not signing.accept(packet(HB, OTHER_KEY, t + 100 * MINUTE))
    assert signing.accept(packet(HB, KEY, t + 1))
    assert signing.stats == SigningStats(verified=1, bad_signature=1)


def test_streams_are_bounded() -> None:
    signing, _, _ = gate()
    t = signing.timestamp
    for link_id in range(MAX_STREAMS):
        assert signing.accept(packet(HB, KEY, t + 1, link_id=link_id))
    assert not signing.accept(packet(HB, KEY, t + 1, link_id=MAX_STREAMS))
    assert signing.accept(packet(HB, KEY, t + 2, link_id=0))  # known streams go on
    assert signing.stats.too_many_streams == 1


def test_outgoing_timestamps_follow_the_wall_clock_and_the_newest_accepted() -> None:
    signing, _, clock = gate(1.7e9)
    start = signing.timestamp
    assert start == timestamp_from_unix(1.7e9)
    clock[0] += 30.0
    signing.tick(0.0, 0.0)
    assert signing.timestamp == start + 30 * 100_000
    clock[0] -= 3600.0  # the wall clock steps back: timestamps never do
    signing.tick(0.0, 5.0)
    assert signing.timestamp == start + 30 * 100_000
    ahead = start + 50 * MINUTE
    assert signing.accept(packet(HB, KEY, ahead))
    assert signing.timestamp == ahead


def test_mavlink1_packets_count_as_unsigned() -> None:
    signing, outbox, _ = gate()
    mav1 = M.MAVLink(None, srcSystem=255, srcComponent=190)
    (decoded,) = M.MAVLink(None).parse_buffer(HB.pack(mav1, force_mavlink1=True))
    assert not signing.accept(decoded)
    assert signing.stats.unsigned == 1
    assert outbox.texts == ["Signing: dropped HEARTBEAT from 255/190 (unsigned); "
                            f"NAMED_VALUE_INT {REPORT_NAME} counts rejections"]
