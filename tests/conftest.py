"""Repository-wide pytest configuration.

``gcs.pytest_plugin`` provides the ``vehicle_link`` fixture (a started ``ftc-vehicle`` and a
connected ground-station link) and the ``vehicle`` marker; see its docstring and the README.

Test tiers: every test that flies a whole mission gets the ``slow`` marker here, by where it
lives (:data:`WHOLE_FLIGHT_FOLDERS`) or by a fixture it uses (:data:`WHOLE_FLIGHT_FIXTURES`),
so test files need not say so; ``make test-fast`` runs ``-m "not slow"``, ``make test`` all.

Start-up designs are cached (:mod:`fcu.design_cache`) in a temporary directory of the test
session, never in the user's cache: the vehicles the tests start inherit it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from fcu.design_cache import CACHE_DIR_ENV

pytest_plugins = ["gcs.pytest_plugin"]

TESTS = Path(__file__).resolve().parent
WHOLE_FLIGHT_FOLDERS = (TESTS / "integration",)  # vehicle processes flying missions
WHOLE_FLIGHT_FIXTURES = frozenset({"vehicle_link", "start_vehicle"})  # a vehicle flies


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark the whole-flight tests ``slow`` (module docstring)."""
    for item in items:
        path = Path(str(item.path))
        if (any(path.is_relative_to(folder) for folder in WHOLE_FLIGHT_FOLDERS)
                or WHOLE_FLIGHT_FIXTURES.intersection(getattr(item, "fixturenames", ()))):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session", autouse=True)
def _design_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    before = os.environ.get(CACHE_DIR_ENV)
    os.environ[CACHE_DIR_ENV] = str(tmp_path_factory.mktemp("design-cache"))
    yield
    if before is None:
        os.environ.pop(CACHE_DIR_ENV, None)
    else:
        os.environ[CACHE_DIR_ENV] = before
