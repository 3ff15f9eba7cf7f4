"""Reading rerun recordings back in tests, with rerun's own tools.

Entities, components and timelines come from ``rerun.recording.load_recording(...).schema()``
in the tests themselves; row values from the ``rerun rrd print -vvv`` command of the wheel
(``python -m rerun_cli``), since rerun 0.29's Python dataframe queries need the optional
``datafusion`` package. Used by tests/flightdata/test_recording.py and
tests/integration/test_gcs_views.py (``tests/`` is on the import path through its conftest).
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from flightdata.recording import SIM_TIMELINE

#: Entity -> a component, of every flight recording (flightdata/recording.py docstring); a
#: headless flight's adds the mission, the wind and the position estimate.
COMMON_ENTITIES = {
    "/world": "ViewCoordinates:xyz",
    "/world/vehicle": "Transform3D:translation",
    "/world/vehicle/arms": "LineStrips3D:strips",
    "/world/vehicle/rotors": "Cylinders3D:colors",
    "/world/reference": "Points3D:positions",
    "/world/reference_path": "LineStrips3D:strips",
    "/world/flown_path": "LineStrips3D:strips",
    "/events": "TextLog:text",
    **{f"/plots/position/{a}/{s}": "Scalars:scalars" for a in "xyz" for s in ("ref", "truth")},
    **{f"/plots/error/{a}": "Scalars:scalars" for a in ("x", "y", "z", "roll", "pitch", "yaw")},
    **{f"/plots/attitude/{a}/{s}": "Scalars:scalars" for a in ("roll", "pitch", "yaw")
       for s in ("ref", "truth")},
    **{f"/plots/pwm/{m}": "Scalars:scalars" for m in (1, 2, 3, 4)},
    **{f"/plots/loe/{m}/{s}": "Scalars:scalars" for m in (1, 2, 3, 4)
       for s in ("true", "estimate")},
}

_DURATION = re.compile(r"^P(?:(\d+)D)?(?:T(?:(\d+)H)?(?:(\d+)M)?(?:([\d.]+)S)?)?$")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*(?:[eE][-+]?\d+)?|NaN|inf)")


def _duration_s(text: str) -> float:
    """ISO 8601 duration as ``rerun rrd print`` shows a duration timeline (P0D, PT12.34S)."""
    m = _DURATION.match(text)
    assert m is not None, text
    days, hours, minutes, seconds = (float(g) if g else 0.0 for g in m.groups())
    return ((days * 24 + hours) * 60 + minutes) * 60 + seconds


def rrd_rows(path: Path, entity: str) -> list[tuple[float, dict[str, str]]]:
    """(sim_time in s, {column: printed cell}) of the temporal rows of ``entity``, by time."""
    out = subprocess.run(
        [sys.executable, "-m", "rerun_cli", "rrd", "print", "-vvv", "--entity", entity,
         str(path)],
        capture_output=True, text=True, check=True,
        env={**os.environ, "CI": "1"},  # rerun's CLI turns its usage analytics off on CI
    ).stdout
    header: list[str] = []
    rows: list[tuple[float, dict[str, str]]] = []
    for line in out.splitlines():
        if "┆" not in line:
            continue
        cells = [c.strip() for c in line.replace("│", "").split("┆")]
        if cells[0] == "RowId":
            header = cells
        elif cells[0].startswith("row_"):
            row = dict(zip(header, cells, strict=True))
            if SIM_TIMELINE in row:  # static rows (styles, geometry) have no time
                rows.append((_duration_s(row[SIM_TIMELINE]), row))
    rows.sort(key=lambda r: r[0])
    return rows


def numbers(cell: str) -> list[float]:
    """Every number in a printed cell, in order (``[[0.1, 2.0]]`` -> [0.1, 2.0])."""
    return [float(x) for x in _NUMBER.findall(cell)]


def scalar_series(path: Path, entity: str) -> tuple[np.ndarray, np.ndarray]:
    rows = rrd_rows(path, entity)
    values = [numbers(r["Scalars:scalars"]) for _, r in rows]
    assert all(len(v) == 1 for v in values)
    return np.array([t for t, _ in rows]), np.array([v[0] for v in values])


def free_port() -> int:
    """A TCP port on loopback that nobody listens on (for a rerun receiver)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@contextmanager
def rerun_receiver(save_to: Path, *, settle_s: float = 0.0) -> Iterator[str]:
    """rerun's own headless gRPC receiver (no viewer), saving what arrives to ``save_to``.

    Yields the URL to stream to once it listens. On exit, after ``settle_s`` (s) for the
    last messages to land, Ctrl-C makes it save and quit (killed if it has not within 30 s).
    """
    port = free_port()
    receiver = subprocess.Popen(
        [sys.executable, "-m", "rerun_cli", "--bind", "127.0.0.1", "--port", str(port),
         "--save", str(save_to)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "CI": "1"},
        start_new_session=True)  # its own process group: the wrapper and the rerun binary
    try:
        assert receiver.stderr is not None
        for line in receiver.stderr:  # wait until it listens
            if "Listening for gRPC connections" in line:
                break
        yield f"rerun+http://127.0.0.1:{port}/proxy"
    finally:
        time.sleep(settle_s)
        os.killpg(receiver.pid, signal.SIGINT)  # the receiver saves and quits on Ctrl-C
        try:
            receiver.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(receiver.pid, signal.SIGKILL)
