"""What the motors' electronic speed controllers (ESCs) measure: rotor speed and current.

A real ESC reports the speed of the motor it drives (from the back-EMF) and the current it
draws; the autopilot forwards them as ESC_STATUS / ESC_INFO. Here they come from the motor
model's thrust, the only thing the plant knows of a rotor:

- speed from the propeller's thrust law ``T = C_T rho n^2 D^4`` (n in rev/s), so a rotor that
  makes no thrust (lost) reads 0 rpm and a stuck one keeps its speed whatever it is commanded;
- current from the induced power the battery model charges for the rotor
  (:mod:`sim.world.battery`: ``P = T^1.5 / (eta sqrt(2 rho A))``) at the bus voltage.

The autopilot never reads these: they go to the ground station only, as SIM_STATE does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flightdata.config import finite, require
from sim.world.battery import AIR_DENSITY_KG_M3, BatteryConfig

__all__ = ["EscConfig", "EscReadings", "esc_readings"]


@dataclass(frozen=True, kw_only=True)
class EscConfig:
    """The propeller the ESCs spin (a 10-inch propeller, as the battery model's disc)."""

    thrust_coeff: float = 0.1  # C_T, -: T = C_T rho n^2 D^4 (a 10x4.7 propeller ~ 0.1)
    prop_diameter_m: float = 0.254  # D, m

    def __post_init__(self) -> None:
        for name in ("thrust_coeff", "prop_diameter_m"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a finite number > 0")


@dataclass(frozen=True)
class EscReadings:
    """One report of the four ESCs (motors 1..4)."""

    rpm: np.ndarray  # rev/min, (4,)
    current_a: np.ndarray  # A, (4,)
    voltage_v: float  # V, the bus


def esc_readings(thrust_n: np.ndarray, bus_voltage_v: float, esc: EscConfig,
                 battery: BatteryConfig) -> EscReadings:
    """The ESCs' report for rotor thrusts ``thrust_n`` (N, motors 1..4) at ``bus_voltage_v``.

    Examples
    --------
    >>> r = esc_readings(np.array([3.48, 3.48, 0.0, 3.48]), 11.1, EscConfig(), BatteryConfig())
    >>> [round(v) for v in r.rpm]
    [4957, 4957, 0, 4957]
    """
    thrust = np.clip(np.nan_to_num(np.asarray(thrust_n, dtype=float), nan=0.0), 0.0, None)
    # n = sqrt(T / (C_T rho D^4)), rev/s
    rev_s = np.sqrt(thrust / (esc.thrust_coeff * AIR_DENSITY_KG_M3 * esc.prop_diameter_m**4))
    # P = T^1.5 / (eta sqrt(2 rho A)), W; I = P / V
    power_w = thrust**1.5 / (battery.efficiency
                             * math.sqrt(2.0 * AIR_DENSITY_KG_M3 * battery.rotor_area_m2))
    volts = float(bus_voltage_v) if math.isfinite(bus_voltage_v) else 0.0
    current = power_w / volts if volts > 0.0 else np.zeros_like(power_w)
    return EscReadings(rpm=60.0 * rev_s, current_a=current, voltage_v=volts)
