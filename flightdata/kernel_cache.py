"""Keep numba's on-disk kernel cache from running stale code.

``@njit(cache=True)`` stores a compiled kernel in ``__pycache__`` beside its module, keyed on
that module's source file only. A kernel that calls kernels of *other* modules has their code
compiled into its own, so after one of those modules changes (an edit, a ``git pull``) the
cached caller would go on running the old callee: silently wrong numbers. A module whose
kernels call other modules' kernels calls :func:`drop_stale_kernels` at import, before any of
its kernels runs: when a module of its folder (or a module elsewhere it names) is newer than
its oldest cached kernel, its cached kernels are deleted, and numba compiles them again
(once) on first call. The cache looked in is the one numba uses for the module: the folder
``NUMBA_CACHE_DIR`` names when it is set, else ``__pycache__`` beside the module when that can
be written, else numba's per-user cache (:func:`kernel_cache_folder`).

:func:`preload_blas_bindings`, called by a composition root before its first kernel runs
(the world's constructor), readies the BLAS and LAPACK bindings numba links compiled code
against, so that the first kernel loaded does not import all of ``scipy.linalg`` for them.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
from pathlib import Path

__all__ = ["drop_stale_kernels", "kernel_cache_folder", "preload_blas_bindings"]

_BLAS_MODULES = ("scipy.linalg.cython_blas", "scipy.linalg.cython_lapack")


def _locator_probe() -> None:
    """A function for numba's cache locators to place (they read its first line only)."""


def kernel_cache_folder(module_file: str) -> Path:
    """The folder where numba keeps the cached kernels of the module at ``module_file``: the
    first of its cache locators that takes the file (``NUMBA_CACHE_DIR``'s folder for it,
    ``__pycache__`` beside it, numba's per-user cache), as numba itself chooses at
    ``@njit(cache=True)``; ``__pycache__`` beside it if numba's locators (its internals)
    cannot be asked."""
    try:
        from numba.core import caching

        # (older numba releases name it _CacheImpl)
        impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")  # noqa: B009
        for locator_class in impl._locator_classes:
            locator = locator_class.from_function(_locator_probe, module_file)
            if locator is not None:
                return Path(locator.get_cache_path())
    except (AttributeError, ImportError, OSError, TypeError):
        pass
    return Path(module_file).parent / "__pycache__"


def drop_stale_kernels(module_file: str, *also: str) -> list[Path]:
    """Delete the cached kernels of the module at ``module_file`` (in
    :func:`kernel_cache_folder`) when any ``.py`` file in its folder, or any of the files
    ``also`` (modules elsewhere whose kernels it compiles in), is newer than the oldest of
    them; returns the files deleted (none when the cache is fresh, absent or cannot be
    read)."""
    source = Path(module_file)
    cache = kernel_cache_folder(module_file)
    try:
        cached = list(cache.glob(f"{source.stem}.*.nbi")) + list(
            cache.glob(f"{source.stem}.*.nbc"))
        if not cached:
            return []
        oldest_s = min(p.stat().st_mtime for p in cached)
        sources = [*source.parent.glob("*.py"), *map(Path, also)]
        newest_source_s = max(p.stat().st_mtime for p in sources)
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


def preload_blas_bindings() -> list[str]:
    """Load SciPy's Cython BLAS and LAPACK binding modules on their own, without the
    ``scipy.linalg`` package around them; returns the names loaded.

    The first kernel a process loads makes numba set up its compiler context, which checks
    for BLAS by ``import scipy.linalg.cython_blas``; the import system runs
    ``scipy.linalg/__init__.py`` first, and that (decompositions, the array-API layer, part
    of ``numpy.f2py``) costs about 0.2 s of CPU at every start-up, for two extension modules
    of about 10 ms. A module already in ``sys.modules`` is not imported again, so loading
    the two extension modules from their files here leaves numba the same modules (the
    kernels that multiply matrices read their BLAS routines from the first one) at a
    fraction of the cost. Nothing is done when they are loaded already or when SciPy or its
    files cannot be found (numba then imports them its own way, or reports their absence);
    ``import scipy.linalg`` later works as usual.
    """
    loaded: list[str] = []
    for name in _BLAS_MODULES:
        if name in sys.modules:
            continue
        try:
            scipy_spec = importlib.util.find_spec("scipy")
            if scipy_spec is None or not scipy_spec.submodule_search_locations:
                return loaded
            folder = Path(next(iter(scipy_spec.submodule_search_locations))) / "linalg"
            stem = name.rpartition(".")[2]
            path = next(p for suffix in importlib.machinery.EXTENSION_SUFFIXES
                        if (p := folder / f"{stem}{suffix}").is_file())
            loader = importlib.machinery.ExtensionFileLoader(name, str(path))
            spec = importlib.util.spec_from_file_location(name, path, loader=loader)
            if spec is None:
                return loaded
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            loader.exec_module(module)
        except (ImportError, OSError, StopIteration):
            sys.modules.pop(name, None)
            return loaded
        loaded.append(name)
    return loaded

