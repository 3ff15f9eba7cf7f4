"""``ftc-gcs fly --signing-key`` against ``ftc-vehicle --signing-key``: a short mission flown
signed end to end; a mismatched key (another key, none on either side) ends in one line
``ftc-gcs: signing: ...`` with exit status 3, without a traceback and without waiting for the
connection time-out. The ``vehicle`` marker's ``signing_key`` signs the fixture's link.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from vehicle_harness import free_port, write_hover_mission

from flightdata.signing import key_from_text
from gcs.mavlink import is_signed, read_tlog
from gcs.spawn import SpawnedVehicle, VehicleSpec

ROOT = Path(__file__).resolve().parents[2]
WALL_S = 300.0  # s: one short flight on a loaded two-core machine
PASSPHRASE = "quadftc-gcs-signing"
KEY = key_from_text(PASSPHRASE)

pytestmark = pytest.mark.slow


def gcs_fly(port: int, tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    mission = write_hover_mission(tmp_path / "hover.toml")  # about 15 s simulated
    return subprocess.run(
        [sys.executable, "-m", "gcs", "fly", "--connect", f"udpin:127.0.0.1:{port}",
         "--mission", str(mission), "--max-flight-s", "60", "--connect-timeout", "120",
         "--quiet", "--tlog", str(tmp_path / "f.tlog"), *args],
        cwd=ROOT, capture_output=True, text=True, timeout=WALL_S, stdin=subprocess.DEVNULL)


def last_line(text: str) -> str:
    return text.strip().splitlines()[-1]


def test_a_short_mission_flown_signed_end_to_end(tmp_path: Path) -> None:
    port = free_port()
    vehicle = SpawnedVehicle(VehicleSpec(speedup=10, seed=3, signing_key=KEY), port,
                             log_path=tmp_path / "vehicle.log").start()
    try:
        proc = gcs_fly(port, tmp_path, "--signing-key", PASSPHRASE)
    finally:
        vehicle.stop()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    events = (tmp_path / "f.events.log").read_text()
    assert "(signing)" in events and "mission flown, vehicle landed and disarmed" in events
    records = list(read_tlog(tmp_path / "f.tlog"))
    ours = [r.message for r in records if r.message.get_srcSystem() == 255]
    theirs = [r.message for r in records if r.message.get_srcSystem() == 1]
    assert len(ours) > 20 and len(theirs) > 1000
    assert all(is_signed(m.get_msgbuf()) for m in ours + theirs)  # both ways, every packet
    assert vehicle.output().strip().splitlines()[-1].endswith(
        ", 0 packets failing the signing check")


def test_mismatched_keys_end_in_one_line(tmp_path: Path) -> None:
    port = free_port()
    with SpawnedVehicle(VehicleSpec(speedup=10, seed=3, signing_key=KEY), port,
                        log_path=tmp_path / "vehicle.log"):
        wrong = gcs_fly(port, tmp_path, "--signing-key", "not-the-passphrase")
        missing = gcs_fly(port, tmp_path)
    for proc in (wrong, missing):
        assert proc.returncode == 3, proc.stdout + proc.stderr
        assert "Traceback" not in proc.stderr
    assert last_line(wrong.stderr).startswith(
        f"ftc-gcs: signing: the autopilot on udpin:127.0.0.1:{port} signs with another key "
        "than --signing-key (")
    assert last_line(missing.stderr) == (
        f"ftc-gcs: signing: the autopilot on udpin:127.0.0.1:{port} signs its packets "
        "(MAVLink 2 signing) and drops unsigned ones: give its key with --signing-key")


def test_a_key_against_a_vehicle_without_one(tmp_path: Path) -> None:
    port = free_port()
    with SpawnedVehicle(VehicleSpec(speedup=10, seed=3), port,
                        log_path=tmp_path / "vehicle.log"):
        proc = gcs_fly(port, tmp_path, "--signing-key", PASSPHRASE)
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    assert last_line(proc.stderr) == (
        f"ftc-gcs: signing: the autopilot on udpin:127.0.0.1:{port} does not sign its packets "
        "(no signing key on the vehicle?), so none verifies with --signing-key")


def test_a_bad_key_is_a_usage_error(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "gcs", "fly", "--signing-key", "hex:00"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "argument --signing-key: signing key: after 'hex:' give exactly 64" in proc.stderr


@pytest.mark.vehicle(speedup=10, seed=3, signing_key=PASSPHRASE)
def test_the_fixture_signs_its_link(vehicle_link) -> None:  # type: ignore[no-untyped-def]
    assert vehicle_link.signing
    assert vehicle_link.conn.mav.signing.secret_key == KEY
    vehicle_link.wait_clock()
    assert vehicle_link.fetch_params()["FS_GCS_TIMEOUT"] == 5.0  # a signed request, answered
    assert vehicle_link.set_param("FS_GCS_TIMEOUT", 7.0) == 7.0  # obeyed and echoed
    assert "MAVLink 2 signing on" in vehicle_link.vehicle.output()
