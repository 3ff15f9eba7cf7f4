"""The endpoint over loopback UDP: identity, streams and their control, TIMESYNC,
STATUSTEXT chunks, robustness against garbage, the UDP link itself."""

from __future__ import annotations

import select
import socket
import statistics
import time
from collections import Counter
from typing import Any

import numpy as np
import pytest
from mavlink_testkit import WAIT_S, Gcs, VehicleThread, memory_endpoint, started
from pymavlink import mavutil

from fcu.mavlink.transport.codec import mavlink2
from fcu.mavlink.transport.udp import UdpLink

M = mavlink2
SLOWEST_S_PER_SIM_S = 4.0  # s wall per simulated s: a vehicle at 20x on a loaded machine, bound


def intervals_ms(msgs: list[Any]) -> list[int]:
    stamps = [m.time_boot_ms for m in msgs]
    return [b - a for a, b in zip(stamps, stamps[1:], strict=False)]


def test_streams_start_by_themselves_with_ardupilot_identity() -> None:
    with Gcs() as gcs:  # never sends anything: the vehicle sends to its default peer
        vehicle = started(gcs)
        try:
            hb = gcs.recv("HEARTBEAT")
            seen = {m.get_type() for m in gcs.collect(
                ["SYS_STATUS", "ATTITUDE", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED",
                 "GPS_RAW_INT", "EXTENDED_SYS_STATE", "HOME_POSITION", "BATTERY_STATUS",
                 "VFR_HUD", "SERVO_OUTPUT_RAW", "MISSION_CURRENT", "SYSTEM_TIME",
                 "SIM_STATE", "NAMED_VALUE_FLOAT", "ATTITUDE_TARGET"], 2.5)}
        finally:
            vehicle.stop()
    assert hb is not None
    assert (hb.get_srcSystem(), hb.get_srcComponent()) == (1, 1)
    assert (hb.type, hb.autopilot) == (M.MAV_TYPE_QUADROTOR, M.MAV_AUTOPILOT_ARDUPILOTMEGA)
    assert hb.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert hb.custom_mode == 0  # boots in STABILIZE, a mode that can arm
    assert seen == {"SYS_STATUS", "ATTITUDE", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED",
                    "GPS_RAW_INT", "EXTENDED_SYS_STATE", "HOME_POSITION", "BATTERY_STATUS",
                    "VFR_HUD", "SERVO_OUTPUT_RAW", "MISSION_CURRENT", "SYSTEM_TIME",
                    "SIM_STATE", "NAMED_VALUE_FLOAT", "ATTITUDE_TARGET"}


def test_packets_are_mavlink2() -> None:
    with Gcs() as gcs:
        vehicle = started(gcs)
        starts: list[int] = []
        try:
            while len(starts) < 50:
                ready, _, _ = select.select([gcs.conn.port], [], [], WAIT_S)
                assert ready, "no telemetry"
                data, _ = gcs.conn.port.recvfrom(65535)
                starts.append(data[0])
        finally:
            vehicle.stop()
    assert set(starts) == {0xFD}  # MAVLink 2 start byte, every packet


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_set_message_interval_changes_the_rate_in_simulated_time() -> None:
    with Gcs() as gcs:
        vehicle = started(gcs)
        try:
            before = gcs.collect("ATTITUDE", 1.0)
            assert gcs.ack(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE,
                           200_000).result == M.MAV_RESULT_ACCEPTED
            gcs.collect("ATTITUDE", 0.3)  # let packets in flight drain
            after = gcs.collect("ATTITUDE", 1.5)
            assert gcs.ack(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE,
                           -1).result == M.MAV_RESULT_ACCEPTED
            gcs.collect("ATTITUDE", 0.3)
            stopped = gcs.collect("ATTITUDE", 1.0)
            assert gcs.ack(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE,
                           0).result == M.MAV_RESULT_ACCEPTED
            gcs.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE)
            interval = gcs.recv("MESSAGE_INTERVAL")
            restored = gcs.collect("ATTITUDE", 1.0)
        finally:
            vehicle.stop()
    # Time stamps are simulated time; 15 %: a tick lands a few ms after a due time.
    assert statistics.median(intervals_ms(before)) == pytest.approx(50, rel=0.15)
    assert statistics.median(intervals_ms(after)) == pytest.approx(200, rel=0.15)
    assert stopped == []
    assert interval is not None and interval.interval_us == 50_000
    assert statistics.median(intervals_ms(restored)) == pytest.approx(50, rel=0.15)


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_request_data_stream_stops_and_restarts_a_group() -> None:
    with Gcs() as gcs:
        vehicle = started(gcs)
        try:
            gcs.mav.request_data_stream_send(1, 1, M.MAV_DATA_STREAM_POSITION, 0, 0)
            gcs.collect("GLOBAL_POSITION_INT", 0.3)
            stopped = gcs.collect(["GLOBAL_POSITION_INT", "LOCAL_POSITION_NED"], 1.0)
            still = gcs.collect("ATTITUDE", 0.5)
            gcs.mav.request_data_stream_send(1, 1, M.MAV_DATA_STREAM_POSITION, 4, 1)
            gcs.collect("GLOBAL_POSITION_INT", 0.3)
            again = gcs.collect("GLOBAL_POSITION_INT", 1.6)
        finally:
            vehicle.stop()
    assert stopped == []
    assert still  # other groups untouched
    assert statistics.median(intervals_ms(again)) == pytest.approx(250, rel=0.15)


def test_timesync_answers_with_simulated_nanoseconds() -> None:
    with Gcs() as gcs:
        vehicle = started(gcs, speedup=10.0)
        try:
            gcs.mav.timesync_send(0, 123456789)
            first = gcs.recv("TIMESYNC", condition=lambda m: m.ts1 == 123456789)
            now = gcs.recv("SYSTEM_TIME")
            gcs.mav.timesync_send(0, 987654321)
            second = gcs.recv("TIMESYNC", condition=lambda m: m.ts1 == 987654321)
            gcs.mav.timesync_send(5, 1)  # a reply to someone else: ignored
            ignored = gcs.collect("TIMESYNC", 0.5)
        finally:
            vehicle.stop()
    assert first is not None and second is not None and now is not None
    assert 0 < first.tc1 <= now.time_boot_ms * 1_000_000 + 1_000_000
    assert second.tc1 >= first.tc1  # never goes backwards
    assert ignored == []


def test_long_statustext_arrives_in_chunks_that_reassemble() -> None:
    text = ("Motor 2 loss of effectiveness estimated at 45 %, fault-tolerant "
            "controller engaged, continuing the mission")
    with Gcs() as gcs:
        vehicle = started(gcs)
        try:
            with vehicle.lock:
                vehicle.vehicle.say(M.MAV_SEVERITY_CRITICAL, text)
            chunks = gcs.collect("STATUSTEXT", 1.0)
        finally:
            vehicle.stop()
    assert len(chunks) == 3
    assert len({c.id for c in chunks}) == 1 and chunks[0].id != 0
    assert [c.chunk_seq for c in chunks] == [0, 1, 2]
    assert "".join(c.text for c in chunks) == text


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_garbage_never_stops_heartbeat_or_telemetry() -> None:
    rng = np.random.default_rng(20240611)
    mav = M.MAVLink(None, srcSystem=255, srcComponent=190)
    valid = M.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(mav)
    with Gcs() as gcs:
        vehicle = started(gcs)
        try:
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                for k in range(600):
                    kind = k % 4
                    if kind == 0:  # pure noise
                        data = rng.integers(0, 256, rng.integers(1, 300)).astype(np.uint8)
                        payload = data.tobytes()
                    elif kind == 1:  # a MAVLink 2 header claiming a long payload, truncated
                        payload = bytes([0xFD, 200, 0, 0, k % 256, 255, 190, 76, 0, 0]) + \
                            rng.integers(0, 256, 20).astype(np.uint8).tobytes()
                    elif kind == 2:  # a valid packet with a flipped byte (bad CRC)
                        broken = bytearray(valid)
                        broken[12] ^= 0xFF
                        payload = bytes(broken)
                    else:  # MAVLink 1 start byte and noise
                        payload = b"\xfe" + rng.integers(0, 256, 40).astype(np.uint8).tobytes()
                    sock.sendto(payload, ("127.0.0.1", vehicle.port))
            finally:
                sock.close()
            beats = gcs.collect("HEARTBEAT", 2.5)
            telemetry = gcs.collect("ATTITUDE", 0.5)
            gcs.recv("HEARTBEAT")  # the vehicle knows us again as a peer
            ack = gcs.ack(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            status = gcs.recv("SYS_STATUS", condition=lambda m: m.errors_comm > 0)
        finally:
            vehicle.stop()
    assert len(beats) >= 2 and telemetry
    assert ack.result == M.MAV_RESULT_ACCEPTED
    stats = vehicle.endpoint.stats
    assert stats.malformed >= 300  # every broken packet is counted ...
    assert stats.handler_errors == 0 and stats.build_errors == 0  # ... and nothing broke
    assert status is not None


def test_garbage_is_counted_and_never_raises_in_memory() -> None:
    endpoint, _, _, _ = memory_endpoint()
    rng = np.random.default_rng(7)
    for _ in range(2000):
        endpoint.handle_bytes(rng.integers(0, 256, rng.integers(0, 400)).astype(
            np.uint8).tobytes(), ("127.0.0.1", 1), 0.0)
    assert endpoint.stats.datagrams == 2000
    assert endpoint.stats.malformed > 0
    assert endpoint.stats.handler_errors == 0


def test_a_client_that_writes_first_becomes_a_peer() -> None:
    vehicle = VehicleThread([]).start()  # no default peers at all
    try:
        conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{vehicle.port}",
                                          source_system=255, source_component=190)
        try:
            conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=WAIT_S)
        finally:
            conn.close()
    finally:
        vehicle.stop()
    assert hb is not None and hb.autopilot == M.MAV_AUTOPILOT_ARDUPILOTMEGA


def test_own_packets_looped_back_are_ignored() -> None:
    endpoint, vehicle, link, _ = memory_endpoint()
    own = M.MAVLink(None, srcSystem=1, srcComponent=1)
    cmd = M.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
    link.inbox.append((cmd.pack(own), ("127.0.0.1", 9)))
    endpoint.tick(0.0, 0.0)
    assert link.take("COMMAND_ACK") == [] and not vehicle.armed


def test_udp_link_tolerates_unreachable_peers() -> None:
    closed = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    closed.bind(("127.0.0.1", 0))
    dead_port = closed.getsockname()[1]
    closed.close()  # nobody listens there: sends provoke ICMP port unreachable
    with UdpLink("127.0.0.1", 0, default_peers=[("127.0.0.1", dead_port)]) as link:
        for _ in range(50):
            link.send(b"\xfd\x00")
            assert link.receive() == []  # never raises, whatever the OS reports
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
            sender.sendto(b"hello", link.local_address)
            deadline = time.monotonic() + WAIT_S
            got: list[tuple[bytes, tuple[str, int]]] = []
            while not got and time.monotonic() < deadline:
                got = link.receive()
                time.sleep(0.01)
    assert got and got[0][0] == b"hello"


def test_udp_link_peer_list_is_bounded_first_come() -> None:
    link = UdpLink("127.0.0.1", 0, default_peers=[("127.0.0.1", 14550)], max_peers=3)
    for port in range(20000, 20010):
        link.add_peer(("127.0.0.1", port))
    # the first three keep their places; later ones are refused, the --out peer stays first
    assert link.peers == [("127.0.0.1", 14550), ("127.0.0.1", 20000), ("127.0.0.1", 20001),
                          ("127.0.0.1", 20002)]
    assert link.refused_peers == 7
    link.close()


def test_message_counts_over_a_simulated_minute_at_20x() -> None:
    with Gcs() as gcs:
        vehicle = started(gcs, speedup=20.0)
        msgs: list[Any] = []
        try:
            t0 = gcs.recv("SYSTEM_TIME")
            assert t0 is not None
            # 30 simulated seconds, however long a loaded machine takes (bounded)
            deadline = time.monotonic() + 30.0 * SLOWEST_S_PER_SIM_S
            while time.monotonic() < deadline:
                msgs += gcs.collect(["HEARTBEAT", "SYS_STATUS", "SYSTEM_TIME"], 0.5)
                if any(m.get_type() == "SYSTEM_TIME"
                       and m.time_boot_ms - t0.time_boot_ms >= 30_000 for m in msgs):
                    break
        finally:
            vehicle.stop()
    times = [m.time_boot_ms for m in msgs if m.get_type() == "SYSTEM_TIME"]
    span_s = (max(times) - t0.time_boot_ms) / 1000.0
    counts = Counter(m.get_type() for m in msgs)
    # 1 Hz of simulated time each, whatever the wall-clock pace: about the span
    assert span_s >= 30.0
    assert counts["SYS_STATUS"] == pytest.approx(span_s, rel=0.2)
    assert counts["HEARTBEAT"] == pytest.approx(span_s, rel=0.2)


def test_a_failing_snapshot_keeps_a_critical_heartbeat() -> None:
    endpoint, vehicle, link, _ = memory_endpoint()
    endpoint.tick(0.0, 0.0)
    link.take()

    def broken() -> None:
        raise RuntimeError("estimator crashed")

    vehicle.snapshot = broken  # type: ignore[assignment, method-assign]
    for k in range(1, 301):  # 3 s
        endpoint.tick(k * 0.01, k * 0.01)
    beats = link.take("HEARTBEAT")
    assert len(beats) == 3
    assert all(b.system_status == M.MAV_STATE_CRITICAL for b in beats)
    assert endpoint.stats.build_errors > 0


def test_sysid_change_applies_at_reboot() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    gcs.put(M.MAVLink_param_set_message(1, 1, b"SYSID_THISMAV", 7.0, M.MAV_PARAM_TYPE_REAL32))
    endpoint.tick(0.0, 0.0)
    assert endpoint.sysid == 1  # not yet
    texts = [m.text for m in link.take("STATUSTEXT")]
    assert any("after reboot" in t for t in texts)
    gcs.put(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0,
                                           0, 0, 0, 0, 0))
    endpoint.tick(1.0, 1.0)
    (ack,) = link.take("COMMAND_ACK")
    assert ack.result == M.MAV_RESULT_ACCEPTED and ack.get_srcSystem() == 1  # ACK as before
    endpoint.tick(0.0, 2.0)  # the rebooted vehicle's clock starts again
    beats = link.take("HEARTBEAT")
    assert beats and {b.get_srcSystem() for b in beats} == {7}
    assert vehicle.reboots == 1
