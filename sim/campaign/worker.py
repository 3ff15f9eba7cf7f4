"""What a Dask worker does for a campaign: warm up once, then fly runs and return rows.

A worker process imports the project and loads (or compiles) its numba kernels once, when it
joins (:class:`WarmUp`, a Dask worker plugin); every run after that builds its own world and
autopilot (about 5 ms) and flies at full speed. A fresh world per run keeps each run
identical, bit for bit, to the same scenario flown alone with ``ftc-scenario run``.

:func:`fly_run` never raises: an exception in a run becomes its row's ``status = "error"``
and ``error`` text, so one bad run never stops a campaign. An exception that reaches Dask
therefore means the worker itself failed (it died, or cannot import the project): the engine
leaves such runs unrecorded, to be flown by the next ``ftc-campaign run``.
"""

from __future__ import annotations

import os
import signal
import socket
import threading
import time
import traceback
from collections.abc import Mapping
from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin

ERROR_TEXT_CHARS = 2000  # the end of a run's traceback kept in its row's ``error``


def worker_name() -> str:
    """``host:pid`` of this process."""
    return f"{socket.gethostname()}:{os.getpid()}"


def fly_run(scenario: Mapping[str, Any], n_faults: int,
            own_fault: int | None) -> dict[str, Any]:
    """Fly one run; its metric columns (:func:`sim.campaign.rows.metric_columns`) plus
    ``status``, ``error``, ``cpu_s`` (this process's CPU seconds for the run) and ``worker``.

    Parameters
    ----------
    scenario : mapping
        The run's scenario as a TOML mapping (:attr:`sim.campaign.expand.RunSpec.scenario`).
    n_faults : int
        Latency columns to fill (the campaign's largest run).
    own_fault : int or None
        Position (1-based) of the campaign's fault among the run's faults.
    """
    from sim.campaign.rows import metric_columns
    from sim.runner import fly
    from sim.scenario import scenario_from_mapping

    cpu_start = time.process_time()
    try:
        result = fly(scenario_from_mapping(scenario))
        row = metric_columns(result.metrics, n_faults, own_fault)
        row.update(status="ok", error=None)
    except Exception as exc:  # a run's failure is data (module docstring)
        text = "".join(traceback.format_exception(exc)).strip()
        row = {"status": "error",
               "error": f"{type(exc).__name__}: {exc}\n{text[-ERROR_TEXT_CHARS:]}"}
    row["cpu_s"] = time.process_time() - cpu_start
    row["worker"] = worker_name()
    return row


class WarmUp(WorkerPlugin):
    """Loads the project and its compiled kernels when a worker joins (module docstring).

    Also makes the worker ignore SIGINT: a Ctrl-C at a terminal reaches every process of the
    foreground group, and stopping the campaign is the client's job (it cancels the runs).
    """

    name = "quadftc-warm-up"

    def setup(self, worker: Any) -> None:
        """Load every kernel a run may need (:func:`prepare_kernels`)."""
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        prepare_kernels()


WARM_UP_CONFIGURATIONS = (
    {"attitude": "lqg", "estimator": "ekf", "dob": "abdob", "ftc": "active"},
    {"attitude": "pd", "estimator": "tskf", "dob": "vbdob"},
)
"""Autopilot configurations whose few ticks between them run every kernel of a flight."""


def prepare_kernels() -> None:
    """Fly a few ticks of each estimator and attitude law so that every kernel a run may
    need is loaded (or, where the cache lacks it, compiled)."""
    from sim.scenario import scenario_from_mapping
    from sim.stack import warm_up

    for autopilot in WARM_UP_CONFIGURATIONS:
        scenario = scenario_from_mapping({"autopilot": autopilot})
        warm_up(scenario.world, scenario.autopilot, seed=0)
