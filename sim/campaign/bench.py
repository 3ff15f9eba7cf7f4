"""``ftc-bench campaign``: campaign throughput on 1 and 2 workers, and the per-run overhead.

    ftc-bench campaign [--repeat N] [--campaign NAME|FILE]

1. The bare flights: every run of the campaign (default ``smoke``) flown one after another
   in this process with :func:`sim.runner.fly`, after a warm-up (no Dask, no Parquet).
2. For 1 and then 2 workers: a local cluster is started and warmed up (timed apart), then the
   whole campaign is flown ``--repeat`` times into a fresh directory each time, exactly as
   ``ftc-campaign run`` does (tasks, rows, Parquet); throughput = runs per minute of wall
   clock from submission to the last row.

Printed: the medians (and spread) of the throughput, the scaling from 1 to 2 workers, and the
per-run overhead over the bare flight: ``workers x wall / runs - bare flight per run``, split
into the part spent outside the flight on the worker (scheduling, transfer, rows, Parquet:
against the flights' own wall time on the workers) and the rest (the flights themselves
running slower side by side on shared cores), and the share of a CPU each flight had (its CPU
time over its wall time: on a machine shared with other work, scaling is bounded by the CPU
left over; the runs per minute per CPU had, doubled, estimate the scaling on two free
CPUs). Figures only; no test times anything.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

from distributed import Client

from sim.campaign.engine import fly_runs, open_client
from sim.campaign.expand import RunSpec, expand, largest_fault_count
from sim.campaign.rows import columns
from sim.campaign.spec import load_campaign
from sim.campaign.store import ResultStore, read_rows

WORKER_COUNTS = (1, 2)


def _bare(runs: list[RunSpec]) -> list[tuple[float, float]]:
    """(wall s, CPU s) of each run flown alone in this process, after a warm-up."""
    from sim.campaign.worker import WarmUp
    from sim.runner import fly
    from sim.scenario import scenario_from_mapping

    WarmUp().setup(None)
    out = []
    for run in runs:
        scenario = scenario_from_mapping(run.scenario)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        fly(scenario)
        out.append((time.perf_counter() - wall0, time.process_time() - cpu0))
    return out


def _campaign_once(client: Client, name: str, runs: list[RunSpec], n_faults: int,
                   groups: tuple[str, ...]) -> tuple[float, float, float]:
    """Wall s of the campaign, and the sums of the runs' wall and CPU s on the workers
    (flown into a temporary directory)."""
    with tempfile.TemporaryDirectory(prefix="ftc-bench-campaign-") as tmp:
        out = Path(tmp)
        with ResultStore(out, columns(groups, n_faults)) as store:
            summary = fly_runs(client, name, runs, store, n_faults)
        rows = read_rows(out)
    if summary.flown != len(runs) or any(r["status"] != "ok" for r in rows):
        raise RuntimeError(f"benchmark campaign: {summary.flown} of {len(runs)} runs flown")
    return (summary.wall_s, sum(r["wall_s"] for r in rows), sum(r["cpu_s"] for r in rows))


def report(campaign_name: str = "smoke", repeat: int = 3) -> None:
    """Measure and print (module docstring)."""
    campaign = load_campaign(campaign_name)
    runs = expand(campaign)
    n_faults = largest_fault_count(runs)
    groups = tuple(dict.fromkeys((*campaign.metrics, "timing")))
    n = len(runs)
    sim_s = sum(float(r.scenario.get("duration_s", 60.0)) for r in runs) / n
    print(f"campaign {campaign.name}: {n} runs of {sim_s:.0f} s simulated; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs at the start")
    bare = _bare(runs)
    bare_per_run = sum(w for w, _ in bare) / n
    print(f"  bare flights, one after another in one process: {n * bare_per_run:.1f} s for "
          f"all, {bare_per_run:.2f} s per run (median "
          f"{statistics.median(w for w, _ in bare):.2f} s), "
          f"{100.0 * sum(c for _, c in bare) / (n * bare_per_run):.0f} % of a CPU")
    throughput: dict[int, float] = {}
    per_cpu: dict[int, float] = {}
    for workers in WORKER_COUNTS:
        start = time.perf_counter()
        with open_client(workers=workers) as client:
            startup = time.perf_counter() - start
            measured = [_campaign_once(client, campaign.name, runs, n_faults, groups)
                        for _ in range(repeat)]
        rates = [60.0 * n / wall for wall, _, _ in measured]
        wall = statistics.median(w for w, _, _ in measured)
        on_workers = statistics.median(f for _, f, _ in measured) / n
        cpu_share = statistics.median(c / f for _, f, c in measured)
        throughput[workers] = statistics.median(rates)
        per_cpu[workers] = throughput[workers] / (workers * cpu_share)
        overhead = workers * wall / n - bare_per_run
        outside = workers * wall / n - on_workers
        print(f"  {workers} worker{'s' if workers > 1 else ' '}: cluster start and warm-up "
              f"{startup:.1f} s (once); throughput median {throughput[workers]:.1f} runs/min "
              f"(min {min(rates):.1f}, max {max(rates):.1f}, {repeat} campaigns)")
        print(f"    per-run overhead over the bare flight: {overhead:+.2f} s "
              f"({100.0 * overhead / bare_per_run:+.0f} %), of which outside the flight "
              f"{outside:+.2f} s, flights slower side by side {on_workers - bare_per_run:+.2f} s")
        print(f"    each flight had {100.0 * cpu_share:.0f} % of a CPU (its CPU time over its "
              "wall time; below 100 % the cores were shared with other work): "
              f"{per_cpu[workers]:.1f} runs per minute per CPU actually had")
    if len(throughput) == 2:
        print(f"  scaling, 2 workers against 1: {throughput[2] / throughput[1]:.2f}x measured; "
              f"{2.0 * per_cpu[2] / per_cpu[1]:.2f}x expected with two free CPUs (an estimate: "
              "the runs per minute per CPU had, doubled)")
