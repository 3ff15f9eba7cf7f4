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

Compiled, one implementation: the laws above are numba functions (:func:`open_circuit_voltage`,
:func:`terminal_voltage`, :func:`battery_step`) on the pack's state record
(:data:`BATTERY_STATE`); :class:`Battery` keeps that record and the power module's pre-drawn
noise (drawn from its generator in blocks: the same numbers, in the same order, as one draw
per reading). The world steps it with its sample buffer, so that the power module's readings
reach the autopilot in the same batch as the sensors' (:meth:`sim.world.World.step`); on its
own, :meth:`Battery.step` queues them for :meth:`Battery.drain_samples`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from flightdata.config import finite, require
from flightdata.vocabulary import BATTERY_SENSOR
from jitsupport.calls import KernelCall
from sim.world.fault_types import SENSOR_NAMES
from sim.world.samples import SAMPLE_RECORD, SensorSample

__all__ = ["BATTERY_INDEX", "BATTERY_STATE", "LIPO_OCV_V", "Battery", "BatteryConfig",
           "BatteryState", "battery_step", "open_circuit_voltage", "terminal_voltage"]

LIPO_OCV_V = (  # (state of charge, open-circuit voltage of one cell in V), rising
    (0.00, 3.27), (0.05, 3.61), (0.10, 3.69), (0.15, 3.71), (0.20, 3.73), (0.30, 3.77),
    (0.40, 3.79), (0.50, 3.82), (0.60, 3.87), (0.70, 3.92), (0.80, 3.99), (0.90, 4.07),
    (1.00, 4.20))
_SOC = np.array([p[0] for p in LIPO_OCV_V])
_OCV = np.array([p[1] for p in LIPO_OCV_V])
AIR_DENSITY_KG_M3 = 1.225  # kg/m^3, sea level (ISA)
MAX_PENDING_SAMPLES = 1000  # samples kept for a caller that does not drain them
BATTERY_INDEX = len(SENSOR_NAMES)
"""The power module's ``sensor`` index in a sample record (after the world's sensors)."""
_NOISE_BLOCK = 64  # normals drawn at a time (two per reading)

BATTERY_STATE = np.dtype([
    ("cells", np.int64),  # -, LiPo cells in series
    ("capacity_ah", np.float64),  # Ah, usable charge (set_capacity changes it)
    ("resistance_ohm", np.float64),  # Ohm, whole pack
    ("induced", np.float64),  # 1 / (eta sqrt(2 rho A)), W per N^1.5
    ("idle_current_a", np.float64),  # A, avionics
    ("voltage_sigma_v", np.float64),  # V, 1 sigma of a voltage reading
    ("current_sigma_a", np.float64),  # A, 1 sigma of a current reading
    ("sample_period_s", np.float64),  # s, 1 / monitor_rate_hz
    ("consumed_ah", np.float64),  # Ah since boot
    ("next_sample_s", np.float64),  # s, time of the power module's next reading
    ("load_w", np.float64),  # W, the power drawn over the latest step
    ("open_circuit_v", np.float64),  # V, now
    ("noise_next", np.int64),  # -, first unused entry of the noise pool
], align=True)
"""The pack's state record (:class:`Battery`'s ``kernel_state``), stepped by
:func:`battery_step`."""


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


@njit(cache=True, error_model="numpy")
def open_circuit_voltage(soc: float, cells: int) -> float:
    """Resting pack voltage at state of charge ``soc`` (0..1), V (linear between the points
    of :data:`LIPO_OCV_V`)."""
    soc = min(max(soc, 0.0), 1.0)
    # bisect_right: the first point above soc, kept within the table's inner intervals
    k = 0
    while k < _SOC.shape[0] and _SOC[k] <= soc:
        k += 1
    k = min(max(k, 1), _SOC.shape[0] - 1)
    s0, s1, v0, v1 = _SOC[k - 1], _SOC[k], _OCV[k - 1], _OCV[k]
    # V_oc = cells (v0 + (v1 - v0) (soc - s0) / (s1 - s0))
    return cells * (v0 + (v1 - v0) * (soc - s0) / (s1 - s0))


@njit(cache=True, error_model="numpy")
def terminal_voltage(open_circuit_v: float, power_w: float, resistance_ohm: float) -> float:
    """Terminal voltage (V) of a source ``open_circuit_v`` behind ``resistance_ohm`` feeding a
    constant-power load ``power_w``; past the largest power it can give, half of ``V_oc``."""
    # V = (V_oc + sqrt(V_oc^2 - 4 P R)) / 2
    disc = open_circuit_v * open_circuit_v - 4.0 * power_w * resistance_ohm
    return 0.5 * (open_circuit_v + math.sqrt(max(disc, 0.0)))


@njit(cache=True, error_model="numpy")
def _power_w(b: np.ndarray, thrust_n: np.ndarray) -> float:
    """Electrical power at motor thrusts ``thrust_n`` (N), W (:meth:`Battery.power_w`)."""
    s = b[0]
    # P = sum_i T_i^1.5 / (eta sqrt(2 rho A)) + I_idle V_oc
    induced = 0.0
    for i in range(thrust_n.shape[0]):
        t = thrust_n[i]
        if t > 0.0:
            induced += t ** 1.5
    return induced * s.induced + s.idle_current_a * s.open_circuit_v


@njit(cache=True, error_model="numpy")
def _soc(b: np.ndarray) -> float:
    s = b[0]
    return max(1.0 - s.consumed_ah / s.capacity_ah, 0.0)


@njit(cache=True, error_model="numpy")
def _readings_due(b: np.ndarray, time_s: float) -> int:
    """Power-module readings due by ``time_s`` (s)."""
    s = b[0]
    n = 0
    t = s.next_sample_s
    while t <= time_s + 1e-9:
        n += 1
        t += s.sample_period_s
    return n


@njit(cache=True, error_model="numpy")
def battery_step(b: np.ndarray, time_s: float, dt_s: float, thrust_n: np.ndarray,
                 noise: np.ndarray, samples: np.ndarray, n_samples: int) -> int:
    """Discharge the pack over ``dt_s`` (s) ending at ``time_s`` (s) at motor thrusts
    ``thrust_n`` (N), and write the power module's readings due by ``time_s``.

    Parameters
    ----------
    b : numpy.ndarray
        :data:`BATTERY_STATE` record, shape (1,), advanced in place.
    time_s, dt_s : float
        End of the step and its length, s.
    thrust_n : numpy.ndarray
        True thrust of motors 1..4, N, shape (4,).
    noise : numpy.ndarray
        Standard normals; two per reading are used from ``b[0].noise_next`` on.
    samples : numpy.ndarray
        :data:`sim.world.samples.SAMPLE_RECORD` array receiving the readings from index
        ``n_samples`` (sensor :data:`BATTERY_INDEX`, value [V, A, 0]).
    n_samples : int
        Readings already in ``samples``.

    Returns
    -------
    int
        The new count of readings in ``samples``; -1 (and nothing done) when ``noise`` or
        ``samples`` has too little room for the readings due.
    """
    s = b[0]
    due = _readings_due(b, time_s)
    if s.noise_next + 2 * due > noise.shape[0] or n_samples + due > samples.shape[0]:
        return -1
    power_w = _power_w(b, thrust_n)
    v_start = terminal_voltage(s.open_circuit_v, power_w, s.resistance_ohm)
    if v_start > 0.0:  # the step discharges at the current of its start
        # SoC -= I dt / (3600 capacity), I = P / V
        s.consumed_ah += power_w / v_start * dt_s / 3600.0
    s.load_w = power_w
    s.open_circuit_v = open_circuit_voltage(_soc(b), s.cells)
    if due == 0:
        return n_samples
    # the reading: the state at the end of the step (open-circuit voltage, sag, current)
    v = terminal_voltage(open_circuit_voltage(_soc(b), s.cells), power_w, s.resistance_ohm)
    current = power_w / v if v > 0.0 else 0.0
    m = n_samples
    while s.next_sample_s <= time_s + 1e-9:
        j = s.noise_next
        rec = samples[m]
        rec.sensor = BATTERY_INDEX
        rec.time_s = time_s
        rec.value[0] = v + s.voltage_sigma_v * noise[j]
        rec.value[1] = current + s.current_sigma_a * noise[j + 1]
        rec.value[2] = 0.0
        s.noise_next = j + 2
        s.next_sample_s += s.sample_period_s
        m += 1
    return m


_battery_step = KernelCall(battery_step)  # (Battery.step_into's: float64 thrusts, its buffers)


class Battery:
    """The pack and its power module (module docstring).

    Parameters
    ----------
    config : BatteryConfig
    rng : numpy.random.Generator
        The power module's noise.

    Attributes
    ----------
    kernel_state : numpy.ndarray
        The :data:`BATTERY_STATE` record, shape (1,).
    """

    def __init__(self, config: BatteryConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng
        self.kernel_state = np.zeros(1, dtype=BATTERY_STATE)
        self._s = s = self.kernel_state[0]  # a view: writes go to the array
        s["cells"] = config.cells
        s["capacity_ah"] = config.capacity_ah
        s["resistance_ohm"] = config.internal_resistance_ohm
        s["induced"] = 1.0 / (config.efficiency * math.sqrt(
            2.0 * AIR_DENSITY_KG_M3 * config.rotor_area_m2))
        s["idle_current_a"] = config.idle_current_a
        s["voltage_sigma_v"] = config.voltage_sigma_v
        s["current_sigma_a"] = config.current_sigma_a
        s["sample_period_s"] = 1.0 / config.monitor_rate_hz
        s["consumed_ah"] = (1.0 - config.initial_soc) * config.capacity_ah
        s["next_sample_s"] = 0.0
        s["load_w"] = 0.0
        s["open_circuit_v"] = open_circuit_voltage(self._soc(), config.cells)
        self._noise = np.zeros(0)
        self._pending = np.zeros(8, dtype=SAMPLE_RECORD)  # readings queued by step()
        self._n_pending = 0
        self._state_now: BatteryState | None = None  # built when read

    @property
    def capacity_ah(self) -> float:
        """Ah, the pack's usable charge."""
        return float(self._s["capacity_ah"])

    @property
    def state(self) -> BatteryState:
        """The pack now (truth), at the end of the latest step."""
        if self._state_now is None:
            self._state_now = self._state(float(self._s["load_w"]))
        return self._state_now

    def set_capacity(self, capacity_ah: float) -> None:
        """A different pack of ``capacity_ah`` (Ah > 0) with the charge used so far."""
        if not (math.isfinite(capacity_ah) and capacity_ah > 0.0):
            raise ValueError(f"capacity_ah = {capacity_ah!r}: must be a finite capacity > 0 Ah")
        state = self.state
        s = self._s
        s["capacity_ah"] = float(capacity_ah)
        s["load_w"] = state.current_a * state.voltage_v
        s["open_circuit_v"] = open_circuit_voltage(self._soc(), self.config.cells)
        self._state_now = None

    def power_w(self, thrust_n: np.ndarray) -> float:
        """Electrical power the motors and avionics draw at ``thrust_n`` (N, per motor), W,
        the avionics counted at the open-circuit voltage."""
        return float(_power_w(self.kernel_state, np.asarray(thrust_n, dtype=np.float64)))

    def _soc(self) -> float:
        s = self._s
        return max(1.0 - float(s["consumed_ah"]) / float(s["capacity_ah"]), 0.0)

    def _state(self, power_w: float) -> BatteryState:
        cfg = self.config
        soc = self._soc()
        v_oc = open_circuit_voltage(soc, cfg.cells)
        v = terminal_voltage(v_oc, power_w, cfg.internal_resistance_ohm)
        current = power_w / v if v > 0.0 else 0.0
        return BatteryState(soc, v_oc, v, current, float(self._s["consumed_ah"]))

    def step_into(self, time_s: float, dt_s: float, thrust_n: np.ndarray,
                  samples: np.ndarray, n_samples: int) -> int:
        """Discharge over ``dt_s`` (s) ending at ``time_s`` (s) at motor thrusts ``thrust_n``
        (N, float64, shape (4,)); the power module's readings due by ``time_s`` go to the
        :data:`~sim.world.samples.SAMPLE_RECORD` array ``samples`` from index ``n_samples``
        (room for them is the caller's: :meth:`readings_due`); returns the new count."""
        self._state_now = None
        m = _battery_step.call(self.kernel_state, time_s, dt_s, thrust_n, self._noise, samples,
                               n_samples)
        if m < 0:  # more noise needed (or no room): draw, then again
            self._draw(self.readings_due(time_s))
            m = battery_step(self.kernel_state, time_s, dt_s, thrust_n, self._noise, samples,
                             n_samples)
            if m < 0:
                raise ValueError(f"samples: no room for {self.readings_due(time_s)} "
                                 f"power-module readings after index {n_samples}")
        return m

    def readings_due(self, time_s: float) -> int:
        """Power-module readings a step ending at ``time_s`` (s) writes."""
        return int(_readings_due(self.kernel_state, time_s))

    def _draw(self, readings: int) -> None:
        """Keep the unused noise and draw more, two normals per reading, at least a block
        (the generator gives the same numbers in one draw as in many)."""
        used = int(self._s["noise_next"])
        fresh = self._rng.normal(size=max(_NOISE_BLOCK, 2 * readings))
        self._noise = np.concatenate((self._noise[used:], fresh))
        self._s["noise_next"] = 0

    def step(self, time_s: float, dt_s: float, thrust_n: np.ndarray) -> None:
        """Discharge over ``dt_s`` (s) ending at ``time_s`` (s) at motor thrusts ``thrust_n``
        (N); queue the power module's samples due by ``time_s``."""
        due = self.readings_due(time_s)
        if self._n_pending + due > self._pending.shape[0]:
            keep = self._pending[:self._n_pending][-MAX_PENDING_SAMPLES:]
            grown = np.zeros(max(2 * self._pending.shape[0], keep.shape[0] + due),
                             dtype=SAMPLE_RECORD)
            grown[:keep.shape[0]] = keep
            self._pending, self._n_pending = grown, keep.shape[0]
        self._n_pending = self.step_into(time_s, dt_s,
                                         np.ascontiguousarray(thrust_n, dtype=np.float64),
                                         self._pending, self._n_pending)

    def drain_samples(self) -> list[SensorSample]:
        """Power-module samples since the previous call (the latest
        :data:`MAX_PENDING_SAMPLES`), oldest first."""
        rows = self._pending[:self._n_pending][-MAX_PENDING_SAMPLES:]
        samples = [SensorSample(BATTERY_SENSOR, float(r["time_s"]), np.array(r["value"][:2]))
                   for r in rows]
        self._n_pending = 0
        return samples
