"""Scenario files: what a headless run flies, with which autopilot, world and faults.

A scenario is a TOML file (the shipped ones live in ``sim/scenarios/``)::

    name = "lqg_loe"                 # used as the key in reports and --json output
    description = "Table 7.4: ..."
    duration_s = 60.0                # s, simulated
    seed = 1                         # every random stream of the run derives from it

    [world]                          # optional: plant_rate_hz (Hz, >= 500)
    [airframe]                       # optional: sim.world.airframe.Airframe fields (Table 7.1)
    [wind]                           # optional: sim.world.wind.WindConfig fields
    [sensors]                        # optional: sim.world.sensors.SensorConfig fields
    [battery]                        # optional: sim.world.battery.BatteryConfig fields
    [autopilot]                      # fcu.autopilot.AutopilotConfig fields:
    attitude = "lqg"                 #   "pd" | "lqg"
    estimator = "ekf"                #   "ekf" | "tskf"
    dob = "none"                     #   "none" | "vbdob" | "abdob"
    height_source = "mocap"          #   "mocap" | "baro"
    [mission]                        # optional, default the thesis mission:
    kind = "thesis"                  #   "thesis" (take off to 0.6 m, 1 m square, land) or
                                     #   "items" with [[mission.items]] tables
                                     #   (fcu.navigation.navigator.MissionItem fields, local NED)
    [[faults]]                       # any number; the keys choose the kind:
    motor = 1                        #   actuator (sim.world.fault_types.ActuatorFault)
    kind = "loe"                     #   loe | lock | float | hardover | total_loss
    start_s = 38.0
    loe = 0.30
    # sensor faults have `sensor = "baro"` (SensorFault),
    # structural ones `mass_loss_kg` (StructuralFault)

A ``type = "actuator" | "sensor" | "structural"`` key may accompany a fault for readability;
it must agree with the other keys.

Defaults when a table is absent: the world of :data:`DEFAULT_WIND` (light indoor
turbulence, see below), sensor noise on at the documented levels, the thesis mission.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from fcu.autopilot import AutopilotConfig
from fcu.model import VehicleModel
from flightdata.config import ConfigError, finite, from_mapping, require
from flightdata.mission import MissionItem, thesis_mission
from sim import shipped
from sim.world import WorldConfig
from sim.world.airframe import Airframe
from sim.world.fault_types import Fault, fault_from_mapping
from sim.world.wind import WindConfig

#: Default wind of a scenario: indoor air, as the Qball-X4 flew. A 0.3 m/s mean draught from
#: the west and Dryden turbulence scaled by a wind of 1.5 m/s at 6 m (W20): sigma_w = 0.15
#: m/s and sigma_u = sigma_v ~ 0.3 m/s at the 10 ft floor of the low-altitude model. The
#: thesis's millimetre-level tracking errors imply turbulence this light; MIL-F-8785C's
#: "light" (W20 = 15 kt) would move a 1.4 kg quadrotor by centimetres.
DEFAULT_WIND = WindConfig(mean_speed_m_s=0.3, mean_from_deg=270.0, turbulence="light",
                          w20_m_s=1.5)

_TOP_KEYS = ("name", "description", "duration_s", "seed", "world", "airframe", "wind",
             "sensors", "battery", "autopilot", "mission", "faults")
_FAULT_TYPES = {"actuator": "motor", "sensor": "sensor", "structural": "mass_loss_kg"}


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """One headless run, complete."""

    name: str
    description: str = ""
    duration_s: float = 60.0  # s, simulated
    seed: int = 1
    world: WorldConfig = field(default_factory=lambda: WorldConfig(wind=DEFAULT_WIND))
    autopilot: AutopilotConfig = field(default_factory=AutopilotConfig)
    mission: tuple[MissionItem, ...] = field(default_factory=thesis_mission)
    faults: tuple[Fault, ...] = ()

    def __post_init__(self) -> None:
        require(finite(self.duration_s) and 0 < self.duration_s <= 3600.0, "duration_s",
                self.duration_s, "must be within (0, 3600] s")
        require(isinstance(self.seed, int) and self.seed >= 0, "seed", self.seed,
                "must be an integer >= 0")

    def with_seed(self, seed: int) -> Scenario:
        """The same scenario under another seed."""
        return replace(self, seed=seed)


def _mission_from(table: Any) -> tuple[MissionItem, ...]:
    require(isinstance(table, Mapping), "mission", table, "must be a table")
    kind = table.get("kind", "thesis")
    if kind == "thesis":
        params = {k: v for k, v in table.items() if k != "kind"}
        try:
            return thesis_mission(**params)
        except TypeError:
            raise ConfigError(f"mission: unknown key among {sorted(params)}; thesis missions "
                              "take alt_m, side_m, takeoff_s, settle_s, leg_s, corner_hold_s, "
                              "final_hold_s, land_s") from None
        except ValueError as exc:
            raise ConfigError(f"mission.{exc}") from None
    if kind == "items":
        extra = sorted(set(table) - {"kind", "items"})
        require(not extra, "mission", extra, "unknown keys (allowed: kind, items)")
        items = table.get("items", [])
        require(isinstance(items, list) and len(items) > 0, "mission.items", items,
                "must be a non-empty array of tables")
        return tuple(from_mapping(MissionItem, item, prefix=f"mission.items[{i}].")
                     for i, item in enumerate(items))
    raise ConfigError(f"mission.kind = {kind!r}: must be 'thesis' or 'items'")


def _fault_from(index: int, table: Any) -> Fault:
    where = f"faults[{index}]"
    require(isinstance(table, Mapping), where, table, "must be a table")
    data = dict(table)
    declared = data.pop("type", None)
    if declared is not None:
        require(declared in _FAULT_TYPES, f"{where}.type", declared,
                f"must be one of {', '.join(_FAULT_TYPES)}")
        key = _FAULT_TYPES[declared]
        require(key in data, f"{where}.type", declared, f"a {declared} fault needs '{key}'")
    try:
        return fault_from_mapping(data)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def scenario_from_mapping(data: Mapping[str, Any], default_name: str = "scenario") -> Scenario:
    """Build a :class:`Scenario` from a parsed TOML document; errors name the key."""
    unknown = sorted(set(data) - set(_TOP_KEYS))
    if unknown:
        raise ConfigError(f"unknown key {unknown[0]}: allowed keys are {', '.join(_TOP_KEYS)}")
    world_table = dict(data.get("world", {}))
    require(not {"airframe", "wind", "sensors", "battery"} & set(world_table), "world",
            world_table, "takes plant_rate_hz only; [airframe], [wind], [sensors] and "
            "[battery] are top-level tables")
    world = from_mapping(WorldConfig, {
        **world_table,
        "airframe": data.get("airframe", {}),
        "sensors": data.get("sensors", {}),
        "battery": data.get("battery", {}),
    }, prefix="")
    wind_table = data.get("wind")
    wind = DEFAULT_WIND if wind_table is None else from_mapping(WindConfig, wind_table, "wind.")
    world = replace(world, wind=wind)
    autopilot = from_mapping(AutopilotConfig, data.get("autopilot", {}), prefix="autopilot.")
    # the autopilot's nominal model follows the simulated airframe unless set explicitly
    if "model" not in data.get("autopilot", {}):
        autopilot = replace(autopilot, model=nominal_model(world.airframe))
    mission = _mission_from(data["mission"]) if "mission" in data else thesis_mission()
    faults_table = data.get("faults", [])
    require(isinstance(faults_table, list), "faults", faults_table, "must be an array of tables")
    faults = tuple(_fault_from(i, t) for i, t in enumerate(faults_table))
    fields = {k: data[k] for k in ("description", "duration_s", "seed") if k in data}
    name = data.get("name", default_name)
    require(isinstance(name, str) and name != "", "name", name, "must be a non-empty string")
    try:
        return Scenario(name=name, world=world, autopilot=autopilot, mission=mission,
                        faults=faults, **fields)
    except TypeError as exc:  # a wrongly typed top-level value
        raise ConfigError(str(exc)) from None


def nominal_model(airframe: Airframe) -> VehicleModel:
    """The autopilot's nominal model equal to the simulated airframe's Table 7.1 values."""
    return VehicleModel(thrust_gain=airframe.thrust_gain,
                        motor_bandwidth=airframe.motor_bandwidth,
                        arm_length=airframe.arm_length, yaw_gain=airframe.yaw_gain,
                        mass=airframe.mass, gravity=airframe.gravity,
                        inertia=airframe.inertia, pwm_min=airframe.pwm_min,
                        pwm_max=airframe.pwm_max, rate_damping=airframe.rate_damping,
                        cp_offset_z=airframe.cp_offset_z)


def shipped_names() -> list[str]:
    """Names of the scenarios shipped in ``sim/scenarios``."""
    return shipped.shipped_names("scenarios")


def scenario_path(name_or_path: str | Path) -> Path:
    """The file of a shipped scenario name, or ``name_or_path`` itself when it is a path.

    Raises
    ------
    ConfigError
        An unknown name (the message lists the known ones).
    """
    return shipped.shipped_path("scenarios", "scenario", name_or_path)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a shipped scenario by name, or a scenario file by path.

    Raises
    ------
    ConfigError
        Unknown name (the message lists the known ones), missing file, bad TOML or a bad
        value (the message names the file and the key).
    """
    return shipped.load_shipped(
        "scenarios", "scenario", name_or_path,
        lambda data, path: scenario_from_mapping(data, default_name=path.stem))
