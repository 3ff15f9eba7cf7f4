"""Registries of pluggable parts: one factory per vocabulary name, checked at import."""

from __future__ import annotations

import pytest

from fcu.registry import Registry, RegistryError


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
