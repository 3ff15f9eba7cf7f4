"""Scenario files and the ftc-scenario command: shipped names, clear errors, JSON metrics."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from flightdata.config import ConfigError
from flightdata.thesis import EXTRA_RUNS, THESIS_CASES, THESIS_RUNS, thesis_tables
from sim.runner import fly
from sim.scenario import load_scenario, shipped_names
from sim.scenario_cli import main


def test_shipped_scenarios_carry_the_thesis_names() -> None:
    names = set(shipped_names())
    assert set(THESIS_RUNS) | set(THESIS_CASES) | set(EXTRA_RUNS) <= names
    assert set(thesis_tables()["runs"]) <= names


@pytest.mark.parametrize("name", sorted(set(thesis_tables()["runs"])))
def test_shipped_runs_have_the_thesis_configuration(name: str) -> None:
    row = thesis_tables()["runs"][name]
    config = load_scenario(name).autopilot
    assert (config.attitude, config.estimator, config.dob) == (
        row["attitude"], row["estimator"], row["dob"])


def test_table_7_3_faults_are_the_thesis_ones() -> None:
    faults = {f.motor: (f.start_s, f.loe) for f in load_scenario("lqg_loe").faults}
    expected = {r["motor"]: (r["at"], r["loe"]) for r in thesis_tables()["loe_chapter7"]}
    assert faults == expected


def test_unknown_name_lists_the_known_ones() -> None:
    with pytest.raises(ConfigError) as err:
        load_scenario("no_such_scenario")
    assert "no_such_scenario" in str(err.value) and "baseline" in str(err.value)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "expected"), [
    ('name = "x"\nspeed = 3\n', "unknown key speed"),
    ('name = "x"\n[autopilot]\nattitude = "mpc"\n', "attitude = 'mpc'"),
    ('name = "x"\n[autopilot]\nloop_rate_hz = -5.0\n', "loop_rate_hz = -5.0"),
    ('name = "x"\n[wind]\nmean_speed_m_s = -1.0\n', "wind.mean_speed_m_s = -1.0"),
    ('name = "x"\nduration_s = 0.0\n', "duration_s = 0.0"),
    ('name = "x"\n[[faults]]\nmotor = 5\nkind = "loe"\nloe = 0.3\n', "motor = 5"),
    ('name = "x"\n[[faults]]\nmotor = 1\nkind = "loe"\nloe = 1.3\n', "loe = 1.3"),
    ('name = "x"\n[[faults]]\ntype = "sensor"\nmotor = 1\nkind = "loe"\n', "needs 'sensor'"),
    ('name = "x"\n[mission]\nkind = "spiral"\n', "mission.kind = 'spiral'"),
    ('name = "x"\n[airframe]\nmass = 0.0\n', "mass = 0.0"),
    ("name = [unclosed\n", "not valid TOML"),
])
def test_bad_scenario_files_name_what_is_wrong(tmp_path: Path, text: str, expected: str) -> None:
    with pytest.raises(ConfigError) as err:
        load_scenario(write(tmp_path, text))
    assert expected in str(err.value)
    assert "s.toml" in str(err.value)  # the file is named too


def test_cli_reports_bad_input_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                           ) -> None:
    bad = write(tmp_path, 'name = "x"\n[[faults]]\nmotor = 5\nkind = "loe"\nloe = 0.3\n')
    assert main(["run", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "motor = 5" in err[0] and "Traceback" not in err[0]
    assert main(["run", "nope"]) == 2
    assert "known scenarios are" in capsys.readouterr().err


@pytest.mark.parametrize("seeds", ["", "3-1", "a-b", "1,1", "-2", "1,x"])
def test_cli_seeds_refuses_a_bad_seed_list_in_one_line(
        seeds: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["seeds", "baseline", "--seeds", seeds])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--seeds" in err and "Traceback" not in err


def test_cli_seeds_counts_outcomes_and_false_alarms(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, 'name = "short"\nduration_s = 12.0\n'
                           '[mission]\nkind = "thesis"\ntakeoff_s = 4.0\nleg_s = 3.0\n')
    out = tmp_path / "seeds.json"
    assert main(["seeds", str(path), "--seeds", "5,6", "--jobs", "1", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert [run["seed"] for run in data["runs"]] == [5, 6]
    assert data["summary"]["runs"] == 2
    assert sum(data["summary"]["outcomes"].values()) == 2
    assert data["summary"]["false_detections"] == 0
    assert "false detections: 0 in 0 of 2 runs" in capsys.readouterr().out


def test_cli_list_names_every_shipped_scenario(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    listed = {line.split()[0] for line in capsys.readouterr().out.splitlines()}
    assert listed == set(shipped_names())


def test_run_json_holds_the_documented_metrics(tmp_path: Path) -> None:
    path = write(tmp_path, 'name = "short"\nduration_s = 12.0\nseed = 3\n'
                           '[mission]\nkind = "thesis"\ntakeoff_s = 4.0\nleg_s = 3.0\n')
    out = tmp_path / "m.json"
    assert main(["run", str(path), "--json", str(out), "--seed", "4"]) == 0
    data = json.loads(out.read_text())
    for key in ("rms", "max"):
        assert set(data[key]) == {"x", "y", "z", "roll", "pitch", "yaw"}
    for key in ("control_effort", "loe_estimate", "detections", "faults", "outcome", "window",
                "sim_s", "wall_s"):
        assert key in data
    assert data["seed"] == 4 and data["sim_s"] == pytest.approx(12.0)


def test_same_seed_same_flight_other_seed_other_flight() -> None:
    scenario = replace(load_scenario("baseline"), duration_s=6.0)
    a, b = fly(scenario), fly(scenario)
    c = fly(scenario.with_seed(2))
    assert (a.log.pos_ned == b.log.pos_ned).all()  # bit-identical
    assert not (a.log.pos_ned == c.log.pos_ned).all()
