"""The flight battery: a 3S LiPo discharged by the motors, and the power module that reads it.

Model (one pack, ``cells`` LiPo cells in series)
-------------------------------------------------
- Open-circuit voltage: ``cells * OCV(SoC)``, the resting voltage of a LiPo cell against its
  state of charge (:data:`LIPO_OCV_V`, a typical discharge curve: 4.20 V full, a plateau near
  3.8 V, a knee below 10 %).
- Load: the motors draw electrical power ``P = sum_i T_i^1.5 / (eta sqrt(2 rho A))`` (momentum
  theory's ideal induced power over the rotor disc ``A``, divided by a propulsion efficiency
  ``eta``), from the *true* thrust of each motor (a motor that lost effectiveness draws less,
  a runaway one more), plus the avionics' constant ``idle_current_a``.
- Terminal voltage under that load: the pack is a source ``V_oc`` behind an internal
  resistance ``R``; a constant-power load draws ``I = P / V`` with ``V = V_oc - I R``, so
  ``V = (V_oc + sqrt(V_oc^2 - 4 P R)) / 2`` (the voltage sags as the load rises, and sags
  more as the pack empties).
- Discharge: ``SoC -= I dt / (3600 capacity_ah)``, stepped once per world step call (the
  pack changes over minutes, not milliseconds), never below 0.

The thrust the plant produces does not depend on the pack voltage (the thesis's motor model
takes PWM): an empty pack does not bring the vehicle down by itself; the autopilot's battery
failsafe does (``BATT_*``).

Defaults, and why: a 3S 2500 mAh pack (a common size for a 1.4 kg quadrotor; the hover draw
of about 12 A empties it in about 12 minutes), 25 mOhm (three cells of 8 mOhm: a 25C pack),
10-inch rotors (A = 0.0507 m^2) at sea-level density, eta 0.5 (figure of merit about 0.7
times motor and ESC efficiency about 0.7), 0.5 A of avionics.

The power module (ArduPilot's BATT_MONITOR analog voltage and current) samples the terminal
voltage and the current at ``monitor_rate_hz`` with Gaussian noise from its own generator.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from flightdata.config import finite, require
from flightdata.vocabulary import BATTERY_SENSOR
from sim.world.samples import SensorSample

__all__ = ["LIPO_OCV_V", "Battery", "BatteryConfig", "BatteryState"]

LIPO_OCV_V = (  # (state of charge, open-circuit voltage of one cell in V), rising
    (0.00, 3.27), (0.05, 3.61), (0.10, 3.69), (0.15, 3.71), (0.20, 3.73), (0.30, 3.77),
    (0.40, 3.79), (0.50, 3.82), (0.60, 3.87), (0.70, 3.92), (0.80, 3.99), (0.90, 4.07),
    (1.00, 4.20))
_SOC = [p[0] for p in LIPO_OCV_V]
_OCV = [p[1] for p in LIPO_OCV_V]
AIR_DENSITY_KG_M3 = 1.225  # kg/m^3, sea level (ISA)
MAX_PENDING_SAMPLES = 1000  # samples kept for a caller that does not drain them


@dataclass(frozen=True, kw_only=True)
class BatteryConfig:
    """The pack, the propulsion's power draw and the power module (module docstring)."""

    cells: int = 3  # -, LiPo cells in series
    capacity_ah: float = 2.5  # Ah, usable charge
    internal_resistance_ohm: float = 0.025  # Ohm, whole pack
    rotor_area_m2: float = 0.0507  # m^2, one rotor disc (10-inch propeller)
    efficiency: float = 0.5  # -, induced power / electrical power
    idle_current_a: float = 0.5  # A, autopilot, radios, markers
    initial_soc: float = 1.0  # -, state of charge at boot
    monitor_rate_hz: float = 10.0  # Hz, power-module samples
    voltage_sigma_v: float = 0.01  # V, 1 sigma of a voltage reading
    current_sigma_a: float = 0.05  # A, 1 sigma of a current reading

    def __post_init__(self) -> None:
        require(isinstance(self.cells, int) and not isinstance(self.cells, bool)
                and 1 <= self.cells <= 14, "cells", self.cells, "must be an integer 1..14")
        for name in ("capacity_ah", "internal_resistance_ohm", "rotor_area_m2", "efficiency",
                     "monitor_rate_hz"):
            value = getattr(self, name)
            require(finite(value) and value > 0.0, name, value, "must be a finite number > 0")
        for name in ("idle_current_a", "voltage_sigma_v", "current_sigma_a"):
            value = getattr(self, name)
            require(finite(value) and value >= 0.0, name, value,
                    "must be a finite number >= 0")
        require(finite(self.efficiency) and self.efficiency <= 1.0, "efficiency",
                self.efficiency, "must be in (0, 1]")
        require(finite(self.initial_soc) and 0.0 <= self.initial_soc <= 1.0, "initial_soc",
                self.initial_soc, "must be in [0, 1]")


@dataclass(frozen=True, slots=True)
class BatteryState:
    """The pack at one instant (truth)."""

    soc: float  # -, state of charge 0..1
    open_circuit_v: float  # V
    voltage_v: float  # V, at the terminals, under load
    current_a: float  # A, drawn
    consumed_ah: float  # Ah since boot


def open_circuit_voltage(soc: float, cells: int) -> float:
    """Resting pack voltage at state of charge ``soc`` (0..1), V (linear between the points
    of :data:`LIPO_OCV_V`)."""
    soc = min(max(soc, 0.0), 1.0)
    k = min(max(bisect.bisect_right(_SOC, soc), 1), len(_SOC) - 1)
    s0, s1, v0, v1 = _SOC[k - 1], _SOC[k], _OCV[k - 1], _OCV[k]
    return cells * (v0 + (v1 - v0) * (soc - s0) / (s1 - s0))


def terminal_voltage(open_circuit_v: float, power_w: float, resistance_ohm: float) -> float:
    """Terminal voltage (V) of a source ``open_circuit_v`` behind ``resistance_ohm`` feeding a
    constant-power load ``power_w``; past the largest power it can give, half of ``V_oc``."""
    disc = open_circuit_v * open_circuit_v - 4.0 * power_w * resistance_ohm
    return 0.5 * (open_circuit_v + math.sqrt(max(disc, 0.0)))


class Battery:
    """The pack and its power module (module docstring).

    Parameters
    ----------
    config : BatteryConfig
    rng : numpy.random.Generator
        The power module's noise.
    """

    def __init__(self, config: BatteryConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng
        self._induced = 1.0 / (config.efficiency * math.sqrt(
            2.0 * AIR_DENSITY_KG_M3 * config.rotor_area_m2))
        self.capacity_ah = config.capacity_ah
        self._consumed_ah = (1.0 - config.initial_soc) * config.capacity_ah
        self._next_sample_s = 0.0
        self._pending: list[SensorSample] = []
        self._load_w = 0.0  # W, the power drawn over the latest step
        self._open_circuit_v = open_circuit_voltage(self._soc(), config.cells)  # V, now
        self._state_now: BatteryState | None = None  # built when read

    @property
    def state(self) -> BatteryState:
        """The pack now (truth), at the end of the latest step."""
        if self._state_now is None:
            self._state_now = self._state(self._load_w)
        return self._state_now

    def set_capacity(self, capacity_ah: float) -> None:
        """A different pack of ``capacity_ah`` (Ah > 0) with the charge used so far."""
        if not (math.isfinite(capacity_ah) and capacity_ah > 0.0):
            raise ValueError(f"capacity_ah = {capacity_ah!r}: must be a finite capacity > 0 Ah")
        state = self.state
        self.capacity_ah = float(capacity_ah)
        self._load_w = state.current_a * state.voltage_v
        self._open_circuit_v = open_circuit_voltage(self._soc(), self.config.cells)
        self._state_now = None

    def power_w(self, thrust_n: np.ndarray) -> float:
        """Electrical power the motors and avionics draw at ``thrust_n`` (N, per motor), W,
        the avionics counted at the open-circuit voltage."""
        induced = 0.0
        for t in np.asarray(thrust_n, dtype=float).tolist():
            if t > 0.0:
                induced += t ** 1.5
        return induced * self._induced + self.config.idle_current_a * self._open_circuit_v

    def _soc(self) -> float:
        return max(1.0 - self._consumed_ah / self.capacity_ah, 0.0)

    def _state(self, power_w: float) -> BatteryState:
        cfg = self.config
        soc = self._soc()
        v_oc = open_circuit_voltage(soc, cfg.cells)
        v = terminal_voltage(v_oc, power_w, cfg.internal_resistance_ohm)
        current = power_w / v if v > 0.0 else 0.0
        return BatteryState(soc, v_oc, v, current, self._consumed_ah)

    def step(self, time_s: float, dt_s: float, thrust_n: np.ndarray) -> None:
        """Discharge over ``dt_s`` (s) ending at ``time_s`` (s) at motor thrusts ``thrust_n``
        (N); queue the power module's samples due by ``time_s``."""
        power_w = self.power_w(thrust_n)
        v_start = terminal_voltage(self._open_circuit_v, power_w,
                                   self.config.internal_resistance_ohm)
        if v_start > 0.0:  # the step discharges at the current of its start
            self._consumed_ah += power_w / v_start * dt_s / 3600.0
        self._load_w = power_w
        self._open_circuit_v = open_circuit_voltage(self._soc(), self.config.cells)
        self._state_now = None
        cfg = self.config
        while self._next_sample_s <= time_s + 1e-9:
            noise = self._rng.normal(size=2)
            state = self.state
            value = np.array([state.voltage_v + cfg.voltage_sigma_v * noise[0],
                              state.current_a + cfg.current_sigma_a * noise[1]])
            self._pending.append(SensorSample(BATTERY_SENSOR, time_s, value))
            self._next_sample_s += 1.0 / cfg.monitor_rate_hz
        if len(self._pending) > MAX_PENDING_SAMPLES:  # nobody drains them: keep the latest
            del self._pending[:-MAX_PENDING_SAMPLES]

    def drain_samples(self) -> list[SensorSample]:
        """Power-module samples since the previous call, oldest first."""
        samples, self._pending = self._pending, []
        return samples
