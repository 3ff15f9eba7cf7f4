"""Small dense matrix kernels for the filters' compiled ticks (no allocation, no BLAS).

The filters' matrices are 16 x 16 or smaller, and most of them are sparse with a fixed
pattern (the EKF's Jacobian and its series, the TSKF's discrete model, the measurement rows).
At that size a BLAS call costs more in its set-up than in its arithmetic, so these kernels
work in place on preallocated buffers, skip zero entries of the left factor, and run their
inner loops along rows (``out[i, :] += a[i, k] b[k, :]``), which the compiler vectorises.
"""

from __future__ import annotations

import math
from typing import Any

from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic
from numba.np.arrayobj import make_array

from fcu.estimation.state import FloatArray
from jitsupport.layout import LANES
from jitsupport.views import refcount_free_kernel

__all__ = ["ROW", "add_mul_vec", "add_scaled_difference_row", "add_scaled_row",
           "mul_at_into", "mul_at_t_into", "mul_bt_nonzero_into", "mul_bt_sparse_into", "mul_into",
           "mul_nonzero_left", "mul_sparse_left", "nonzero_columns", "set_scaled_row",
           "spd_inverse", "spd_quadratic", "spd_solve", "sub_mul_vec_into", "symmetrize",
           "transpose_into"]


ROW = 16
"""Entries of a row that :func:`add_scaled_row` updates (the filters' 16 states)."""
_LANES = LANES  # doubles of one vector register (AVX-512); a row is two of them
_BIASES = 4  # the TSKF's biases (one per motor): the inner size of its small products


def _row_vectors(context: Any, builder: Any, ary_t: Any, ary_v: Any, r_t: Any,
                 r_v: Any) -> list[Any]:
    """Pointers to the ``ROW // _LANES`` vectors of row ``r`` of the C-order matrix ``ary``
    (``ROW`` columns; not checked)."""
    vec = ir.VectorType(ir.DoubleType(), _LANES)
    intp = ir.IntType(64)
    data = make_array(ary_t)(context, builder, ary_v).data
    r = context.cast(builder, r_v, r_t, types.intp)
    row = builder.gep(data, [builder.mul(r, ir.Constant(intp, ROW))])
    return [builder.bitcast(builder.gep(row, [ir.Constant(intp, at)]), vec.as_pointer())
            for at in range(0, ROW, _LANES)]


def _splat(context: Any, builder: Any, a_t: Any, a_v: Any) -> Any:
    """The scalar ``a`` in every lane of a vector."""
    vec = ir.VectorType(ir.DoubleType(), _LANES)
    scale = context.cast(builder, a_v, a_t, types.float64)
    splat = builder.insert_element(ir.Constant(vec, ir.Undefined), scale,
                                   ir.Constant(ir.IntType(32), 0))
    return builder.shuffle_vector(splat, ir.Constant(vec, ir.Undefined),
                                  ir.Constant(ir.VectorType(ir.IntType(32), _LANES),
                                              [0] * _LANES))


def _rows_typed(*arrays: Any) -> bool:
    """Whether every one of ``arrays`` is typed as a C-order 2D float64 array."""
    return all(isinstance(m, types.Array) and m.ndim == 2 and m.layout == "C"
               and m.dtype == types.float64 for m in arrays)


def _scaled_row_intrinsic(accumulate: bool) -> Any:
    """The codegen of ``out[i, :ROW] = s + a * b[k, :ROW]`` as two vector operations of
    ``_LANES`` entries, ``s`` the row itself (``accumulate``) or 0.0, each lane the scalar
    ``s + a * b[k, j]`` (a product, then a sum: the same rounding); rows not checked."""

    def typer(typingctx: Any, out: Any, i: Any, a: Any, b: Any, k: Any) -> Any:
        if not _rows_typed(out, b):
            return None

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            out_v, i_v, a_v, b_v, k_v = args
            out_t, i_t, a_t, b_t, k_t = signature.args
            splat = _splat(context, builder, a_t, a_v)
            for dst, src in zip(_row_vectors(context, builder, out_t, out_v, i_t, i_v),
                                _row_vectors(context, builder, b_t, b_v, k_t, k_v),
                                strict=True):
                term = builder.load(src, align=8)
                acc = (builder.load(dst, align=8) if accumulate
                       else ir.Constant(dst.type.pointee, [0.0] * _LANES))
                builder.store(builder.fadd(acc, builder.fmul(splat, term)), dst, align=8)
            return context.get_dummy_value()

        return types.none(out, i, a, b, k), codegen

    return typer


@intrinsic
def _add_scaled_difference_row(typingctx: Any, out: Any, i: Any, a: Any, b: Any, k: Any,
                               c: Any, d: Any, q: Any) -> Any:
    """``out[i, :ROW] += a * b[k, :ROW] - c * d[q, :ROW]`` as two vector operations of
    ``_LANES`` entries, each lane the scalar ``out + (a * b - c * d)`` (two products, their
    difference, then the sum: the same rounding); rows not checked."""
    if not _rows_typed(out, b, d):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        out_v, i_v, a_v, b_v, k_v, c_v, d_v, q_v = args
        out_t, i_t, a_t, b_t, k_t, c_t, d_t, q_t = signature.args
        a_splat, c_splat = _splat(context, builder, a_t, a_v), _splat(context, builder, c_t, c_v)
        for dst, b_src, d_src in zip(_row_vectors(context, builder, out_t, out_v, i_t, i_v),
                                     _row_vectors(context, builder, b_t, b_v, k_t, k_v),
                                     _row_vectors(context, builder, d_t, d_v, q_t, q_v),
                                     strict=True):
            diff = builder.fsub(builder.fmul(a_splat, builder.load(b_src, align=8)),
                                builder.fmul(c_splat, builder.load(d_src, align=8)))
            builder.store(builder.fadd(builder.load(dst, align=8), diff), dst, align=8)
        return context.get_dummy_value()

    return types.none(out, i, a, b, k, c, d, q), codegen


_add_scaled_row = intrinsic(_scaled_row_intrinsic(True))
_add_scaled_row.__doc__ = "``out[i, :ROW] += a * b[k, :ROW]`` (:func:`_scaled_row_intrinsic`)."
_set_scaled_row = intrinsic(_scaled_row_intrinsic(False))
_set_scaled_row.__doc__ = ("``out[i, :ROW] = 0.0 + a * b[k, :ROW]`` "
                           "(:func:`_scaled_row_intrinsic`).")


@njit(cache=True, error_model="numpy", inline="always")
def add_scaled_row(out: FloatArray, i: int, a: float, b: FloatArray, k: int) -> None:
    """``out[i, :] += a * b[k, :]`` for ``out`` and ``b`` of :data:`ROW` columns (the
    filters' 16 states; ValueError otherwise) and rows ``0 <= i, k`` within them, to the bit
    the loop ``for j in range(ROW): out[i, j] += a * b[k, j]``.

    The compiler unrolls that loop, of a known count, before it could vectorise it, and it
    cannot keep the row's entries apart from ``b``'s (both may be views of one array), so it
    stays scalar: this makes it two vector operations of eight lanes. Same-row updates
    follow one another in memory, so ``out`` and ``b`` may be the same array."""
    if out.shape[1] != ROW or b.shape[1] != ROW:
        raise ValueError("add_scaled_row: rows of 16 entries only")
    _add_scaled_row(out, i, a, b, k)


@njit(cache=True, error_model="numpy", inline="always")
def set_scaled_row(out: FloatArray, i: int, a: float, b: FloatArray, k: int) -> None:
    """``out[i, :] = 0.0 + a * b[k, :]`` as :func:`add_scaled_row` (the same conditions), to
    the bit the loop ``for j in range(ROW): out[i, j] = 0.0 + a * b[k, j]``: the first term
    of a row built as a sum, :func:`add_scaled_row` the others."""
    if out.shape[1] != ROW or b.shape[1] != ROW:
        raise ValueError("set_scaled_row: rows of 16 entries only")
    _set_scaled_row(out, i, a, b, k)


@njit(cache=True, error_model="numpy", inline="always")
def add_scaled_difference_row(out: FloatArray, i: int, a: float, b: FloatArray, k: int,
                              c: float, d: FloatArray, q: int) -> None:
    """``out[i, :] += a * b[k, :] - c * d[q, :]`` as :func:`add_scaled_row` (the same
    conditions, ``d`` too), to the bit the loop
    ``for j in range(ROW): out[i, j] += a * b[k, j] - c * d[q, j]``."""
    if out.shape[1] != ROW or b.shape[1] != ROW or d.shape[1] != ROW:
        raise ValueError("add_scaled_difference_row: rows of 16 entries only")
    _add_scaled_difference_row(out, i, a, b, k, c, d, q)  # type: ignore[call-arg]


@njit(cache=True, error_model="numpy", inline="always")
def _add_scaled(out: FloatArray, i: int, a: float, b: FloatArray, k: int, w: int) -> None:
    """``out[i, :w] += a * b[k, :w]``, the loop ``for j in range(w)``: as two vector
    operations for the filters' 16-entry rows (:func:`add_scaled_row`), else as written
    (unrolled where the caller's ``w`` is a constant)."""
    if w == ROW and out.shape[1] == ROW:
        add_scaled_row(out, i, a, b, k)
    else:
        for j in range(w):
            out[i, j] += a * b[k, j]


@refcount_free_kernel
def mul_sparse_left(out: FloatArray, a: FloatArray, b: FloatArray) -> None:
    """``out = a b`` for ``a`` (n, k) with many zeros, ``b`` (k, w); ``out`` (n, w) must not
    share memory with ``a`` or ``b``."""
    w = b.shape[1]
    if w == _BIASES:  # the TSKF's 4 columns (V): a count the compiler knows, it unrolls
        _mul_sparse_rows(out, a, b, _BIASES)
    else:
        _mul_sparse_rows(out, a, b, w)


@njit(cache=True, error_model="numpy", inline="always")
def _mul_sparse_rows(out: FloatArray, a: FloatArray, b: FloatArray, w: int) -> None:
    """:func:`mul_sparse_left` with ``b``'s ``w`` columns given."""
    n, kk = a.shape
    for i in range(n):
        for j in range(w):
            out[i, j] = 0.0
        # out[i, :] = sum_k a[i, k] b[k, :]   (zero a[i, k] skipped)
        for k in range(kk):
            aik = a[i, k]
            if aik != 0.0:
                _add_scaled(out, i, aik, b, k, w)


@refcount_free_kernel
def mul_nonzero_left(out: FloatArray, a: FloatArray, nz: FloatArray, b: FloatArray) -> None:
    """``out = a b`` as :func:`mul_sparse_left` (the same products in the same order, zero
    ``a[i, k]`` skipped) with the non-zero columns of each row of ``a`` listed beforehand in
    ``nz`` (:func:`nonzero_columns`): for a left factor used more than once."""
    w = b.shape[1]
    if w == _BIASES:  # the TSKF's 4 columns (V): a count the compiler knows, it unrolls
        _mul_nonzero_rows(out, a, nz, b, _BIASES)
    else:
        _mul_nonzero_rows(out, a, nz, b, w)


@njit(cache=True, error_model="numpy", inline="always")
def _mul_nonzero_rows(out: FloatArray, a: FloatArray, nz: FloatArray, b: FloatArray,
                      w: int) -> None:
    """:func:`mul_nonzero_left` with ``b``'s ``w`` columns given."""
    for i in range(a.shape[0]):
        for j in range(w):
            out[i, j] = 0.0
        # out[i, :] = sum_k a[i, k] b[k, :]   (over the non-zero a[i, k])
        for t in range(int(nz[i, 0])):
            k = int(nz[i, 1 + t])
            _add_scaled(out, i, a[i, k], b, k, w)


@refcount_free_kernel
def mul_into(out: FloatArray, a: FloatArray, b: FloatArray) -> None:
    """``out = a b`` for ``a`` (n, k), ``b`` (k, w) (``out`` (n, w) must not share memory
    with ``a`` or ``b``)."""
    kk, w = b.shape
    if kk == _BIASES and w == _BIASES:
        # a right factor of the TSKF's 4 x 4 (P^gamma and its kin): counts the compiler
        # knows, it unrolls
        _mul_rows(out, a, b, _BIASES, _BIASES)
    else:
        _mul_rows(out, a, b, kk, w)


@njit(cache=True, error_model="numpy", inline="always")
def _mul_rows(out: FloatArray, a: FloatArray, b: FloatArray, kk: int, w: int) -> None:
    """:func:`mul_into` with ``b``'s shape (``kk``, ``w``) given."""
    for i in range(a.shape[0]):
        for j in range(w):
            # out[i, j] = sum_k a[i, k] b[k, j]
            acc = 0.0
            for k in range(kk):
                acc += a[i, k] * b[k, j]
            out[i, j] = acc


@refcount_free_kernel
def mul_at_into(out: FloatArray, a: FloatArray, b: FloatArray) -> None:
    """``out = a' b`` for ``a`` (k, n), ``b`` (k, w) (``out`` (n, w) must not share memory
    with ``a`` or ``b``)."""
    kk, n = a.shape
    w = b.shape[1]
    for i in range(n):
        for j in range(w):
            # out[i, j] = sum_k a[k, i] b[k, j]
            acc = 0.0
            for k in range(kk):
                acc += a[k, i] * b[k, j]
            out[i, j] = acc


@refcount_free_kernel
def mul_at_t_into(out: FloatArray, a: FloatArray, b: FloatArray) -> None:
    """``out = (a' b)' = b' a`` for ``a`` (k, n), ``b`` (k, w): :func:`mul_at_into`'s result
    transposed, to the bit (each entry the same products summed over ``k`` in the same order
    from 0), with its inner loop along the rows of ``a`` (``out`` (w, n) must not share memory
    with ``a`` or ``b``)."""
    kk, n = a.shape
    w = b.shape[1]
    for j in range(w):
        for i in range(n):
            out[j, i] = 0.0
        # out[j, :] = sum_k b[k, j] a[k, :]
        for k in range(kk):
            _add_scaled(out, j, b[k, j], a, k, n)


@refcount_free_kernel
def nonzero_columns(nz: FloatArray, s: FloatArray) -> None:
    """Index of the non-zero entries of each row of ``s`` (w, k), for
    :func:`mul_bt_nonzero_into`: ``nz[r, 0]`` their count, ``nz[r, 1:1 + count]`` their
    columns in ascending order (``nz``: (w, k + 1), small integers held exactly as floats)."""
    w, kk = s.shape
    for r in range(w):
        # without a branch: every column written at the next free place, which only a
        # non-zero entry keeps (a zero one is overwritten by the next column, or left past
        # the count)
        count = 0
        for k in range(kk):
            nz[r, 1 + count] = k
            count += s[r, k] != 0.0
        nz[r, 0] = count


@refcount_free_kernel
def mul_bt_nonzero_into(out: FloatArray, a: FloatArray, s: FloatArray, nz: FloatArray) -> None:
    """``out = a s'`` as :func:`mul_bt_sparse_into` (the same products in the same order, zero
    ``s[j, k]`` skipped) with the non-zero columns of ``s`` listed beforehand in ``nz``
    (:func:`nonzero_columns`), so the zeros are not visited at all."""
    n = a.shape[0]
    w = s.shape[0]
    for i in range(n):
        for j in range(w):
            # out[i, j] = sum_k a[i, k] s[j, k]   (over the non-zero s[j, k])
            acc = 0.0
            for t in range(int(nz[j, 0])):
                k = int(nz[j, 1 + t])
                acc += a[i, k] * s[j, k]
            out[i, j] = acc


@refcount_free_kernel
def mul_bt_sparse_into(out: FloatArray, a: FloatArray, s: FloatArray) -> None:
    """``out = a s'`` for ``a`` (n, k), ``s`` (w, k) with many zeros (a selection or a
    measurement matrix; zero entries skipped), ``out`` (n, w) not sharing memory with them."""
    n, kk = a.shape
    w = s.shape[0]
    for i in range(n):
        for j in range(w):
            # out[i, j] = sum_k a[i, k] s[j, k]   (zero s[j, k] skipped)
            acc = 0.0
            for k in range(kk):
                s_jk = s[j, k]
                if s_jk != 0.0:
                    acc += a[i, k] * s_jk
            out[i, j] = acc


@refcount_free_kernel
def sub_mul_vec_into(out: FloatArray, y: FloatArray, a: FloatArray, v: FloatArray) -> None:
    """``out = y - a v`` for ``a`` (m, n) with many zeros (skipped), ``v`` (n,), ``y`` and
    ``out`` (m,) (a residual: measurement minus its prediction)."""
    m, n = a.shape
    for i in range(m):
        # (a v)[i] = sum_k a[i, k] v[k]   (zero a[i, k] skipped)
        acc = 0.0
        for k in range(n):
            a_ik = a[i, k]
            if a_ik != 0.0:
                acc += a_ik * v[k]
        out[i] = y[i] - acc


@refcount_free_kernel
def add_mul_vec(x: FloatArray, k: FloatArray, y: FloatArray) -> None:
    """``x += k y`` for ``k`` (n, m), ``y`` (m,) (a gain times an innovation)."""
    n, m = k.shape
    for i in range(n):
        acc = 0.0
        for r in range(m):
            acc += k[i, r] * y[r]
        x[i] += acc


def _transpose_block(builder: Any, rows: list[Any]) -> list[Any]:
    """The 8 x 8 block whose rows are the ``_LANES``-vectors ``rows``, transposed: its columns
    as vectors, by three rounds of two-vector shuffles (pairs of entries, of pairs, of
    quads: each round swaps the off-diagonal halves of 2 x 2 sub-blocks one size larger)."""
    i32 = ir.IntType(32)

    def shuffle(a: Any, b: Any, picks: list[int]) -> Any:
        return builder.shuffle_vector(a, b, ir.Constant(ir.VectorType(i32, _LANES), picks))

    for size in (1, 2, 4):
        # entries of a: index t; of b: _LANES + t. Rows r, r + size paired in each group of
        # 2 size rows: the first takes a's lower and b's lower entry of each 2 size stretch,
        # the second the upper ones
        lo = [t + (_LANES if (t // size) % 2 else 0) - (size if (t // size) % 2 else 0)
              for t in range(_LANES)]
        hi = [t + (0 if (t // size) % 2 else size) + (_LANES if (t // size) % 2 else 0)
              for t in range(_LANES)]
        out = list(rows)
        for r in range(_LANES):
            if (r // size) % 2 == 0:
                a, b = rows[r], rows[r + size]
                out[r] = shuffle(a, b, lo)
                out[r + size] = shuffle(a, b, hi)
        rows = out
    return rows


@intrinsic
def _transpose_rows(typingctx: Any, out: Any, a: Any) -> Any:
    """``out[:ROW, :ROW] = a[:ROW, :ROW]'`` for C-order arrays of :data:`ROW` columns: the
    ``ROW`` rows of ``a`` loaded as vectors of ``_LANES``, each 8 x 8 block transposed in
    registers (:func:`_transpose_block`), stored as the mirror block; every entry is loaded
    before any is stored (shapes not checked)."""
    if not all(isinstance(m, types.Array) and m.ndim == 2 and m.layout == "C"
               and m.dtype == types.float64 for m in (out, a)):
        return None
    vec = ir.VectorType(ir.DoubleType(), _LANES)
    intp = ir.IntType(64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        out_t, a_t = signature.args
        src = make_array(a_t)(context, builder, args[1]).data
        dst = make_array(out_t)(context, builder, args[0]).data

        def at(data: Any, r: int, c: int) -> Any:
            return builder.bitcast(builder.gep(data, [ir.Constant(intp, r * ROW + c)]),
                                   vec.as_pointer())

        halves = ROW // _LANES
        blocks = {(bi, bj): [builder.load(at(src, bi * _LANES + r, bj * _LANES), align=8)
                             for r in range(_LANES)]
                  for bi in range(halves) for bj in range(halves)}
        for (bi, bj), rows in blocks.items():
            # block (bi, bj) of a, transposed, is block (bj, bi) of a'
            for c, col in enumerate(_transpose_block(builder, rows)):
                builder.store(col, at(dst, bj * _LANES + c, bi * _LANES), align=8)
        return context.get_dummy_value()

    return types.none(out, a), codegen


@refcount_free_kernel
def transpose_into(out: FloatArray, a: FloatArray) -> None:
    """``out = a'`` (``out`` must not share memory with ``a``). A matrix of the filters' 16
    states is moved as 8 x 8 blocks of vector registers (:func:`_transpose_rows`)."""
    n, w = a.shape
    if n == ROW and w == ROW and out.shape[0] == ROW and out.shape[1] == ROW:
        _transpose_rows(out, a)  # type: ignore[call-arg]
        return
    for i in range(n):
        for j in range(w):
            out[j, i] = a[i, j]


@refcount_free_kernel
def symmetrize(a: FloatArray) -> None:
    """``a = (a + a') / 2`` in place (square ``a``)."""
    n = a.shape[0]
    for i in range(n):
        for j in range(i + 1, n):
            v = 0.5 * (a[i, j] + a[j, i])
            a[i, j] = v
            a[j, i] = v


@njit(cache=True, error_model="numpy", inline="always")
def _cholesky(a: FloatArray, m: int, low: FloatArray) -> None:
    """Lower Cholesky factor of the top-left (m, m) block of ``a`` into ``low``:
    ``a = L L'`` (``a`` symmetric positive definite)."""
    for j in range(m):
        s = a[j, j]
        for k in range(j):
            s -= low[j, k] * low[j, k]
        d = math.sqrt(s)
        low[j, j] = d
        for i in range(j + 1, m):
            s = a[i, j]
            for k in range(j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s / d
        for i in range(j):
            low[i, j] = 0.0


@njit(cache=True, error_model="numpy", inline="always")
def spd_inverse(a: FloatArray, m: int, out: FloatArray, low: FloatArray,
                low_inv: FloatArray) -> None:
    """Inverse of the symmetric positive definite top-left (m, m) block of ``a``, written to
    the top-left block of ``out`` (``low``, ``low_inv``: scratch of at least (m, m)).

    ``a = L L'`` (Cholesky), ``a^-1 = L^-T L^-1``; the result is exactly symmetric.
    """
    _cholesky(a, m, low)
    # L^-1, lower triangular, by forward substitution column by column
    for j in range(m):
        low_inv[j, j] = 1.0 / low[j, j]
        for i in range(j + 1, m):
            s = 0.0
            for k in range(j, i):
                s -= low[i, k] * low_inv[k, j]
            low_inv[i, j] = s / low[i, i]
    # a^-1 = L^-T L^-1:  out[i, j] = sum_{k >= max(i, j)} L^-1[k, i] L^-1[k, j]
    for i in range(m):
        for j in range(i, m):
            s = 0.0
            for k in range(j, m):
                s += low_inv[k, i] * low_inv[k, j]
            out[i, j] = s
            out[j, i] = s


@njit(cache=True, error_model="numpy", inline="always")
def spd_solve(a: FloatArray, m: int, b: FloatArray, out: FloatArray, low: FloatArray) -> None:
    """``a^-1 b`` for the symmetric positive definite top-left (m, m) block of ``a`` and ``b``
    of shape (m, k), written to ``out`` (m, k) (``low``: scratch of at least (m, m)), without
    forming ``a^-1``.

    ``a = L L'`` (Cholesky); ``z = L^-1 b`` by forward, ``out = L^-T z`` by back
    substitution, a row of k entries at a time (``z`` kept in ``out``).
    """
    _cholesky(a, m, low)
    k = b.shape[1]
    # z = L^-1 b:  z[i] = (b[i] - sum_{q < i} L[i, q] z[q]) / L[i, i]
    for i in range(m):
        for j in range(k):
            out[i, j] = b[i, j]
        for q in range(i):
            l_iq = low[i, q]
            for j in range(k):
                out[i, j] -= l_iq * out[q, j]
        d = low[i, i]
        for j in range(k):
            out[i, j] /= d
    # out = L^-T z:  out[i] = (z[i] - sum_{q > i} L[q, i] out[q]) / L[i, i]
    for i in range(m - 1, -1, -1):
        for q in range(i + 1, m):
            l_qi = low[q, i]
            for j in range(k):
                out[i, j] -= l_qi * out[q, j]
        d = low[i, i]
        for j in range(k):
            out[i, j] /= d


# inlined into its callers (a few per tick): the call, with its many array arguments, cost
# about as much as a small channel's arithmetic
@njit(cache=True, error_model="numpy", inline="always")
def spd_quadratic(a: FloatArray, m: int, v: FloatArray, low: FloatArray,
                  tmp: FloatArray) -> float:
    """``v' a^-1 v`` for the symmetric positive definite top-left (m, m) block of ``a``:
    ``a = L L'``, ``w = L^-1 v``, ``v' a^-1 v = w' w`` (``low`` (m, m), ``tmp`` (m,):
    scratch)."""
    _cholesky(a, m, low)
    # w = L^-1 v   (forward substitution)
    acc = 0.0
    for i in range(m):
        s = v[i]
        for k in range(i):
            s -= low[i, k] * tmp[k]
        tmp[i] = s / low[i, i]
        acc += tmp[i] * tmp[i]
    return acc
