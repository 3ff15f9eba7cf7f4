"""Cached kernels of a module are dropped when the contents of a module of its folder (or of a
module it names) changed, in the folder numba keeps them in; modification times alone do not."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core import config as numba_config

from jitsupport.cache import drop_stale_kernels, kernel_cache_folder, sources_fingerprint


@pytest.fixture(autouse=True)
def _in_tree_cache(monkeypatch: pytest.MonkeyPatch) -> None:
    """numba's cache beside the modules (``__pycache__``), whatever NUMBA_CACHE_DIR the
    test run was given."""
    monkeypatch.setattr(numba_config, "CACHE_DIR", "")


def _package(tmp_path: Path) -> tuple[Path, list[Path]]:
    """A folder of two modules whose caller's kernels were cached from the sources as they
    are (fingerprint written), and a callee's kernel."""
    (tmp_path / "caller.py").write_text("def tick(): ...\n")
    (tmp_path / "callee.py").write_text("def step(): ...\n")
    cache = tmp_path / "__pycache__"
    assert drop_stale_kernels(str(tmp_path / "caller.py")) == []  # fingerprint written
    files = [cache / "caller.tick-10.py311.nbi", cache / "caller.tick-10.py311.1.nbc",
             cache / "callee.step-5.py311.nbi"]
    for f in files:
        f.write_bytes(b"x")
    return tmp_path, files


def test_a_changed_sibling_drops_only_the_callers_kernels(tmp_path: Path) -> None:
    pkg, (index, data, other) = _package(tmp_path)
    (pkg / "callee.py").write_text("def step(): return 1\n")  # edited after the compile
    deleted = drop_stale_kernels(str(pkg / "caller.py"))
    assert sorted(deleted) == sorted([index, data])
    assert not index.exists() and not data.exists() and other.exists()
    assert drop_stale_kernels(str(pkg / "caller.py")) == []  # the new sources' fingerprint


def test_a_pull_that_leaves_the_sources_as_they_were_keeps_the_kernels(tmp_path: Path) -> None:
    pkg, files = _package(tmp_path)
    for f in (pkg / "caller.py", pkg / "callee.py"):  # rewritten with the same contents
        f.write_text(f.read_text())
        os.utime(f, (4e9, 4e9))  # newer than every cached kernel
    assert drop_stale_kernels(str(pkg / "caller.py")) == []
    assert all(f.exists() for f in files)


def test_a_changed_module_named_from_elsewhere_drops_the_callers_kernels(
        tmp_path: Path) -> None:
    shared = tmp_path / "other" / "shared.py"  # another folder's module it compiles in
    shared.parent.mkdir()
    shared.write_text("A = 1\n")
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    pkg_files = _package(pkg)[1]
    index, data = pkg_files[:2]
    assert drop_stale_kernels(str(pkg / "caller.py"), str(shared))  # not in the fingerprint yet
    for f in (index, data):
        f.write_bytes(b"x")  # compiled again
    assert drop_stale_kernels(str(pkg / "caller.py"), str(shared)) == []
    shared.write_text("A = 2\n")
    assert sorted(drop_stale_kernels(str(pkg / "caller.py"), str(shared))) == sorted(
        [index, data])


def test_kernels_without_a_fingerprint_are_dropped(tmp_path: Path) -> None:
    pkg, (index, data, other) = _package(tmp_path)
    (pkg / "__pycache__" / "caller.sources").unlink()
    assert sorted(drop_stale_kernels(str(pkg / "caller.py"))) == sorted([index, data])


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
    # the fingerprint of the sources compiled from, then a sibling edited: the kernels numba
    # would load are dropped
    (folder / "kernels.sources").write_text(sources_fingerprint(str(module)))
    assert drop_stale_kernels(str(module)) == []
    (module.parent / "helper.py").write_text("X = 1\n")
    assert sorted(drop_stale_kernels(str(module))) == cached
    assert not any(f.exists() for f in cached)


def test_the_folder_looked_in_is_where_numba_caches_beside_the_module(tmp_path: Path) -> None:
    module = _kernel_module(tmp_path / "pkg")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    _compile(module, env)
    folder = kernel_cache_folder(str(module))
    assert folder == module.parent / "__pycache__"
    assert len(list(folder.glob("kernels.twice-*.nb[ic]"))) == 2
