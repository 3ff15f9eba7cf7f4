"""The simulated vehicle's own MAVLink surface: injection onto the world's fault engine."""

from __future__ import annotations

import pytest

from fcu.autopilot import AutopilotConfig
from fcu.mavlink.enums import FailureType, FailureUnit
from fcu.mavlink.port import GeoPoint
from sim.vehicle_port import SimVehicle, VehicleSetup
from sim.world import WorldConfig

MOTOR = int(FailureUnit.SYSTEM_MOTOR)
WRONG = int(FailureType.WRONG)


@pytest.fixture
def vehicle() -> SimVehicle:
    v = SimVehicle(VehicleSetup(world=WorldConfig(), autopilot=AutopilotConfig(), seed=3,
                                origin=GeoPoint(-35.0, 149.0, 500.0)))
    v.first_tick()
    return v


def test_a_timed_injection_starts_on_its_tick_and_a_repeat_adds_nothing(
        vehicle: SimVehicle) -> None:
    assert vehicle.inject_failure(MOTOR, WRONG, 3, at_s=0.5).accepted
    assert vehicle.inject_failure(MOTOR, WRONG, 3, at_s=0.5).accepted  # ACK lost, re-sent
    while vehicle.time_s < 0.6:
        vehicle.tick()
    events = [(e.kind, e.time_s) for e in vehicle.world.faults.events]
    assert events == [("injected", 0.0), ("started", pytest.approx(0.5, abs=1e-12))]
    assert vehicle.world.faults.true_loe(0.6)[2] == pytest.approx(0.3)  # SIM_FI_LOE


def test_an_injection_without_a_time_or_in_the_past_acts_now(vehicle: SimVehicle) -> None:
    for _ in range(10):
        vehicle.tick()
    assert vehicle.inject_failure(MOTOR, WRONG, 1, at_s=0.05).accepted  # already past
    assert vehicle.world.faults.true_loe(vehicle.time_s)[0] == pytest.approx(0.3)


def test_sys_failure_en_0_denies_injection_and_1_allows_it(vehicle: SimVehicle) -> None:
    assert vehicle.sim_params.value("SYS_FAILURE_EN") == 1.0  # the default: injection on
    assert vehicle.sim_params.set_param("SYS_FAILURE_EN", 0.0).accepted
    refused = vehicle.inject_failure(MOTOR, WRONG, 1)
    assert not refused.accepted and not refused.unsupported  # DENIED, not UNSUPPORTED
    assert "SYS_FAILURE_EN = 0" in refused.reason
    assert vehicle.world.faults.scheduled() == []
    assert vehicle.sim_params.set_param("SYS_FAILURE_EN", 1.0).accepted
    assert vehicle.inject_failure(MOTOR, WRONG, 1).accepted
    assert vehicle.world.faults.true_loe(vehicle.time_s)[0] == pytest.approx(0.3)
