"""Calls of a compiled kernel whose argument types never change, past numba's type dispatch.

A numba kernel called from Python goes through its dispatcher: it works out each argument's
type key (an array's dtype, rank, layout and writeability; float, int or bool), finds the
machine code compiled for those types, converts the arguments and runs the code. The type
keys cost 20-40 ns an argument: 0.7 us of a 25-argument call. A tick makes the same few
calls with arguments of the same types every time (the callers' own buffers, scalars they
convert), so :class:`KernelCall` pays for the dispatch once. Its first call goes through the
dispatcher, which checks the types and loads (or compiles) the code; later calls go straight
to that code's entry (``dispatcher.overloads[types].entry_point``, what the dispatcher calls
once it has chosen), which still converts each argument but checks no type.

An argument of another type than the first call's would there be read as if it had the first
call's type (an int64 array as float64, a strided view as contiguous). So a call site uses a
KernelCall only where it fixes its arguments' types itself, and its kernel writes only into
arrays the call site makes itself (a read-only array passed where the first call's was
writeable is read alike). With the environment variable ``QUADFTC_CHECK_KERNEL_CALLS=1``
(the test suite sets it) every call compares the type keys with the first call's and raises
TypeError on a difference other than writeability: each flight the tests fly checks that
its call sites keep to their types.

The entry is numba's (``overloads`` and ``entry_point`` are attributes of its dispatcher and
compile result, not a documented interface): if a numba release moves them, this module is the
one place to change (without an entry, a KernelCall calls the dispatcher).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import types

__all__ = ["CHECK_ENV", "KernelCall"]

CHECK_ENV = "QUADFTC_CHECK_KERNEL_CALLS"
"""Environment variable: ``1`` checks every call's argument types against the first's."""


class KernelCall:
    """``kernel`` (a numba dispatcher) called through :attr:`call` with arguments of fixed
    types, dispatched once (module docstring).

    ``KernelCall(kernel).call(*args)`` returns what ``kernel(*args)`` does. Make one per call
    site, at module level; the bench (``ftc-bench tick``) times a call site by wrapping its
    :attr:`call`.
    """

    __slots__ = ("call", "kernel")

    def __init__(self, kernel: Any) -> None:
        self.kernel = kernel
        self.call: Callable[..., Any] = self._first

    def _first(self, *args: Any) -> Any:
        """The first call: through the dispatcher; later ones go to the code it chose."""
        result = self.kernel(*args)
        entry = _entry_point(self.kernel, args)
        if entry is None:  # (no overload for exactly these types: the dispatcher each time)
            self.call = self.kernel
        elif os.environ.get(CHECK_ENV) == "1":
            self.call = _checked(self.kernel, entry, args)
        else:
            self.call = entry
        return result

    def __repr__(self) -> str:
        return f"KernelCall({self.kernel.__name__})"


def _entry_point(kernel: Any, args: tuple[Any, ...]) -> Callable[..., Any] | None:
    """The entry of ``kernel``'s machine code compiled for exactly the types of ``args``, or
    None."""
    try:
        types = tuple(kernel.typeof_pyval(a) for a in args)
        compiled = kernel.overloads.get(types)
        return None if compiled is None else compiled.entry_point
    except (AttributeError, TypeError, ValueError):  # not a dispatcher as numba's are now
        return None


def _type_key(arg: Any) -> Any:
    """What numba's typing of ``arg`` depends on, cheaply: an array's dtype, rank and
    contiguity; any other value's Python type (a key seen for the first time is checked
    with numba's own typing, :func:`_same_types`)."""
    if isinstance(arg, np.ndarray):
        flags = arg.flags
        return (arg.dtype, arg.ndim, flags.c_contiguous, flags.f_contiguous, flags.aligned)
    return type(arg)


def _type_keys(args: tuple[Any, ...]) -> tuple[Any, ...]:
    return tuple(map(_type_key, args))


def _checked(kernel: Any, entry: Callable[..., Any],
             first_args: tuple[Any, ...]) -> Callable[..., Any]:
    """``entry``, each call's argument types first compared with ``first_args``' (TypeError
    naming the kernel and the argument when numba would type one differently, its
    writeability aside)."""
    first_types = tuple(_read_as(kernel.typeof_pyval(a)) for a in first_args)
    accepted = {_type_keys(first_args)}  # the type keys seen and found to match

    def call(*args: Any) -> Any:
        keys = _type_keys(args)
        if keys not in accepted:
            _same_types(kernel, args, first_types)
            accepted.add(keys)
        return entry(*args)

    return call


def _read_as(numba_type: Any) -> Any:
    """``numba_type``, an array type as writeable: the kernels read an array the same way
    whether or not its caller may write to it, and write only into their call site's own
    buffers."""
    return numba_type.copy(readonly=False) if isinstance(numba_type, types.Array) else numba_type


def _same_types(kernel: Any, args: tuple[Any, ...], first_types: tuple[Any, ...]) -> None:
    """TypeError unless ``args`` have ``first_types`` (:func:`_read_as`)."""
    if len(args) != len(first_types):
        raise TypeError(f"{kernel.__name__}: {len(args)} arguments, the first call had "
                        f"{len(first_types)}")
    for i, (arg, first) in enumerate(zip(args, first_types, strict=True)):
        got = _read_as(kernel.typeof_pyval(arg))
        if got != first:
            raise TypeError(f"{kernel.__name__}: argument {i} is {got}, the first call's was "
                            f"{first} (a KernelCall's argument types must not change)")
