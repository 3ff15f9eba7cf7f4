"""ArduPilot-SITL-style ``SIM_*`` parameters of the simulated vehicle.

Each of these *is* a fault or a world setting and acts as soon as it is set (0 = off); a
parameter-owned fault stays until its parameter is reset. The table is in
:mod:`sim.vehicle_port`'s docstring. :class:`SimParams` is a
:class:`fcu.mavlink.port.ParamProvider`: the vehicle process hands it to the endpoint in
``extra_params``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

from fcu.mavlink.port_records import CommandResult, ParamSpec
from sim.world.fault_types import ActuatorFault, Fault, SensorFault, StructuralFault
from sim.world.wind import WindConfig
from sim.world.world import World

__all__ = ["FI_DEFAULTS", "SimParamHost", "SimParams"]


class SimParamHost(Protocol):
    """What the ``SIM_*`` parameters act on (:class:`sim.vehicle_port.SimVehicle`)."""

    @property
    def world(self) -> World: ...

    def owned_fault(self, slot: str) -> Fault | None: ...

    def own_fault(self, slot: str, fault: Fault | None) -> None: ...

    def notice(self, text: str) -> None: ...


FI_UNITS = {"GYR": "rad/s", "ACC": "m/s^2", "MAG": "rad", "BAR": "m", "GPS": "m"}
"""Unit of each SIM_FI_<S> sensor stem."""
FI_DEFAULTS = {"GYR": (0.05, 0.005), "ACC": (0.5, 0.05), "MAG": (0.2, 0.02),
               "BAR": (0.5, 0.05), "GPS": (0.3, 0.03)}
"""(bias default, drift rate default) per SIM_FI stem, sensor units (per s for drifts)."""


@dataclass
class _SimParam:
    spec: ParamSpec
    apply: Callable[[float], CommandResult] | None = None  # None: stored only (magnitudes)


@dataclass
class SimParams:
    """The ``SIM_*`` parameters of one vehicle (see the module docstring).

    A :class:`fcu.mavlink.port.ParamProvider`: pass it to the endpoint in ``extra_params``.
    """

    vehicle: SimParamHost
    speedup: float = 1.0  # SIM_SPEEDUP at boot
    start_paused: bool = False  # SIM_PAUSE at boot
    _params: dict[str, _SimParam] = field(default_factory=dict)
    _values: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        world_config = self.vehicle.world.config
        wind = world_config.wind
        self._wind_config: WindConfig = wind
        mass_kg = world_config.airframe.mass
        defs: list[_SimParam] = [
            _SimParam(ParamSpec(name="SIM_ENGINE_FAIL", value=0, min_value=0, max_value=15,
                                integer=True, description="Motors hit by SIM_ENGINE_MUL, "
                                "bitmask (bit 0 = motor 1)"),
                      lambda x: self._motors_changed()),
            _SimParam(ParamSpec(name="SIM_ENGINE_MUL", value=1.0, min_value=0.0,
                                max_value=1.0, description="Thrust multiplier of the "
                                "SIM_ENGINE_FAIL motors (LOE = 1 - mul)"),
                      lambda x: self._motors_changed()),
        ]
        for m in (1, 2, 3, 4):
            defs.append(_SimParam(ParamSpec(
                name=f"SIM_MOT{m}_LOE", value=0.0, min_value=0.0, max_value=1.0,
                description=f"Loss of effectiveness of motor {m} (0 healthy, 1 no thrust)"),
                lambda x: self._motors_changed()))
        defs += [
            _SimParam(ParamSpec(name="SIM_BARO_GLITCH", value=0.0, min_value=-100.0,
                                max_value=100.0, description="Barometer bias, m"),
                      lambda x: self._sensor_slot("SIM_BARO_GLITCH", None if x == 0 else
                                                  SensorFault(sensor="baro", kind="bias",
                                                              magnitude=x))),
            _SimParam(ParamSpec(name="SIM_BARO_DRIFT", value=0.0, min_value=-10.0,
                                max_value=10.0, description="Barometer drift, m/s"),
                      lambda x: self._sensor_slot("SIM_BARO_DRIFT", None if x == 0 else
                                                  SensorFault(sensor="baro", kind="drift",
                                                              rate=x))),
            _SimParam(ParamSpec(name="SIM_BARO_FREEZE", value=0, min_value=0, max_value=1,
                                allowed=(0.0, 1.0), integer=True,
                                description="Barometer holds its last reading (0/1)"),
                      lambda x: self._sensor_slot("SIM_BARO_FREEZE", None if x == 0 else
                                                  SensorFault(sensor="baro", kind="freeze"))),
            _SimParam(ParamSpec(name="SIM_MASS_DROP", value=0.0, min_value=0.0,
                                max_value=round(0.5 * mass_kg, 3),
                                description="Mass that has left the airframe, kg"),
                      self._mass_drop),
            _SimParam(ParamSpec(name="SIM_WIND_SPD", value=wind.mean_speed_m_s,
                                min_value=0.0, max_value=30.0,
                                description="Mean wind speed, m/s"),
                      lambda x: self._wind(mean_speed_m_s=x)),
            _SimParam(ParamSpec(name="SIM_WIND_DIR", value=wind.mean_from_deg, min_value=0.0,
                                max_value=360.0,
                                description="Direction the wind blows from, deg"),
                      lambda x: self._wind(mean_from_deg=x)),
            _SimParam(ParamSpec(name="SIM_WIND_TURB", value=wind.w20_effective_m_s,
                                min_value=0.0, max_value=30.0,
                                description="Dryden turbulence W20, m/s (0 none)"),
                      self._turbulence),
            _SimParam(ParamSpec(name="SIM_BATT_CAP_AH",
                                value=self.vehicle.world.battery.capacity_ah, min_value=0.001,
                                max_value=1000.0, description="Capacity of the simulated "
                                "pack, Ah (the charge used so far stays used)"),
                      self._battery_capacity),
            _SimParam(ParamSpec(name="SIM_PAUSE", value=1 if self.start_paused else 0,
                                min_value=0, max_value=1, allowed=(0.0, 1.0), integer=True,
                                description="Hold simulated time (1) or run (0)"),
                      lambda x: CommandResult.ok()),
            _SimParam(ParamSpec(name="SIM_SPEEDUP", value=self.speedup, min_value=0.0,
                                description="Simulated s per wall s (read-only, --speedup; "
                                "0 = unthrottled)"),
                      lambda x: CommandResult.denied("read-only (set by --speedup at start)")),
            _SimParam(ParamSpec(name="SIM_FI_LOE", value=0.3, min_value=0.0, max_value=1.0,
                                description="LOE of INJECT_FAILURE MOTOR WRONG/DRIFT")),
            _SimParam(ParamSpec(name="SYS_FAILURE_EN", value=1, min_value=0, max_value=1,
                                allowed=(0.0, 1.0), integer=True,
                                description="MAV_CMD_INJECT_FAILURE accepted (1) or DENIED (0)")),
        ]
        for stem, (bias, rate) in FI_DEFAULTS.items():
            unit = FI_UNITS[stem]
            defs += [
                _SimParam(ParamSpec(name=f"SIM_FI_{stem}_BIAS", value=bias, min_value=-1e3,
                                    max_value=1e3, description=f"Bias of INJECT_FAILURE "
                                    f"{stem} WRONG, {unit}")),
                _SimParam(ParamSpec(name=f"SIM_FI_{stem}_DRIFT", value=rate, min_value=-1e3,
                                    max_value=1e3, description=f"Drift of INJECT_FAILURE "
                                    f"{stem} DRIFT, {unit}/s")),
            ]
        self._params = {d.spec.name: d for d in defs}
        self._values = {d.spec.name: float(d.spec.value) for d in defs}

    @property
    def failure_injection_enabled(self) -> bool:
        """SYS_FAILURE_EN is 1."""
        return self._values["SYS_FAILURE_EN"] != 0.0

    @property
    def paused(self) -> bool:
        """SIM_PAUSE is 1."""
        return self._values["SIM_PAUSE"] != 0.0

    def value(self, name: str) -> float:
        """Current value of ``name``."""
        return self._values[name]

    # ParamProvider
    def param_specs(self) -> Sequence[ParamSpec]:
        """Definitions with current values."""
        return [replace(p.spec, value=self._values[n]) for n, p in self._params.items()]

    def set_param(self, name: str, value: float) -> CommandResult:
        """Apply a validated change; the value is kept only when accepted."""
        param = self._params.get(name)
        if param is None:
            return CommandResult.denied(f"unknown parameter {name}")
        old = self._values[name]
        self._values[name] = float(value)
        if param.apply is None:
            return CommandResult.ok()
        try:
            result = param.apply(float(value))
        except ValueError as err:
            result = CommandResult.denied(str(err))
        if not result.accepted:
            self._values[name] = old
        return result

    # appliers
    def _motors_changed(self) -> CommandResult:
        mask = int(self._values["SIM_ENGINE_FAIL"])
        mul = self._values["SIM_ENGINE_MUL"]
        for m in (1, 2, 3, 4):
            eff = 1.0 - self._values[f"SIM_MOT{m}_LOE"]
            if mask & (1 << (m - 1)):
                eff *= mul
            gamma = min(max(1.0 - eff, 0.0), 1.0)
            slot = f"SIM motor {m}"
            held = self.vehicle.owned_fault(slot)
            wanted = None if gamma <= 0.0 else ActuatorFault(motor=m, kind="loe", loe=gamma)
            if held == wanted:
                continue
            self.vehicle.own_fault(slot, wanted)
        return CommandResult.ok()

    def _sensor_slot(self, slot: str, fault: SensorFault | None) -> CommandResult:
        self.vehicle.own_fault(slot, fault)
        return CommandResult.ok()

    def _mass_drop(self, mass_kg: float) -> CommandResult:
        fault = None if mass_kg == 0.0 else StructuralFault(mass_loss_kg=mass_kg)
        self.vehicle.own_fault("SIM_MASS_DROP", fault)
        return CommandResult.ok()

    def _battery_capacity(self, capacity_ah: float) -> CommandResult:
        self.vehicle.world.battery.set_capacity(capacity_ah)
        self.vehicle.notice(f"SIM: battery capacity {capacity_ah:g} Ah")
        return CommandResult.ok()

    def _wind(self, **change: Any) -> CommandResult:
        config = replace(self._wind_config, **change)
        self.vehicle.world.set_wind(config)
        self._wind_config = config
        self.vehicle.notice("SIM: wind " + _wind_text(config))
        return CommandResult.ok()

    def _turbulence(self, w20_m_s: float) -> CommandResult:
        cfg = self._wind_config
        if w20_m_s == 0.0:
            return self._wind(turbulence="none", w20_m_s=None)
        named = cfg.turbulence if cfg.turbulence != "none" else "light"
        return self._wind(turbulence=named, w20_m_s=w20_m_s)


def _wind_text(cfg: Any) -> str:
    turb = "no turbulence" if cfg.turbulence == "none" else \
        f"turbulence W20 {cfg.w20_effective_m_s:.2f} m/s"
    return f"{cfg.mean_speed_m_s:.2f} m/s from {cfg.mean_from_deg:.0f} deg, {turb}"
