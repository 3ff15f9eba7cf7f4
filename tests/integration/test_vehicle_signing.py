"""MAVLink 2 signing against the real vehicle process over loopback UDP.

After SETUP_SIGNING, 1,000 unsigned, wrongly keyed, corrupted, replayed and stale commands
(PARAM_SET FS_GCS_TIMEOUT and DO_SET_MODE GUIDED, both visible when obeyed) change nothing
and get no answer, while the key holder is obeyed; everything the vehicle sends verifies with
the key under pymavlink. A vehicle started with ``--signing-key`` signs from its first
packet. MAVProxy's ``signing setup`` / ``signing remove`` drive it.

Pacing never depends on time: after each batch of forged packets a signed PARAM_REQUEST_READ
goes to the same socket, and its answer means the vehicle has handled everything before it.
"""

from __future__ import annotations

import random
import time
from pathlib import Path
from typing import Any

import pytest
from test_mavproxy import STARTUP_S, MavProxy
from vehicle_harness import ANSWER_S, Gcs, M

from flightdata.signing import key_from_text, timestamp_from_unix

PASSPHRASE = "quadftc-signing-test"
KEY = key_from_text(PASSPHRASE)
WRONG_KEY = key_from_text("somebody-else")
MINUTE = 6_000_000  # signature timestamp units (10 us) in one minute
GUIDED, STABILIZE = 4, 0  # ArduCopter custom modes
FORGED = 1000
KINDS = ("unsigned", "wrong key", "bad signature", "replayed", "stale")


def verified(raw: list[bytes], key: bytes) -> list[Any]:
    """Decode datagrams in order with pymavlink holding ``key`` (BAD_DATA where one fails)."""
    parser = M.MAVLink(None)
    parser.robust_parsing = True
    parser.signing.secret_key = key
    return [m for data in raw for m in parser.parse_buffer(data) or []]


def packer(key: bytes | None, timestamp: int = 0, link_id: int = 0) -> Any:
    mav = M.MAVLink(None, srcSystem=255, srcComponent=190)
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = key is not None
    mav.signing.timestamp = timestamp
    mav.signing.link_id = link_id
    return mav


def signed_by(gcs: Gcs, msg: Any) -> bytes:
    """``msg`` packed by ``gcs`` (signed with its key), sent, and returned as sent."""
    data = bytes(msg.pack(gcs.mav))
    gcs.mav.seq = (gcs.mav.seq + 1) % 256
    gcs.send_raw(data)
    return data


def param_set(value: float) -> Any:
    return M.MAVLink_param_set_message(1, 1, b"FS_GCS_TIMEOUT", value, M.MAV_PARAM_TYPE_REAL32)


def set_mode(mode: int) -> Any:
    return M.MAVLink_command_long_message(1, 1, M.MAV_CMD_DO_SET_MODE, 0,
                                          M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode,
                                          0, 0, 0, 0, 0)


def forged(kind: str, k: int, rng: random.Random, replayable: list[bytes], now: int) -> bytes:
    """One packet of ``kind`` carrying a command that would change something if obeyed."""
    msg = set_mode(GUIDED) if k % 2 else param_set(77.0)
    if kind == "unsigned":
        return bytes(msg.pack(packer(None)))
    if kind == "wrong key":
        return bytes(msg.pack(packer(WRONG_KEY, now + k)))
    if kind == "bad signature":
        data = bytearray(msg.pack(packer(KEY, now + 10 * MINUTE + k)))
        data[-1 - rng.randrange(6)] ^= 1 << rng.randrange(8)  # one bit of the signature
        return bytes(data)
    if kind == "replayed":
        if k % 4 < 2:
            return replayable[k % 2]  # a genuine packet again, byte for byte
        return bytes(msg.pack(packer(KEY, now - 10 * MINUTE)))  # our stream, old timestamp
    # a correctly signed first packet of a new stream, two minutes behind the vehicle
    return bytes(msg.pack(packer(KEY, now - 2 * MINUTE, link_id=1 + k % 250)))


def test_setup_signing_then_no_forged_command_is_obeyed_and_signed_ones_are(
        start_vehicle: Any) -> None:
    gcs = Gcs(keep_raw=True)
    try:
        start_vehicle("--speedup", "1", outs=[gcs.port])
        gcs.wait_heartbeat()
        since = gcs.mark()
        gcs.send(M.MAVLink_setup_signing_message(1, 1, list(KEY),
                                                 timestamp_from_unix(time.time())))
        gcs.sign_with(KEY)
        gcs.wait("STATUSTEXT", lambda m: m.text == "Signing enabled: unsigned packets are "
                 "dropped", since=since)
        assert gcs.raw is not None
        del gcs.raw[:]  # from here on, every datagram the vehicle sends must verify

        # genuine commands, captured for replaying, then undone by genuine commands
        replayable = [signed_by(gcs, param_set(33.0))]
        assert gcs.wait("PARAM_VALUE", lambda m: m.param_id == "FS_GCS_TIMEOUT"
                        ).param_value == 33.0
        assert gcs.param_set("FS_GCS_TIMEOUT", 5.0).param_value == 5.0
        since = gcs.mark()
        replayable.append(signed_by(gcs, set_mode(GUIDED)))
        assert gcs.wait("COMMAND_ACK", since=since).result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(STABILIZE).result == M.MAV_RESULT_ACCEPTED
        gcs.wait_mode(STABILIZE)

        start = gcs.mark()
        rng = random.Random(256)
        now = timestamp_from_unix(time.time())
        sent = dict.fromkeys(KINDS, 0)
        barriers = 0
        for k in range(FORGED):
            kind = rng.choice(KINDS)
            sent[kind] += 1
            gcs.send_raw(forged(kind, k, rng, replayable, now))
            if k % 50 == 49:  # everything so far handled once this signed read is answered
                assert gcs.param_get("FS_GCS_TIMEOUT") == 5.0
                barriers += 1
        report = gcs.wait("NAMED_VALUE_INT", lambda m: m.name == "SIGN_REJ"
                          and m.value >= FORGED, since=start)
        gcs.wait_heartbeat(ANSWER_S)  # one more, to see the mode after the barrage
        after = gcs.messages(since=start)

        assert min(sent.values()) > 150  # every kind well represented
        assert report.value == FORGED  # each forged packet counted once, nothing else
        values = [m for m in after if m.get_type() == "PARAM_VALUE"]
        assert len(values) == barriers and {m.param_value for m in values} == {5.0}
        assert [m for m in after if m.get_type() == "COMMAND_ACK"] == []
        beats = [m for m in after if m.get_type() == "HEARTBEAT"]
        assert beats and {m.custom_mode for m in beats} == {STABILIZE}
        dropped = [m.text for m in gcs.messages("STATUSTEXT") if "Signing: dropped" in m.text]
        assert len(dropped) == 1  # announced once

        # the key holder is still obeyed
        assert gcs.set_mode(GUIDED).result == M.MAV_RESULT_ACCEPTED
        gcs.wait_mode(GUIDED)
        assert gcs.param_set("FS_GCS_TIMEOUT", 77.0).param_value == 77.0

        raw = list(gcs.raw)
        good = verified(raw, KEY)
        assert len(raw) > 50 and len(good) >= len(raw)  # a second or more of telemetry
        assert [m for m in good if m.get_type() == "BAD_DATA"] == []
        assert all(m._signed for m in good)  # every signature verified, timestamps rising
        assert {m.get_type() for m in verified(raw, WRONG_KEY)} == {"BAD_DATA"}
    finally:
        gcs.close()


def test_a_vehicle_started_with_a_key_signs_from_its_first_packet(start_vehicle: Any) -> None:
    gcs = Gcs(signing_key=KEY, keep_raw=True)
    stranger = Gcs()  # no key
    try:
        vehicle = start_vehicle("--speedup", "1", "--signing-key", PASSPHRASE, outs=[gcs.port])
        listening = next(line for line in vehicle.lines if "listening on udp" in line)
        assert "MAVLink 2 signing on" in listening
        assert PASSPHRASE not in " ".join(vehicle.lines)  # the key is never printed
        gcs.wait_heartbeat()
        assert gcs.raw is not None
        first = gcs.raw[0]
        assert first[0] == 0xFD and first[2] & M.MAVLINK_IFLAG_SIGNED
        assert [m.get_type() for m in verified([first], KEY)] != ["BAD_DATA"]

        stranger.vehicle = vehicle.address
        stranger.send(set_mode(GUIDED))  # unsigned: dropped
        assert gcs.param_get("FS_GCS_TIMEOUT") == 5.0  # handled after the stranger's command
        since = gcs.mark()
        hb = gcs.wait("HEARTBEAT", lambda m: m.get_srcComponent() == 1, since=since)
        assert hb.custom_mode == STABILIZE
        stranger.pump(0.2)
        assert stranger.messages() == []  # nothing ever went to the unsigned sender
        assert gcs.set_mode(GUIDED).result == M.MAV_RESULT_ACCEPTED
    finally:
        gcs.close()
        stranger.close()
    assert vehicle.stop() == 0
    assert "1 packets failing the signing check" in vehicle.lines[-1]


@pytest.mark.slow
def test_mavproxy_signing_setup_and_remove(start_vehicle: Any, tmp_path: Path) -> None:
    watcher = Gcs(keep_raw=True)
    try:
        vehicle = start_vehicle("--speedup", "2", outs=[watcher.port])
        host, port = vehicle.address
        mp = MavProxy(f"udpout:{host}:{port}", tmp_path)
        try:
            mp.expect(r"Detected vehicle 1:1", timeout_s=STARTUP_S)
            mp.expect(r"STABILIZE>", timeout_s=ANSWER_S)
            since = mp.send(f"signing setup {PASSPHRASE}")
            mp.expect(r"Setup signing key", since)
            mp.expect(r"Signing enabled: unsigned packets are dropped", since)
            since = mp.send("mode GUIDED")  # MAVProxy now signs: obeyed
            mp.expect(r"DO_SET_MODE: ACCEPTED", since)
            mp.expect(r"GUIDED>", since)

            watcher.wait("STATUSTEXT", lambda m: "Signing enabled" in m.text, since=0)
            assert watcher.raw is not None
            del watcher.raw[:]
            watcher.wait("HEARTBEAT", lambda m: m.custom_mode == GUIDED)
            signed = list(watcher.raw)
            assert [m for m in verified(signed, KEY) if m.get_type() == "BAD_DATA"] == []

            since = mp.send("signing remove")
            mp.expect(r"Removed signing", since)
            mp.expect(r"Signing disabled", since)
            since = mp.send("mode STABILIZE")  # unsigned again, and obeyed
            mp.expect(r"DO_SET_MODE: ACCEPTED", since)
        finally:
            assert mp.close()
        mark = watcher.mark()
        watcher.wait("HEARTBEAT", lambda m: m.custom_mode == STABILIZE, since=mark)
        del watcher.raw[:]
        watcher.wait("HEARTBEAT")
        assert not any(data[2] & M.MAVLINK_IFLAG_SIGNED for data in watcher.raw)
    finally:
        watcher.close()
