"""The simulated 3S LiPo: open-circuit curve, sag under the motors' power, discharge."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flightdata.config import ConfigError
from sim.world import World, WorldConfig
from sim.world.battery import (
    AIR_DENSITY_KG_M3,
    BATTERY_INDEX,
    Battery,
    BatteryConfig,
    open_circuit_voltage,
    terminal_voltage,
)

HOVER_THRUST_N = 1.42 * 9.81 / 4.0  # N per motor, the nominal airframe in hover


def battery(seed: int = 1, **changes: float) -> Battery:
    return Battery(BatteryConfig(**changes), np.random.default_rng(seed))  # type: ignore[arg-type]


def test_open_circuit_voltage_spans_a_lipo_from_full_to_empty() -> None:
    assert open_circuit_voltage(1.0, 3) == pytest.approx(12.6)  # 4.20 V per cell
    assert open_circuit_voltage(0.0, 3) == pytest.approx(9.81)  # 3.27 V per cell
    socs = np.linspace(0.0, 1.0, 101)
    volts = [open_circuit_voltage(s, 3) for s in socs]
    assert np.all(np.diff(volts) > 0.0)  # the more charge, the higher


def test_terminal_voltage_solves_the_constant_power_load() -> None:
    v_oc, power_w, r_ohm = 12.0, 150.0, 0.025
    v = terminal_voltage(v_oc, power_w, r_ohm)
    current = power_w / v
    assert v == pytest.approx(v_oc - current * r_ohm, abs=1e-12)  # V = Voc - I R
    assert terminal_voltage(v_oc, 0.0, r_ohm) == v_oc
    # beyond the largest power (Voc^2 / 4R) the source collapses to half its voltage
    assert terminal_voltage(v_oc, v_oc ** 2 / (4 * r_ohm) * 2, r_ohm) == v_oc / 2


def test_hover_power_is_momentum_theory_over_the_efficiency() -> None:
    pack = battery()
    cfg = pack.config
    thrust = np.full(4, HOVER_THRUST_N)
    induced = 4 * HOVER_THRUST_N ** 1.5 / math.sqrt(2 * AIR_DENSITY_KG_M3 * cfg.rotor_area_m2)
    idle = cfg.idle_current_a * open_circuit_voltage(1.0, 3)
    assert pack.power_w(thrust) == pytest.approx(induced / cfg.efficiency + idle)
    assert 120.0 < pack.power_w(thrust) < 180.0  # W: 10-15 A from a 3S pack in hover


def test_voltage_sags_under_load_and_falls_as_the_pack_discharges() -> None:
    pack = battery()
    pack.step(0.01, 0.01, np.zeros(4))
    idle = pack.state
    pack.step(0.02, 0.01, np.full(4, HOVER_THRUST_N))
    loaded = pack.state
    assert 10.0 < loaded.current_a < 15.0
    assert loaded.voltage_v == pytest.approx(loaded.open_circuit_v
                                             - loaded.current_a * 0.025, abs=1e-9)
    assert idle.voltage_v - loaded.voltage_v > 0.2  # V, the sag of ~12 A through 25 mOhm
    start_v = loaded.voltage_v
    t = 0.02
    drawn_as = loaded.consumed_ah * 3600.0
    for _ in range(6000):  # 60 s of hover
        t += 0.01
        pack.step(t, 0.01, np.full(4, HOVER_THRUST_N))
        drawn_as += pack.state.current_a * 0.01  # the current reported after each step
    end = pack.state
    # a step discharges at the current of its start; the state reports the current at its
    # end, a few microamps more
    assert end.consumed_ah == pytest.approx(drawn_as / 3600.0, rel=1e-4)
    assert end.current_a > loaded.current_a  # constant power: less voltage, more current
    assert end.soc == pytest.approx(1.0 - end.consumed_ah / 2.5)
    assert end.voltage_v < start_v - 0.05  # down the discharge curve


def test_a_tiny_pack_empties_and_keeps_the_charge_used() -> None:
    pack = battery()
    pack.step(1.0, 1.0, np.full(4, HOVER_THRUST_N))
    used = pack.state.consumed_ah
    pack.set_capacity(2.0 * used)
    assert pack.state.soc == pytest.approx(0.5)
    for k in range(2, 10):
        pack.step(float(k), 1.0, np.full(4, HOVER_THRUST_N))
    assert pack.state.soc == 0.0 and pack.state.open_circuit_v == pytest.approx(9.81)
    with pytest.raises(ValueError, match="capacity_ah"):
        pack.set_capacity(0.0)


def test_the_power_module_samples_at_its_rate_with_seeded_noise() -> None:
    a, b = battery(seed=5), battery(seed=5)
    for pack in (a, b):
        for k in range(1, 101):  # 1 s in 10 ms steps
            pack.step(k * 0.01, 0.01, np.full(4, HOVER_THRUST_N))
    samples = a.drain_samples()
    assert len(samples) == 11  # t = 0, 0.1, ..., 1.0 at 10 Hz
    assert {s.sensor for s in samples} == {"battery"}
    assert [s.value.tolist() for s in samples] == [s.value.tolist() for s in
                                                   b.drain_samples()]
    assert a.drain_samples() == []
    volts = np.array([s.value[0] for s in samples[1:]])
    assert np.all(np.abs(volts - a.state.voltage_v) < 6 * 0.01 + 0.05)  # noise + discharge


def test_the_world_carries_the_battery_and_its_stream_does_not_shift_the_others() -> None:
    world = World(WorldConfig(), seed=4)
    before = world.step(np.zeros(4), 50)  # 0.1 s on the ground
    power = before.sensor_index == BATTERY_INDEX
    assert before.sensor_names[BATTERY_INDEX] == "battery"
    assert power.sum() == 2 and power[-2:].all()  # t = 0 and 0.1 s, after the sensors'
    assert np.all(before.time_s[power] == world.time_s)  # stamped at the end of the call
    assert world.battery.state.current_a == pytest.approx(0.5, rel=0.05)  # avionics only
    assert np.allclose(before.values[power, 1], 0.5, atol=6 * 0.05)  # A, 6 sigma of noise
    assert world.battery.drain_samples() == []  # the batch has them
    # the sensors' noise comes from the same children of the seed as without a battery
    other = World(WorldConfig(battery=BatteryConfig(voltage_sigma_v=0.5)), seed=4)
    again = other.step(np.zeros(4), 50)
    assert np.array_equal(before.values[~power], again.values[~power])
    assert not np.array_equal(before.values[power], again.values[power])


def test_the_worlds_readings_are_those_of_a_lone_pack_at_the_same_thrusts() -> None:
    world = World(WorldConfig(), seed=4)
    # the same pack on its own, on the world's seed child for it (the fourth)
    alone = Battery(BatteryConfig(), np.random.default_rng(
        np.random.SeedSequence(4).spawn(4)[3]))
    readings = []
    for _ in range(40):  # 0.4 s, the motors spinning up from rest
        batch = world.step(np.full(4, 0.6), 5)
        alone.step(world.time_s, 5 * world.dt_s, world.plant.state[13:17])
        power = batch.sensor_index == BATTERY_INDEX
        readings += [(t, v) for t, v in zip(batch.time_s[power].tolist(),
                                             batch.values[power, :2].tolist(), strict=True)]
    assert [t for t, _ in readings] == pytest.approx([0.01, 0.1, 0.2, 0.3, 0.4])
    assert readings == [(s.time_s, s.value.tolist()) for s in alone.drain_samples()]
    assert world.battery.state == alone.state
    assert world.battery.state.current_a > 1.0  # A: the motors draw more than the avionics


@pytest.mark.parametrize(("field", "value"), [("cells", 0), ("capacity_ah", -1.0),
                                              ("efficiency", 1.5), ("initial_soc", 2.0)])
def test_bad_battery_settings_name_the_field(field: str, value: float) -> None:
    with pytest.raises(ConfigError, match=field):
        BatteryConfig(**{field: value})  # type: ignore[arg-type]
