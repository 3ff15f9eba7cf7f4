"""Cached kernels of a module are dropped when a module of its folder is newer."""

from __future__ import annotations

import os
from pathlib import Path

from flightdata.kernel_cache import drop_stale_kernels


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
