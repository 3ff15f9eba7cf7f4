"""Repository-wide pytest configuration.

``gcs.pytest_plugin`` provides the ``vehicle_link`` fixture (a started ``ftc-vehicle`` and a
connected ground-station link) and the ``vehicle`` marker; see its docstring and the README.
An installed quadftc registers it through its ``pytest11`` entry point; this file names it
in ``pytest_plugins`` only when that entry point is not installed (an install that predates
it, or plugin autoloading turned off), since pytest refuses a plugin registered twice.

Test tiers: every test that flies a whole mission gets the ``slow`` marker here, by where it
lives (:data:`WHOLE_FLIGHT_FOLDERS`) or by a fixture it uses (:data:`WHOLE_FLIGHT_FIXTURES`),
so test files need not say so; ``make test-fast`` runs ``-m "not slow"``, ``make test`` all.

On pytest-xdist workers (``make test``) the whole flights go first, so that the longest modules
do not end the run alone; before the workers start, ``ftc-vehicle --precompile`` compiles
numba's kernels (seconds once they are cached), so that no vehicle started by a test compiles
them (minutes on a loaded machine) and the workers do not compile the same kernels twice.

Start-up designs are cached (:mod:`flightdata.design_cache`) in a temporary directory of the test
session, never in the user's cache: the vehicles the tests start inherit it.

Every compiled call made through a :class:`jitsupport.calls.KernelCall` checks its
argument types against its first call's (the vehicles the tests start inherit that too), so
that a call site whose types drift fails the flight that shows it.
"""

from __future__ import annotations

import importlib.metadata
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from flightdata.design_cache import CACHE_DIR_ENV
from jitsupport.calls import CHECK_ENV

os.environ[CHECK_ENV] = "1"  # (module docstring; set before any kernel is first called)

PLUGIN = "gcs.pytest_plugin"


def _plugin_from_entry_point() -> bool:
    """pytest loads :data:`PLUGIN` by itself: an installed ``pytest11`` entry point names it
    and plugin autoloading is on."""
    if os.environ.get("PYTEST_DISABLE_PLUGIN_AUTOLOAD"):
        return False
    return any(ep.value == PLUGIN for ep in importlib.metadata.entry_points(group="pytest11"))


if not _plugin_from_entry_point():
    pytest_plugins = [PLUGIN]

TESTS = Path(__file__).resolve().parent
WHOLE_FLIGHT_FOLDERS = (TESTS / "integration",)  # vehicle processes flying missions
WHOLE_FLIGHT_FIXTURES = frozenset({"vehicle_link", "start_vehicle"})  # a vehicle flies
# every kernel the project can run (sim.preparation.precompile; make setup has run it already,
# so this only loads them, unless a test run follows an edit of kernel code)
KERNEL_WARM_UP = [sys.executable, "-m", "sim", "--precompile"]
WARM_UP_S = 1200.0  # s wall: every kernel compiled from scratch on a loaded machine


def _in_whole_flight_folder(item: pytest.Item) -> bool:
    path = Path(str(item.path))
    return any(path.is_relative_to(folder) for folder in WHOLE_FLIGHT_FOLDERS)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark the whole-flight tests ``slow``; on xdist workers, put them first (module
    docstring)."""
    for item in items:
        if (_in_whole_flight_folder(item)
                or WHOLE_FLIGHT_FIXTURES.intersection(getattr(item, "fixturenames", ()))):
            item.add_marker(pytest.mark.slow)
    if hasattr(config, "workerinput"):  # a stable sort: every worker collects the same order
        items.sort(key=lambda item: not _in_whole_flight_folder(item))


def pytest_sessionstart(session: pytest.Session) -> None:
    """Before xdist's workers start, when whole flights may run: compile the kernels once."""
    config = session.config
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return  # a worker, or a run in one process: kernels compile on first use
    if "not slow" in (config.getoption("markexpr", "") or ""):
        return  # no whole flight in this run
    with tempfile.TemporaryDirectory() as designs:  # never the user's design cache
        done = subprocess.run(KERNEL_WARM_UP, cwd=TESTS.parent, capture_output=True,
                              text=True, timeout=WARM_UP_S, stdin=subprocess.DEVNULL,
                              env={**os.environ, CACHE_DIR_ENV: designs})
    if done.returncode != 0:
        raise pytest.UsageError(f"kernel warm-up flight failed: {done.stderr[-2000:]}")


@pytest.fixture(scope="session", autouse=True)
def _design_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    before = os.environ.get(CACHE_DIR_ENV)
    os.environ[CACHE_DIR_ENV] = str(tmp_path_factory.mktemp("design-cache"))
    yield
    if before is None:
        os.environ.pop(CACHE_DIR_ENV, None)
    else:
        os.environ[CACHE_DIR_ENV] = before
