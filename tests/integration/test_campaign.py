"""Campaigns flown for real: the ``smoke`` campaign on a local Dask cluster against
``ftc-scenario``, on a separately started scheduler and workers, interrupted and resumed;
a run that raises is recorded with its error.

Every comparison of rows leaves out the columns that cannot repeat (``wall_s`` and ``cpu_s``,
the wall clock and CPU time of the run, and ``worker``, the process that flew it) and compares
the rest exactly.
Waits are bounded (generous: two shared cores) and nothing is timed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import psutil
import pytest
from distributed import Client

from sim.campaign.cli import main
from sim.campaign.rows import metric_columns
from sim.campaign.store import read_manifest, read_rows
from sim.scenario_cli import main as scenario_main

pytestmark = pytest.mark.slow

BIN = Path(sys.executable).parent
VOLATILE = ("wall_s", "cpu_s", "worker")
READY_S = 300.0  # s, bound on any wait for a process or a row (two loaded cores)
SMOKE_RUNS = 12


def flown(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Rows by run id, without the columns that cannot repeat."""
    return {r["run_id"]: {k: v for k, v in r.items() if k not in VOLATILE} for r in rows}


def wait_for(what: str, probe: Callable[[], Any], timeout_s: float = READY_S) -> Any:
    """Poll ``probe`` until it returns something truthy; fail after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = probe()
        if value:
            return value
        time.sleep(0.2)
    pytest.fail(f"{what} not within {timeout_s:.0f} s")


@pytest.fixture(scope="module")
def smoke_local(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The smoke campaign flown once on a local cluster of two workers."""
    out = tmp_path_factory.mktemp("smoke_local")
    assert main(["run", "smoke", "--out", str(out), "--workers", "2"]) == 0
    return out


def test_smoke_on_two_local_workers_equals_ftc_scenario_run_by_run(smoke_local: Path,
                                                                  tmp_path: Path) -> None:
    rows = read_rows(smoke_local)
    assert len(rows) == SMOKE_RUNS and all(r["status"] == "ok" for r in rows)
    manifest = read_manifest(smoke_local)
    own = {r["run_id"]: r["own_fault"] for r in manifest["runs"]}
    assert main(["export", "smoke", "--out", str(tmp_path / "scenarios")]) == 0
    for row in rows:
        scenario = tmp_path / "scenarios" / f"{row['run_id']}.toml"
        result = tmp_path / f"{row['run_id']}.json"
        assert scenario_main(["run", str(scenario), "--json", str(result)]) in (0, 1)
        metrics = json.loads(result.read_text())
        # the raw figures themselves, bit for bit
        assert (row["rms_x"], row["max_z"], row["control_effort"], row["outcome_time_s"]) == (
            metrics["rms"]["x"], metrics["max"]["z"], metrics["control_effort"],
            metrics["outcome"]["time_s"])
        expected = metric_columns(metrics, manifest["n_faults"], own[row["run_id"]])
        assert {k: row[k] for k in expected if k not in VOLATILE} == {
            k: v for k, v in expected.items() if k not in VOLATILE}
        assert row["seed"] == metrics["seed"]


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """End a process group this test started: SIGTERM, then SIGKILL after a bound."""
    if proc.poll() is not None:
        return
    os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(60)


@contextmanager
def dask_cluster(folder: Path, workers: int) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """A ``dask scheduler`` and ``workers`` single-threaded ``dask worker`` processes on
    127.0.0.1, each in its own process group, stopped on exit. Yields the scheduler's
    address and the worker processes."""
    scheduler_file = folder / "scheduler.json"
    procs: list[subprocess.Popen[bytes]] = []

    def start(*args: str) -> subprocess.Popen[bytes]:
        log = (folder / f"dask-{len(procs)}.log").open("wb")
        proc = subprocess.Popen([str(BIN / "dask"), *args], stdout=log, stderr=log,
                                start_new_session=True)
        procs.append(proc)
        return proc

    def address() -> str | None:
        try:
            return str(json.loads(scheduler_file.read_text())["address"])
        except (FileNotFoundError, json.JSONDecodeError, KeyError):
            return None

    try:
        start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
              "--scheduler-file", str(scheduler_file))
        addr = wait_for("the scheduler's address", address)
        worker_procs = [start("worker", "--scheduler-file", str(scheduler_file), "--host",
                              "127.0.0.1", "--nthreads", "1", "--nworkers", "1",
                              "--no-dashboard") for _ in range(workers)]
        with Client(addr, timeout="60s") as client:
            client.wait_for_workers(workers, timeout=READY_S)
        yield addr, worker_procs
    finally:
        for proc in reversed(procs):
            _stop(proc)


def test_same_rows_through_a_separate_scheduler_and_two_workers(smoke_local: Path,
                                                                tmp_path: Path) -> None:
    out = tmp_path / "out"
    with dask_cluster(tmp_path, workers=2) as (address, workers):
        assert address.startswith("tcp://127.0.0.1:")
        assert main(["run", "smoke", "--out", str(out), "--scheduler", address]) == 0
        worker_pids = {p.pid for w in workers
                       for p in psutil.Process(w.pid).children(recursive=True)}
        worker_pids |= {w.pid for w in workers}
    rows = read_rows(out)
    assert flown(rows) == flown(read_rows(smoke_local))
    # flown by the dask worker processes started above, not by this one
    assert {int(r["worker"].rsplit(":", 1)[1]) for r in rows} <= worker_pids


def _default_sigint() -> None:
    """In the child before exec: SIGINT handled by default (see :func:`campaign_started`)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


LONG_SMOKE_RUNS = 48  # the smoke campaign's grid with 12 random samples instead of 3


@pytest.fixture(scope="module")
def long_smoke(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The smoke campaign with four times its runs (a file), and its rows flown once on a
    local cluster of two workers (a folder): long enough that a campaign interrupted once
    its first row is on disk still has most of its runs to fly, however loaded the machine
    (the 12 smoke runs fly in about 4 s, and a test reading the first row back had seen them
    all finish first)."""
    folder = tmp_path_factory.mktemp("long_smoke")
    text = (Path(__file__).resolve().parents[2] / "sim" / "campaigns" / "smoke.toml"
            ).read_text()
    assert "samples = 3\n" in text
    campaign = folder / "long_smoke.toml"
    campaign.write_text(text.replace('name = "smoke"', 'name = "long_smoke"')
                        .replace("samples = 3\n", "samples = 12\n"))
    out = folder / "out"
    assert main(["run", str(campaign), "--out", str(out), "--workers", "2"]) == 0
    assert len(read_rows(out)) == LONG_SMOKE_RUNS
    return campaign, out


@contextmanager
def campaign_started(campaign: Path, out: Path) -> Iterator[subprocess.Popen[str]]:
    """``ftc-campaign run CAMPAIGN --out OUT --workers 2`` in a process of its own (stdout
    and stderr as one text), handed over as soon as a first row's file is on disk (looked
    for, not read: reading it back takes seconds on a loaded machine); killed on the way out
    if it is still running.

    The process starts with SIGINT at its default, as a terminal's foreground command does:
    a test runner's worker may ignore SIGINT, and an ignored signal is inherited, so Python
    in the child would never turn Ctrl-C into KeyboardInterrupt (the campaign then flew on
    to the end and exited 0)."""
    proc = subprocess.Popen([str(BIN / "ftc-campaign"), "run", str(campaign), "--out",
                             str(out), "--workers", "2"], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True,
                            preexec_fn=_default_sigint)
    try:
        wait_for("a first row on disk", lambda: any((out / "runs").glob("*.parquet")))
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(60)


def test_interrupted_campaign_flies_only_the_missing_runs_when_run_again(
        long_smoke: tuple[Path, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    campaign, reference = long_smoke
    out = tmp_path / "out"
    with campaign_started(campaign, out) as proc:
        proc.send_signal(signal.SIGINT)  # Ctrl-C
        text, _ = proc.communicate(timeout=READY_S)
    assert proc.returncode == 130, text
    assert "interrupted; run the same command again" in text
    before = {r["run_id"]: r for r in read_rows(out)}
    done = len(before)
    assert 1 <= done < LONG_SMOKE_RUNS

    capsys.readouterr()
    assert main(["run", str(campaign), "--out", str(out), "--workers", "2"]) == 0
    printed = capsys.readouterr().out
    assert f"{LONG_SMOKE_RUNS} runs, {done} already in" in printed
    assert f"flown {LONG_SMOKE_RUNS - done} runs" in printed
    after = read_rows(out)
    assert len(after) == LONG_SMOKE_RUNS
    # the rows of the first attempt are untouched (same worker, same wall time): not re-flown
    assert {r["run_id"]: r for r in after if r["run_id"] in before} == before
    assert flown(after) == flown(read_rows(reference))


def test_a_worker_lost_mid_campaign_costs_no_run(long_smoke: tuple[Path, Path],
                                                 tmp_path: Path) -> None:
    campaign, reference = long_smoke
    out = tmp_path / "out"
    with campaign_started(campaign, out) as proc:
        workers = [p for p in psutil.Process(proc.pid).children(recursive=True)
                   if "spawn_main" in " ".join(p.cmdline())]
        assert len(workers) == 2
        workers[0].kill()  # SIGKILL: the worker and the run it was flying are lost
        text, _ = proc.communicate(timeout=2 * READY_S)
    # the scheduler gives the lost run to a worker again (the nanny restarts the dead one)
    assert proc.returncode == 0, text
    assert flown(read_rows(out)) == flown(read_rows(reference))


def test_a_run_that_raises_is_recorded_and_the_campaign_goes_on(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # 5 kg cannot leave a 1.4 kg airframe: the fault engine refuses it when the run starts
    campaign = tmp_path / "raises.toml"
    campaign.write_text('scenario = "short_square"\nduration_s = 3.0\n[fault]\nstart_s = 1.0\n'
                        '[grid]\nfault.kind = ["mass_loss"]\nfault.magnitude = [0.1, 5.0]\n')
    out = tmp_path / "out"
    assert main(["run", str(campaign), "--out", str(out), "--workers", "1"]) == 1
    assert "1 runs raised" in capsys.readouterr().err
    rows = {r["fault_magnitude"]: r for r in read_rows(out)}
    assert rows[0.1]["status"] == "ok" and rows[0.1]["error"] is None
    assert rows[0.1]["outcome"] in ("landed", "airborne", "crashed", "flyaway")
    failed = rows[5.0]
    assert failed["status"] == "error" and failed["outcome"] is None
    assert failed["error"].startswith("ConfigError: mass_loss_kg = 5.0: must be less than "
                                      "the remaining airframe mass")
    # a failed run counts as finished: running again flies nothing (and starts no cluster)
    assert main(["run", str(campaign), "--out", str(out), "--workers", "1"]) == 1
    assert "2 runs, 2 already in" in capsys.readouterr().out
