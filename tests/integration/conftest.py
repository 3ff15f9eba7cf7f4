"""Fixtures of the integration tests: a vehicle subprocess and ground stations, torn down."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence

import pytest
from vehicle_harness import Gcs, VehicleProcess

VehicleFactory = Callable[..., VehicleProcess]


@pytest.fixture
def gcs() -> Iterator[Gcs]:
    """A pymavlink ground station on a free loopback port."""
    station = Gcs()
    yield station
    station.close()


@pytest.fixture
def start_vehicle() -> Iterator[VehicleFactory]:
    """Start ``python -m sim`` with extra options; every vehicle is stopped at teardown.

    Teardown sends SIGTERM and checks the vehicle stopped cleanly (exit status 0).
    """
    started: list[VehicleProcess] = []

    def start(*args: str, outs: Sequence[int] = ()) -> VehicleProcess:
        out_args = [a for port in outs for a in ("--out", f"127.0.0.1:{port}")] or \
            ["--out", "none"]
        vehicle = VehicleProcess([*out_args, *args])
        started.append(vehicle)
        return vehicle

    yield start
    codes = [(v.stop(), v) for v in started]
    for code, vehicle in codes:
        assert code == 0, f"vehicle exit status {code}: {vehicle.stderr_text[-2000:]}"
