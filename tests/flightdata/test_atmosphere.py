"""The ICAO standard atmosphere against its published table."""

from __future__ import annotations

import math

import pytest

from flightdata.atmosphere import isa_altitude_m, isa_pressure_pa, isa_temperature_c


@pytest.mark.parametrize(("alt_m", "pressure_pa", "temperature_c"), [
    (0.0, 101_325.0, 15.0), (1_000.0, 89_874.6, 8.5), (5_000.0, 54_019.9, -17.5),
    (11_000.0, 22_632.1, -56.5)])  # ICAO Doc 7488 table values
def test_standard_atmosphere_matches_the_icao_table(alt_m: float, pressure_pa: float,
                                                    temperature_c: float) -> None:
    assert isa_pressure_pa(alt_m) == pytest.approx(pressure_pa, rel=2e-5)  # table rounding
    assert isa_temperature_c(alt_m) == pytest.approx(temperature_c, abs=1e-9)


def test_pressure_falls_by_rho_g_per_metre_near_the_ground_and_inverts() -> None:
    # dp/dh = -rho g, rho = 1.225 kg/m^3 at sea level: about 12 Pa per metre
    assert isa_pressure_pa(0.0) - isa_pressure_pa(1.0) == pytest.approx(1.225 * 9.80665,
                                                                        rel=1e-3)
    for alt_m in (-200.0, 0.0, 584.0, 3_000.0, 10_999.0):
        assert isa_altitude_m(isa_pressure_pa(alt_m)) == pytest.approx(alt_m, abs=1e-6)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_altitude_of_an_impossible_pressure_is_refused(bad: float) -> None:
    with pytest.raises(ValueError, match="pressure_pa"):
        isa_altitude_m(bad)
