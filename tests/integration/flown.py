"""Headless flights of shipped scenarios, each flown once per test session."""

from __future__ import annotations

from functools import cache
from typing import Any

from sim.runner import FlightResult, fly
from sim.scenario import load_scenario


@cache
def flight(name: str, seed: int | None = None) -> FlightResult:
    """The runner's flight of a shipped scenario (its own seed unless ``seed`` is given)."""
    scenario = load_scenario(name)
    return fly(scenario if seed is None else scenario.with_seed(seed))


def metrics(name: str, seed: int | None = None) -> dict[str, Any]:
    """The runner's metrics of a shipped scenario (its own seed unless ``seed`` is given)."""
    return flight(name, seed).metrics
