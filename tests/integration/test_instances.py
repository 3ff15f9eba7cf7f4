"""Several vehicles at once: ``ftc-vehicle --instance 0`` and ``--instance 1`` on their
ArduPilot-SITL-style ports, flown at the same time by two ``ftc-gcs fly``; and the
``vehicle_link`` fixture under pytest-xdist (``pytest -n 2``), one vehicle per worker.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from vehicle_harness import VehicleProcess, write_hover_mission

from gcs.mavlink import read_tlog

ROOT = Path(__file__).resolve().parents[2]
WALL_S = 600.0  # s: two short flights side by side on a loaded two-core machine
ALT_M = (0.6, 1.0)  # m: instance 0 and instance 1 hover at different heights

pytestmark = pytest.mark.slow


def port_taken(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return True
    return False


def test_two_instances_flown_at_once(tmp_path: Path) -> None:
    ports = (14550, 14555, 14560, 14565)  # ground station and vehicle of instances 0 and 1
    taken = [p for p in ports if port_taken(p)]
    if taken:
        pytest.skip(f"UDP port(s) {taken} on 127.0.0.1 in use by another program")
    vehicles = [VehicleProcess(["--instance", str(n), "--speedup", "10", "--seed", "3",
                                "--start-paused"], any_port=False) for n in (0, 1)]
    try:
        assert [v.address for v in vehicles] == [("127.0.0.1", 14555), ("127.0.0.1", 14565)]
        lines = [next(ln for ln in v.lines if "listening on udp" in ln) for v in vehicles]
        assert "telemetry to 127.0.0.1:14550, 127.0.0.1:14540" in lines[0]
        assert "telemetry to 127.0.0.1:14560, 127.0.0.1:14541;" in lines[1]
        assert "instance 1" in lines[1]
        flights = []
        for n, alt_m in enumerate(ALT_M):
            mission = write_hover_mission(tmp_path / f"hover{n}.toml", alt_m)
            flights.append(subprocess.Popen(
                [sys.executable, "-m", "gcs", "fly", "--connect",
                 f"udpin:127.0.0.1:{14550 + 10 * n}", "--mission", str(mission),
                 "--max-flight-s", "60", "--connect-timeout", "120", "--quiet",
                 "--tlog", str(tmp_path / f"f{n}.tlog"), "--json", str(tmp_path / f"f{n}.json")],
                cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                stdin=subprocess.DEVNULL))
        outputs = [proc.communicate(timeout=WALL_S) for proc in flights]
    finally:
        codes = [v.stop() for v in vehicles]
    for proc, (out, err) in zip(flights, outputs, strict=True):
        assert proc.returncode == 0, out + err
    assert codes == [0, 0]
    for n, alt_m in enumerate(ALT_M):
        data = json.loads((tmp_path / f"f{n}.json").read_text())
        assert data["result"] == "ok" and not data["crashed"]  # flown, landed, disarmed
        # each ground station heard its own vehicle only: the heights never mix
        heights = [r.message.relative_alt / 1000.0 for r in read_tlog(tmp_path / f"f{n}.tlog")
                   if r.message.get_type() == "GLOBAL_POSITION_INT"]
        assert max(heights) == pytest.approx(alt_m, abs=0.15)  # m: 0.4 m apart


EXAMPLE = '''
import json
import os

import pytest


def record(link, name):
    out = os.path.join(os.environ["EXAMPLE_RESULTS"], name + ".json")
    with open(out, "w") as f:
        json.dump({"worker": os.environ.get("PYTEST_XDIST_WORKER"),
                   "pid": link.vehicle.pid,
                   "port": link.conn.port.getsockname()[1]}, f)


@pytest.mark.vehicle(speedup=10, seed=1)
def test_one(vehicle_link):
    vehicle_link.wait_clock()
    assert vehicle_link.fetch_params()["SYSID_THISMAV"] == 1
    record(vehicle_link, "one")


@pytest.mark.vehicle(speedup=10, seed=2, signing_key="xdist-example")
def test_two(vehicle_link):
    vehicle_link.wait_clock()
    assert vehicle_link.set_param("FS_GCS_TIMEOUT", 9.0) == 9.0
    record(vehicle_link, "two")
'''


def test_the_fixture_runs_under_xdist_with_a_vehicle_per_worker(tmp_path: Path) -> None:
    # (no conftest line: the installed package's pytest11 entry point loads the plugin)
    (tmp_path / "test_example.py").write_text(textwrap.dedent(EXAMPLE))
    results = tmp_path / "results"
    results.mkdir()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-n", "2", "-p", "no:cacheprovider", "-q",
         "--rootdir", str(tmp_path), "test_example.py"],
        cwd=tmp_path, capture_output=True, text=True, timeout=WALL_S,
        stdin=subprocess.DEVNULL, env={**os.environ, "EXAMPLE_RESULTS": str(results)})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "2 passed" in proc.stdout
    runs = [json.loads((results / f"{name}.json").read_text()) for name in ("one", "two")]
    # fewer tests than twice the workers: xdist hands them out one per worker
    assert {r["worker"] for r in runs} == {"gw0", "gw1"}
    assert runs[0]["pid"] != runs[1]["pid"] and runs[0]["port"] != runs[1]["port"]
