"""Kernels compiled for one declared signature.

numba compiles a kernel that another kernel calls with a constant argument (``f(a, 0, 16)``,
a module constant, an omitted default) for that argument's *value* (a ``Literal`` type): a
whole compile, and a cache entry, for every distinct constant, each giving the same machine
code once LLVM has inlined the call. A kernel declared with its signature
(:func:`typed_kernel`) is compiled once, at import (or loaded from the cache), and every call
converts its arguments to that signature. Only a kernel whose constant arguments are meant to
be specialised keeps numba's lazy form (the small products' unrolled four-column variants in
:mod:`fcu.estimation.small_matrix`).

Signatures are numba's strings: ``"int64(float64[:, ::1], int64)"``; ``[::1]`` is a
C-contiguous axis, ``void`` no result. A declared kernel takes no default arguments (numba
cannot fill them into a declared signature): its callers pass every argument.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit

__all__ = ["typed_kernel"]


def typed_kernel(signature: str, *, refcount_free: bool = False) -> Callable[[Any], Any]:
    """``@njit(signature, cache=True, error_model="numpy")``; ``refcount_free``: compiled
    without numba's runtime, as :data:`jitsupport.views.refcount_free_kernel`."""
    options: dict[str, Any] = {"cache": True, "error_model": "numpy"}
    if refcount_free:
        options["_nrt"] = False
    return njit(signature, **options)
