"""``ftc-gcs`` without a vehicle: clear one-line failures and exit codes, in bounded time."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
WALL_LIMIT_S = 60.0  # s: start-up of a Python process on a loaded two-core machine, and more


def run_gcs(*args: str, timeout_s: float = WALL_LIMIT_S) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "gcs", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout_s, stdin=subprocess.DEVNULL)


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_no_vehicle_exits_3_with_one_line_within_the_timeout(tmp_path: Path) -> None:
    port = free_udp_port()
    start = time.monotonic()
    proc = run_gcs("fly", "--connect", f"udpin:127.0.0.1:{port}", "--connect-timeout", "2",
                   "--quiet", "--out-dir", str(tmp_path))
    elapsed = time.monotonic() - start
    assert proc.returncode == 3, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines[-1] == (f"ftc-gcs: vehicle not found: no HEARTBEAT from an autopilot on "
                         f"udpin:127.0.0.1:{port} within 2 s")
    assert elapsed < WALL_LIMIT_S
    # no flight: no table of nothing, and no records of nothing left behind
    assert "flight:" not in proc.stdout and "records:" not in proc.stdout
    assert list(tmp_path.iterdir()) == []
    assert "Traceback" not in proc.stderr


def test_no_vehicle_leaves_no_out_dir_it_created(tmp_path: Path) -> None:
    out = tmp_path / "new" / "out"
    proc = run_gcs("fly", "--connect", f"udpin:127.0.0.1:{free_udp_port()}",
                   "--connect-timeout", "1", "--quiet", "--out-dir", str(out))
    assert proc.returncode == 3, proc.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("url", "words"), [
    ("bogus:foo", "port 'foo' is not a number"),
    ("udpin:127.0.0.1:99999", "port 99999 not in 0..65535"),
    ("udpout:127.0.0.1:0", "port 0 not in 1..65535"),
    ("udpin:127.0.0.1", "HOST:PORT"),
    ("carrier-pigeon:1:2", "'carrier-pigeon' is not one of"),
])
def test_a_bad_connection_string_is_one_line(tmp_path: Path, url: str, words: str) -> None:
    proc = run_gcs("fly", "--connect", url, "--quiet", "--out-dir", str(tmp_path))
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"ftc-gcs: error: --connect {url!r}: ")
    assert words in lines[0]
    assert proc.stdout == "" and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("option", "path", "words"), [
    ("--figures", "/proc/nope", "cannot write there"),
    ("--report", "/proc/nope", "cannot write there"),
    ("--json", "/proc/nope/f.json", "cannot write"),
    ("--rrd", "/proc/nope.rrd", "cannot write"),
    ("--tlog", "/proc/nope/f.tlog", "cannot write"),
    ("--out-dir", "/proc/nope", "cannot write there"),
])
def test_unwritable_outputs_are_refused_before_connecting(tmp_path: Path, option: str,
                                                          path: str, words: str) -> None:
    proc = run_gcs("fly", "--connect", f"udpin:127.0.0.1:{free_udp_port()}",
                   "--connect-timeout", "30", "--quiet", *(("--out-dir", str(tmp_path))
                                                          if option != "--out-dir" else ()),
                   option, path)
    assert proc.returncode == 2, proc.stderr
    (line,) = proc.stderr.strip().splitlines()
    assert line.startswith(f"ftc-gcs: error: {option} {path}: ") and words in line, line
    assert list(tmp_path.iterdir()) == []


def test_report_of_a_file_that_is_not_a_tlog_fails(tmp_path: Path) -> None:
    notalog = tmp_path / "notalog.toml"
    notalog.write_text('[[items]]\ncommand = "takeoff"\nalt_m = 1.0\n' * 20)
    proc = run_gcs("report", str(notalog))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stdout == ""
    (line,) = proc.stderr.strip().splitlines()
    assert line == f"ftc-gcs: error: {notalog}: not a .tlog (no MAVLink packets in it)"


def test_report_of_a_tlog_without_a_vehicle_fails(tmp_path: Path) -> None:
    from gcs.mavlink import mavlink2
    from gcs.records import TlogWriter

    path = tmp_path / "gcs_only.tlog"
    mav = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)
    writer = TlogWriter(path)
    for _ in range(5):  # only a ground station's own heartbeats: nobody answered
        writer.write(mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_GCS, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3).pack(mav))
    writer.close()
    proc = run_gcs("report", str(path))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stdout == ""
    (line,) = proc.stderr.strip().splitlines()
    assert line == (f"ftc-gcs: error: {path}: no flight in it (no HEARTBEAT from an "
                    "autopilot among its 5 packets)")


def test_bad_fault_flag_is_a_usage_error(tmp_path: Path) -> None:
    proc = run_gcs("fly", "--fault", "7:0.2@22", "--out-dir", str(tmp_path))
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines()[-1].startswith("ftc-gcs: error: --fault '7:0.2@22'")


def test_bad_mission_file_is_a_usage_error(tmp_path: Path) -> None:
    bad = tmp_path / "m.toml"
    bad.write_text('[[items]]\ncommand = "jump"\n')
    proc = run_gcs("fly", "--mission", str(bad), "--out-dir", str(tmp_path))
    assert proc.returncode == 2 and "items[0].command" in proc.stderr


def test_report_of_a_missing_file_is_a_usage_error(tmp_path: Path) -> None:
    proc = run_gcs("report", str(tmp_path / "none.tlog"))
    assert proc.returncode == 2 and "no such file" in proc.stderr


def test_help_lists_the_commands() -> None:
    proc = run_gcs("--help")
    assert proc.returncode == 0
    for word in ("fly", "demo", "report"):
        assert word in proc.stdout


def test_a_spawned_vehicle_that_cannot_start_is_reported_at_once(tmp_path: Path) -> None:
    start = time.monotonic()
    proc = run_gcs("fly", "--spawn-vehicle", "--scenario", "no_such_scenario", "--quiet",
                   "--out-dir", str(tmp_path))
    assert proc.returncode == 3, proc.stderr
    line = proc.stderr.strip().splitlines()[-1]
    assert line.startswith("ftc-gcs: vehicle not found: the vehicle process exited with status "
                           "2: ftc-vehicle: error: ")
    assert "no_such_scenario" in line
    assert time.monotonic() - start < 30.0  # s: well before the 60 s connect timeout


def test_two_stations_in_one_out_dir_keep_their_own_records(tmp_path: Path) -> None:
    """Records are named by the second a station starts: a second station in the same folder
    (and second) takes ``-2``, and when it finds no vehicle it removes only its own."""
    waiting = subprocess.Popen(
        [sys.executable, "-m", "gcs", "fly", "--connect", f"udpin:127.0.0.1:{free_udp_port()}",
         "--connect-timeout", "300", "--quiet", "--out-dir", str(tmp_path)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        stdin=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + WALL_LIMIT_S
        while not list(tmp_path.glob("*.tlog")) and time.monotonic() < deadline:
            time.sleep(0.05)
        (first,) = tmp_path.glob("*.tlog")
        proc = run_gcs("fly", "--connect", f"udpin:127.0.0.1:{free_udp_port()}",
                       "--connect-timeout", "1", "--quiet", "--out-dir", str(tmp_path))
        assert proc.returncode == 3, proc.stderr
        assert first.exists()  # the waiting station's tlog survived the other's clean-up
    finally:
        waiting.kill()
        waiting.communicate(timeout=WALL_LIMIT_S)


def test_a_record_name_is_claimed_once(tmp_path: Path) -> None:
    from gcs.cli import _claim_stem

    stems = [_claim_stem(tmp_path / "out", "flight-20261124-120000") for _ in range(3)]
    assert stems == ["flight-20261124-120000", "flight-20261124-120000-2",
                     "flight-20261124-120000-3"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(f"{s}.tlog"
                                                                          for s in stems)


def test_demo_may_restart_the_autopilot_and_fly_only_when_told() -> None:
    from gcs.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["demo"]).reboot is True  # its own vehicle: never a prompt
    assert parser.parse_args(["fly"]).reboot is False
    assert parser.parse_args(["fly", "--reboot"]).reboot is True
