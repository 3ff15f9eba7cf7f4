"""Named state in one flat float array: the one layout helper of the compiled kernels.

A compiled filter, monitor or control part keeps its state in one ``float64`` array, so that
a kernel takes all of it as one argument and the tick's data stay together in memory. The
array is declared as a :class:`Layout`: named fields in order, each with its size, like the
members of a C struct. The helper counts the offsets; a module binds each field's start to
a constant for its kernels (numba folds module-level integers into the compiled code, so a
slice ``work[P:P + NN]`` costs what a hand-written offset did)::

    WORK = Layout("ekf work")
    X = WORK.field("x", N)  # posterior x
    P = WORK.field("P", N * N)  # posterior P (N x N, row-major)
    WORK_SIZE = WORK.size

Python finds a field by name (``WORK["P"].start``); :func:`aligned_zeros` allocates the
array on a cache-line boundary (the row kernels of :mod:`fcu.estimation.small_matrix` load
whole vectors of :data:`LANES` doubles; tests/jitsupport/test_layout.py checks that the
matrices they update start on a vector boundary).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["LANES", "Field", "Layout", "OneStatePart", "aligned_zeros", "hold"]

LANES = 8  # doubles in one 64-byte cache line (and one AVX-512 vector)


@dataclass(frozen=True, slots=True)
class Field:
    """One named stretch of a :class:`Layout`: ``array[start:start + size]``."""

    name: str
    start: int  # entries from the start of the array
    size: int  # entries

    @property
    def stop(self) -> int:
        """One past the field's last entry."""
        return self.start + self.size


class Layout:
    """The fields of one flat array, in the order :meth:`field` declares them."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._fields: dict[str, Field] = {}
        self._inner: dict[str, Field] = {}  # the fields of nested records, "name.field"
        self.size = 0  # entries of the whole array so far

    def field(self, name: str, size: int) -> int:
        """Declare the next field, ``size`` entries; returns its start."""
        if name in self._fields:
            raise ValueError(f"{self.name}: field {name!r} declared twice")
        if size < 0:
            raise ValueError(f"{self.name}: field {name!r} has size {size}")
        start = self.size
        self._fields[name] = Field(name, start, size)
        self.size = start + size
        return start

    def nest(self, name: str, inner: Layout) -> int:
        """Declare the next field as a copy of ``inner``'s whole array (a record inside a
        record); each of its fields is found as ``"name.field"``. Returns its start."""
        start = self.field(name, inner.size)
        for f in inner.fields:
            self._inner[f"{name}.{f.name}"] = Field(f"{name}.{f.name}", start + f.start,
                                                    f.size)
        return start

    def __getitem__(self, name: str) -> Field:
        try:
            return self._fields[name] if name in self._fields else self._inner[name]
        except KeyError:
            raise KeyError(f"{self.name} has no field {name!r} "
                           f"(fields: {', '.join(self._fields)})") from None

    @property
    def fields(self) -> tuple[Field, ...]:
        """Every field, in order (a nested record as one field)."""
        return tuple(self._fields.values())


def aligned_zeros(n: int) -> npt.NDArray[np.float64]:
    """``n`` float zeros whose memory starts on a 64-byte boundary (a cache line, and one
    vector of :data:`LANES` doubles): the filters' packed state, in which every matrix the
    kernels update by whole rows starts at a multiple of ``LANES`` entries, so that none of
    their vector loads and stores straddles two cache lines (numpy's own allocation is
    16-byte aligned: then most of them would, at a cost of about 0.6 us per estimation tick
    of :func:`fcu.estimation.pair.pair_tick`)."""
    raw = np.zeros(n + LANES)
    start = (-(raw.ctypes.data // 8)) % LANES  # entries to the next boundary
    return raw[start:start + n]


def hold(view: npt.NDArray[np.float64], values: npt.NDArray[np.float64]
         ) -> npt.NDArray[np.float64]:
    """``view`` with ``values`` copied in: what a part rebinds a state array to when it is
    asked to keep that state in another array (a compiled chain's workspace), so that its
    own methods and the compiled call work on the same numbers."""
    view[:] = values.reshape(-1)
    return view


class OneStatePart:
    """A compiled part whose kernel reads one parameter vector, :attr:`par`, and updates one
    state vector, :attr:`state` (what a compiled caller such as the control chain asks of a
    part: :meth:`kernel_params`, :meth:`kernel_states`, :meth:`hold_states_in`)."""

    par: npt.NDArray[np.float64]
    state: npt.NDArray[np.float64]

    def kernel_params(self) -> tuple[npt.NDArray[np.float64], ...]:
        """What the kernel reads: :attr:`par`."""
        return (self.par,)

    def kernel_states(self) -> tuple[npt.NDArray[np.float64], ...]:
        """What the kernel updates: :attr:`state`."""
        return (self.state,)

    def hold_states_in(self, views: Sequence[npt.NDArray[np.float64]]) -> None:
        """Keep :attr:`state` in ``views[0]`` (same size) from now on."""
        (view,) = views
        self.state = hold(view, self.state)
