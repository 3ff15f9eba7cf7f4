"""Kernel calls past the dispatcher: the same results, and type drift caught when checked."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from jitsupport.calls import CHECK_ENV, KernelCall


@njit(cache=False)
def _scaled_sum(values: np.ndarray, scale: float, out: np.ndarray) -> tuple[float, bool]:
    """``out[:] = scale * values``; returns the sum and whether it is positive."""
    total = 0.0
    for i in range(values.shape[0]):
        out[i] = scale * values[i]
        total += out[i]
    return total, total > 0.0


def test_later_calls_skip_the_dispatcher_and_give_its_results(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(CHECK_ENV, raising=False)
    kc = KernelCall(_scaled_sum)
    rng = np.random.default_rng(3)
    out, expected_out = np.empty(5), np.empty(5)
    values = rng.normal(size=5)
    assert kc.call(values, 2.0, out) == _scaled_sum(values, 2.0, expected_out)
    # after the first call: the machine code's entry, not the dispatcher
    assert kc.call is not _scaled_sum
    assert kc.call is _scaled_sum.overloads[tuple(map(_scaled_sum.typeof_pyval,
                                                      (values, 2.0, out)))].entry_point
    for _ in range(20):
        values, scale = rng.normal(size=5), float(rng.normal())
        got = kc.call(values, scale, out)
        assert got == _scaled_sum(values, scale, expected_out)
        np.testing.assert_array_equal(out, expected_out)


def test_checked_calls_refuse_an_argument_of_another_type(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(CHECK_ENV, "1")
    kc = KernelCall(_scaled_sum)
    out = np.empty(4)
    kc.call(np.ones(4), 1.0, out)
    assert kc.call(np.arange(4.0), 0.5, out) == (3.0, True)  # same types: fine
    # another dtype, a strided view, an int for the float: each would be read wrongly or
    # not at all by the first call's machine code
    with pytest.raises(TypeError, match=r"_scaled_sum: argument 0 is array\(int64"):
        kc.call(np.arange(4), 1.0, out)
    with pytest.raises(TypeError, match=r"argument 0 is array\(float64, 1d, A\)"):
        kc.call(np.ones(8)[::2], 1.0, out)
    with pytest.raises(TypeError, match="argument 1 is int64"):
        kc.call(np.ones(4), 2, out)
    with pytest.raises(TypeError, match="_scaled_sum: 2 arguments, the first call had 3"):
        kc.call(np.ones(4), 1.0)


def test_equal_record_dtypes_made_apart_pass_the_check(monkeypatch: pytest.MonkeyPatch) -> None:
    # the world's parts each make their state records: equal dtypes, not one object
    monkeypatch.setenv(CHECK_ENV, "1")

    @njit(cache=False)
    def first_a(records: np.ndarray) -> float:
        return records[0]["a"]

    kc = KernelCall(first_a)
    fields = [("a", "f8"), ("b", "i8")]
    one, other = np.zeros(1, dtype=np.dtype(fields)), np.ones(1, dtype=np.dtype(fields))
    assert kc.call(one) == 0.0
    assert kc.call(other) == 1.0


def test_writeability_alone_is_no_other_type(monkeypatch: pytest.MonkeyPatch) -> None:
    # a reference's read-only vectors and a caller's own arrays are read alike
    monkeypatch.setenv(CHECK_ENV, "1")
    kc = KernelCall(_scaled_sum)
    out = np.empty(3)
    kc.call(np.ones(3), 1.0, out)
    locked = np.arange(3.0)
    locked.setflags(write=False)
    assert kc.call(locked, 2.0, out) == (6.0, True)
    np.testing.assert_array_equal(out, (0.0, 2.0, 4.0))
