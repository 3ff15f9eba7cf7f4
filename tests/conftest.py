"""Repository-wide pytest configuration.

``gcs.pytest_plugin`` provides the ``vehicle_link`` fixture (a started ``ftc-vehicle`` and a
connected ground-station link) and the ``vehicle`` marker; see its docstring and the README.

Start-up designs are cached (:mod:`fcu.design_cache`) in a temporary directory of the test
session, never in the user's cache: the vehicles the tests start inherit it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from fcu.design_cache import CACHE_DIR_ENV

pytest_plugins = ["gcs.pytest_plugin"]


@pytest.fixture(scope="session", autouse=True)
def _design_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    before = os.environ.get(CACHE_DIR_ENV)
    os.environ[CACHE_DIR_ENV] = str(tmp_path_factory.mktemp("design-cache"))
    yield
    if before is None:
        os.environ.pop(CACHE_DIR_ENV, None)
    else:
        os.environ[CACHE_DIR_ENV] = before
