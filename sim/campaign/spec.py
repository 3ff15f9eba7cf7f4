"""Campaign files: a base scenario, the axes to sweep and the metrics to keep.

A campaign is a TOML file (the shipped ones live in ``sim/campaigns/``)::

    name = "smoke"                    # default: the file's stem
    description = "12 short runs"
    scenario = "short_square"         # the base scenario: a shipped name or a .toml file
                                      # (a relative path is relative to this file)
    base_faults = "keep"              # "keep" (default) or "drop" the base scenario's faults
    duration_s = 18.0                 # optional: overrides the base's (s, simulated)
    metrics = ["outcome", "tracking", "effort", "detection", "estimate", "response", "timing"]
                                      # the groups of result columns kept (default: all;
                                      # "outcome" always is), sim.campaign.rows

    [fault]                           # optional: the fault every run adds, a scenario
    motor = 1                         # [[faults]] table; the fault.* axes override its
    kind = "loe"                      # fields (sim.campaign.axes)
    start_s = 6.0

    [grid]                            # every combination of these values
    seed = {range = [1, 50]}          #   integers first..last (a third number: the step)
    fault.magnitude = {linspace = [0.0, 1.0, 21]}   # start, stop, count (both ends in)
    wind = ["indoor", "moderate"]     #   or an array of values
    autopilot.ftc = ["passive", "active"]
    # autopilot = [{attitude = "pd", dob = "none"}, {attitude = "lqg", dob = "abdob"}]
    #   an array of tables: whole configurations, one level each (instead of autopilot.*)
    # air = [{wind = "indoor"}, {wind = "moderate", mean_wind_m_s = 4.0}]
    #   the same for the air: a wind level with its mean wind, one level each

    [random]                          # seeded random samples, each crossed with the grid
    samples = 3                       # how many
    sampler_seed = 7                  # seed of the sampler (not of the flights; default 1)
    fault.start_s = {uniform = [5.0, 8.0]}     # numbers in [low, high], to 1e-6
    seed = {integers = [1, 1000]}     # integers low..high (both in)
    # fault.motor = {choice = [1, 3]}  # one of the values

The axes and their values are those of :mod:`sim.campaign.axes`. An axis is swept by the grid
or by the samples, not both; an axis that does not apply to a run's fault kind (a motor for a
sensor fault) is ignored for that run, and runs that come out the same are flown once
(:mod:`sim.campaign.expand`). Every problem is one :class:`~flightdata.config.ConfigError`
line naming the file, the key, the value and what is allowed, as for scenarios.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from flightdata.config import ConfigError, finite, require
from sim import shipped
from sim.campaign.axes import AXES, Axis
from sim.campaign.rows import METRIC_GROUPS

_TOP_KEYS = ("name", "description", "scenario", "base_faults", "duration_s", "metrics",
             "fault", "grid", "random")
_GRID_FORMS = ("range", "linspace")
_RANDOM_FORMS = ("uniform", "integers", "choice")
_RANDOM_KEYS = ("samples", "sampler_seed")
MAX_RUNS = 1_000_000  # a campaign larger than this is almost certainly a typo in a range
UNIFORM_DECIMALS = 6  # uniform samples are rounded to 1e-6 of their unit (readable, stable ids)
LINSPACE_DECIMALS = 12  # linspace values are rounded to 1e-12 (0.15, not 0.15000000000000002)

Level = Mapping[str, Any]  # axis name -> value: one level of one grid factor


@dataclass(frozen=True)
class Distribution:
    """How a random axis is drawn: ``uniform`` (low, high), ``integers`` (low, high, both
    in) or ``choice`` (the values)."""

    form: str
    args: tuple[Any, ...]

    def draw(self, rng: np.random.Generator) -> Any:
        """One value from ``rng``."""
        if self.form == "uniform":
            return round(float(rng.uniform(self.args[0], self.args[1])), UNIFORM_DECIMALS)
        if self.form == "integers":
            return int(rng.integers(self.args[0], self.args[1] + 1))
        return self.args[int(rng.integers(len(self.args)))]


@dataclass(frozen=True, kw_only=True)
class RandomSamples:
    """The ``[random]`` table: ``samples`` draws of every distribution, seeded."""

    samples: int
    sampler_seed: int
    axes: Mapping[str, Distribution]

    def levels(self) -> list[dict[str, Any]]:
        """The samples in order, each axis drawn in the order of its name."""
        rng = np.random.default_rng(self.sampler_seed)
        return [{name: self.axes[name].draw(rng) for name in sorted(self.axes)}
                for _ in range(self.samples)]


@dataclass(frozen=True, kw_only=True)
class Campaign:
    """A campaign file, validated (module docstring)."""

    name: str
    description: str = ""
    source: str = ""  # the file it was read from
    scenario: str  # base scenario: a shipped name or a path (resolved against the file)
    base_faults: str = "keep"  # "keep" | "drop"
    duration_s: float | None = None  # s, simulated; None keeps the base's
    metrics: tuple[str, ...] = METRIC_GROUPS
    fault: Mapping[str, Any] | None = None  # the added fault's table (before the axes)
    grid: tuple[tuple[Level, ...], ...] = ()  # factors, each its levels
    random: RandomSamples | None = None
    swept: tuple[str, ...] = field(default=())  # the axes swept, by name

    def levels(self) -> list[dict[str, Any]]:
        """Every combination of grid levels crossed with every random sample, in order
        (grid factors outermost first, the samples innermost)."""
        combos: list[dict[str, Any]] = [{}]
        for factor in self.grid:
            combos = [{**c, **level} for c in combos for level in factor]
        samples = self.random.levels() if self.random is not None else [{}]
        return [{**c, **s} for c in combos for s in samples]


def _flatten(table: Mapping[str, Any], prefix: str, forms: tuple[str, ...]) -> dict[str, Any]:
    """Nested tables as dotted names; a table keyed by one of ``forms`` is a value."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping) and not set(value) & set(forms):
            out.update(_flatten(value, name + ".", forms))
        else:
            out[name] = value
    return out


def _axis(name: str, where: str) -> Axis:
    if name not in AXES:
        raise ConfigError(f"unknown axis {where}.{name}: axes are {', '.join(AXES)}")
    return AXES[name]


def _checked(axis: Axis, key: str, value: Any) -> Any:
    problem = axis.check(value)
    require(problem is None, key, value, problem or "")
    return axis.coerce(value)


def _grid_values(axis: Axis, key: str, spec: Any) -> list[Any]:
    """The values of one grid axis: an array, ``{range = ...}`` or ``{linspace = ...}``."""
    allowed = ("must be a non-empty array of values, {range = [first, last]} (integers) or "
               "{linspace = [start, stop, count]} (numbers)")
    if isinstance(spec, list):
        require(len(spec) > 0, key, spec, allowed)
        values = [_checked(axis, f"{key}[{i}]", v) for i, v in enumerate(spec)]
    elif isinstance(spec, Mapping) and len(spec) == 1 and "range" in spec:
        args = spec["range"]
        ok = (isinstance(args, list) and len(args) in (2, 3)
              and all(isinstance(a, int) and not isinstance(a, bool) for a in args))
        require(ok and axis.kind is int, key, spec,
                "range takes [first, last] or [first, last, step] integers, on an integer axis")
        step = args[2] if len(args) == 3 else 1
        require(step >= 1 and args[0] <= args[1], key, spec,
                "range needs first <= last and a step >= 1")
        values = [_checked(axis, key, v) for v in range(args[0], args[1] + 1, step)]
    elif isinstance(spec, Mapping) and len(spec) == 1 and "linspace" in spec:
        args = spec["linspace"]
        ok = (isinstance(args, list) and len(args) == 3 and finite(args[0]) and finite(args[1])
              and isinstance(args[2], int) and not isinstance(args[2], bool) and args[2] >= 2)
        require(ok and axis.kind is float, key, spec,
                "linspace takes [start, stop, count] with count >= 2, on a number axis")
        values = [_checked(axis, key, round(float(v), LINSPACE_DECIMALS))
                  for v in np.linspace(args[0], args[1], args[2])]
    else:
        raise ConfigError(f"{key} = {spec!r}: {allowed}")
    require(len(set(values)) == len(values), key, spec, "values must be distinct")
    return values


# grid keys that take an array of tables, each a whole level of several axes: the key, the
# prefix of its axes' names, and what its tables hold (for messages)
_WHOLE_LEVELS = {"autopilot": ("autopilot.", "autopilot keys"),
                 "air": ("", "wind and mean_wind_m_s")}


def _configurations(key: str, tables: list[Any], prefix: str, holds: str
                    ) -> tuple[Level, ...]:
    """``grid.autopilot`` or ``grid.air`` as an array of tables: whole configurations (or
    whole airs), one level each."""
    levels = []
    for i, table in enumerate(tables):
        where = f"{key}[{i}]"
        require(isinstance(table, Mapping) and len(table) > 0, where, table,
                f"must be a non-empty table of {holds}")
        level = {}
        for name, value in table.items():
            axis = _axis(f"{prefix}{name}", "grid")
            air_axis = axis.name in ("wind", "mean_wind_m_s")
            require(bool(prefix) or air_axis, f"{where}.{name}", value,
                    f"a table of grid.air holds {holds} only")
            level[axis.name] = _checked(axis, f"{where}.{name}", value)
        levels.append(level)
    require(len({tuple(sorted(lv.items())) for lv in levels}) == len(levels), key, tables,
            "levels must be distinct")
    return tuple(levels)


def _grid(table: Any) -> tuple[tuple[tuple[Level, ...], ...], set[str]]:
    require(isinstance(table, Mapping), "grid", table, "must be a table of axes")
    factors: list[tuple[Level, ...]] = []
    swept: set[str] = set()
    for whole, (prefix, holds) in _WHOLE_LEVELS.items():
        levels = table.get(whole)
        if isinstance(levels, list):
            factors.append(_configurations(f"grid.{whole}", levels, prefix, holds))
            swept |= {name for level in factors[-1] for name in level}
            table = {k: v for k, v in table.items() if k != whole}
    for name, spec in _flatten(table, "", _GRID_FORMS).items():
        axis = _axis(name, "grid")
        require(name not in swept, f"grid.{name}", spec,
                "is already set by the grid's arrays of whole levels (autopilot, air)")
        factors.append(tuple({name: v} for v in _grid_values(axis, f"grid.{name}", spec)))
        swept.add(name)
    return tuple(factors), swept


def _distribution(axis: Axis, key: str, spec: Any) -> Distribution:
    allowed = ("must be {uniform = [low, high]} (numbers), {integers = [low, high]} "
               "(integers) or {choice = [values]}")
    require(isinstance(spec, Mapping) and len(spec) == 1 and set(spec) <= set(_RANDOM_FORMS),
            key, spec, allowed)
    form, args = next(iter(spec.items()))
    if form == "choice":
        require(isinstance(args, list) and len(args) > 0, key, spec,
                "choice takes a non-empty array of values")
        values = tuple(_checked(axis, f"{key}.choice[{i}]", v) for i, v in enumerate(args))
        return Distribution("choice", values)
    ok = isinstance(args, list) and len(args) == 2
    if form == "uniform":
        require(ok and axis.kind is float and all(finite(a) for a in args), key, spec,
                "uniform takes [low, high] numbers, on a number axis")
        require(args[0] < args[1], key, spec, "uniform needs low < high")
        for bound in args:
            _checked(axis, key, float(bound))
        return Distribution("uniform", (float(args[0]), float(args[1])))
    require(ok and axis.kind is int
            and all(isinstance(a, int) and not isinstance(a, bool) for a in args), key, spec,
            "integers takes [low, high] integers, on an integer axis")
    require(args[0] <= args[1], key, spec, "integers needs low <= high")
    for bound in args:
        _checked(axis, key, bound)
    return Distribution("integers", (args[0], args[1]))


def _random(table: Any, grid_swept: set[str]) -> RandomSamples:
    require(isinstance(table, Mapping), "random", table, "must be a table")
    samples = table.get("samples")
    require(isinstance(samples, int) and not isinstance(samples, bool) and samples >= 1,
            "random.samples", samples, "must be an integer >= 1")
    sampler_seed = table.get("sampler_seed", 1)
    require(isinstance(sampler_seed, int) and not isinstance(sampler_seed, bool)
            and sampler_seed >= 0, "random.sampler_seed", sampler_seed,
            "must be an integer >= 0")
    axes_table = {k: v for k, v in table.items() if k not in _RANDOM_KEYS}
    dists = {}
    for name, spec in _flatten(axes_table, "", _RANDOM_FORMS).items():
        axis = _axis(name, "random")
        require(name not in grid_swept, f"random.{name}", spec,
                "is swept by the grid already; an axis is swept by one of the two")
        dists[name] = _distribution(axis, f"random.{name}", spec)
    require(len(dists) > 0, "random", dict(table), "needs at least one axis to draw")
    return RandomSamples(samples=samples, sampler_seed=sampler_seed, axes=dists)


def _base_scenario(value: Any, source: Path | None) -> str:
    require(isinstance(value, str) and value != "", "scenario", value,
            "must name a shipped scenario or a .toml file")
    if (value.endswith(".toml") or "/" in value) and source is not None \
            and not Path(value).is_absolute():
        return str(source.parent / value)
    return str(value)


def campaign_from_mapping(data: Mapping[str, Any], *, default_name: str = "campaign",
                          source: Path | None = None) -> Campaign:
    """Build a :class:`Campaign` from a parsed TOML document; errors name the key."""
    unknown = sorted(set(data) - set(_TOP_KEYS))
    if unknown:
        raise ConfigError(f"unknown key {unknown[0]}: allowed keys are {', '.join(_TOP_KEYS)}")
    require("scenario" in data, "scenario", None, "is required: the base scenario's name or file")
    name = data.get("name", default_name)
    require(isinstance(name, str) and name != "", "name", name, "must be a non-empty string")
    description = data.get("description", "")
    require(isinstance(description, str), "description", description, "must be a string")
    base_faults = data.get("base_faults", "keep")
    require(base_faults in ("keep", "drop"), "base_faults", base_faults,
            "must be 'keep' or 'drop'")
    duration_s = data.get("duration_s")
    require(duration_s is None or (finite(duration_s) and 0 < duration_s <= 3600.0),
            "duration_s", duration_s, "must be within (0, 3600] s")
    metrics = data.get("metrics", list(METRIC_GROUPS))
    require(isinstance(metrics, list) and all(m in METRIC_GROUPS for m in metrics), "metrics",
            metrics, f"must be an array of {', '.join(map(repr, METRIC_GROUPS))}")
    fault = data.get("fault")
    require(fault is None or isinstance(fault, Mapping), "fault", fault,
            "must be a table (a scenario's [[faults]] entry)")
    factors, swept = _grid(data.get("grid", {}))
    random = _random(data["random"], swept) if "random" in data else None
    if random is not None:
        swept |= set(random.axes)
    campaign = Campaign(
        name=name, description=description, source="" if source is None else str(source),
        scenario=_base_scenario(data["scenario"], source), base_faults=base_faults,
        duration_s=None if duration_s is None else float(duration_s),
        metrics=tuple(g for g in METRIC_GROUPS if g in metrics or g == "outcome"),
        fault=None if fault is None else dict(fault), grid=factors, random=random,
        swept=tuple(a for a in AXES if a in swept))
    count = math.prod(len(f) for f in factors) * (random.samples if random else 1)
    require(count <= MAX_RUNS, "grid", f"{count} runs", f"a campaign holds at most {MAX_RUNS}")
    return campaign


def shipped_campaigns() -> list[str]:
    """Names of the campaigns shipped in ``sim/campaigns``."""
    return shipped.shipped_names("campaigns")


def load_campaign(name_or_path: str | Path) -> Campaign:
    """Load a shipped campaign by name, or a campaign file by path.

    Raises
    ------
    ConfigError
        Unknown name, missing file, bad TOML or a bad value; the message names the file and
        the key.
    """
    return shipped.load_shipped(
        "campaigns", "campaign", name_or_path,
        lambda data, path: campaign_from_mapping(data, default_name=path.stem, source=path))
