"""Fuzzing the vehicle's MAVLink endpoint: 50,000 seeded datagrams of random bytes, cut and
corrupted frames, and valid frames with every field at an extreme (:mod:`mavlink_fuzz`).

In memory against the real simulated vehicle (deterministic): nothing raises inside the
endpoint (no handler or build error, nothing logged). Over UDP against ``ftc-vehicle``: the
telemetry keeps coming during and after the burst, the vehicle still answers, and its stderr
holds no traceback.
"""

from __future__ import annotations

import itertools
import logging
import socket
import time

import pytest
from conftest import VehicleFactory
from mavlink_fuzz import fuzz_datagrams
from vehicle_harness import ANSWER_S, Gcs, M

from fcu.autopilot import AutopilotConfig
from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.port_records import GeoPoint
from sim.vehicle_port import SimVehicle, VehicleSetup
from sim.world import WorldConfig

DATAGRAMS = 50_000
SEGMENTS = 5  # the burst is watched in five parts: telemetry must come in each
BATCH = 50  # datagrams sent back to back, then the ground station reads
RATE_PER_S = 2500.0  # datagrams per wall second: what the vehicle handles at speed-up 1
# (3 ms of each 10 ms tick); faster, the excess is dropped by the operating system, as a
# saturated radio drops it (the endpoint's receive budget keeps the simulation's pace)


class MemoryLink:
    """A Link that delivers nothing and forgets what is sent."""

    def __init__(self) -> None:
        self.sent = 0

    def send(self, data: bytes, to: tuple[str, int] | None = None) -> None:
        self.sent += 1

    def receive(self) -> list[tuple[bytes, tuple[str, int]]]:
        return []

    def add_peer(self, peer: tuple[str, int]) -> None:
        pass


def test_fuzz_in_memory_against_the_simulated_vehicle_never_raises(
        caplog: pytest.LogCaptureFixture) -> None:
    datagrams, counts = fuzz_datagrams(DATAGRAMS, seed=20240615)
    assert len(counts.by_message) == 25  # every message kind of the list was made
    vehicle = SimVehicle(VehicleSetup(world=WorldConfig(), autopilot=AutopilotConfig(), seed=5,
                                      origin=GeoPoint(-35.363261, 149.165230, 584.0)))
    vehicle.first_tick()
    endpoint = MavlinkEndpoint(vehicle.port, MemoryLink(), injector=vehicle,
                               extra_params=[vehicle.sim_params])
    with caplog.at_level(logging.WARNING):
        for k, data in enumerate(datagrams):
            endpoint.handle_bytes(data, ("127.0.0.1", 40000 + k % 40), k * 1e-3)
            if k % 100 == 0:  # the vehicle flies on between datagrams, as it does over UDP
                vehicle.tick()
                endpoint.tick(vehicle.time_s, k * 1e-3)
    stats = endpoint.stats
    assert stats.datagrams == DATAGRAMS
    assert stats.handler_errors == 0 and stats.build_errors == 0
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR] == []
    # every valid frame was parsed, every broken datagram counted
    assert stats.messages >= counts.extreme + 2 * counts.several
    assert stats.malformed >= counts.truncated + counts.bad_crc
    assert stats.commands > 1000


def test_fuzz_burst_over_udp_keeps_the_telemetry_and_the_answers(
        start_vehicle: VehicleFactory, gcs: Gcs) -> None:
    datagrams, counts = fuzz_datagrams(DATAGRAMS, seed=7)
    vehicle = start_vehicle("--speedup", "1", outs=[gcs.port])
    gcs.wait_heartbeat()
    marks = [gcs.mark()]
    fuzzer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        per_segment = DATAGRAMS // SEGMENTS
        start = time.monotonic()
        for k in range(0, DATAGRAMS, BATCH):
            for data in datagrams[k:k + BATCH]:
                fuzzer.sendto(data, vehicle.address)
            while time.monotonic() < start + (k + BATCH) / RATE_PER_S:  # pacing only
                gcs.pump(0.005)
            if (k + BATCH) % per_segment == 0:
                marks.append(gcs.mark())
    finally:
        fuzzer.close()
    during = [gcs.messages(since=a)[:b - a] for a, b in itertools.pairwise(marks)]
    gcs.collect(1.0)
    after = gcs.collect(2.0)
    answer = gcs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    status = gcs.wait("SYS_STATUS", timeout_s=ANSWER_S)
    assert vehicle.proc.poll() is None, "the vehicle died"
    code = vehicle.stop()
    # telemetry during each fifth of the burst, and after it
    assert len(during) == SEGMENTS
    for part, msgs in enumerate(during):
        assert any(m.get_type() == "ATTITUDE" for m in msgs), f"no ATTITUDE in part {part}"
    assert sum(m.get_type() == "HEARTBEAT" for part in during for m in part) >= 2
    assert sum(m.get_type() == "HEARTBEAT" for m in after) >= 1
    assert sum(m.get_type() == "ATTITUDE" for m in after) >= 10  # 20 Hz for 2 s
    assert answer.result == M.MAV_RESULT_ACCEPTED
    # the broken datagrams reached the vehicle and were counted, not obeyed
    assert status.errors_comm >= 0.5 * counts.malformed
    assert code == 0
    assert "Traceback" not in vehicle.stderr_text, vehicle.stderr_text[-3000:]
