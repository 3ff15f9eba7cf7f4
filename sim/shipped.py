"""The TOML files shipped inside the package, found by name.

Scenarios (``sim/scenarios``) and campaigns (``sim/campaigns``) are both given on the
command line as a shipped name (``lqg_loe``) or as a path to a ``.toml`` file; this module
is the one place that tells the two apart and lists the shipped ones.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

from flightdata.config import ConfigError, load_toml

__all__ = ["load_shipped", "shipped_names", "shipped_path"]

T = TypeVar("T")


def shipped_names(folder: str) -> list[str]:
    """Names (file stems, sorted) of the ``.toml`` files shipped in ``sim/<folder>``."""
    files = resources.files("sim") / folder
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))


def shipped_path(folder: str, noun: str, name_or_path: str | Path) -> Path:
    """The file of a name shipped in ``sim/<folder>``, or ``name_or_path`` itself when it is
    a path (it ends in ``.toml``, holds a ``/`` or exists).

    Raises
    ------
    ConfigError
        An unknown name; the message calls it a ``noun`` and lists the shipped names.
    """
    text = str(name_or_path)
    if text.endswith(".toml") or "/" in text or Path(text).exists():
        return Path(text)
    names = shipped_names(folder)
    if text not in names:
        raise ConfigError(f"unknown {noun} {text!r}: known {noun}s are "
                          f"{', '.join(names)} (or give a .toml file)")
    return Path(str(resources.files("sim") / folder / f"{text}.toml"))


def load_shipped(folder: str, noun: str, name_or_path: str | Path,
                 build: Callable[[Mapping[str, Any], Path], T]) -> T:
    """``build(data, path)`` on the TOML file :func:`shipped_path` finds.

    Raises
    ------
    ConfigError
        Unknown name, missing file, bad TOML, or what ``build`` raises, prefixed with the
        file's path.
    """
    path = shipped_path(folder, noun, name_or_path)
    data = load_toml(path)
    try:
        return build(data, path)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
