"""``ftc-gcs`` without a vehicle: clear one-line failures and exit codes, in bounded time."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from pathlib import Path

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
    # the records exist even for a flight that never started
    assert list(tmp_path.glob("*.events.log"))


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
