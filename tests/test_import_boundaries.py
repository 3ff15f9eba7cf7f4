"""The rooms of the house (STYLE.md, docs/design.md "Packages and who may import whom").

Each folder below may import, of the project's packages, only the prefixes it lists; the
most specific folder that holds a file decides. A folder named here must exist and hold Python
files, so a rule cannot outlive the code it guards.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("flightdata", "jitsupport", "fcu", "sim", "gcs")
ALLOWED: dict[str, tuple[str, ...]] = {
    # the shared vocabulary and flight-data toolkit: none of the three rooms
    "flightdata": ("flightdata",),
    # the compiled kernels' support (layouts, cache, views, calls): none of the rooms either
    "jitsupport": ("jitsupport",),
    # the autopilot: itself and the shared vocabulary, never the world or the ground station
    "fcu": ("fcu", "flightdata", "jitsupport"),
    # the ground station: pymavlink and the shared vocabulary only
    "gcs": ("gcs", "flightdata"),
    # the simulated world knows nothing of the autopilot nor of the composition roots
    "sim/world": ("sim.world", "flightdata", "jitsupport"),
    # the composition roots wire the world to the autopilot
    "sim": ("sim", "fcu", "flightdata", "jitsupport"),
    # campaigns compose headless runs: scenarios in, rows out; the autopilot only through them
    "sim/campaign": ("sim", "flightdata"),
}


def project_imports(path: Path) -> list[str]:
    """Full module names of the project's packages imported by one Python file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    names: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.append(node.module)
    return [n for n in names if n.split(".")[0] in PACKAGES]


def rule_for(relative: Path, allowed: dict[str, tuple[str, ...]]) -> tuple[str, ...] | None:
    """The allowed prefixes of the most specific folder holding ``relative``."""
    best: str | None = None
    for folder in allowed:
        if relative.parts[:len(Path(folder).parts)] == Path(folder).parts:
            if best is None or len(Path(folder).parts) > len(Path(best).parts):
                best = folder
    return None if best is None else allowed[best]


def crossings(root: Path, allowed: dict[str, tuple[str, ...]]) -> list[str]:
    """Every import that crosses a boundary under ``root``, as readable lines."""
    out = []
    for folder in {Path(f).parts[0] for f in allowed}:
        for path in sorted((root / folder).rglob("*.py")):
            relative = path.relative_to(root)
            prefixes = rule_for(relative, allowed)
            assert prefixes is not None
            for name in project_imports(path):
                if not any(name == p or name.startswith(p + ".") for p in prefixes):
                    out.append(f"{relative} imports {name}")
    return out


def test_no_import_crosses_a_boundary() -> None:
    assert not crossings(ROOT, ALLOWED), "\n".join(crossings(ROOT, ALLOWED))


@pytest.mark.parametrize("folder", sorted(ALLOWED))
def test_every_ruled_folder_exists_and_holds_code(folder: str) -> None:
    assert list((ROOT / folder).rglob("*.py")), f"{folder}/ has no Python files"


def test_the_checker_finds_crossings_in_a_made_up_tree(tmp_path: Path) -> None:
    files = {
        "fcu/ok.py": "import numpy\nfrom fcu.model import VehicleModel\nimport flightdata\n",
        "fcu/bad.py": "from sim.world import World\n",
        "sim/world/bad.py": "from sim.runner import fly\nimport fcu.autopilot\n",
        "sim/root.py": "import fcu.autopilot\nfrom sim.world import World\n",
        "gcs/bad.py": "from fcu import hal\n",
        "flightdata/bad.py": "import gcs.cli\n",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    found = crossings(tmp_path, ALLOWED)
    assert sorted(found) == sorted([
        "fcu/bad.py imports sim.world", "sim/world/bad.py imports sim.runner",
        "sim/world/bad.py imports fcu.autopilot", "gcs/bad.py imports fcu",
        "flightdata/bad.py imports gcs.cli"])
