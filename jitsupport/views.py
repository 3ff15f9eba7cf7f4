"""Array views for compiled kernels that cost next to nothing to make.

The filters and the control chain keep their matrices in one flat workspace each and view
stretches of it as matrices. numba's ``reshape`` makes such a view through its general
reshape routine (an out-of-line call that checks every layout), and every view, reshaped or
sliced, takes and later drops a reference to the memory with atomic operations: about 20 ns
a view, and a tick makes a few hundred. :func:`shaped` builds a C-order view directly, and
:func:`borrowed` re-issues a kernel's argument as a view that holds no reference, so that its
slices cost no reference counting either. Both views are valid only while the array they
come from is alive: a kernel makes them of its own arguments (or views of them) and never
returns or keeps them (as ``numba.carray`` views of foreign memory). Never of an array the
kernel allocates itself: numba frees a local array after its last use, which may come before
the view's.

Views without a reference still leave numba's reference counting *calls* (a call to the
runtime's incref or decref, which then finds no reference to count) wherever a view is made,
passed or dropped: a few hundred per estimation tick. :data:`refcount_free_kernel` compiles a
kernel that allocates nothing without numba's runtime (NRT), so without any of those calls.

Kernels that use them compile this module's code into their own: their modules pass this
file to :func:`jitsupport.cache.drop_stale_kernels`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

__all__ = ["borrowed", "carve", "refcount_free_kernel", "shaped"]

# (_nrt: a target option of numba's that its type stubs do not list)
refcount_free_kernel = njit(cache=True, error_model="numpy",  # type: ignore[call-overload]
                            _nrt=False)
"""``@njit(cache=True, error_model="numpy")`` for a kernel that allocates nothing, compiled
without numba's runtime (NRT, its option ``_nrt=False``): no reference counting calls at all
(module docstring; about 0.6 us of the 9 us of :func:`fcu.estimation.pair.pair_tick`). Such a
kernel cannot allocate an array, return a view (a function that does, inlined into it with
``inline="always"``, may) or assign a slice that may overlap its source: numba refuses to
compile it. It may be called from any kernel or from Python; the kernels it calls are
compiled with their own options."""


@intrinsic
def _c_order_view(typingctx: Any, flat: Any, shape: Any) -> Any:
    """``flat`` (1D, C-contiguous) viewed with ``shape`` (a tuple of ints), C order, sharing
    its memory; the size is not checked (:func:`shaped` does).

    The view holds no reference to ``flat``'s memory (module docstring)."""
    if not (isinstance(flat, types.Array) and flat.ndim == 1 and flat.layout == "C"
            and isinstance(shape, types.UniTuple) and isinstance(shape.dtype, types.Integer)):
        return None
    ndim = shape.count
    view_type = flat.copy(ndim=ndim, layout="C")

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        flat_value, shape_value = args
        src = make_array(signature.args[0])(context, builder, flat_value)
        view = make_array(view_type)(context, builder)
        dims = [context.cast(builder, builder.extract_value(shape_value, i), shape.dtype,
                             types.intp) for i in range(ndim)]
        itemsize = context.get_constant(
            types.intp, context.get_abi_sizeof(context.get_data_type(flat.dtype)))
        # C order: the last axis steps one item, each axis before it a whole row of the next
        strides = [itemsize]
        for dim in reversed(dims[1:]):
            strides.insert(0, builder.mul(strides[0], dim))
        populate_array(view, data=src.data, shape=cgutils.pack_array(builder, dims),
                       strides=cgutils.pack_array(builder, strides), itemsize=itemsize,
                       meminfo=None, parent=None)
        return view._getvalue()

    return view_type(flat, shape), codegen


@intrinsic
def _unreferenced(typingctx: Any, array: Any) -> Any:
    """``array`` (C-contiguous) again, holding no reference to its memory
    (:func:`borrowed`)."""
    if not (isinstance(array, types.Array) and array.layout == "C"):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        src = make_array(array)(context, builder, args[0])
        view = make_array(array)(context, builder)
        populate_array(view, data=src.data, shape=src.shape, strides=src.strides,
                       itemsize=src.itemsize, meminfo=None, parent=None)
        return view._getvalue()

    return array(array), codegen


@njit(cache=True, error_model="numpy", inline="always")
def borrowed(array: np.ndarray) -> np.ndarray:
    """``array`` (C-contiguous) again, holding no reference to its memory, as the views of
    :func:`shaped`: slices of it then cost no reference counting either. For a kernel's own
    arguments, which outlive the call; never returned or kept."""
    return _unreferenced(array)  # type: ignore[call-arg]


@njit(cache=True, error_model="numpy", inline="always")
def shaped(flat: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``flat.reshape(shape)`` for a C-contiguous 1D ``flat`` of exactly that many entries
    (ValueError otherwise): a view in C order, without numba's general reshape call and
    without a reference to ``flat``'s memory, so valid only while ``flat`` is (a kernel's
    view of its own arguments, never returned or kept)."""
    size = 1
    for dim in shape:
        size *= dim
    if size != flat.size:
        raise ValueError("shaped: the shape does not match the size")
    return _c_order_view(flat, shape)  # type: ignore[call-arg]


@njit(cache=True, error_model="numpy", inline="always")
def carve(flat: np.ndarray, at: int, shape: tuple[int, ...],
          room: int = -1) -> tuple[np.ndarray, int]:
    """The next matrix of a workspace laid out as it is used: ``flat[at:]`` viewed with
    ``shape`` (:func:`shaped`), and where the next one starts, ``room`` entries on (the
    view's size when ``room`` is -1; a larger ``room`` keeps the place of the largest such
    matrix, so the views after it stay put whatever the sizes of this call)::

        ap, at = carve(scratch, 0, (n, n))
        w, at = carve(scratch, at, (n, n_g))
    """
    size = 1
    for dim in shape:
        size *= dim
    return shaped(flat[at:at + size], shape), at + (size if room < 0 else room)
