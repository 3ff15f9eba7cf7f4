"""The rooms of the house (STYLE.md): fcu never imports sim or gcs; gcs never imports fcu or sim.

The plant modules of sim do not import fcu either: only the composition roots listed below
wire the simulator and the autopilot together.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = {"fcu": {"sim", "gcs"}, "gcs": {"fcu", "sim"}, "sim": {"gcs"}}
# sim modules allowed to import fcu: the composition roots and their helpers
SIM_COMPOSITION_ROOTS = {"runner", "scenario", "scenario_cli", "vehicle", "vehicle_cli",
                         "vehicle_port", "demo", "bench", "thesis_report", "recording",
                         "figures", "progress"}


def imported_packages(path: Path) -> set[str]:
    """Top-level package names imported by one Python file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def python_files(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_no_forbidden_imports(package: str) -> None:
    files = python_files(package)
    assert files, f"{package}/ has no Python files"
    crossings = []
    for path in files:
        forbidden = set(FORBIDDEN[package])
        if package == "sim" and path.stem not in SIM_COMPOSITION_ROOTS:
            forbidden.add("fcu")
        bad = imported_packages(path) & forbidden
        if bad:
            crossings.append(f"{path.relative_to(ROOT)} imports {sorted(bad)}")
    assert not crossings, "\n".join(crossings)


def test_checker_detects_a_crossing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("import sim.dynamics\nfrom gcs import cli\n")
    assert imported_packages(bad) == {"sim", "gcs"}
