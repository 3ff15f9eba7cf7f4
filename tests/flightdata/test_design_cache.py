"""The start-up design cache: a design read back from disk is the fresh design to the bit, and
any changed input (argument, library version, directory) makes it again."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import flightdata.design_cache as design_cache
from fcu.control.attitude_lqr import _axis_lqr_arrays
from fcu.control.attitude_reference import _reference_filter_design
from fcu.control.dob import _discretise
from fcu.control.motor_lead import _lead_design
from fcu.model import VehicleModel
from flightdata.design_cache import CACHE_DIR_ENV, cached_design

INERTIA = VehicleModel().inertia  # kg*m^2, per axis

CALLS: list[float] = []


@cached_design
def _scaled(gain: float, matrix: np.ndarray) -> tuple[np.ndarray, ...]:
    """A stand-in design that counts how often it is really made."""
    CALLS.append(gain)
    return gain * matrix, np.array([gain, 1.0 / 3.0])


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache directory for this test, and no design remembered in memory."""
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path))
    for wrapper in (_scaled, _axis_lqr_arrays, _reference_filter_design, _lead_design,
                    _discretise, design_cache._cont2discrete):
        wrapper.cache_clear()  # type: ignore[attr-defined]
    CALLS.clear()
    return tmp_path


def _stored(cache: Path) -> list[Path]:
    return sorted((cache / "designs").glob("*.npz"))


def _assert_same_bits(got: tuple[np.ndarray, ...], fresh: tuple[np.ndarray, ...]) -> None:
    assert len(got) == len(fresh)
    for a, b in zip(got, fresh, strict=True):
        assert (a.dtype, a.shape) == (np.asarray(b).dtype, np.asarray(b).shape)
        assert a.tobytes() == np.asarray(b).tobytes()


def test_a_design_is_made_once_then_read_back_from_disk(cache: Path) -> None:
    matrix = np.array([[1.0, 2.0], [3.0, 4.0]])
    first = _scaled(0.1, matrix)
    assert CALLS == [0.1] and len(_stored(cache)) == 1
    _scaled.cache_clear()  # type: ignore[attr-defined]  # as a new process would
    again = _scaled(0.1, matrix)
    assert CALLS == [0.1]  # read from disk, not made
    _assert_same_bits(again, first)
    with pytest.raises(ValueError, match="read-only"):
        again[0][0, 0] = 0.0


@pytest.mark.parametrize("change", ["argument", "array", "library"])
def test_a_changed_input_misses_the_cache(cache: Path, monkeypatch: pytest.MonkeyPatch,
                                         change: str) -> None:
    matrix = np.array([[1.0, 2.0], [3.0, 4.0]])
    _scaled(0.1, matrix)
    _scaled.cache_clear()  # type: ignore[attr-defined]
    gain = 0.1
    if change == "argument":
        gain = np.nextafter(0.1, 1.0)  # the next float: a different key
    elif change == "array":
        matrix = matrix.copy()
        matrix[1, 1] = 4.5
    else:
        monkeypatch.setattr(design_cache, "_library_versions", lambda: "numpy 0; scipy 0")
    made = _scaled(gain, matrix)
    assert len(CALLS) == 2 and len(_stored(cache)) == 2
    _assert_same_bits(made, (gain * matrix, np.array([gain, 1.0 / 3.0])))


def test_an_unreadable_entry_is_made_again(cache: Path) -> None:
    _scaled(0.2, np.eye(2))
    (path,) = _stored(cache)
    path.write_bytes(b"not an npz file")
    _scaled.cache_clear()  # type: ignore[attr-defined]
    _assert_same_bits(_scaled(0.2, np.eye(2)), (0.2 * np.eye(2), np.array([0.2, 1.0 / 3.0])))
    assert len(CALLS) == 2


def test_cache_off_stores_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(CACHE_DIR_ENV, "off")
    assert design_cache.cache_dir() is None
    monkeypatch.delenv(CACHE_DIR_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert design_cache.cache_dir() == tmp_path / "quadftc"


DESIGNS: list[tuple[str, Callable[..., tuple[np.ndarray, ...]], tuple[Any, ...]]] = [
    ("lqr", _axis_lqr_arrays, (float(INERTIA[0]), 0.01, (3e6, 1.2e6, 5e3), 4e4)),
    ("reference filter", _reference_filter_design, (0.01, 15.0, 1.0)),
    ("motor lead", _lead_design, (15.0, 60.0, 0.01)),
    ("abdob", _discretise, ("abdob", tuple(float(i) for i in INERTIA), 0.01, 5.0, 15.0)),
    ("vbdob", _discretise, ("vbdob", tuple(float(i) for i in INERTIA), 0.01, 5.0, None)),
    ("c2d", design_cache._cont2discrete,
     (np.array([[0.0, 1.0], [-4.0, -0.5]]), np.array([[0.0], [1.0]]), np.eye(2),
      np.zeros((2, 1)), 0.01, "zoh")),
]


@pytest.mark.parametrize(("name", "wrapper", "args"), DESIGNS, ids=[d[0] for d in DESIGNS])
def test_each_cached_design_equals_a_fresh_design_bit_for_bit(
        cache: Path, name: str, wrapper: Callable[..., tuple[np.ndarray, ...]],
        args: tuple[Any, ...]) -> None:
    wrapper(*args)  # made and stored
    wrapper.cache_clear()  # type: ignore[attr-defined]
    from_disk = wrapper(*args)
    assert len(_stored(cache)) == 1
    _assert_same_bits(from_disk, wrapper.design(*args))  # type: ignore[attr-defined]
