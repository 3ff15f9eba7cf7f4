"""Outputs that cannot be written are refused in one line before anything runs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from sim.scenario_cli import main as scenario_main

ROOT = Path(__file__).resolve().parents[2]
WALL_LIMIT_S = 120.0  # s: a Python start-up on a loaded machine; the run itself never starts


def test_vehicle_timing_log_that_cannot_be_written_is_refused_before_start() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "sim", "--timing-log", "/proc/nope/t.csv", "--duration", "0.5",
         "--bind", "127.0.0.1:0", "--out", "none"],
        cwd=ROOT, capture_output=True, text=True, timeout=WALL_LIMIT_S,
        stdin=subprocess.DEVNULL)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stdout == ""  # never started listening
    (line,) = proc.stderr.strip().splitlines()
    assert line.startswith("ftc-vehicle: error: --timing-log /proc/nope/t.csv: cannot write: ")


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_vehicle_timing_log_in_a_new_folder_is_written(tmp_path: Path) -> None:
    path = tmp_path / "new" / "t.csv"
    proc = subprocess.run(
        [sys.executable, "-m", "sim", "--timing-log", str(path), "--duration", "0.2",
         "--speedup", "10", "--bind", "127.0.0.1:0", "--out", "none"],
        cwd=ROOT, capture_output=True, text=True, timeout=WALL_LIMIT_S,
        stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    rows = path.read_text().splitlines()
    assert rows[0] == "tick,start_wall_s,busy_s" and len(rows) == 1 + 20  # 0.2 s at 100 Hz


@pytest.mark.parametrize(("option", "path", "words"), [
    ("--figures", "/proc/nope", "--figures /proc/nope: cannot write there: "),
    ("--json", "/proc/nope/m.json", "--json /proc/nope/m.json: cannot write: "),
    ("--rrd", "/proc/nope.rrd", "--rrd /proc/nope.rrd: cannot write: "),
])
def test_scenario_outputs_that_cannot_be_written_are_refused_before_flying(
        option: str, path: str, words: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert scenario_main(["run", "baseline", option, path]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # nothing flown, nothing summarised
    (line,) = err.strip().splitlines()
    assert line.startswith(f"ftc-scenario: {words}")
