"""A campaign as its runs: each a complete scenario (as a TOML mapping), its axes and an id.

Each combination of levels (:meth:`sim.campaign.spec.Campaign.levels`) is applied to the base
scenario's TOML mapping, the way a person would edit the file:

- ``seed`` and ``duration_s`` replace the top-level keys; ``base_faults = "drop"`` empties
  ``faults``;
- ``fault.opposite_after_s``: the campaign's actuator fault again on the opposite motor
  (1 and 2, 3 and 4), that many seconds later (0: both at once);
- ``wind``: ``"indoor"`` removes the ``[wind]`` table (the scenarios' default air); an
  intensity sets ``turbulence`` and drops ``w20_m_s`` (keeping the base's mean wind);
  ``mean_wind_m_s`` then sets the mean wind's speed;
- ``autopilot.<key>`` sets ``[autopilot] <key>``;
- the campaign's ``[fault]`` table, with the ``fault.*`` axes applied, is appended to
  ``[[faults]]`` (``fault.kind = "none"``: nothing is appended). ``fault.magnitude`` sets
  the field that is the kind's magnitude (``loe``, ``magnitude``, ``rate`` or
  ``mass_loss_kg``, :mod:`sim.campaign.axes`); an axis that does not apply to the kind (a
  motor for a sensor fault, a magnitude for a ``lock``) is ignored for that run.

The result is checked by the scenario loader (:func:`sim.scenario.scenario_from_mapping`), so
a value out of range is one line naming the campaign file, the run and the key. The run's id
is a hash of its scenario mapping (every key that decides the flight; not its name): the same
run has the same id in every campaign and every session, a run whose scenario changed gets a
new one, and runs that come out the same are flown once.
"""

from __future__ import annotations

import copy
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from flightdata.config import ConfigError, load_toml, require
from flightdata.vocabulary import ACTUATOR_FAULT_KINDS, OPPOSITE_MOTOR, SENSOR_FAULT_KINDS
from sim.campaign.axes import AXES, AXIS_COLUMNS, INDOOR_WIND, NO_FAULT
from sim.campaign.spec import Campaign
from sim.scenario import DEFAULT_WIND, Scenario, scenario_from_mapping, scenario_path
from sim.world.fault_types import ActuatorFault, Fault, SensorFault, StructuralFault

RUN_ID_LENGTH = 16  # hex digits of the SHA-256 kept: 64 bits, no collision in any campaign

#: The field that is each fault kind's magnitude (``fault.magnitude``); other kinds have none.
MAGNITUDE_FIELDS: Mapping[str, str] = {"loe": "loe", "bias": "magnitude",
                                       "loss_of_accuracy": "magnitude", "drift": "rate",
                                       "mass_loss": "mass_loss_kg"}
_SUBJECTS = ("motor", "sensor", "mass_loss_kg")


@dataclass(frozen=True)
class RunSpec:
    """One run of a campaign.

    Attributes
    ----------
    run_id : str
        Stable id (module docstring).
    index : int
        Position in the campaign, from 0.
    axes : mapping
        Every axis column (:data:`sim.campaign.axes.AXIS_COLUMNS`) -> the value flown.
    scenario : mapping
        The run's scenario as a TOML mapping (:func:`sim.scenario.scenario_from_mapping`).
    own_fault : int or None
        1-based position of the campaign's fault in the scenario's faults; None without one.
    """

    run_id: str
    index: int
    axes: Mapping[str, Any]
    scenario: Mapping[str, Any]
    own_fault: int | None

    @property
    def n_faults(self) -> int:
        """Faults of the run's scenario."""
        return len(self.scenario.get("faults", []))


def run_id(scenario: Mapping[str, Any]) -> str:
    """The id of a run's scenario mapping: a hash of every key but ``name`` and
    ``description``."""
    flight = {k: v for k, v in scenario.items() if k not in ("name", "description")}
    text = json.dumps(flight, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:RUN_ID_LENGTH]


def _wind(table: Mapping[str, Any] | None, level: str) -> dict[str, Any] | None:
    """The ``[wind]`` table of a ``wind`` level (None: the default indoor air)."""
    if level == INDOOR_WIND:
        return None
    base = dict(table) if table is not None else {
        "mean_speed_m_s": DEFAULT_WIND.mean_speed_m_s,
        "mean_from_deg": DEFAULT_WIND.mean_from_deg}
    base.pop("w20_m_s", None)
    return {**base, "turbulence": level}


def _fault_table(template: Mapping[str, Any] | None,
                 level: Mapping[str, Any]) -> dict[str, Any] | None:
    """The campaign's fault of one run as a ``[[faults]]`` table (None: no fault)."""
    axes = {k[len("fault."):]: v for k, v in level.items() if k.startswith("fault.")}
    if template is None and not axes:
        return None
    table = {k: v for k, v in (template or {}).items() if k != "type"}
    kind = axes.get("kind", table.get("kind", "mass_loss" if "mass_loss_kg" in table else None))
    require(kind is not None, "fault.kind", None,
            "the campaign's fault needs a kind: give [fault] kind or a fault.kind axis")
    problem = AXES["fault.kind"].check(kind)
    require(problem is None, "fault.kind", kind, problem or "")
    assert isinstance(kind, str)
    if kind == NO_FAULT:
        return None
    if kind in ACTUATOR_FAULT_KINDS:
        subject = "motor"
    elif kind in SENSOR_FAULT_KINDS:
        subject = "sensor"
    else:
        subject = "mass_loss_kg"
    table = {k: v for k, v in table.items() if k not in _SUBJECTS or k == subject}
    if subject != "mass_loss_kg":
        table["kind"] = kind
        if subject in axes:
            table[subject] = axes[subject]
        require(subject in table, f"fault.{subject}", None,
                f"a {kind!r} fault needs a {subject}: give [fault] {subject} or a "
                f"fault.{subject} axis")
    else:
        table.pop("kind", None)
    field = MAGNITUDE_FIELDS.get(kind)
    if field is not None and "magnitude" in axes:
        table[field] = axes["magnitude"]
    if "start_s" in axes:
        table["start_s"] = axes["start_s"]
    if "profile" in axes and kind == "loe":
        table["profile"] = axes["profile"]
    return table


def fault_columns(fault: Fault | None) -> dict[str, Any]:
    """The ``fault_*`` axis columns of the campaign's fault of a run (None: no fault)."""
    out: dict[str, Any] = {"fault_kind": NO_FAULT, "fault_motor": None, "fault_sensor": None,
                           "fault_magnitude": None, "fault_start_s": None,
                           "fault_profile": None}
    if isinstance(fault, ActuatorFault):
        out.update(fault_kind=fault.kind, fault_motor=fault.motor, fault_start_s=fault.start_s)
        if fault.kind == "loe":
            out.update(fault_magnitude=fault.loe, fault_profile=fault.profile)
    elif isinstance(fault, SensorFault):
        out.update(fault_kind=fault.kind, fault_sensor=fault.sensor,
                   fault_start_s=fault.start_s)
        field = MAGNITUDE_FIELDS.get(fault.kind)
        if field is not None:
            out["fault_magnitude"] = getattr(fault, field)
    elif isinstance(fault, StructuralFault):
        out.update(fault_kind="mass_loss", fault_magnitude=fault.mass_loss_kg,
                   fault_start_s=fault.start_s)
    return out


def axis_columns(scenario: Scenario, own_fault: Fault | None,
                 opposite: Fault | None = None) -> dict[str, Any]:
    """Every axis column of a run, read from its resolved scenario (``opposite``: the
    campaign's fault copied onto the opposite motor, ``fault.opposite_after_s``)."""
    wind = scenario.world.wind
    if wind == DEFAULT_WIND:
        wind_level = INDOOR_WIND
    else:
        wind_level = wind.turbulence if wind.w20_m_s is None else "custom"
    ap = scenario.autopilot
    out = {"seed": scenario.seed, **fault_columns(own_fault), "wind": wind_level,
           "mean_wind_m_s": wind.mean_speed_m_s,
           "attitude": ap.attitude, "estimator": ap.estimator, "dob": ap.dob, "ftc": ap.ftc,
           "height_source": ap.height_source,
           "fault_opposite_after_s": (None if opposite is None or own_fault is None
                                      else opposite.start_s - own_fault.start_s)}
    return {c: out[c] for c in AXIS_COLUMNS}


def _describe(level: Mapping[str, Any]) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in level.items()) or "the base scenario"


def _apply(campaign: Campaign, base: Mapping[str, Any],
           level: Mapping[str, Any]) -> tuple[dict[str, Any], int]:
    """The scenario mapping of one level and how many faults the campaign appended to it: 0,
    1, or 2 (its fault and the copy on the opposite motor, ``fault.opposite_after_s``)."""
    scenario = copy.deepcopy(dict(base))
    scenario.pop("name", None)
    scenario.pop("description", None)
    if campaign.base_faults == "drop":
        scenario["faults"] = []
    if campaign.duration_s is not None:
        scenario["duration_s"] = campaign.duration_s
    if "seed" in level:
        scenario["seed"] = level["seed"]
    if "wind" in level:
        wind = _wind(scenario.get("wind"), level["wind"])
        if wind is None:
            scenario.pop("wind", None)
        else:
            scenario["wind"] = wind
    if "mean_wind_m_s" in level:
        wind = scenario.get("wind") or {"mean_from_deg": DEFAULT_WIND.mean_from_deg,
                                        "turbulence": "none"}
        scenario["wind"] = {**wind, "mean_speed_m_s": level["mean_wind_m_s"]}
    autopilot = {k[len("autopilot."):]: v for k, v in level.items()
                 if k.startswith("autopilot.")}
    if autopilot:
        scenario["autopilot"] = {**scenario.get("autopilot", {}), **autopilot}
    fault = _fault_table(campaign.fault, level)
    if fault is None:
        return scenario, 0
    added = [fault]
    delay = level.get("fault.opposite_after_s")
    if delay is not None:
        require("motor" in fault, "fault.opposite_after_s", delay,
                f"copies an actuator fault onto the opposite motor; a {fault.get('kind')!r} "
                "fault has none")
        added.append({**fault, "motor": OPPOSITE_MOTOR[fault["motor"]],
                      "start_s": float(fault.get("start_s", 0.0)) + delay})
    scenario["faults"] = [*scenario.get("faults", []), *added]
    return scenario, len(added)


def expand(campaign: Campaign) -> list[RunSpec]:
    """Every run of ``campaign``, in order, each once.

    Raises
    ------
    ConfigError
        The base scenario cannot be read, or a run's scenario is invalid; the message names
        the campaign file, the run's levels and the key.
    """
    where = campaign.source or campaign.name
    path = scenario_path(campaign.scenario)
    base = load_toml(path)
    runs: list[RunSpec] = []
    seen: set[str] = set()
    for level in campaign.levels():
        try:
            mapping, added = _apply(campaign, base, level)
            scenario = scenario_from_mapping(mapping, default_name=campaign.name)
        except ConfigError as exc:
            raise ConfigError(f"{where}: run with {_describe(level)}: {exc}") from None
        rid = run_id(mapping)
        if rid in seen:
            continue
        seen.add(rid)
        mapping["name"] = f"{campaign.name}-{rid}"
        own = scenario.faults[-added] if added else None
        opposite = scenario.faults[-1] if added == 2 else None
        runs.append(RunSpec(rid, len(runs), axis_columns(scenario, own, opposite), mapping,
                            len(scenario.faults) - added + 1 if added else None))
    return runs


def largest_fault_count(runs: list[RunSpec]) -> int:
    """The most faults any run has (the number of ``fault<k>_latency_s`` columns)."""
    return max((r.n_faults for r in runs), default=0)
