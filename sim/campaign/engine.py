"""Runs as Dask tasks: on a local cluster of worker processes, or on an existing cluster.

::

    with open_client(workers=2) as client:              # or scheduler="tcp://host:8786"
        summary = fly_runs(client, campaign.name, runs, store, n_faults)

A local cluster (:func:`open_client` without ``scheduler``) has ``workers`` single-threaded
worker processes on 127.0.0.1 (default: one per CPU), started by this process and stopped
with it. With ``scheduler`` the same tasks go to a running ``dask scheduler`` and its
``dask worker`` processes, which must be able to import this project (installed in their
Python). Either way every worker gets the :class:`sim.campaign.worker.WarmUp` plugin when it
joins, and each run is one task keyed by its run id.

Each finished run's row goes to the store as it arrives. A run whose task fails in Dask (its
worker died more often than the scheduler allows, or cannot import the project) is left
unrecorded and counted in :attr:`Summary.unflown`; the next ``ftc-campaign run`` flies it.
Ctrl-C cancels what is left; what finished is kept.
"""

from __future__ import annotations

import importlib.util
import logging
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import IO, Any

from distributed import Client, LocalCluster, as_completed

from sim.campaign.expand import RunSpec
from sim.campaign.store import ResultStore
from sim.campaign.worker import WarmUp, fly_run, prepare_kernels
from sim.preparation import Progress, reporting

CONNECT_TIMEOUT_S = 30.0  # s to reach an existing scheduler before giving up
_BAR_WIDTH = 40


class SchedulerUnreachable(ConnectionError):
    """The scheduler named by ``--scheduler`` did not answer, or its workers cannot load
    this project."""


@dataclass
class Summary:
    """What one ``fly_runs`` did.

    Attributes
    ----------
    total : int
        Runs handed to it.
    flown : int
        Runs that finished (a row each, ``ok`` or ``error``).
    errors : int
        Of those, the runs whose flight raised (``status = "error"``).
    unflown : int
        Runs whose task failed in Dask or was cancelled: no row; a re-run flies them.
    first_failure : str or None
        The first such Dask failure, for the message.
    interrupted : bool
        Ended by Ctrl-C.
    wall_s : float
        Wall-clock seconds from submission to the last row.
    """

    total: int
    flown: int = 0
    errors: int = 0
    unflown: int = 0
    first_failure: str | None = None
    interrupted: bool = False
    wall_s: float = 0.0


def default_workers() -> int:
    """One worker per CPU this process may use."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
               else (os.cpu_count() or 1))


@contextmanager
def open_client(*, workers: int | None = None, scheduler: str | None = None,
                warm_up: bool = True,
                report: Callable[[Progress], object] | None = None) -> Iterator[Client]:
    """A Dask client on a new local cluster (``workers`` processes) or on ``scheduler``.

    With ``warm_up``, the kernels are compiled once before the runs fan out: for a local
    cluster in this process before its workers start (``report`` gets the progress every
    few seconds: minutes where nothing was compiled yet, a second otherwise), on a running
    cluster by one worker first; then every worker loads them as it joins
    (:class:`sim.campaign.worker.WarmUp`), from the cache the first compile filled (the
    workers of one machine share it; another machine's compile their own).

    Raises
    ------
    SchedulerUnreachable
        The scheduler could not be reached within :data:`CONNECT_TIMEOUT_S`, or its workers
        cannot load the project.
    """
    cluster: LocalCluster | None = None
    if scheduler is None:
        if warm_up:
            with reporting(report):
                prepare_kernels()
        cluster = LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1,
                               processes=True, host="127.0.0.1",
                               dashboard_address="127.0.0.1:0",
                               silence_logs=logging.ERROR)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
        except OSError as exc:
            raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {scheduler}: "
                                       f"{exc}") from None
    try:
        if warm_up:
            try:
                if scheduler is not None:  # one worker compiles, then all load
                    client.submit(prepare_kernels, pure=False).result()
                client.register_plugin(WarmUp())
            except Exception as exc:  # raised on a worker: its Python lacks the project
                raise SchedulerUnreachable(
                    f"the workers of {scheduler or 'the local cluster'} cannot load this "
                    f"project ({type(exc).__name__}: {exc}); install it in their Python"
                ) from None
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _row(campaign: str, run: RunSpec, result: dict[str, Any]) -> dict[str, Any]:
    return {"run_id": run.run_id, "index": run.index, "campaign": campaign, **run.axes,
            **result}


def fly_runs(client: Client, campaign: str, runs: Sequence[RunSpec], store: ResultStore,
             n_faults: int, progress: IO[str] | None = None) -> Summary:
    """Fly ``runs`` as Dask tasks; each row goes to ``store`` as it finishes.

    Parameters
    ----------
    client : distributed.Client
    campaign : str
        The campaign's name (the ``campaign`` column).
    runs : sequence of RunSpec
        The runs to fly (those not finished yet).
    store : ResultStore
        Where the rows go (entered).
    n_faults : int
        Latency columns per row (:func:`sim.campaign.expand.largest_fault_count`).
    progress : text stream, optional
        Where a progress bar is drawn (a terminal); nothing is drawn without one.
    """
    summary = Summary(total=len(runs))
    start = time.perf_counter()
    futures = {}
    for run in runs:
        future = client.submit(fly_run, run.scenario, n_faults, run.own_fault,
                               key=f"quadftc-run-{run.run_id}")
        futures[future.key] = (future, run)
    bar = _Bar(progress, len(runs))
    try:
        for future in as_completed([f for f, _ in futures.values()]):
            run = futures[future.key][1]
            if future.status == "finished":
                row = _row(campaign, run, future.result())
                store.add(row)
                summary.flown += 1
                summary.errors += row["status"] == "error"
            else:
                summary.unflown += 1
                if summary.first_failure is None:
                    summary.first_failure = _failure(future)
            future.release()
            bar.draw(summary.flown + summary.unflown, summary.errors)
    except KeyboardInterrupt:
        summary.interrupted = True
        pending = [f for f, _ in futures.values() if not f.done()]
        summary.unflown += len(pending)
        try:
            client.cancel(pending)
        except Exception:  # the scheduler may already be gone; nothing left to cancel
            pass
    finally:
        bar.finish()
        summary.wall_s = time.perf_counter() - start
    return summary


def _failure(future: Any) -> str:
    """What a task that did not finish died of, in one line."""
    try:
        exc = future.exception()
    except BaseException as cancelled:  # a cancelled future raises instead of returning
        exc = cancelled
    return f"{type(exc).__name__}: {exc}".splitlines()[0]


def dashboard_link(client: Client) -> str | None:
    """The scheduler's dashboard address when it serves one: a scheduler in this process
    (a local cluster) draws it only with bokeh installed; another says so itself."""
    if isinstance(client.cluster, LocalCluster) and importlib.util.find_spec("bokeh") is None:
        return None
    try:
        served = "dashboard" in client.scheduler_info().get("services", {})
    except Exception:  # an old or restricted scheduler: no link, no harm
        return None
    return str(client.dashboard_link) if served else None


class _Bar:
    """Dask's console progress bar, drawn from the runs as they finish (terminal only)."""

    def __init__(self, stream: IO[str] | None, total: int) -> None:
        self.stream = stream
        self.total = total
        self.start = time.perf_counter()

    def draw(self, done: int, errors: int) -> None:
        if self.stream is None:
            return
        frac = done / self.total if self.total else 1.0
        elapsed = time.perf_counter() - self.start
        rate = 60.0 * done / elapsed if elapsed > 0 else 0.0
        failed = f", {errors} failed" if errors else ""
        self.stream.write(f"\r[{'#' * int(_BAR_WIDTH * frac):<{_BAR_WIDTH}}] | "
                          f"{int(100 * frac)}% Completed | {elapsed:.1f}s | "
                          f"{done}/{self.total} runs{failed}, {rate:.1f}/min")
        self.stream.flush()

    def finish(self) -> None:
        if self.stream is not None:
            self.stream.write("\x1b[2K\r")
            self.stream.flush()


def is_terminal(stream: IO[str]) -> bool:
    """True when ``stream`` is an interactive terminal (progress is drawn only there)."""
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


def progress_stream() -> IO[str] | None:
    """Standard error when it is a terminal, else None (quiet in pipes, logs and CI)."""
    return sys.stderr if is_terminal(sys.stderr) else None
