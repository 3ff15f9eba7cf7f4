"""Keep numba's on-disk kernel cache from running stale code.

``@njit(cache=True)`` stores a compiled kernel in ``__pycache__`` beside its module, keyed on
that module's source file only. A kernel that calls kernels of *other* modules has their code
compiled into its own, so after one of those modules changes (an edit, a ``git pull``) the
cached caller would go on running the old callee: silently wrong numbers. A module whose
kernels call other modules' kernels calls :func:`drop_stale_kernels` at import, before any of
its kernels runs: when a module of its folder is newer than its oldest cached kernel, its
cached kernels are deleted, and numba compiles them again (once) on first call.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["drop_stale_kernels"]


def drop_stale_kernels(module_file: str) -> list[Path]:
    """Delete the cached kernels of the module at ``module_file`` when any ``.py`` file in
    its folder is newer than the oldest of them; returns the files deleted (none when the
    cache is fresh, absent or cannot be read)."""
    source = Path(module_file)
    cache = source.parent / "__pycache__"
    try:
        cached = list(cache.glob(f"{source.stem}.*.nbi")) + list(
            cache.glob(f"{source.stem}.*.nbc"))
        if not cached:
            return []
        oldest_s = min(p.stat().st_mtime for p in cached)
        newest_source_s = max(p.stat().st_mtime for p in source.parent.glob("*.py"))
    except OSError:
        return []
    if newest_source_s <= oldest_s:
        return []
    deleted = []
    for path in cached:
        try:
            path.unlink()
            deleted.append(path)
        except OSError:
            pass  # another process got there first, or a read-only cache: numba copes
    return deleted
