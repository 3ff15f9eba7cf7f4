"""pytest plugin: a simulated vehicle and a connected ground-station link, for your own tests.

Installing quadftc enables it: its ``pytest11`` entry point (``quadftc =
"gcs.pytest_plugin"``) makes pytest load it in any project, with no ``conftest.py`` line. (An
install older than the entry point needs ``pytest_plugins = ["gcs.pytest_plugin"]`` in a
``conftest.py``; this repository's ``tests/conftest.py`` adds it only then.) Then write
telemetry-based integration tests in a few lines::

    import pytest
    from gcs.faults import FaultSpec

    @pytest.mark.vehicle(speedup=10, seed=1, scenario="lqg_loe")
    def test_motor_3_fault_is_detected(vehicle_link):
        outcome = vehicle_link.fly(faults=[FaultSpec(motor=3, loe=0.2, at_s=22.0)])
        assert outcome.error is None
        assert outcome.report.rms["z"] < 0.05                     # m
        assert [d.motor for d in outcome.report.detections] == [3]

Fixture ``vehicle_link``: starts ``python -m sim`` (``ftc-vehicle``) on loopback at the
marker's speed-up, with simulated time held at 0 until the flight starts (so a flight is the
headless runner's timeline, reproducible for a seed), opens a :class:`VehicleLink` (a
:class:`gcs.station.GroundStation` recording to ``tmp_path/flight.tlog``), waits for the
vehicle's HEARTBEAT, and yields the link. At the end the link is closed and the vehicle
stopped. Use its ground-station methods directly (``set_param``, ``upload_mission``,
``arm``, ``set_mode``, ``start_mission``, ``pump``, ``report``...) or fly a whole mission
with :meth:`VehicleLink.fly`.

Marker ``@pytest.mark.vehicle(...)``: ``speedup`` (default 10), ``seed`` (default: the
scenario's), ``scenario`` (world and autopilot configuration; default the vehicle's
``baseline``), ``start_paused`` (default True), ``extra_args`` (more ``ftc-vehicle``
options), ``connect_timeout_s`` (wall, default 60, for a vehicle that reports no boot
progress; one that compiles its kernels, reporting progress, is waited for as long as it
reports: ``gcs.link.Link.wait_vehicle``),
``signing_key`` (MAVLink 2 signing: a KEY as ``ftc-vehicle --signing-key`` takes it, a
passphrase or ``hex:`` and 64 hex digits, or the 32 bytes; the vehicle starts with it and the
link signs with it; default None, unsigned).

Everything runs on 127.0.0.1 with ports the operating system picks (both the vehicle and the
link bind port 0), so tests run in parallel under pytest-xdist (``pytest -n 2``): each
worker starts its own vehicle for each test that asks for one, and no two share a port. The
ground station never imports the simulator.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from flightdata.signing import KEY_BYTES, key_from_text
from gcs.faults import FaultSpec
from gcs.flight import FlightOutcome, FlightPlan, fly
from gcs.mavlink import open_link
from gcs.mission import WireItem, thesis_mission
from gcs.records import EventLog, TlogWriter
from gcs.spawn import SpawnedVehicle, VehicleSpec
from gcs.station import GroundStation

__all__ = ["VehicleLink", "vehicle_link"]


class VehicleLink(GroundStation):
    """A :class:`GroundStation` connected to a vehicle the fixture started.

    Attributes
    ----------
    vehicle : SpawnedVehicle
        The vehicle process (``kill()`` loses it mid-flight, ``output()`` shows its log).
    """

    vehicle: SpawnedVehicle

    def fly(self, *, faults: Sequence[FaultSpec] = (), mission: Sequence[WireItem] | None = None,
            params: dict[str, float] | None = None, **plan: Any) -> FlightOutcome:
        """Fly a whole mission (default: the thesis mission) as ``ftc-gcs fly`` does.

        Parameters
        ----------
        faults : sequence of FaultSpec
            Injections, simulated seconds after the mission start.
        mission : sequence of WireItem or None
            Items seq 1..n (None: :func:`gcs.mission.thesis_mission`).
        params : dict or None
            Parameters to set before arming (e.g. ``{"ATT_CTRL": 0}``).
        **plan
            Other :class:`gcs.flight.FlightPlan` fields (``max_flight_s``...).

        Returns
        -------
        FlightOutcome
            Report (from the .tlog), injection timing, error. The link is closed afterwards.
        """
        flight_plan = FlightPlan(mission=list(thesis_mission() if mission is None else mission),
                                 faults=list(faults), params=dict(params or {}), **plan)
        return fly(self, flight_plan)


def pytest_configure(config: pytest.Config) -> None:
    """Register the ``vehicle`` marker."""
    config.addinivalue_line(
        "markers", "vehicle(speedup=10, seed=None, scenario=None, start_paused=True, "
        "extra_args=(), connect_timeout_s=60, signing_key=None): options of the vehicle_link "
        "fixture")


def _signing_key(value: object) -> bytes | None:
    """The marker's ``signing_key`` as 32 bytes (pytest.UsageError when it is not a key)."""
    if value is None:
        return None
    if isinstance(value, bytes) and len(value) == KEY_BYTES and any(value):
        return value
    if isinstance(value, str):
        try:
            return key_from_text(value)
        except ValueError as err:
            raise pytest.UsageError(f"vehicle marker: {err}") from None
    raise pytest.UsageError(f"vehicle marker: signing_key must be a KEY string or "
                            f"{KEY_BYTES} bytes, not all zero")


@pytest.fixture
def vehicle_link(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[VehicleLink]:
    """A started vehicle and a ground-station link to it (see the module docstring)."""
    marker = request.node.get_closest_marker("vehicle")
    options: dict[str, Any] = dict(marker.kwargs) if marker is not None else {}
    connect_timeout_s = float(options.pop("connect_timeout_s", 60.0))
    extra = tuple(options.pop("extra_args", ()))
    signing_key = _signing_key(options.pop("signing_key", None))
    spec = VehicleSpec(speedup=float(options.pop("speedup", 10.0)),
                       seed=options.pop("seed", None), scenario=options.pop("scenario", None),
                       start_paused=bool(options.pop("start_paused", True)), extra_args=extra,
                       signing_key=signing_key)
    if options:
        raise pytest.UsageError(f"vehicle marker: unknown option(s) {sorted(options)}")
    url = "udpin:127.0.0.1:0"
    conn = open_link(url)
    link = VehicleLink(conn, url, tlog=TlogWriter(tmp_path / "flight.tlog"),
                       events=EventLog(tmp_path / "flight.events.log"), signing_key=signing_key)
    port = int(conn.port.getsockname()[1])
    vehicle = SpawnedVehicle(spec, port, log_path=tmp_path / "vehicle.log")
    link.vehicle = vehicle
    vehicle.start()
    try:
        try:
            link.wait_vehicle(connect_timeout_s, vehicle.why_gone)
        except Exception as err:  # (a boot that stopped reporting names its last progress)
            raise RuntimeError(f"vehicle did not come up: {err}; its output: "
                               f"{vehicle.output()[-2000:]}") from None
        yield link
    finally:
        link.close()
        vehicle.stop()
