"""Validation helper for the autopilot's frozen configuration dataclasses.

Errors name the key, the value and what is allowed, so a composition root that loads a
configuration file can show them to a person as they are.
"""

from __future__ import annotations

import math


class ConfigValueError(ValueError):
    """An autopilot configuration value is out of its allowed range."""


def require(ok: bool, key: str, value: object, allowed: str) -> None:
    """Raise ConfigValueError ``"<key> = <value>: <allowed>"`` unless ``ok``."""
    if not ok:
        raise ConfigValueError(f"{key} = {value!r}: {allowed}")


def is_finite(value: object) -> bool:
    """True for a finite real number (bools excluded)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
