"""``ftc-bench compile``: what a fresh machine pays to compile the kernels, beside a warm load.

Each round, in folders of its own (``NUMBA_CACHE_DIR`` and ``QUADFTC_CACHE_DIR`` pointed at
new, empty folders, so nothing of this machine's caches is used or touched):

1. cold: ``ftc-vehicle --precompile`` compiles every kernel the project can run and makes the
   start-up designs (:func:`sim.preparation.precompile`): what ``make setup`` costs once;
2. warm: the same command again, loading what the first filled: what ``make setup`` costs
   after that;
3. first use: ``ftc-scenario run baseline``, then ``ftc-vehicle`` to its first ready
   HEARTBEAT (STANDBY), both on the filled caches: what a user meets after ``make setup``.

CPU seconds are the children's own (``resource.getrusage(RUSAGE_CHILDREN)``), which hardly
depend on the machine's load; wall seconds are printed beside them. Medians over
``--repeat`` rounds.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

__all__ = ["report_compile"]

COLD_TIMEOUT_S = 3600.0  # s wall: a cold build on a loaded 2-core machine


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed_run(command: Sequence[str], env: dict[str, str]) -> tuple[float, float]:
    """Run ``command`` to completion; its (wall, CPU) seconds.

    Raises
    ------
    RuntimeError
        It failed: its status and the end of its output.
    """
    cpu0, wall0 = _children_cpu_s(), time.perf_counter()
    done = subprocess.run(list(command), env=env, capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, timeout=COLD_TIMEOUT_S)
    wall, cpu = time.perf_counter() - wall0, _children_cpu_s() - cpu0
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited with {done.returncode}: "
                           f"{(done.stderr or done.stdout)[-1000:]}")
    return wall, cpu


def _round(folder: Path) -> dict[str, tuple[float, float]]:
    """One round in ``folder``: cold and warm precompile, first scenario, first vehicle."""
    from sim.startup_bench import first_heartbeat_s, script_command, vehicle_command

    env = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "numba"),
           "QUADFTC_CACHE_DIR": str(folder / "designs")}
    precompile = [*script_command("ftc-vehicle", "sim"), "--precompile"]
    figures = {"cold": _timed_run(precompile, env), "warm": _timed_run(precompile, env),
               "scenario": _timed_run([*script_command("ftc-scenario", "sim.scenario_cli"), "run",
                                       "baseline"], env)}
    saved = {k: os.environ.get(k) for k in ("NUMBA_CACHE_DIR", "QUADFTC_CACHE_DIR")}
    os.environ.update({k: env[k] for k in saved})
    try:
        _, _, ready_wall_s, ready_cpu_s = first_heartbeat_s(vehicle_command)
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    figures["vehicle"] = (ready_wall_s, ready_cpu_s)
    return figures


def report_compile(repeat: int) -> None:
    """Print the figures of :func:`_round`, medians over ``repeat`` rounds."""
    rounds = []
    for k in range(repeat):
        with tempfile.TemporaryDirectory(prefix="quadftc-compile-") as folder:
            rounds.append(_round(Path(folder)))
        print(f"compile: round {k + 1} of {repeat} done", file=sys.stderr, flush=True)

    def median(key: str, column: int) -> float:
        return statistics.median(r[key][column] for r in rounds)

    def spread(key: str) -> str:
        cpus = [r[key][1] for r in rounds]
        return (f"CPU median {median(key, 1):7.2f} s (min {min(cpus):.2f}, max {max(cpus):.2f})"
                f", wall median {median(key, 0):7.2f} s")

    print(f"compile: empty numba and design caches, {repeat} round(s); CPU is the child's own")
    print(f"  cold build of every kernel and design (ftc-vehicle --precompile): {spread('cold')}")
    print(f"  warm load of the same (the command again):                     {spread('warm')}")
    print(f"  ratio cold / warm (CPU): {median('cold', 1) / median('warm', 1):.1f}x")
    print("  after it, the first use:")
    print(f"    ftc-scenario run baseline (60 s flight), launch to exit:     {spread('scenario')}")
    print(f"    ftc-vehicle, launch to its first ready HEARTBEAT (STANDBY): {spread('vehicle')}")
