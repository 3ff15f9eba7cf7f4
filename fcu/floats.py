"""Plain-float helpers for the per-tick hot paths of the autopilot.

The controllers, the navigator and the allocation work on 3- and 4-element vectors, for
which a numpy call (0.3-2.5 us of overhead each) costs far more than the arithmetic:
per tick they therefore compute with Python floats. Element-wise float operations round
exactly as numpy's element-wise operations do, so the results are the same to the last bit
as long as each expression keeps numpy's order of operations. Two things do not carry over
and stay numpy calls where they appear: matrix products (BLAS fuses multiply-adds) and
numpy's own ``tan``, ``arcsin``, ``arctan2`` and ``hypot`` (SIMD versions that may differ
from ``math``'s in the last bit).

The helpers below reproduce numpy's semantics for one element at a time. Those marked
``@register_jitable`` are also what the kernels call: numba compiles the same function into
a kernel that calls it (no compiled twin to keep in step); a kernel module that calls them
names this file to :func:`jitsupport.cache.drop_stale_kernels`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba.extending import register_jitable

_FLOAT64 = np.dtype(np.float64)  # compared with ==: arrays from cached kernels carry their own
# float64 dtype object, for which `is` fails


@register_jitable(error_model="numpy")
def clip(value: float, lo: float, hi: float) -> float:
    """``np.clip`` of one float: raised to ``lo``, then lowered to ``hi`` (so ``hi`` wins
    when ``lo > hi``, as in numpy); a NaN value passes through."""
    value = lo if value < lo else value
    return hi if value > hi else value


def sign(value: float) -> float:
    """``np.sign`` of one float: -1.0, 0.0 (for +-0) or 1.0; NaN for NaN."""
    if value > 0.0:
        return 1.0
    if value < 0.0:
        return -1.0
    return value if value != value else 0.0


@register_jitable(error_model="numpy")
def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi), rad: ``(a + pi) % (2 pi) - pi`` (Python's float modulo,
    which numpy's and numba's follow); a Python float for any float given."""
    return float((angle_rad + math.pi) % (2.0 * math.pi) - math.pi)


@register_jitable(error_model="numpy")
def py_min(a: float, b: float) -> float:
    """Builtin ``min(a, b)``: ``b`` only when strictly smaller (for kernels)."""
    return b if b < a else a


@register_jitable(error_model="numpy")
def py_max(a: float, b: float) -> float:
    """Builtin ``max(a, b)``: ``b`` only when strictly larger (for kernels)."""
    return b if b > a else a


def floats(value: np.ndarray | Sequence[float], n: int) -> list[float]:
    """The ``n`` entries of a float vector as Python floats (any array-like of shape (n,)).

    Raises ValueError when ``value`` does not hold exactly ``n`` entries.
    """
    if type(value) is np.ndarray and value.dtype == _FLOAT64 and value.shape == (n,):
        return value.tolist()
    if type(value) is tuple and len(value) == n:
        return [float(v) for v in value]
    return np.asarray(value, dtype=float).reshape(n).tolist()
