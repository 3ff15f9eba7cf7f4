"""Kernel preparation: the progress it reports, counted from numba's own compile events."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from sim.preparation import Progress, project_kernels

ROOT = Path(__file__).resolve().parents[2]


def test_a_progress_line_fits_one_statustext() -> None:
    worst = Progress(compiled=9999, total=9999, elapsed_s=99999.0)
    assert len(worst.line()) <= 50  # one STATUSTEXT, no chunks
    assert worst.line().startswith("preparing: 9999 of 9999 kernels compiled")
    assert Progress(compiled=3, total=5, elapsed_s=2.4, done=True).line() == (
        "ready: 3 of 5 kernels compiled, 2 s")


def test_the_project_kernels_are_the_dispatchers_of_its_modules_each_once() -> None:
    from numba.core.dispatcher import Dispatcher

    import fcu.control.attitude_pd as attitude_pd
    import fcu.monitoring.watched_pair as watched_pair

    kernels = project_kernels()
    assert attitude_pd.pd_tick in kernels and watched_pair.pair_watch_tick in kernels
    assert len(kernels) == len({id(k) for k in kernels})
    assert all(isinstance(k, Dispatcher) for k in kernels)
    assert all(k.py_func.__module__.split(".")[0] in ("sim", "fcu", "flightdata", "jitsupport")
               for k in kernels)


_COUNT_A_COMPILE = """
from sim.preparation import KernelProgress
from sim.world import sensors
with KernelProgress() as progress:
    before = progress.snapshot().compiled
    sensors._euler_zyx_compiled(1.0, 0.0, 0.0, 0.0)  # compiled: the cache is empty
    sensors._euler_zyx_compiled(0.5, 0.5, 0.5, 0.5)  # the same types: nothing more
    sensors._euler_zyx_compiled(1, 0, 0, 0)          # integers: a second specialisation
final = progress.finish()
print(before, final.compiled, final.total >= final.compiled, final.done)
print("\\n".join(progress.kernel_names))
"""


def test_compiles_are_counted_once_per_kernel_and_signature(tmp_path: Path) -> None:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    done = subprocess.run([sys.executable, "-c", _COUNT_A_COMPILE], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600, check=True)
    first, *names = done.stdout.strip().splitlines()
    assert first == "0 1 True True"  # one kernel compiled, in two specialisations:
    assert len(names) == 2 and all(n.startswith("sim.world.sensors._euler_zyx(") for n in names)
    # loaded from the cache the first process filled: compiled nothing
    again = subprocess.run([sys.executable, "-c", _COUNT_A_COMPILE], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=600, check=True)
    assert again.stdout.splitlines()[0] == "0 0 True True"
