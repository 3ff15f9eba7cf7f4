"""Kernel views: reshapes that share memory, and borrowed arrays, inside compiled code."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from jitsupport.views import borrowed, shaped


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

