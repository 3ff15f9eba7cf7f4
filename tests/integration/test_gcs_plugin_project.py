"""A project of its own that installs quadftc gets ``vehicle_link`` without a conftest line.

The test writes a throwaway project outside the repository (a folder with one test file that
uses the ``vehicle_link`` fixture and the ``vehicle`` marker, no ``conftest.py``, no pytest
configuration) and runs pytest on it in a subprocess with the installed package: the plugin
arrives through quadftc's ``pytest11`` entry point. It is skipped, saying so, when the
quadftc installed here predates that entry point (reinstall it: ``make setup``).
"""

from __future__ import annotations

import importlib.metadata
import os
import subprocess
import sys
from pathlib import Path

import pytest

PLUGIN = "gcs.pytest_plugin"
RUN_WALL_S = 600.0  # s: a vehicle start-up and a 60 s mission at speed-up 20, loaded CI

pytestmark = pytest.mark.slow

USER_TEST = '''\
import pytest


@pytest.mark.vehicle(speedup=20, seed=1)
def test_the_thesis_mission_is_flown_and_landed(vehicle_link):
    outcome = vehicle_link.fly()

    assert outcome.error is None  # flown, landed and disarmed
    assert outcome.report.flight_s > 50.0  # s in the air of the ~56 s mission
    assert outcome.report.rms["z"] < 0.05  # m
'''


def _entry_point_installed() -> bool:
    return any(ep.value == PLUGIN for ep in importlib.metadata.entry_points(group="pytest11"))


@pytest.mark.skipif(not _entry_point_installed(),
                    reason="the installed quadftc predates its pytest11 entry point: "
                    "reinstall it (make setup)")
def test_a_project_of_its_own_gets_vehicle_link_without_a_conftest(tmp_path: Path) -> None:
    project = tmp_path / "my-flights"
    (project / "tests").mkdir(parents=True)
    (project / "tests" / "test_hover.py").write_text(USER_TEST)
    # (the same interpreter and import path as this process, whose metadata the skip reads)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTEST_ADDOPTS", "PYTEST_PLUGINS", "PYTEST_DISABLE_PLUGIN_AUTOLOAD")}
    proc = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider",
                           "-rA", "tests"], cwd=project, env=env, capture_output=True,
                          text=True, timeout=RUN_WALL_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert "1 passed" in proc.stdout
    assert not list(project.rglob("conftest.py"))  # nothing but the test file
