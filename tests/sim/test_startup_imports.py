"""Start-up stays light: the vehicle, the headless runner and the ground station load no
design or plotting library when imported (python-control, scipy.linalg, matplotlib, rerun,
filterpy, dask). Designs come from the design cache; the libraries are imported where they
are used (a design missing from the cache, turbulence's rediscretisation, figures)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("control", "scipy.linalg", "scipy.signal", "matplotlib", "rerun", "filterpy", "dask",
         "distributed")


def test_the_entry_points_import_no_design_or_plotting_library() -> None:
    code = ("import sys\n"
            "import sim.scenario_cli, sim.vehicle, gcs.cli, fcu.autopilot\n"
            f"heavy = {HEAVY!r}\n"
            "print(sorted(m for m in sys.modules if any(m == h or m.startswith(h + '.') "
            "for h in heavy)))\n")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
