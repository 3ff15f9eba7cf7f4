"""Compiled scalar helpers the control kernels share, with Python's and ``fcu.floats``'s
semantics (so a kernel rounds, and picks among equal values, exactly as the float code it
replaced): ``clip`` raises to ``lo`` then lowers to ``hi``; ``py_min``/``py_max`` keep the
first argument unless the second is strictly smaller/larger (builtin ``min``/``max``)."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, error_model="numpy")
def clip(value: float, lo: float, hi: float) -> float:
    """``fcu.floats.clip``: raised to ``lo``, then lowered to ``hi``; NaN passes through."""
    value = lo if value < lo else value
    return hi if value > hi else value


@njit(cache=True, error_model="numpy")
def py_min(a: float, b: float) -> float:
    """Builtin ``min(a, b)``: ``b`` only when strictly smaller."""
    return b if b < a else a


@njit(cache=True, error_model="numpy")
def py_max(a: float, b: float) -> float:
    """Builtin ``max(a, b)``: ``b`` only when strictly larger."""
    return b if b > a else a


@njit(cache=True, error_model="numpy")
def wrap_pi(angle_rad: float) -> float:
    """``fcu.floats.wrap_pi``: ``(a + pi) % (2 pi) - pi``, rad (Python's float modulo)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi
