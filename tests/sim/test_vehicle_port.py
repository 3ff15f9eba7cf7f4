"""The simulated vehicle's own MAVLink surface: injection onto the world's fault engine."""

from __future__ import annotations

import pytest

from fcu.autopilot import AutopilotConfig
from fcu.mavlink.enums import FailureType, FailureUnit
from fcu.mavlink.port_records import GeoPoint, StatusText
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


def texts_after(vehicle: SimVehicle, *changes: tuple[str, float]) -> list[str]:
    """The STATUSTEXTs the vehicle says for these SIM_* changes (a few ticks later)."""
    vehicle.port.drain_events()
    for name, value in changes:
        assert vehicle.sim_params.set_param(name, value).accepted
    for _ in range(3):
        vehicle.tick()
    return [e.text for e in vehicle.port.drain_events() if isinstance(e, StatusText)]


def test_each_sim_motor_change_is_said_once_as_it_happened(vehicle: SimVehicle) -> None:
    assert texts_after(vehicle, ("SIM_MOT3_LOE", 0.2)) == ["SIM: set motor 3: loe 20 % (step)"]
    # a second motor: nothing is said (or done) about the first
    assert texts_after(vehicle, ("SIM_MOT1_LOE", 0.3)) == ["SIM: set motor 1: loe 30 % (step)"]
    assert texts_after(vehicle, ("SIM_MOT1_LOE", 0.3)) == []  # the same value again
    assert texts_after(vehicle, ("SIM_ENGINE_FAIL", 5)) == []  # SIM_ENGINE_MUL is still 1
    assert texts_after(vehicle, ("SIM_ENGINE_MUL", 0.5)) == [
        "SIM: changed motor 1: loe 30 % (step) -> loe 65 % (step)",
        "SIM: changed motor 3: loe 20 % (step) -> loe 60 % (step)"]
    assert texts_after(vehicle, ("SIM_ENGINE_FAIL", 0), ("SIM_MOT3_LOE", 0.0)) == [
        "SIM: changed motor 1: loe 65 % (step) -> loe 30 % (step)",
        "SIM: changed motor 3: loe 60 % (step) -> loe 20 % (step)",
        "SIM: cleared motor 3: loe 20 % (step)"]
    assert vehicle.world.faults.true_loe(vehicle.time_s) == pytest.approx([0.3, 0, 0, 0])


def test_sensor_and_mass_parameters_say_what_they_did(vehicle: SimVehicle) -> None:
    assert texts_after(vehicle, ("SIM_BARO_GLITCH", 0.1)) == ["SIM: set baro: bias 0.1"]
    assert texts_after(vehicle, ("SIM_BARO_GLITCH", 0.2)) == [
        "SIM: changed baro: bias 0.1 -> bias 0.2"]
    assert texts_after(vehicle, ("SIM_BARO_GLITCH", 0.0)) == ["SIM: cleared baro: bias 0.2"]
    assert texts_after(vehicle, ("SIM_MASS_DROP", 0.3)) == ["SIM: set airframe: loses 0.3 kg"]


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
