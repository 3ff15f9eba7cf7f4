"""``ftc-campaign`` on bad input and its quick commands (nothing is flown)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from sim.campaign.cli import main
from sim.campaign.expand import expand
from sim.campaign.spec import load_campaign, shipped_campaigns
from sim.scenario import load_scenario


def test_list_names_every_shipped_campaign_with_its_size(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == shipped_campaigns()
    assert any(line.split()[:3] == ["smoke", "12", "runs"] for line in lines)


@pytest.mark.parametrize(("argv", "expected"), [
    (["run", "smoke", "--out", "x", "--workers", "0"],
     "argument --workers: '0': must be an integer in 1..1024"),
    (["run", "smoke", "--out", "x", "--scheduler", "localhost:8786"],
     "argument --scheduler: 'localhost:8786': must be a Dask scheduler address"),
    (["run", "smoke", "--out", "x", "--scheduler", "tcp://h:1", "--workers", "2"],
     "not allowed with argument"),
    (["run", "smoke"], "the following arguments are required: --out"),
    (["run", "smoke", "--out", "x", "--open"], "--open opens the report: give --report too"),
    (["run", "no_such_campaign", "--out", "x"], "unknown campaign 'no_such_campaign'"),
])
def test_bad_flags_are_one_line_and_status_2(argv: list[str], expected: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        raise SystemExit(main(argv))
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("ftc-campaign: ")
    assert expected in err


def test_a_bad_campaign_file_is_one_line_naming_it(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.toml"
    path.write_text('scenario = "short_square"\n[grid]\nwind = ["breezy"]\n')
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == (f"ftc-campaign: {path}: grid.wind[0] = 'breezy': must be one of 'indoor', "
                   "'none', 'light', 'moderate', 'severe'\n")
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_report_of_an_empty_directory_is_one_line(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds no campaign" in err


def test_export_writes_each_run_as_a_scenario_file(tmp_path: Path) -> None:
    assert main(["export", "smoke", "--out", str(tmp_path)]) == 0
    runs = expand(load_campaign("smoke"))
    files = sorted(tmp_path.glob("*.toml"))
    assert [f.stem for f in files] == sorted(r.run_id for r in runs)
    run = runs[0]
    data = tomllib.loads((tmp_path / f"{run.run_id}.toml").read_text())
    assert data == dict(run.scenario)
    scenario = load_scenario(tmp_path / f"{run.run_id}.toml")
    assert scenario.seed == run.axes["seed"] and scenario.faults[0].loe == \
        run.axes["fault_magnitude"]
