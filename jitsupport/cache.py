"""Keep numba's on-disk kernel cache from running stale code.

``@njit(cache=True)`` stores a compiled kernel in ``__pycache__`` beside its module, keyed on
that module's source file only. A kernel that calls kernels of *other* modules has their code
compiled into its own, so after one of those modules changes (an edit, a ``git pull``) the
cached caller would go on running the old callee: silently wrong numbers. A module whose
kernels call other modules' kernels calls :func:`drop_stale_kernels` at import, before any of
its kernels runs: when the contents of a module of its folder (or of a module elsewhere it
names) differ from those its cached kernels were compiled from, its cached kernels are
deleted, and numba compiles them again (once) on first call. Contents, not modification
times: a ``git pull`` that does not touch kernel code keeps the compiled cache.
The cache looked in is the one numba uses for the module: the folder
``NUMBA_CACHE_DIR`` names when it is set, else ``__pycache__`` beside the module when that can
be written, else numba's per-user cache (:func:`kernel_cache_folder`).

:func:`preload_blas_bindings`, called by a composition root before its first kernel runs
(the world's constructor), readies the BLAS and LAPACK bindings numba links compiled code
against, so that the first kernel loaded does not import all of ``scipy.linalg`` for them.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import sys
from pathlib import Path

__all__ = ["drop_stale_kernels", "kernel_cache_folder", "preload_blas_bindings",
           "sources_fingerprint"]

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


def sources_fingerprint(module_file: str, *also: str) -> str:
    """SHA-256 of the contents of every ``.py`` file in the folder of ``module_file`` and of
    the files ``also``, with their names: what the module's kernels are compiled from."""
    source = Path(module_file)
    digest = hashlib.sha256()
    for path in sorted({*source.parent.glob("*.py"), *map(Path, also)}):
        digest.update(path.name.encode() + b"\0")
        try:
            digest.update(path.read_bytes())
        except OSError:
            digest.update(b"(unreadable)")
        digest.update(b"\0")
    return digest.hexdigest()


def drop_stale_kernels(module_file: str, *also: str) -> list[Path]:
    """Delete the cached kernels of the module at ``module_file`` (in
    :func:`kernel_cache_folder`) when the sources they were compiled from have changed; returns
    the files deleted (none when the cache is current, absent or cannot be read).

    The sources are every ``.py`` file in the module's folder and the files ``also`` (modules
    elsewhere whose kernels it compiles in); their :func:`sources_fingerprint` is kept beside
    the kernels (``<module>.sources``). Contents are compared, not modification times: a
    ``git pull`` or a checkout that leaves those files as they were keeps the kernels, one that
    changes any of them drops them (numba compiles them again, once, on first call). Kernels
    with no fingerprint beside them (written by an older release) are dropped.
    """
    source = Path(module_file)
    cache = kernel_cache_folder(module_file)
    stamp = cache / f"{source.stem}.sources"
    fingerprint = sources_fingerprint(module_file, *also)
    try:
        if stamp.read_text() == fingerprint:
            return []
    except OSError:
        pass  # no fingerprint yet
    deleted = []
    try:
        cached = [*cache.glob(f"{source.stem}.*.nbi"), *cache.glob(f"{source.stem}.*.nbc")]
    except OSError:
        cached = []
    for path in cached:
        try:
            path.unlink()
            deleted.append(path)
        except OSError:
            pass  # another process got there first, or a read-only cache: numba copes
    try:
        cache.mkdir(parents=True, exist_ok=True)
        partial = stamp.with_name(f"{stamp.name}.{os.getpid()}")
        partial.write_text(fingerprint)
        partial.replace(stamp)  # (atomic: a process starting meanwhile reads a whole one)
    except OSError:
        pass  # a read-only cache: numba cannot write kernels there either
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

