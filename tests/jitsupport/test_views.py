"""Kernel views: reshapes that share memory, and borrowed arrays, inside compiled code."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from jitsupport.views import borrowed, carve, shaped


@njit(cache=False)
def _views(flat: np.ndarray, rows: int, cols: int) -> tuple[np.ndarray, np.ndarray, float]:
    """A matrix and a stack of two matrices out of ``flat`` (written through), and the sum
    of a borrowed copy's slice."""
    matrix = shaped(flat[1:1 + rows * cols], (rows, cols))
    matrix[rows - 1, cols - 1] = -1.0
    stack = shaped(flat[:2 * rows * cols], (2, rows, cols))
    return matrix.copy(), stack.copy(), borrowed(flat)[2:5].sum()


def test_shaped_views_are_reshapes_sharing_memory() -> None:
    flat = np.arange(40.0)
    matrix, stack, part = _views(flat, 3, 4)
    # a write through the view lands in flat, C order: row 2, column 3 of the block at 1
    assert flat[1 + 2 * 4 + 3] == -1.0
    expected = np.arange(40.0)
    expected[12] = -1.0
    np.testing.assert_array_equal(matrix, expected[1:13].reshape(3, 4))
    np.testing.assert_array_equal(stack, expected[:24].reshape(2, 3, 4))
    assert part == 2.0 + 3.0 + 4.0


def test_a_shape_that_does_not_fit_is_refused() -> None:
    with pytest.raises(ValueError, match="shape does not match"):
        _views(np.zeros(10), 3, 4)



@njit(cache=False)
def _carved(flat: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Three matrices carved one after the other, the second keeping room for 4 x 4."""
    a, at = carve(flat, 0, (2, 3))
    b, at = carve(flat, at, (m, m), 16)
    c, at = carve(flat, at, (m,))
    a[1, 2] = -1.0
    c[0] = -2.0
    return a.copy(), b.copy(), c.copy(), at


@pytest.mark.parametrize("m", [1, 2, 4])
def test_carve_lays_views_after_each_other_keeping_the_room_asked_for(m: int) -> None:
    flat = np.arange(40.0)
    a, b, c, end = _carved(flat, m)
    assert end == 6 + 16 + m  # the second view takes 16 entries whatever m is
    assert flat[5] == -1.0 and flat[22] == -2.0  # written through, C order
    np.testing.assert_array_equal(a, [[0.0, 1.0, 2.0], [3.0, 4.0, -1.0]])
    np.testing.assert_array_equal(b, np.arange(6.0, 6.0 + m * m).reshape(m, m))
    np.testing.assert_array_equal(c, np.r_[-2.0, np.arange(23.0, 22.0 + m)])
