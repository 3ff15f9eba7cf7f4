"""Small dense matrix kernels for the filters' compiled ticks (no allocation, no BLAS).

The filters' matrices are 16 x 16 or smaller, and most of them are sparse with a fixed
pattern (the EKF's Jacobian and its series, the TSKF's discrete model, the measurement rows).
At that size a BLAS call costs more in its set-up than in its arithmetic, so these kernels
work in place on preallocated buffers, skip zero entries of the left factor, and run their
inner loops along rows (``out[i, :] += a[i, k] b[k, :]``): plain loops, no intrinsics.
"""

from __future__ import annotations

import math

from numba import njit

from fcu.estimation.state import FloatArray
from jitsupport.views import refcount_free_kernel

__all__ = ["ROW", "add_mul_vec", "add_scaled_difference_row", "add_scaled_row",
           "mul_at_into", "mul_at_t_into", "mul_bt_nonzero_into", "mul_bt_sparse_into", "mul_into",
           "mul_nonzero_left", "mul_sparse_left", "nonzero_columns", "set_scaled_row",
           "spd_inverse", "spd_quadratic", "spd_solve", "sub_mul_vec_into", "symmetrize",
           "transpose_into"]


ROW = 16
"""Entries of a row that :func:`add_scaled_row` updates (the filters' 16 states)."""
_BIASES = 4  # the TSKF's biases (one per motor): the inner size of its small products


@njit(cache=True, error_model="numpy", inline="always")
def add_scaled_row(out: FloatArray, i: int, a: float, b: FloatArray, k: int) -> None:
    """``out[i, :] += a * b[k, :]`` for ``out`` and ``b`` of :data:`ROW` columns (the
    filters' 16 states) and rows ``0 <= i, k`` within them; ``out`` and ``b`` may be the
    same array.

    Not checked (the row kernels): the callers' matrices are views of :data:`ROW` columns
    by construction; a check that may raise keeps the call out of its caller's loop.
    Inlined (``inline="always"``), and counted by the row's own length (``out.shape[1]``):
    a constant count is unrolled before it could be vectorised. Both filters' compiled
    call, 20th percentile per call (``ftc-bench tick``): 23.0 us unchecked but called,
    20.5 us inlined, 17.1 us counted by the row's length."""
    for j in range(out.shape[1]):
        out[i, j] += a * b[k, j]


@njit(cache=True, error_model="numpy", inline="always")
def set_scaled_row(out: FloatArray, i: int, a: float, b: FloatArray, k: int) -> None:
    """``out[i, :] = 0.0 + a * b[k, :]`` as :func:`add_scaled_row` (the same conditions,
    not checked): the first term of a row built as a sum, :func:`add_scaled_row` the
    others."""
    for j in range(out.shape[1]):
        out[i, j] = 0.0 + a * b[k, j]


@njit(cache=True, error_model="numpy", inline="always")
def add_scaled_difference_row(out: FloatArray, i: int, a: float, b: FloatArray, k: int,
                              c: float, d: FloatArray, q: int) -> None:
    """``out[i, :] += a * b[k, :] - c * d[q, :]`` as :func:`add_scaled_row` (the same
    conditions, ``d`` too; not checked)."""
    for j in range(out.shape[1]):
        out[i, j] += a * b[k, j] - c * d[q, j]


@njit(cache=True, error_model="numpy", inline="always")
def _add_scaled(out: FloatArray, i: int, a: float, b: FloatArray, k: int, w: int) -> None:
    """``out[i, :w] += a * b[k, :w]`` (unrolled where the caller's ``w`` is a constant)."""
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@refcount_free_kernel
def transpose_into(out: FloatArray, a: FloatArray) -> None:
    """``out = a'`` (``out`` must not share memory with ``a``)."""
    n, w = a.shape
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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
@njit(cache=True, error_model="numpy")
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
