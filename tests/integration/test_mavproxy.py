"""MAVProxy (PyPI ``MAVProxy``), run without a terminal, drives the vehicle process: modes,
arming and parameters, then a mission loaded from a waypoint file and flown in AUTO, and a
fence and rally points loaded from QGC WPL files (``fence load``, ``rally load``), and
ALT_HOLD flown with ``rc`` overrides.

MAVProxy connects out to the vehicle (``--master=udpout:``; the vehicle answers whoever
writes to it), with its default modules. Its interactive shell reads commands from a pipe:
the test writes one command at a time and waits (bounded) for MAVProxy to print the answer,
because MAVProxy's ``--cmd`` runs before any HEARTBEAT is heard. Closing the pipe (EOF) ends
MAVProxy.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from vehicle_harness import Gcs

from fcu.mavlink.geo import ned_to_geo
from sim.vehicle import DEFAULT_HOME

STARTUP_S = 90.0  # s wall: MAVProxy imports, then (FTP tried first) the parameter download
ANSWER_S = 20.0  # s wall


class MavProxy:
    """A MAVProxy process whose shell we type into and whose output we read."""

    def __init__(self, master: str, workdir: Path) -> None:
        exe = shutil.which("mavproxy.py", path=str(Path(sys.executable).parent))
        assert exe is not None, "MAVProxy is not installed in this environment"
        self.proc = subprocess.Popen(
            [sys.executable, exe, f"--master={master}", "--no-state", "--source-system=255"],
            cwd=workdir, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True, bufsize=1)
        self.output = ""
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        while True:
            chunk = self.proc.stdout.read(1)
            if not chunk:
                return
            with self._lock:
                self.output += chunk

    def mark(self) -> int:
        with self._lock:
            return len(self.output)

    def expect(self, pattern: str, since: int = 0, timeout_s: float = ANSWER_S) -> re.Match:
        """Wait for ``pattern`` (a regex) in the output after position ``since``."""
        deadline = time.monotonic() + timeout_s
        regex = re.compile(pattern)
        while time.monotonic() < deadline:
            with self._lock:
                match = regex.search(self.output, since)
            if match:
                return match
            if self.proc.poll() is not None:
                break
            time.sleep(0.05)
        raise AssertionError(f"MAVProxy did not print {pattern!r} within {timeout_s} s; "
                             f"output after {since}:\n{self.output[since:][-3000:]}")

    def send(self, line: str) -> int:
        """Type a command; returns the output position before it (for :meth:`expect`)."""
        since = self.mark()
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return since

    def answers(self, line: str, *patterns: str) -> None:
        """Type ``line`` and wait for each of ``patterns`` (regexes) in what follows it."""
        since = self.send(line)
        for pattern in patterns:
            self.expect(pattern, since)

    def close(self) -> bool:
        """EOF on the shell ends MAVProxy (its exit status is always 1); True if it did.

        A MAVProxy that lingers is killed (only this process) and False returned.
        """
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            self.proc.stdin.close()
        try:
            self.proc.wait(30)
            return True
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(30)
            return False


@pytest.mark.slow
def test_mavproxy_shows_modes_arms_and_reads_parameters(start_vehicle, tmp_path: Path) -> None:
    vehicle = start_vehicle("--speedup", "2")
    host, port = vehicle.address
    mp = MavProxy(f"udpout:{host}:{port}", tmp_path)
    try:
        mp.expect(r"Detected vehicle 1:1", timeout_s=STARTUP_S)
        mp.expect(r"STABILIZE>", timeout_s=ANSWER_S)  # our mode, by ArduCopter name
        count = int(mp.expect(r"Received (\d+) parameters", timeout_s=STARTUP_S).group(1))
        assert count > 50
        assert "FTP: request timed out" not in mp.output  # NAKed: parameters came at once

        mp.answers("mode GUIDED", r"DO_SET_MODE: ACCEPTED", r"GUIDED>")
        mp.answers("mode ACRO",  # an ArduCopter mode this vehicle does not fly
                   r"DO_SET_MODE: DENIED", r"AP: Mode ACRO refused")
        mp.answers("arm throttle", r"COMPONENT_ARM_DISARM: ACCEPTED", r"ARMED")

        mp.answers("param show ATT_CTRL", r"ATT_CTRL\s+1(\.0)?\b")
        mp.answers("param show SIM_ENGINE_*",
                   r"SIM_ENGINE_FAIL\s+0(\.0)?\b", r"SIM_ENGINE_MUL\s+1(\.0)?\b")
        mp.answers("param set ATT_CTRL 0",  # armed: refused, value unchanged
                   r"AP: ATT_CTRL: change it disarmed on the ground",
                   # MAVProxy retries a PARAM_SET until the echo matches, three times, then
                   # gives up
                   r"Failed to set ATT_CTRL to 0 \(invalid returned value 1")
        mp.answers("param show ATT_CTRL", r"ATT_CTRL\s+1(\.0)?\b")

        mp.answers("disarm", r"DISARMED")
        mp.answers("mode LOITER", r"LOITER>")
        mp.answers("param set WPNAV_SPEED 75",  # disarmed on the ground: accepted
                   r"AP: WPNAV_SPEED = 75: autopilot rebuilt")
        mp.answers("param show WPNAV_SPEED", r"WPNAV_SPEED\s+75(\.0)?\b")
    finally:
        ended = mp.close()
    assert ended, mp.output[-3000:]


def _square_wpl(path: Path, side_m: float, alt_m: float) -> None:
    """A QGC WPL 110 file (MAVProxy's ``wp load`` format): home, take-off to ``alt_m``, three
    corners of a square of ``side_m`` (north, then east; relative-altitude global frame
    around the vehicle's default home), land."""
    home = DEFAULT_HOME
    rows = ["QGC WPL 110",
            f"0\t1\t0\t16\t0\t0\t0\t0\t{home.lat_deg}\t{home.lon_deg}\t{home.alt_m}\t1",
            f"1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t{alt_m}\t1"]
    for seq, (north, east) in enumerate(((side_m, 0.0), (side_m, side_m), (0.0, side_m)), 2):
        lat, lon, _ = ned_to_geo(np.array([north, east, 0.0]), home)
        rows.append(f"{seq}\t0\t3\t16\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t{alt_m}\t1")
    rows.append("5\t0\t3\t21\t0\t0\t0\t0\t0\t0\t0\t1")
    path.write_text("\n".join(rows) + "\n")


@pytest.mark.slow
def test_mavproxy_flies_a_mission_file_and_the_vehicle_lands(start_vehicle,
                                                             tmp_path: Path) -> None:
    """What a MAVProxy user does: load a waypoint file, take off in GUIDED, fly it in AUTO;
    the vehicle reaches each item in turn, lands and disarms. At 2x, not faster: the test
    reads each item's STATUSTEXT, sent once, and a MAVProxy starved of CPU on a loaded machine
    lets its socket buffer fill (the kernel then drops datagrams) in under a second of
    telemetry at 5x."""
    vehicle = start_vehicle("--speedup", "2")
    host, port = vehicle.address
    _square_wpl(tmp_path / "square.txt", side_m=2.0, alt_m=2.0)
    mp = MavProxy(f"udpout:{host}:{port}", tmp_path)
    try:
        mp.expect(r"Detected vehicle 1:1", timeout_s=STARTUP_S)
        mp.expect(r"Received (\d+) parameters", timeout_s=STARTUP_S)
        mp.answers("wp load square.txt", r"Sent all 6 waypoints",
                   r"MISSION_ACK: TYPE_MISSION: ACCEPTED", r"AP: mission of 5 items loaded")
        mp.answers("mode GUIDED", r"GUIDED>")
        mp.answers("arm throttle", r"COMPONENT_ARM_DISARM: ACCEPTED", r"ARMED")
        mp.answers("takeoff 2", r"NAV_TAKEOFF: ACCEPTED", r"AP: take-off complete at 2.00 m")
        since = mp.send("mode AUTO")
        mp.expect(r"AUTO>", since)
        # each corner in its order, where the file put it (NED metres in the report; MAVProxy
        # sends latitude and longitude in degE7, truncated: 1.1 cm steps), then the landing
        corners = []
        for seq, north, east in ((2, 2.0, 0.0), (3, 2.0, 2.0), (4, 0.0, 2.0)):
            reached = mp.expect(rf"AP: reached item {seq}: NAV_WAYPOINT "
                                r"\((-?[\d.]+), (-?[\d.]+), (-?[\d.]+)\)", since,
                                timeout_s=120.0)
            target = [float(v) for v in reached.groups()]
            assert target == pytest.approx([north, east, -2.0], abs=0.015), reached.group(0)
            corners.append(reached.start())
        assert corners == sorted(corners)
        landed = mp.expect(r"AP: reached item 5: NAV_LAND", since, timeout_s=120.0).start()
        assert landed > corners[-1]
        mp.expect(r"AP: SIM: outcome: landed", since, timeout_s=60.0)
        mp.expect(r"DISARMED", since, timeout_s=60.0)
    finally:
        ended = mp.close()
    assert ended, mp.output[-3000:]


def _plan_wpl(path: Path, command: int, points: list[tuple[float, float]], p1: float) -> Path:
    """A QGC WPL 110 file of ``command`` items (fence vertices, rally points) at ``points``
    (deg), what MAVProxy's ``fence load`` and ``rally load`` read."""
    lines = ["QGC WPL 110"]
    for seq, (lat, lon) in enumerate(points):
        lines.append(f"{seq}\t0\t0\t{command}\t{p1:g}\t0\t0\t0\t{lat:.7f}\t{lon:.7f}\t0\t1")
    path.write_text("\n".join(lines) + "\n")
    return path


def _wpl_items(path: Path, digits: int = 7) -> list[tuple[int, float, float, float]]:
    """(command, param1, latitude, longitude) of each item of a QGC WPL 110 file, the
    position rounded to ``digits`` decimals of a degree."""
    lines = path.read_text().splitlines()
    assert lines[0].startswith("QGC WPL 110"), lines[:1]
    rows = [line.split("\t") for line in lines[1:] if line.strip()]
    return [(int(r[3]), float(r[4]), round(float(r[8]), digits), round(float(r[9]), digits))
            for r in rows]


def _listed_items(mp: MavProxy, command: str, count: int) -> list[tuple[int, float, float, float]]:
    """What ``fence list`` / ``rally list`` downloads and prints (10 decimals of a degree:
    the vehicle's degE7 exactly), as :func:`_wpl_items` reads a file."""
    since = mp.send(command)
    item = r"(\d+) \d+ (-?[\d.]+) (-?[\d.]+) -?[\d.]+ p1=(-?[\d.]+)"
    mp.expect(rf"({item}.*\n){{{count}}}", since)
    found = re.findall(item, mp.output[since:])[:count]
    return [(int(c), float(p1), round(float(lat), 7), round(float(lon), 7))
            for c, lat, lon, p1 in found]


@pytest.mark.slow
def test_mavproxy_loads_a_fence_and_rally_points_and_enables_the_fence(
        start_vehicle, tmp_path: Path) -> None:
    vehicle = start_vehicle("--speedup", "5")
    host, port = vehicle.address
    corners = [ned_to_geo(np.array([n, e, 0.0]), DEFAULT_HOME)[:2]
               for n, e in ((-50.0, -50.0), (50.0, -50.0), (50.0, 50.0), (-50.0, 50.0))]
    _plan_wpl(tmp_path / "fence.txt", 5001, corners, 4)  # inclusion polygon vertices
    _plan_wpl(tmp_path / "rally.txt", 5100, corners[:2], 0)
    mp = MavProxy(f"udpout:{host}:{port}", tmp_path)
    try:
        mp.expect(r"Detected vehicle 1:1", timeout_s=STARTUP_S)
        mp.expect(r"Received (\d+) parameters", timeout_s=STARTUP_S)
        mp.answers("fence load fence.txt", r"Sent all 4 fence items",
                   r"AP: Fence: 4 items stored")
        mp.answers("rally load rally.txt", r"Sent all 2 rally items",
                   r"AP: Rally: 2 items stored")
        mp.answers("fence enable", r"AP: FENCE_ENABLE = 1")  # DO_FENCE_ENABLE
        # downloaded back (MISSION_REQUEST_LIST of each type): the items loaded, to the degE7
        # MAVProxy sent (it truncates: within one step, 1e-7 deg)
        for kind, count in (("fence", 4), ("rally", 2)):
            listed = _listed_items(mp, f"{kind} list", count)
            loaded = _wpl_items(tmp_path / f"{kind}.txt")
            assert [i[:2] for i in listed] == [i[:2] for i in loaded]
            np.testing.assert_allclose([i[2:] for i in listed], [i[2:] for i in loaded],
                                       rtol=0, atol=1.01e-7)
        # and saved to a file again (MAVProxy writes 6 decimals of a degree: 0.11 m)
        mp.answers("fence save fence_back.txt", r"Saved 4 fence items to fence_back.txt")
        mp.answers("rally save rally_back.txt", r"Saved 2 rally items to rally_back.txt")
        for kind in ("fence", "rally"):
            assert _wpl_items(tmp_path / f"{kind}_back.txt", 6) == \
                _wpl_items(tmp_path / f"{kind}.txt", 6)
    finally:
        ended = mp.close()
    assert ended, mp.output[-3000:]


def _altitude_m(gcs: Gcs) -> float:
    """The latest estimated altitude (LOCAL_POSITION_NED), m."""
    return -float(gcs.messages("LOCAL_POSITION_NED")[-1].z)


def _after_simulated(gcs: Gcs, seconds: float) -> float:
    """Wait (bounded) for ``seconds`` of simulated time (LOCAL_POSITION_NED's clock); the
    altitude then, m."""
    start_ms = gcs.messages("LOCAL_POSITION_NED")[-1].time_boot_ms
    msg = gcs.wait("LOCAL_POSITION_NED",
                   lambda m: m.time_boot_ms >= start_ms + 1000.0 * seconds, timeout_s=120.0)
    return -float(msg.z)


@pytest.mark.slow
def test_mavproxy_rc_overrides_fly_alt_hold_and_their_loss_lands(start_vehicle, gcs: Gcs,
                                                                tmp_path: Path) -> None:
    """MAVProxy's joystick-free ``rc`` command (RC_CHANNELS_OVERRIDE at 10 Hz): throttle
    (channel 3) above the dead zone climbs in ALT_HOLD, mid-stick holds the altitude; when
    MAVProxy goes away with the override in force, the RC failsafe lands the vehicle."""
    vehicle = start_vehicle("--speedup", "5", outs=[gcs.port])
    gcs.start_reader()
    host, port = vehicle.address
    mp = MavProxy(f"udpout:{host}:{port}", tmp_path)
    try:
        mp.expect(r"Detected vehicle 1:1", timeout_s=STARTUP_S)
        mp.expect(r"Received (\d+) parameters", timeout_s=STARTUP_S)
        mp.answers("mode GUIDED", r"GUIDED>")
        mp.answers("arm throttle", r"COMPONENT_ARM_DISARM: ACCEPTED", r"ARMED")
        mp.answers("takeoff 2", r"NAV_TAKEOFF: ACCEPTED", r"AP: take-off complete at 2.00 m")
        mp.answers("mode ALT_HOLD", r"ALT_HOLD>")
        mp.answers("rc 3 1500", r"AP: ALT_HOLD: flown by the sticks")
        start = _after_simulated(gcs, 2.0)  # settled at mid-stick
        # mid-stick: held (0.1 m: the altitude loop's error in the light indoor draught)
        assert _after_simulated(gcs, 10.0) == pytest.approx(start, abs=0.1)
        since = gcs.mark()
        mp.send("rc 3 1700")  # 0.7: (0.7 - 0.6) / 0.4 of PILOT_SPEED_UP, 0.125 m/s
        # from when the override arrives (MAVProxy's shell and 10 Hz loop take wall time,
        # several simulated seconds on a loaded machine): 1.0 m in 8 s
        gcs.wait("LOCAL_POSITION_NED", lambda m: m.vz < -0.1, since=since, timeout_s=120.0)
        climbing = _after_simulated(gcs, 0.0)
        climbed = _after_simulated(gcs, 8.0) - climbing
        assert 0.85 < climbed < 1.15, f"climbed {climbed:.2f} m"  # the velocity loop's error
        since = gcs.mark()
        mp.send("rc 3 1500")  # the climb rate back to 0 at PILOT_ACCEL_Z once it arrives
        gcs.wait("LOCAL_POSITION_NED", lambda m: abs(m.vz) < 0.02, since=since,
                 timeout_s=120.0)
        held = _after_simulated(gcs, 1.0)
        assert _after_simulated(gcs, 10.0) == pytest.approx(held, abs=0.1)
        assert not [t for t in gcs.texts() if "Radio failsafe" in t]
        since = gcs.mark()
    finally:
        ended = mp.close()
    assert ended, mp.output[-3000:]
    # MAVProxy gone with the override in force: no input for RC_FS_TIMEOUT (1 s wall)
    assert "LAND" in gcs.wait_text("Radio failsafe: no sticks", since)
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == 9, since=since)  # LAND
