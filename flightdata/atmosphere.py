"""The ICAO standard atmosphere below 11 km: pressure and temperature from altitude, and back.

One definition for every room: a barometer turns pressure into altitude with these formulas,
so SCALED_PRESSURE sends the pressure that gives back the barometer's altitude.

Troposphere (ICAO Doc 7488, ISO 2533), altitude ``h`` above mean sea level in metres::

    T(h) = T0 - L h
    p(h) = p0 (T(h) / T0) ** (g0 M / (R L))
"""

from __future__ import annotations

import math

__all__ = ["ISA_P0_PA", "ISA_T0_K", "MAX_ALT_M", "isa_altitude_m", "isa_pressure_pa",
           "isa_temperature_c"]

ISA_P0_PA = 101_325.0  # Pa, sea-level pressure
ISA_T0_K = 288.15  # K, sea-level temperature
LAPSE_K_M = 0.0065  # K/m, temperature lapse rate
G0_M_S2 = 9.80665  # m/s^2, standard gravity
MOLAR_MASS_KG_MOL = 0.0289644  # kg/mol, dry air
GAS_CONSTANT = 8.31432  # J/(mol K), the value the ICAO atmosphere is defined with
EXPONENT = G0_M_S2 * MOLAR_MASS_KG_MOL / (GAS_CONSTANT * LAPSE_K_M)  # about 5.2559
MAX_ALT_M = 11_000.0  # m, top of the troposphere (the formulas' validity)
KELVIN_C = 273.15  # K at 0 degrees Celsius


def isa_temperature_c(alt_m: float) -> float:
    """Air temperature at ``alt_m`` (m AMSL, clipped to [-500, 11000] m), degrees Celsius."""
    h = min(max(float(alt_m), -500.0), MAX_ALT_M)
    return ISA_T0_K - LAPSE_K_M * h - KELVIN_C


def isa_pressure_pa(alt_m: float) -> float:
    """Static pressure at ``alt_m`` (m AMSL, clipped to [-500, 11000] m), Pa."""
    h = min(max(float(alt_m), -500.0), MAX_ALT_M)
    return ISA_P0_PA * ((ISA_T0_K - LAPSE_K_M * h) / ISA_T0_K) ** EXPONENT


def isa_altitude_m(pressure_pa: float) -> float:
    """Altitude (m AMSL) at which the standard atmosphere has ``pressure_pa`` (Pa > 0)."""
    if not (math.isfinite(pressure_pa) and pressure_pa > 0.0):
        raise ValueError(f"pressure_pa = {pressure_pa!r}: must be a finite pressure > 0 Pa")
    return ISA_T0_K / LAPSE_K_M * (1.0 - (pressure_pa / ISA_P0_PA) ** (1.0 / EXPONENT))
