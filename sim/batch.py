"""Fly many headless runs, in parallel processes: the thesis report and seed sweeps.

A run is a shipped scenario name or scenario file with an optional seed override; its result
is the runner's metrics (:func:`sim.runner.flight_metrics`). Workers are forked processes
that ignore Ctrl-C (the parent's to handle: it terminates the pool).
"""

from __future__ import annotations

import multiprocessing
import signal
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import IO, Any

from flightdata.report import relative_paths

Run = tuple[str, int | None]  # (scenario name or file, seed override or None)


def fly_one(run: Run, out_dir: str | None = None) -> dict[str, Any]:
    """Fly one run; with an output directory, draw its figures there too.

    Returns the run's metrics, plus ``"figures"``: kind -> paths relative to the output
    directory (PNG first, then PDF) when figures were drawn (in ``out_dir/figures/<name>/``).
    """
    from sim.runner import fly
    from sim.scenario import load_scenario

    name, seed = run
    scenario = load_scenario(name)
    if seed is not None:
        scenario = scenario.with_seed(seed)
    result = fly(scenario)
    metrics = dict(result.metrics)
    if out_dir is not None:
        from flightdata.figures import save_figures

        root = Path(out_dir)
        written = save_figures(result.log, root / "figures" / scenario.name,
                               name=scenario.name)
        metrics["figures"] = relative_paths(written, root)
    return metrics


def _fly_indexed(work: tuple[int, Run, str | None]) -> tuple[int, dict[str, Any]]:
    index, run, out_dir = work
    return index, fly_one(run, out_dir)


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def fly_many(runs: Sequence[Run], jobs: int = 2, progress: IO[str] | None = None,
             out_dir: Path | None = None) -> list[dict[str, Any]]:
    """Fly every run (in ``jobs`` parallel processes when > 1); metrics in the runs' order.

    A progress line per finished run goes to ``progress`` when given.
    """
    work = [(i, run, None if out_dir is None else str(out_dir)) for i, run in enumerate(runs)]
    out: dict[int, dict[str, Any]] = {}
    finished: Iterable[tuple[int, dict[str, Any]]]
    if jobs <= 1 or len(work) <= 1:
        finished = map(_fly_indexed, work)
        for index, metrics in finished:
            out[index] = metrics
            _progress(progress, metrics, len(out), len(work))
    else:
        ctx = multiprocessing.get_context("fork")
        with ctx.Pool(min(jobs, len(work)), initializer=_ignore_sigint) as pool:
            for index, metrics in pool.imap_unordered(_fly_indexed, work):
                out[index] = metrics
                _progress(progress, metrics, len(out), len(work))
    return [out[i] for i in range(len(work))]


def _progress(stream: IO[str] | None, metrics: dict[str, Any], done: int, total: int) -> None:
    if stream is not None:
        rtf = metrics["sim_s"] / max(metrics["wall_s"], 1e-9)
        stream.write(f"[{done}/{total}] {metrics['name']} (seed {metrics['seed']}): "
                     f"{metrics['sim_s']:.0f} s simulated, {rtf:.0f}x real time, "
                     f"{metrics['outcome']['kind']}\n")
        stream.flush()
