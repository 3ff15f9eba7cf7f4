"""Start-up designs (LQR gains, ``c2d`` discretisations, filter designs), cached on disk.

Gains come from design code at start-up (python-control's ``dlqr`` and ``c2d``), never from
pasted numbers. Importing python-control and running its designs costs seconds, far more
than the rest of a start-up, and a design is a pure function of its inputs; so a design
function decorated with :func:`cached_design` is run once and its result kept in a
per-user cache directory, keyed by a hash of everything it depends on:

- the design function (module and name) and the source of its module,
- every argument (floats by their exact ``repr``, arrays by dtype, shape and bytes),
- the versions of numpy, scipy and python-control.

A changed input, changed design code or another library version gives another key, so the
design is made afresh (and stored); nothing is ever read back that the same code and
libraries would not compute now. Results are tuples of numpy arrays stored as ``.npz``
(no pickles), exact to the bit. A cache directory that cannot be written only costs the
design time.

Directory: ``$QUADFTC_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/quadftc``, else
``~/.cache/quadftc``. ``QUADFTC_CACHE_DIR=off`` turns the disk cache off (the designs are
then made once per process).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import inspect
import os
import sys
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, TypeVar

import numpy as np

__all__ = ["CACHE_DIR_ENV", "CachedDesign", "cache_dir", "cached_design", "cont2discrete"]

CACHE_DIR_ENV = "QUADFTC_CACHE_DIR"
"""Environment variable naming the cache directory (``off``: no disk cache)."""

Arrays = tuple[np.ndarray, ...]
_MAX_MEMO = 64  # designs kept in memory per design function
_F = TypeVar("_F", bound=Callable[..., Arrays])


class CachedDesign(Protocol):
    """A design function wrapped by :func:`cached_design`."""

    design: Callable[..., Arrays]  # the undecorated function: a fresh design, never cached

    def __call__(self, *args: Any) -> Arrays: ...

    def cache_key(self, *args: Any) -> str: ...

    def cache_clear(self) -> None: ...


def cache_dir() -> Path | None:
    """The cache directory now (see the module docstring); None when turned off."""
    chosen = os.environ.get(CACHE_DIR_ENV)
    if chosen == "off":
        return None
    if chosen:
        return Path(chosen)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "quadftc"


@functools.cache
def _library_versions() -> str:
    import scipy

    try:
        control_version = importlib.metadata.version("control")
    except importlib.metadata.PackageNotFoundError:
        control_version = "absent"
    return f"numpy {np.__version__}; scipy {scipy.__version__}; control {control_version}"


@functools.cache
def _source_digest(module_name: str) -> str:
    module = sys.modules[module_name]
    return hashlib.sha256(Path(inspect.getfile(module)).read_bytes()).hexdigest()


def _feed(digest: Any, value: Any) -> None:
    """Add ``value`` to ``digest`` unambiguously (type tags, lengths, exact floats)."""
    if isinstance(value, np.ndarray):
        data = np.ascontiguousarray(value)
        digest.update(f"ndarray {data.dtype.str} {data.shape};".encode())
        digest.update(data.tobytes())
    elif isinstance(value, tuple | list):
        digest.update(f"{type(value).__name__} {len(value)}[".encode())
        for item in value:
            _feed(digest, item)
        digest.update(b"]")
    elif value is None or isinstance(value, bool | int | float | str | np.floating):
        digest.update(f"{type(value).__name__} {value!r};".encode())
    else:
        raise TypeError(f"design input {value!r}: not a number, string, None, array or tuple")


def _read(path: Path) -> Arrays | None:
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = tuple(stored[f"arr_{i}"] for i in range(len(stored.files)))
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None  # absent, or written by a process that died half-way: made afresh
    return arrays


def _write(path: Path, arrays: Arrays) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as out:
                np.savez(out, *arrays)  # stored as arr_0, arr_1, ...
            os.replace(tmp, path)  # atomic: a concurrent reader sees all or nothing
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    except OSError:
        pass  # an unwritable cache only costs the design time


def cached_design(design: _F) -> _F:
    """Decorate a pure design function returning a tuple of numpy arrays (module docstring).

    The wrapper returns read-only arrays, shared by every caller in the process; its
    ``design`` attribute is the undecorated function, ``cache_key(*args)`` the key and
    ``cache_clear()`` forgets this process's designs (the disk cache is kept).
    """
    name = f"{design.__module__}.{design.__qualname__}"

    def cache_key(*args: Any) -> str:
        digest = hashlib.sha256()
        for part in (name, _source_digest(design.__module__), _library_versions()):
            digest.update(part.encode() + b"\n")
        _feed(digest, args)
        return digest.hexdigest()

    memo: dict[str, Arrays] = {}  # this process's designs, by key

    def made(key: str, args: tuple[Any, ...]) -> Arrays:
        directory = cache_dir()
        path = None if directory is None else directory / "designs" / f"{key}.npz"
        arrays = None if path is None else _read(path)
        if arrays is None:
            arrays = tuple(np.asarray(a) for a in design(*args))
            if path is not None:
                _write(path, arrays)
        for a in arrays:
            a.setflags(write=False)
        return arrays

    @functools.wraps(design)
    def wrapper(*args: Any) -> Arrays:
        key = cache_key(*args)
        arrays = memo.get(key)
        if arrays is None:
            arrays = made(key, args)
            if len(memo) >= _MAX_MEMO:
                memo.clear()
            memo[key] = arrays
        return arrays

    wrapper.design = design  # type: ignore[attr-defined]
    wrapper.cache_key = cache_key  # type: ignore[attr-defined]
    wrapper.cache_clear = memo.clear  # type: ignore[attr-defined]
    return wrapper  # type: ignore[return-value]


@cached_design
def _cont2discrete(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, dt_s: float,
                   method: str) -> Arrays:
    from scipy.signal import cont2discrete as scipy_cont2discrete

    return tuple(scipy_cont2discrete((a, b, c, d), dt_s, method=method)[:4])


def cont2discrete(system: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], dt: float,
                  method: str = "zoh") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                float]:
    """``scipy.signal.cont2discrete`` of a state-space ``(A, B, C, D)``, cached as the designs
    are (scipy.signal is imported only when the cache misses). Returns ``(Ad, Bd, Cd, Dd,
    dt)`` as scipy does; the arrays are read-only."""
    a, b, c, d = (np.asarray(m, dtype=float) for m in system)
    ad, bd, cd, dd = _cont2discrete(a, b, c, d, float(dt), method)
    return ad, bd, cd, dd, dt
