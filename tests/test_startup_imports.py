"""Start-up stays light: what a command imports loads no library it does not use at once.

The vehicle, the headless runner and the ground station load no design or plotting library
(python-control, scipy.linalg, scipy.signal, matplotlib, rerun, filterpy, dask): designs come
from the design cache, and each library is imported where it is used (a design missing from
the cache, turbulence's rediscretisation, figures, campaigns). A calm world, built and
stepped, loads no scipy.linalg either once its designs are cached. The flight-data toolkit
loads neither matplotlib nor rerun until a figure or a recording is made.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ENTRY_POINTS = "sim.scenario_cli, sim.vehicle, gcs.cli, fcu.autopilot"
DESIGN_AND_PLOTTING = ("control", "scipy.linalg", "scipy.signal", "matplotlib", "rerun",
                       "filterpy", "dask", "distributed")
TOOLKIT = ("flightdata.figures, flightdata.recording, flightdata.report, flightdata.metrics, "
           "flightdata.series, flightdata.geometry")


@pytest.mark.parametrize(("modules", "heavy"), [(ENTRY_POINTS, DESIGN_AND_PLOTTING),
                                                (TOOLKIT, ("matplotlib", "rerun"))],
                         ids=["entry-points", "flightdata-toolkit"])
def test_importing_loads_no_heavy_library(modules: str, heavy: tuple[str, ...]) -> None:
    code = (f"import sys\nimport {modules}\n"
            f"print(sorted(m for m in sys.modules if any(m == h or m.startswith(h + '.') "
            f"for h in {heavy!r})))\n")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


CALM_WORLD = """
import sys
import numpy as np
from sim.world import World, WorldConfig
world = World(WorldConfig(), seed=3)
world.step(np.full(4, 1500.0), 50)
print(sorted(m for m in sys.modules if m == "scipy.linalg" or m.startswith("scipy.signal")))
"""


def test_a_calm_world_loads_no_scipy_linalg_once_its_designs_are_cached() -> None:
    # the first run may make the wind's grid coefficients (scipy.linalg.expm) and store them;
    # the second reads them back, and numba's first kernel load finds the BLAS bindings
    # loaded on their own (jitsupport.cache.preload_blas_bindings)
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", CALM_WORLD], cwd=REPO,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
