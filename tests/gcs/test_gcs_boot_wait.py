"""``wait_vehicle`` waits for a booting vehicle as long as it reports progress, and says what
the last report was when the reports stop."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Iterator

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from gcs.errors import VehicleNotFound
from gcs.station import GroundStation

LOOPBACK = "127.0.0.1"
PERIOD_S = 0.1  # s wall between the fake vehicle's packets


class FakeBootingVehicle:
    """Sends boot HEARTBEATs and, while ``reporting()``, progress lines to a ground station;
    a STANDBY HEARTBEAT once ``ready()``."""

    def __init__(self, port: int, reporting: Callable[[float], bool],
                 ready: Callable[[float], bool]) -> None:
        self.address = (LOOPBACK, port)
        self.reporting, self.ready = reporting, ready
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.mav = mav.MAVLink(None, srcSystem=1, srcComponent=1)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.lines = 0

    def _send(self, msg: mav.MAVLink_message) -> None:
        self.sock.sendto(msg.pack(self.mav), self.address)

    def _run(self) -> None:
        start_s = time.monotonic()
        while not self.stop.wait(PERIOD_S):
            elapsed_s = time.monotonic() - start_s
            state = mav.MAV_STATE_STANDBY if self.ready(elapsed_s) else mav.MAV_STATE_BOOT
            self._send(mav.MAVLink_heartbeat_message(
                mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0, state, 3))
            if state == mav.MAV_STATE_BOOT and self.reporting(elapsed_s):
                self.lines += 1
                text = f"preparing: {self.lines} of 130 kernels compiled, {elapsed_s:.0f} s"
                self._send(mav.MAVLink_statustext_message(mav.MAV_SEVERITY_INFO,
                                                          text.encode(), 0, 0))

    def __enter__(self) -> FakeBootingVehicle:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop.set()
        self.thread.join()
        self.sock.close()


@pytest.fixture
def station() -> Iterator[GroundStation]:
    gs = GroundStation.open(f"udpin:{LOOPBACK}:0")
    yield gs
    gs.close()


def _port(gs: GroundStation) -> int:
    return int(gs.conn.port.getsockname()[1])


def test_a_vehicle_reporting_progress_is_waited_for_past_the_timeout(station):
    # boots for 4 s, reporting all along; the ground station's own timeout is 1 s
    with FakeBootingVehicle(_port(station), reporting=lambda t: True,
                            ready=lambda t: t > 4.0) as vehicle:
        start_s = time.monotonic()
        assert station.wait_vehicle(timeout_s=1.0, progress_gap_s=30.0) == (1, 1)
        waited_s = time.monotonic() - start_s
    assert waited_s > 4.0 - PERIOD_S
    assert station.vehicle_ready
    shown = [line for line in station.events.lines if "vehicle preparing:" in line]
    assert len(shown) >= 2 and vehicle.lines >= len(shown)


def test_a_vehicle_that_stops_reporting_is_a_failure_naming_the_last_report(station):
    # reports for 1 s, then only boot HEARTBEATs: given up progress_gap_s after the last line
    with FakeBootingVehicle(_port(station), reporting=lambda t: t < 1.0,
                            ready=lambda t: False) as vehicle:
        with pytest.raises(VehicleNotFound) as err:
            station.wait_vehicle(timeout_s=0.5, progress_gap_s=2.0)
    last = f"preparing: {vehicle.lines} of 130 kernels compiled"
    assert "stopped reporting its boot progress" in str(err.value)
    assert last in str(err.value)
    assert not station.vehicle_ready


def test_a_booting_vehicle_that_reports_nothing_gets_the_timeout(station):
    with FakeBootingVehicle(_port(station), reporting=lambda t: False,
                            ready=lambda t: False):
        with pytest.raises(VehicleNotFound, match="still booting after 1 s"):
            station.wait_vehicle(timeout_s=1.0)


def test_fly_against_a_vehicle_that_never_finishes_booting_leaves_no_records(
        tmp_path, capsys):
    from gcs.cli import main

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:  # a port free right now
        probe.bind((LOOPBACK, 0))
        port = int(probe.getsockname()[1])
    tlog = tmp_path / "out" / "f.tlog"
    with FakeBootingVehicle(port, reporting=lambda t: False, ready=lambda t: False):
        status = main(["fly", "--connect", f"udpin:{LOOPBACK}:{port}", "--connect-timeout",
                       "1", "--quiet", "--tlog", str(tlog)])
    assert status != 0
    assert "still booting after 1 s" in capsys.readouterr().err
    assert not tlog.exists() and not tlog.with_suffix(".events.log").exists()
    assert not tlog.parent.exists()  # the folder made for them went too
