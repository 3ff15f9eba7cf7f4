"""The small matrix kernels of the filters' ticks against numpy's dense algebra."""

from __future__ import annotations

import numpy as np
from numba import njit

from fcu.estimation.ekf import EkfProcessNoise
from fcu.estimation.ekf_model import model_jacobian, pack_params
from fcu.estimation.small_matrix import (
    add_mul_vec,
    add_scaled_difference_row,
    add_scaled_row,
    mul_at_into,
    mul_at_t_into,
    mul_bt_nonzero_into,
    mul_bt_sparse_into,
    mul_into,
    mul_nonzero_left,
    mul_sparse_left,
    nonzero_columns,
    spd_inverse,
    spd_quadratic,
    spd_solve,
    sub_mul_vec_into,
    symmetrize,
    transpose_into,
)
from fcu.model import VehicleModel

RNG = np.random.default_rng(3)


def _spd(m: int) -> np.ndarray:
    a = RNG.normal(size=(m, m))
    return a @ a.T + m * np.eye(m)


def _filter_jacobian_dt() -> np.ndarray:
    """A dt at a flying state: the sparsity pattern the filters' products see."""
    x = np.zeros(16)
    x[12:16] = 3.5
    x[6:12] = [0.05, -0.04, 0.3, 0.2, -0.1, 0.05]
    return model_jacobian(x, pack_params(VehicleModel()), False) * 0.01


def test_sparse_product_is_the_matrix_product() -> None:
    a = _filter_jacobian_dt()
    b = RNG.normal(size=(16, 16))
    out = np.full((16, 16), np.nan)  # every entry must be written
    mul_sparse_left(out, a, b)
    # same products, summed in another order: agreement to rounding
    np.testing.assert_allclose(out, a @ b, rtol=1e-13, atol=1e-15)
    assert np.count_nonzero(a) < 64  # the case the kernel is for: mostly zeros


def test_spd_inverse_and_quadratic_form() -> None:
    for m in (1, 2, 3, 10):
        s = _spd(m)
        out = np.full((m, m), np.nan)
        spd_inverse(s, m, out, np.empty((m, m)), np.empty((m, m)))
        # Cholesky against LU: agreement to rounding on a well-conditioned matrix
        np.testing.assert_allclose(out, np.linalg.inv(s), rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(out, out.T)  # symmetric by construction
        v = RNG.normal(size=m)
        quad = spd_quadratic(s, m, v, np.empty((m, m)), np.empty(m))
        assert abs(quad - v @ np.linalg.solve(s, v)) < 1e-12 * abs(quad)


def test_spd_solve() -> None:
    for m, k in ((1, 1), (3, 4), (9, 4), (16, 4)):
        s = _spd(m)
        b = RNG.normal(size=(m, k))
        out = np.full((m, k), np.nan)
        spd_solve(s, m, b, out, np.empty((m, m)))
        # Cholesky against LU: agreement to rounding on a well-conditioned matrix
        np.testing.assert_allclose(out, np.linalg.solve(s, b), rtol=1e-12, atol=1e-14)


def test_transpose_and_symmetrize() -> None:
    a = RNG.normal(size=(16, 4))
    out = np.empty((4, 16))
    transpose_into(out, a)
    np.testing.assert_array_equal(out, a.T)
    # the filters' 16 x 16 (moved as vector blocks)
    a = RNG.normal(size=(16, 16))
    out = np.empty((16, 16))
    transpose_into(out, a)
    np.testing.assert_array_equal(out, a.T)
    q = np.diag(EkfProcessNoise().diagonal()) + RNG.normal(size=(16, 16))
    ref = 0.5 * (q + q.T)
    symmetrize(q)
    np.testing.assert_array_equal(q, q.T)
    np.testing.assert_allclose(q, ref, rtol=1e-15)


def test_dense_and_transposed_products_are_the_matrix_products() -> None:
    for n, k, w in ((16, 4, 4), (3, 16, 4), (4, 3, 3), (1, 1, 1)):
        a, b = RNG.normal(size=(n, k)), RNG.normal(size=(k, w))
        out = np.full((n, w), np.nan)  # every entry must be written
        mul_into(out, a, b)
        np.testing.assert_allclose(out, a @ b, rtol=1e-13, atol=1e-14)
        at = np.ascontiguousarray(a.T)
        out_t = np.full((n, w), np.nan)
        mul_at_into(out_t, at, b)  # a' b with a given transposed
        np.testing.assert_array_equal(out_t, out)  # the same sums in the same order


def test_product_by_a_sparse_transposed_right_factor() -> None:
    sel = np.zeros((3, 16))
    sel[0, 0] = sel[1, 1] = 1.0
    sel[2, 8] = -1.0  # a selection, as the measurement rows are
    a = RNG.normal(size=(16, 16))
    out = np.full((16, 3), np.nan)
    mul_bt_sparse_into(out, a, sel)
    np.testing.assert_allclose(out, a @ sel.T, rtol=1e-13, atol=1e-15)
    np.testing.assert_array_equal(out[:, 2], -a[:, 8])  # one non-zero entry: exact


def test_residual_and_gain_products_of_vectors() -> None:
    a = RNG.normal(size=(3, 16))
    a[:, ::2] = 0.0  # zero entries are skipped
    v, y = RNG.normal(size=16), RNG.normal(size=3)
    out = np.full(3, np.nan)
    sub_mul_vec_into(out, y, a, v)
    np.testing.assert_allclose(out, y - a @ v, rtol=1e-13, atol=1e-14)
    k, x = RNG.normal(size=(16, 3)), RNG.normal(size=16)
    x_after = x.copy()
    add_mul_vec(x_after, k, y)
    np.testing.assert_allclose(x_after, x + k @ y, rtol=1e-13, atol=1e-14)


def test_listed_non_zero_products_are_the_sparse_products_to_the_bit() -> None:
    a = _filter_jacobian_dt()
    b = RNG.normal(size=(16, 16))
    nz = np.full((16, 17), np.nan)
    nonzero_columns(nz, a)
    for r in range(16):  # the count, then the non-zero columns in ascending order
        cols = np.flatnonzero(a[r])
        assert nz[r, 0] == len(cols)
        np.testing.assert_array_equal(nz[r, 1:1 + len(cols)], cols)
    ref, out = np.empty((16, 16)), np.full((16, 16), np.nan)
    mul_sparse_left(ref, a, b)
    mul_nonzero_left(out, a, nz, b)
    np.testing.assert_array_equal(out, ref)  # the same products in the same order
    h = a[[6, 9, 11]]  # three measurement-like rows
    nz_h = np.full((3, 17), np.nan)
    nonzero_columns(nz_h, h)
    ref, out = np.empty((16, 3)), np.full((16, 3), np.nan)
    mul_bt_sparse_into(ref, b, h)
    mul_bt_nonzero_into(out, b, h, nz_h)
    np.testing.assert_array_equal(out, ref)


def test_transposed_product_is_the_product_transposed_to_the_bit() -> None:
    for k, n, w in ((3, 16, 3), (10, 16, 10), (1, 16, 1)):
        a, b = RNG.normal(size=(k, n)), RNG.normal(size=(k, w))
        ref = np.empty((n, w))
        mul_at_into(ref, a, b)
        out = np.full((w, n), np.nan)
        mul_at_t_into(out, a, b)
        np.testing.assert_array_equal(out, ref.T)


def test_the_update_keeps_the_covariance_symmetric_and_positive() -> None:
    from fcu.estimation.kalman_update import kalman_update

    p0 = _spd(16) / 16.0
    h = np.zeros((3, 16))
    h[0, 0] = h[1, 1] = h[2, 2] = 1.0
    h[:, 3:6] = -0.004 * np.eye(3)
    r = np.diag([1e-6, 1e-6, 4e-6])  # precise: P drops by orders of magnitude on those rows
    x, p, s_mat, _, k = kalman_update(np.zeros(16), p0, np.array([1e-3, 2e-3, -1e-3]), h, r)
    assert np.array_equal(p, p.T)
    assert np.linalg.eigvalsh(p).min() > 0.0
    # the Joseph form (I - K H) P (I - K H)' + K R K', evaluated densely
    i_kh = np.eye(16) - k @ h
    np.testing.assert_allclose(p, i_kh @ p0 @ i_kh.T + k @ r @ k.T, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(s_mat, h @ p0 @ h.T + r, rtol=1e-12)


@njit
def _row_updates(out: np.ndarray, b: np.ndarray, d: np.ndarray) -> None:
    add_scaled_row(out, 0, 0.3, b, 2)
    add_scaled_difference_row(out, 1, 0.7, b, 1, -1.3, d, 3)


def test_row_updates_are_the_loops_to_the_bit() -> None:
    out, b, d = RNG.normal(size=(2, 16)), RNG.normal(size=(3, 16)), RNG.normal(size=(4, 16))
    ref = out.copy()
    for j in range(16):
        ref[0, j] += 0.3 * b[2, j]
        ref[1, j] += 0.7 * b[1, j] - -1.3 * d[3, j]
    _row_updates(out, b, d)
    np.testing.assert_array_equal(out, ref)
