"""The ESCs' report: rotor speed from the propeller's thrust law, current from the battery
model's induced power at the bus voltage."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.world.battery import AIR_DENSITY_KG_M3, BatteryConfig
from sim.world.esc import EscConfig, esc_readings


def test_speed_follows_the_thrust_law_and_current_the_induced_power() -> None:
    esc, battery = EscConfig(), BatteryConfig()
    thrust = np.array([1.0, 4.0, 0.0, 9.0])
    r = esc_readings(thrust, 12.0, esc, battery)
    # T = C_T rho n^2 D^4: four times the thrust is twice the speed
    assert r.rpm[1] == pytest.approx(2.0 * r.rpm[0], rel=1e-12)
    assert r.rpm[3] == pytest.approx(3.0 * r.rpm[0], rel=1e-12)
    n = r.rpm[0] / 60.0
    assert esc.thrust_coeff * AIR_DENSITY_KG_M3 * n * n * esc.prop_diameter_m**4 == \
        pytest.approx(1.0, rel=1e-12)
    # P = T^1.5 / (eta sqrt(2 rho A)) = V I
    power = 8.0 / (battery.efficiency * math.sqrt(2 * AIR_DENSITY_KG_M3 * battery.rotor_area_m2))
    assert r.current_a[1] * 12.0 == pytest.approx(power, rel=1e-12)
    assert (r.rpm[2], r.current_a[2], r.voltage_v) == (0.0, 0.0, 12.0)  # a lost rotor


def test_no_bus_voltage_or_bad_thrust_reads_zero() -> None:
    r = esc_readings(np.array([np.nan, -1.0, 2.0, 2.0]), float("nan"), EscConfig(),
                     BatteryConfig())
    assert r.rpm[0] == r.rpm[1] == 0.0 and r.rpm[2] > 0.0
    assert np.all(r.current_a == 0.0) and r.voltage_v == 0.0


@pytest.mark.parametrize("bad", [{"thrust_coeff": 0.0}, {"prop_diameter_m": float("inf")}])
def test_bad_settings_are_named(bad: dict[str, float]) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        EscConfig(**bad)
