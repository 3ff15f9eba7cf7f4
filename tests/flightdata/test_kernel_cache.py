"""Cached kernels of a module are dropped when a module of its folder is newer, in the
folder numba keeps them in."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core import config as numba_config

from flightdata.kernel_cache import drop_stale_kernels, kernel_cache_folder


@pytest.fixture(autouse=True)
def _in_tree_cache(monkeypatch: pytest.MonkeyPatch) -> None:
    """numba's cache beside the modules (``__pycache__``), whatever NUMBA_CACHE_DIR the
    test run was given."""
    monkeypatch.setattr(numba_config, "CACHE_DIR", "")


def _package(tmp_path: Path) -> tuple[Path, list[Path]]:
    (tmp_path / "caller.py").write_text("")
    (tmp_path / "callee.py").write_text("")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    files = [cache / "caller.tick-10.py311.nbi", cache / "caller.tick-10.py311.1.nbc",
             cache / "callee.step-5.py311.nbi"]
    for f in files:
        f.write_bytes(b"x")
    return tmp_path, files


def _age(path: Path, mtime_s: float) -> None:
    os.utime(path, (mtime_s, mtime_s))


def test_a_newer_sibling_drops_only_the_callers_kernels(tmp_path: Path) -> None:
    pkg, (index, data, other) = _package(tmp_path)
    for f in (pkg / "caller.py", index, data, other):
        _age(f, 1000.0)
    _age(pkg / "callee.py", 2000.0)  # edited after the caller was compiled
    deleted = drop_stale_kernels(str(pkg / "caller.py"))
    assert sorted(deleted) == sorted([index, data])
    assert not index.exists() and not data.exists() and other.exists()


def test_a_newer_module_named_from_elsewhere_drops_the_callers_kernels(
        tmp_path: Path) -> None:
    pkg, (index, data, other) = _package(tmp_path)
    shared = tmp_path / "other" / "shared.py"  # another folder's module it compiles in
    shared.parent.mkdir()
    shared.write_text("")
    for f in (pkg / "caller.py", pkg / "callee.py", index, data, other):
        _age(f, 1000.0)
    _age(shared, 2000.0)
    assert drop_stale_kernels(str(pkg / "caller.py")) == []  # not named: not looked at
    deleted = drop_stale_kernels(str(pkg / "caller.py"), str(shared))
    assert sorted(deleted) == sorted([index, data])


def test_a_fresh_cache_is_kept(tmp_path: Path) -> None:
    pkg, files = _package(tmp_path)
    for f in (pkg / "caller.py", pkg / "callee.py"):
        _age(f, 1000.0)
    for f in files:
        _age(f, 2000.0)  # compiled after the last edit
    assert drop_stale_kernels(str(pkg / "caller.py")) == []
    assert all(f.exists() for f in files)


def test_no_cache_folder_is_nothing_to_do(tmp_path: Path) -> None:
    (tmp_path / "caller.py").write_text("")
    assert drop_stale_kernels(str(tmp_path / "caller.py")) == []


def _kernel_module(folder: Path) -> Path:
    folder.mkdir(parents=True)
    module = folder / "kernels.py"
    module.write_text("from numba import njit\n\n\n@njit(cache=True)\n"
                      "def twice(x):\n    return 2.0 * x\n")
    return module


def _compile(module: Path, env: dict[str, str]) -> None:
    """``twice`` compiled (and cached by numba) in a process of its own."""
    subprocess.run([sys.executable, "-c", "import kernels; kernels.twice(1.5)"],
                   cwd=module.parent, env=env, check=True, timeout=300)


def test_the_folder_looked_in_is_where_numba_caches_with_numba_cache_dir(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    module = _kernel_module(tmp_path / "pkg")
    numba_cache = tmp_path / "numba-cache"
    _compile(module, {**os.environ, "NUMBA_CACHE_DIR": str(numba_cache)})
    monkeypatch.setattr(numba_config, "CACHE_DIR", str(numba_cache))
    folder = kernel_cache_folder(str(module))
    assert folder.is_relative_to(numba_cache)
    cached = sorted(folder.glob("kernels.twice-*.nb[ic]"))
    assert len(cached) == 2  # the index and the code numba wrote
    assert not list(module.parent.glob("__pycache__/*.nb[ic]"))  # none beside the module
    # a sibling edited after the compile: the kernels numba would load are dropped
    for f in cached:
        os.utime(f, (1000.0, 1000.0))
    (module.parent / "helper.py").write_text("")
    assert sorted(drop_stale_kernels(str(module))) == cached
    assert not any(f.exists() for f in cached)


def test_the_folder_looked_in_is_where_numba_caches_beside_the_module(tmp_path: Path) -> None:
    module = _kernel_module(tmp_path / "pkg")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    _compile(module, env)
    folder = kernel_cache_folder(str(module))
    assert folder == module.parent / "__pycache__"
    assert len(list(folder.glob("kernels.twice-*.nb[ic]"))) == 2
