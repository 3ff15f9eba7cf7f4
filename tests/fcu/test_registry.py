"""Registries of pluggable parts: one factory per vocabulary name, checked at import."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

import fcu.control.registry
import fcu.estimation.registry
from fcu.control.registry import ALLOCATOR_REGISTRY, ATTITUDE_LAW_REGISTRY, DOB_REGISTRY
from fcu.estimation.registry import ESTIMATOR_REGISTRY
from fcu.registry import Registry, RegistryError
from flightdata import vocabulary


def test_a_registry_lists_its_names_in_vocabulary_order() -> None:
    reg = Registry("part", "part", ("a", "b", "c"), {"c": 3, "a": 1, "b": 2})
    assert reg.names == ("a", "b", "c")  # the vocabulary's order (= parameter values)
    assert [reg.factory(name) for name in reg] == [1, 2, 3]
    assert "b" in reg and "d" not in reg and len(reg) == 3


def test_a_vocabulary_name_without_a_factory_fails_naming_it() -> None:
    with pytest.raises(RegistryError, match="no factory for 'c'"):
        Registry("part", "part", ("a", "b", "c"), {"a": 1, "b": 2})


def test_a_factory_whose_name_is_not_in_the_vocabulary_fails_naming_it() -> None:
    with pytest.raises(RegistryError, match="'d' not in the vocabulary"):
        Registry("part", "part", ("a", "b"), {"a": 1, "b": 2, "d": 4})


def test_a_vocabulary_that_repeats_a_name_fails() -> None:
    with pytest.raises(RegistryError, match="repeats a name"):
        Registry("part", "part", ("a", "a"), {"a": 1})


def test_an_unknown_name_is_refused_naming_the_key_and_the_choices() -> None:
    reg = Registry("part", "dob", ("none", "vbdob"), {"none": 0, "vbdob": 1})
    with pytest.raises(ValueError, match="dob = 'kalman': must be one of 'none', 'vbdob'"):
        reg.factory("kalman")


@pytest.mark.parametrize(("registry", "names"), [
    (ESTIMATOR_REGISTRY, vocabulary.ESTIMATORS),
    (ATTITUDE_LAW_REGISTRY, vocabulary.ATTITUDE_LAWS),
    (DOB_REGISTRY, vocabulary.DISTURBANCE_OBSERVERS),
    (ALLOCATOR_REGISTRY, vocabulary.ALLOCATORS),
], ids=["estimator", "attitude", "dob", "allocator"])
def test_each_registry_holds_exactly_its_vocabulary(registry: Registry[object],
                                                     names: tuple[str, ...]) -> None:
    assert registry.names == names
    assert vocabulary.CONFIG_CHOICES[registry.key] == names  # the key the config validates


def _import_copy(module_path: str) -> None:
    """Execute the source of ``module_path`` as a fresh module (sys.modules untouched)."""
    spec = importlib.util.spec_from_file_location("registry_probe", module_path)
    assert spec is not None and spec.loader is not None
    spec.loader.exec_module(importlib.util.module_from_spec(spec))


@pytest.mark.parametrize(("module", "vocabulary_name"), [
    (fcu.control.registry, "ATTITUDE_LAWS"),
    (fcu.control.registry, "DISTURBANCE_OBSERVERS"),
    (fcu.control.registry, "ALLOCATORS"),
    (fcu.estimation.registry, "ESTIMATORS"),
], ids=["attitude", "dob", "allocator", "estimator"])
def test_a_name_added_to_the_vocabulary_alone_fails_at_import(
        monkeypatch: pytest.MonkeyPatch, module: object, vocabulary_name: str) -> None:
    path = str(Path(getattr(module, "__file__", "")))
    _import_copy(path)  # as shipped: imports cleanly
    names = getattr(vocabulary, vocabulary_name)
    monkeypatch.setattr(vocabulary, vocabulary_name, (*names, "newcomer"))
    with pytest.raises(RegistryError, match="no factory for 'newcomer'"):
        _import_copy(path)
