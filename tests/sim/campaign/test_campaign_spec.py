"""Campaign files and their runs: axes, stable run ids, one-line errors (no flight flown)."""

from __future__ import annotations

from pathlib import Path

import pytest

from flightdata.config import ConfigError
from sim.campaign.axes import AXIS_COLUMNS
from sim.campaign.expand import expand, largest_fault_count, run_id
from sim.campaign.spec import load_campaign, shipped_campaigns
from sim.scenario import DEFAULT_WIND, load_scenario, scenario_from_mapping


def write(tmp_path: Path, text: str, name: str = "c.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


BASE = 'scenario = "short_square"\n'


def test_smoke_is_twelve_distinct_runs_of_the_documented_axes() -> None:
    campaign = load_campaign("smoke")
    runs = expand(campaign)
    assert len(runs) == 12
    assert len({r.run_id for r in runs}) == 12
    assert [r.index for r in runs] == list(range(12))
    assert {r.axes["fault_magnitude"] for r in runs} == {0.25, 0.5}
    assert {r.axes["ftc"] for r in runs} == {"passive", "active"}
    # three random samples of (start, seed), each crossed with the four grid points
    samples = {(r.axes["fault_start_s"], r.axes["seed"]) for r in runs}
    assert len(samples) == 3
    assert all(5.0 <= start <= 8.0 for start, _ in samples)
    assert all(set(r.axes) == set(AXIS_COLUMNS) for r in runs)
    assert largest_fault_count(runs) == 1 and {r.own_fault for r in runs} == {1}


def test_run_ids_are_stable_and_follow_the_flight_not_the_name() -> None:
    first = expand(load_campaign("smoke"))
    again = expand(load_campaign("smoke"))
    assert [r.run_id for r in first] == [r.run_id for r in again]
    scenario = dict(first[0].scenario)
    assert run_id(scenario) == first[0].run_id
    assert run_id({**scenario, "name": "other", "description": "x"}) == first[0].run_id
    assert run_id({**scenario, "seed": scenario["seed"] + 1}) != first[0].run_id


def test_each_run_is_the_base_scenario_with_its_levels(tmp_path: Path) -> None:
    path = write(tmp_path, BASE + 'duration_s = 9.0\n[fault]\nmotor = 2\nkind = "loe"\n'
                 'start_s = 4.0\n[grid]\nfault.magnitude = [0.3]\nwind = ["indoor", "moderate"]\n'
                 'autopilot.estimator = ["tskf"]\nseed = [7]\n')
    runs = expand(load_campaign(path))
    base = load_scenario("short_square")
    for run in runs:
        flown = scenario_from_mapping(run.scenario)
        assert flown.duration_s == 9.0 and flown.seed == 7
        assert flown.mission == base.mission
        assert flown.autopilot.estimator == "tskf" and flown.autopilot.dob == "abdob"
        (fault,) = flown.faults
        assert (fault.motor, fault.kind, fault.loe, fault.start_s) == (2, "loe", 0.3, 4.0)
    winds = {r.axes["wind"]: scenario_from_mapping(r.scenario).world.wind for r in runs}
    assert winds["indoor"] == DEFAULT_WIND
    # an intensity keeps the base's mean wind and drops the indoor W20 override
    assert winds["moderate"].turbulence == "moderate" and winds["moderate"].w20_m_s is None
    assert winds["moderate"].mean_speed_m_s == DEFAULT_WIND.mean_speed_m_s


def test_mean_wind_axis_sets_the_speed_after_the_turbulence_level(tmp_path: Path) -> None:
    path = write(tmp_path, BASE + '[grid]\nwind = ["indoor", "severe"]\n'
                 'mean_wind_m_s = [0.0, 8.0]\n')
    runs = expand(load_campaign(path))
    flown = {(r.axes["wind"], r.axes["mean_wind_m_s"]):
             scenario_from_mapping(r.scenario).world.wind for r in runs}
    assert flown[("severe", 8.0)].mean_speed_m_s == 8.0
    assert flown[("severe", 8.0)].turbulence == "severe"
    # on indoor air the mean wind comes without turbulence
    assert flown[("none", 8.0)].turbulence == "none"
    assert flown[("none", 0.0)].mean_speed_m_s == 0.0
    assert {r.axes["mean_wind_m_s"] for r in runs} == {0.0, 8.0}


def test_air_levels_pair_a_wind_level_with_its_mean_wind(tmp_path: Path) -> None:
    path = write(tmp_path, BASE + '[grid]\nair = [{wind = "indoor"}, '
                 '{wind = "moderate", mean_wind_m_s = 4.0}, {wind = "severe", '
                 'mean_wind_m_s = 8.0}]\nseed = [1, 2]\n')
    runs = expand(load_campaign(path))
    assert len(runs) == 3 * 2  # the airs are levels, not crossed with each other
    flown = {(r.axes["wind"], r.axes["mean_wind_m_s"]):
             scenario_from_mapping(r.scenario).world.wind for r in runs}
    assert set(flown) == {("indoor", DEFAULT_WIND.mean_speed_m_s), ("moderate", 4.0),
                          ("severe", 8.0)}
    assert flown[("severe", 8.0)].turbulence == "severe"
    assert flown[("indoor", DEFAULT_WIND.mean_speed_m_s)] == DEFAULT_WIND


def test_opposite_after_copies_the_fault_onto_the_opposite_motor(tmp_path: Path) -> None:
    path = write(tmp_path, BASE + 'base_faults = "drop"\n[fault]\nkind = "total_loss"\n'
                 'start_s = 10.0\n[grid]\nfault.motor = [1, 4]\n'
                 'fault.opposite_after_s = [0.0, 2.5]\n')
    runs = expand(load_campaign(path))
    assert len(runs) == 4
    for r in runs:
        faults = scenario_from_mapping(r.scenario).faults
        first, second = faults
        assert second.motor == {1: 2, 4: 3}[first.motor] and second.kind == first.kind
        assert second.start_s - first.start_s == r.axes["fault_opposite_after_s"]
        assert r.axes["fault_motor"] == first.motor  # the campaign's fault is the first
    sensor = write(tmp_path, BASE + '[fault]\nsensor = "baro"\nkind = "bias"\n'
                   'magnitude = 0.1\n[grid]\nfault.opposite_after_s = [0.0]\n', "s.toml")
    with pytest.raises(ConfigError, match="copies an actuator fault onto the opposite motor"):
        expand(load_campaign(sensor))


def test_grid_forms_and_seeded_samples(tmp_path: Path) -> None:
    text = (BASE + '[fault]\nmotor = 1\nkind = "loe"\n[grid]\nseed = {range = [3, 9, 3]}\n'
            'fault.magnitude = {linspace = [0.0, 1.0, 21]}\n'
            '[random]\nsamples = 2\nsampler_seed = SEED\nfault.start_s = {uniform = [1, 2]}\n')
    runs = expand(load_campaign(write(tmp_path, text.replace("SEED", "5"))))
    assert len(runs) == 3 * 21 * 2
    assert sorted({r.axes["seed"] for r in runs}) == [3, 6, 9]
    # linspace values are the round numbers, not 0.15000000000000002
    assert sorted({r.axes["fault_magnitude"] for r in runs})[3] == 0.15
    same = expand(load_campaign(write(tmp_path, text.replace("SEED", "5"), "d.toml")))
    other = expand(load_campaign(write(tmp_path, text.replace("SEED", "6"), "e.toml")))
    starts = [r.axes["fault_start_s"] for r in runs]
    assert starts == [r.axes["fault_start_s"] for r in same]
    assert starts != [r.axes["fault_start_s"] for r in other]


def test_axes_that_do_not_apply_are_ignored_and_equal_runs_flown_once(tmp_path: Path) -> None:
    path = write(tmp_path, BASE + '[fault]\nstart_s = 5.0\n[grid]\n'
                 'fault.kind = ["none", "loe", "lock"]\nfault.motor = [1, 2]\n'
                 'fault.magnitude = [0.2, 0.4]\n')
    runs = expand(load_campaign(path))
    kinds = [r.axes["fault_kind"] for r in runs]
    # none: one run; loe: 2 motors x 2 magnitudes; lock: 2 motors (no magnitude)
    assert kinds.count("none") == 1 and kinds.count("loe") == 4 and kinds.count("lock") == 2
    none = next(r for r in runs if r.axes["fault_kind"] == "none")
    assert none.own_fault is None and none.axes["fault_motor"] is None
    assert all(r.axes["fault_magnitude"] is None for r in runs if r.axes["fault_kind"] == "lock")


def test_sensor_and_structural_faults_take_their_magnitude_field(tmp_path: Path) -> None:
    path = write(tmp_path, BASE + '[fault]\nsensor = "baro"\nstart_s = 5.0\n[grid]\n'
                 'fault.kind = ["bias", "drift", "mass_loss"]\nfault.magnitude = [0.2]\n')
    runs = {r.axes["fault_kind"]: scenario_from_mapping(r.scenario).faults[-1]
            for r in expand(load_campaign(path))}
    assert runs["bias"].magnitude == 0.2  # type: ignore[union-attr]
    assert runs["drift"].rate == 0.2  # type: ignore[union-attr]
    assert runs["mass_loss"].mass_loss_kg == 0.2  # type: ignore[union-attr]


def test_keep_and_drop_the_base_faults(tmp_path: Path) -> None:
    keep = expand(load_campaign(write(tmp_path, 'scenario = "lqg_loe"\n[fault]\nmotor = 2\n'
                                      'kind = "float"\nstart_s = 9.0\n', "k.toml")))
    drop = expand(load_campaign(write(tmp_path, 'scenario = "lqg_loe"\nbase_faults = "drop"\n'
                                      '[fault]\nmotor = 2\nkind = "float"\n', "d.toml")))
    assert keep[0].n_faults == 4 and keep[0].own_fault == 4
    assert drop[0].n_faults == 1 and drop[0].own_fault == 1


@pytest.mark.parametrize(("text", "expected"), [
    ('scenario = "short_square"\nbogus = 1\n', "unknown key bogus"),
    ('name = "x"\n', "scenario = None: is required"),
    ('scenario = "nope"\n', "unknown scenario 'nope'"),
    (BASE + '[grid]\nfault.colour = ["red"]\n', "unknown axis grid.fault.colour"),
    (BASE + '[grid]\nautopilot.ftc = ["passive", "semi"]\n',
     "grid.autopilot.ftc[1] = 'semi': must be one of 'passive', 'active'"),
    (BASE + '[grid]\nseed = {range = [1.0, 3.0]}\n', "range takes [first, last]"),
    (BASE + '[grid]\nfault.motor = {linspace = [1, 4, 4]}\n', "linspace takes"),
    (BASE + '[grid]\nseed = [1, 1]\n', "values must be distinct"),
    (BASE + '[grid]\nair = [{wind = "moderate", seed = 3}]\n',
     "grid.air[0].seed = 3: a table of grid.air holds wind and mean_wind_m_s only"),
    (BASE + '[grid]\nair = [{wind = "gale"}]\n', "grid.air[0].wind = 'gale'"),
    (BASE + '[grid]\nair = [{wind = "light"}]\nwind = ["severe"]\n',
     "is already set by the grid's arrays of whole levels"),
    (BASE + '[grid]\nwind = []\n', "grid.wind = []: must be a non-empty array"),
    (BASE + '[grid]\nseed = [1]\n[random]\nsamples = 2\nseed = {integers = [1, 9]}\n',
     "random.seed"),
    (BASE + '[random]\nsamples = 0\nseed = {integers = [1, 9]}\n', "random.samples = 0"),
    (BASE + '[random]\nsamples = 2\nfault.start_s = {uniform = [5, 1]}\n',
     "uniform needs low < high"),
    (BASE + 'metrics = ["outcome", "speed"]\n', "metrics = ['outcome', 'speed']"),
    (BASE + 'base_faults = "some"\n', "base_faults = 'some': must be 'keep' or 'drop'"),
    (BASE + '[grid]\nfault.magnitude = [0.5]\n', "needs a kind"),
    (BASE + '[fault]\nkind = "loe"\n[grid]\nfault.magnitude = [0.5]\n',
     "a 'loe' fault needs a motor"),
    (BASE + '[fault]\nmotor = 1\nkind = "loe"\n[grid]\nfault.magnitude = [0.5, 1.5]\n',
     "run with fault.magnitude = 1.5: faults[0]: loe = 1.5: must be within [0, 1]"),
])
def test_bad_campaigns_fail_in_one_line_naming_file_and_key(tmp_path: Path, text: str,
                                                             expected: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as err:
        expand(load_campaign(path))
    message = str(err.value)
    assert "\n" not in message
    assert expected in message
    if "unknown scenario" not in expected:
        assert message.startswith(str(path))


def test_every_shipped_campaign_expands() -> None:
    sizes = {name: len(expand(load_campaign(name))) for name in shipped_campaigns()}
    assert sizes["smoke"] == 12
    assert sizes["loe_envelope"] == 21 * 4 * 3 * 2
    assert sizes["thesis_faults"] == 9 * 3 * 50
    assert sizes["false_alarms_indoor"] == 1000
    assert sizes["false_alarms_outdoor"] == 300
    # kinds x phases x motors x airs x configurations
    assert sizes["rotor_loss_envelope"] == 5 * 4 * 4 * 3 * 4
    assert sizes["rotor_loss_fast"] == 2 * 4 * 4 * 2
    assert sizes["rotor_loss_thesis"] == 3 * 4 * 4 * 4
    assert sizes["rotor_loss_height"] == 13 * 4 * 2 * 2
    assert sizes["rotor_loss_severe_height"] == 7 * 4 * 2
    assert sizes["rotor_loss_seeds"] == 4 * 4 * 4 * 4
    # attitude laws x estimators x seeds, fault-free
    assert sizes["severe_baseline"] == 2 * 2 * 32
    # motor 1 or 3 and its opposite, together or 5 s apart, two phases, two airs, 20 seeds
    assert sizes["two_rotor_loss"] == 2 * 2 * 2 * 2 * 20
    # heights x pairs x airs x seeds
    assert sizes["two_rotor_height"] == 7 * 2 * 2 * 2


def test_unknown_campaign_lists_the_shipped_ones() -> None:
    with pytest.raises(ConfigError) as err:
        load_campaign("nope")
    assert all(name in str(err.value) for name in shipped_campaigns())
