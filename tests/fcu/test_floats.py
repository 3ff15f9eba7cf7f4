"""The scalar helpers Python and the kernels share (fcu.floats): one definition, run by the
interpreter and compiled into kernels, must give the same bits both ways."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from fcu.floats import clip, py_max, py_min, wrap_pi
from flightdata.geometry import wrap_pi_array

ANGLES = [-math.pi, math.pi, 3 * math.pi, -7.0, 0.5, 179.0, -1e-17, 2 * math.pi - 1e-12]


@njit(cache=False)
def _compiled_wrap(angles: np.ndarray) -> np.ndarray:
    out = np.empty_like(angles)
    for i in range(angles.size):
        out[i] = wrap_pi(angles[i])
    return out


@njit(cache=False)
def _compiled_others(a: float, b: float) -> tuple[float, float, float]:
    return clip(a, -1.0, b), py_min(a, b), py_max(a, b)


def test_wrap_pi_is_half_open_and_the_same_interpreted_compiled_and_for_arrays() -> None:
    python = np.array([wrap_pi(a) for a in ANGLES])
    assert all(type(wrap_pi(a)) is float for a in np.array(ANGLES))  # numpy scalars in, floats out
    assert np.all((python >= -math.pi) & (python < math.pi))
    assert python[1] == -math.pi  # +pi maps to -pi
    np.testing.assert_array_equal(_compiled_wrap(np.array(ANGLES)), python)
    np.testing.assert_array_equal(wrap_pi_array(ANGLES), python)
    # the +-180 deg seam: 179 deg against -179 deg is a 2 deg error, not 358
    assert math.degrees(wrap_pi(math.radians(179.0) - math.radians(-179.0))) == pytest.approx(
        -2.0)


@pytest.mark.parametrize(("a", "b"), [(0.5, 2.0), (-3.0, 2.0), (5.0, 2.0), (1.0, 1.0),
                                      (0.0, -0.0), (math.nan, 1.0)])
def test_clip_min_max_compiled_as_interpreted(a: float, b: float) -> None:
    python = (clip(a, -1.0, b), py_min(a, b), py_max(a, b))
    compiled = _compiled_others(a, b)
    assert [math.copysign(1.0, v) if v == 0 else v for v in compiled] == pytest.approx(
        [math.copysign(1.0, v) if v == 0 else v for v in python], nan_ok=True)
    assert python[1:] == (min(a, b), max(a, b)) or math.isnan(a)  # builtin semantics
