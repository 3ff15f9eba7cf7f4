"""The ground station's MAVLink choices and its records: MAVLink 2, ardupilotmega, .tlog."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from pymavlink import mavutil

from gcs.mavlink import decode_packet, mavlink2, open_link, read_tlog, use_mavlink2
from gcs.records import EventLog, TlogWriter

M = mavlink2


def _packets(n: int) -> list[bytes]:
    mav = M.MAVLink(None, srcSystem=1, srcComponent=1)
    out = []
    for k in range(n):
        msg = M.MAVLink_attitude_message(k * 10, 0.1 * k, -0.2, 0.3, 0.0, 0.0, 0.0)
        out.append(bytes(msg.pack(mav)))
        mav.seq = (mav.seq + 1) % 256
    return out


def test_link_speaks_mavlink2_without_touching_the_environment() -> None:
    before = os.environ.get("MAVLINK20")
    conn = open_link("udpin:127.0.0.1:0")
    try:
        assert conn.WIRE_PROTOCOL_VERSION == "2.0"
        assert type(conn.mav).__module__ == "pymavlink.dialects.v20.ardupilotmega"
        assert conn.first_byte is False  # mavutil's auto-switch (which sets MAVLINK20) is off
        msg = M.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)
        packet = msg.pack(conn.mav)
        assert packet[0] == M.PROTOCOL_MARKER_V2
    finally:
        conn.close()
    assert os.environ.get("MAVLINK20") == before


def test_use_mavlink2_replaces_a_v1_codec() -> None:
    class Fake:
        source_system, source_component = 255, 190
        mav = None
        WIRE_PROTOCOL_VERSION = "1.0"
        first_byte = True

    fake = Fake()
    use_mavlink2(fake)
    assert type(fake.mav).__module__ == "pymavlink.dialects.v20.ardupilotmega"
    assert fake.WIRE_PROTOCOL_VERSION == "2.0" and fake.first_byte is False


def test_tlog_round_trip_and_pymavlink_reads_it(tmp_path: Path) -> None:
    path = tmp_path / "x.tlog"
    writer = TlogWriter(path)
    packets = _packets(50)
    for k, packet in enumerate(packets):
        writer.write(packet, 1_700_000_000.0 + k * 0.01)
    writer.close()
    records = list(read_tlog(path))
    assert [r.message.time_boot_ms for r in records] == [k * 10 for k in range(50)]
    assert records[3].unix_time_us == 1_700_000_000_030_000
    # pymavlink's own reader (what mavlogdump.py and MAVExplorer use) sees the same messages
    log = mavutil.mavlink_connection(str(path))
    got = []
    while (m := log.recv_match(type="ATTITUDE")) is not None:
        got.append(m.time_boot_ms)
    log.close()
    assert got == [k * 10 for k in range(50)]


def test_truncated_tlog_keeps_every_whole_record(tmp_path: Path) -> None:
    path = tmp_path / "cut.tlog"
    writer = TlogWriter(path)
    for packet in _packets(10):
        writer.write(packet)
    writer.close()
    data = path.read_bytes()
    path.write_bytes(data[:-7])  # an interruption in the middle of the last record
    assert len(list(read_tlog(path))) == 9


def test_tlog_is_flushed_as_it_is_written(tmp_path: Path) -> None:
    path = tmp_path / "live.tlog"
    writer = TlogWriter(path)
    writer.write(_packets(1)[0])
    assert len(list(read_tlog(path))) == 1  # readable before close: nothing buffered
    writer.close()


def test_event_log_lines_are_flushed(tmp_path: Path) -> None:
    log = EventLog(tmp_path / "e.log")
    log.write("INJECT", "motor 3", 22.0)
    assert "t=  22.000 s  INJECT    motor 3" in (tmp_path / "e.log").read_text()
    log.close()


@pytest.mark.parametrize("junk", [b"", b"\x00\x01\x02", b"\xfd\x09"])
def test_decode_packet_rejects_junk(junk: bytes) -> None:
    assert decode_packet(junk) is None
