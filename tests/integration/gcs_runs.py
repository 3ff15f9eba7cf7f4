"""Helpers of the back-to-back ``ftc-gcs fly`` tests: one flight as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

from vehicle_harness import ROOT

FLIGHT_WALL_S = 400.0  # s: a ~60 s mission at speed-up 20 is ~5 s with set-up; loaded CI


def gcs_fly(connect: str, out: Path, name: str, *args: str,
            timeout_s: float = FLIGHT_WALL_S) -> tuple[subprocess.CompletedProcess[str],
                                                        dict[str, Any] | None, str]:
    """One ``ftc-gcs fly``; returns the process, its JSON (None when none was written) and
    its event log."""
    tlog, js = out / f"{name}.tlog", out / f"{name}.json"
    proc = subprocess.run(
        [sys.executable, "-m", "gcs", "fly", "--connect", connect, "--tlog", str(tlog),
         "--json", str(js), "--quiet", *args],
        cwd=ROOT, capture_output=True, text=True, timeout=timeout_s, stdin=subprocess.DEVNULL)
    events = tlog.with_suffix(".events.log")
    return (proc, json.loads(js.read_text()) if js.exists() else None,
            events.read_text() if events.exists() else "")


def assert_landed(proc: subprocess.CompletedProcess[str], data: dict[str, Any] | None) -> None:
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert data is not None and data["result"] == "ok" and not data["crashed"]
    assert "Traceback" not in proc.stderr
