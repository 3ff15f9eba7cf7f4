"""The first run on a fresh machine: kernels compiled at install, a boot that reports progress.

- ``ftc-gcs demo`` with empty kernel and design caches (as on a machine where nothing was
  compiled): the vehicle compiles for minutes on a loaded machine, reporting its progress,
  and the ground station waits for it and flies.
- ``ftc-gcs fly`` against a vehicle that stays in MAV_STATE_BOOT, reporting progress, longer
  than the ground station's 60 s connect time-out: it waits and flies.
- After ``ftc-vehicle --precompile`` on empty caches, flights of every attitude law, estimator,
  observer and FTC mode, the vehicle's own boot, and a campaign worker's preparation compile
  nothing more.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
COLD_WALL_S = 2400.0  # s: every kernel compiled from scratch on a loaded 2-core machine

pytestmark = pytest.mark.slow


def _empty_caches(tmp_path: Path) -> dict[str, str]:
    return {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache"),
            "QUADFTC_CACHE_DIR": str(tmp_path / "design-cache")}


def test_demo_flies_with_empty_kernel_and_design_caches(tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "gcs", "demo", "--out-dir", str(out)],
                          cwd=ROOT, env=_empty_caches(tmp_path), capture_output=True, text=True,
                          timeout=COLD_WALL_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "RESULT    mission flown, vehicle landed and disarmed" in proc.stderr
    compiled = [int(n) for n in re.findall(r"vehicle preparing: (\d+) of \d+ kernels compiled",
                                           proc.stderr)]
    assert compiled and max(compiled) > 20  # it compiled, and said so on the terminal
    assert (tmp_path / "numba-cache").is_dir()  # into the cache it was given
    [tlog] = out.glob("demo-*.tlog")
    assert tlog.stat().st_size > 100_000  # a whole flight's telemetry


def test_fly_waits_for_a_vehicle_booting_longer_than_its_connect_timeout(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "gcs", "fly", "--spawn-vehicle", "--speedup", "20",
         "--connect-timeout", "60", "--vehicle-arg=--boot-delay", "--vehicle-arg=70",
         "--tlog", str(tmp_path / "f.tlog")],
        cwd=ROOT, capture_output=True, text=True, timeout=900.0, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    reported_s = [int(s) for s in re.findall(r"vehicle preparing: \d+ of \d+ kernels compiled, "
                                             r"(\d+) s", proc.stderr)]
    assert max(reported_s) >= 65  # still booting, and reporting, after the 60 s time-out
    assert "RESULT    mission flown, vehicle landed and disarmed" in proc.stderr


_CHECK_NOTHING_COMPILES = """
import sys
from sim.campaign.worker import prepare_kernels
from sim.preparation import KernelProgress, prepare_vehicle
from sim.runner import fly
from sim.scenario import load_scenario, scenario_from_mapping

with KernelProgress() as progress:
    for attitude in ("pd", "lqg"):
        for estimator in ("ekf", "tskf"):
            for dob in ("none", "vbdob", "abdob"):
                for ftc in ("passive", "active"):
                    scenario = scenario_from_mapping({
                        "duration_s": 3.0, "autopilot": {"attitude": attitude,
                        "estimator": estimator, "dob": dob, "ftc": ftc}})
                    fly(scenario)
    for name in ("motor1_lost", "case5", "mocap_lost", "active_loe65"):
        fly(load_scenario(name))
    scenario = load_scenario("baseline")
    prepare_vehicle(scenario.world, scenario.autopilot, scenario.seed)
    prepare_kernels()
print("\\n".join(progress.kernel_names))
print(progress.snapshot().compiled)
"""


def test_after_precompile_no_configuration_compiles_anything(tmp_path: Path) -> None:
    env = _empty_caches(tmp_path)
    done = subprocess.run([sys.executable, "-m", "sim", "--precompile"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=COLD_WALL_S,
                          stdin=subprocess.DEVNULL)
    assert done.returncode == 0, done.stderr[-3000:]
    final = done.stdout.strip().splitlines()[-1]
    assert re.fullmatch(r"ftc-vehicle: ready: \d+ of \d+ kernels compiled, \d+ s", final), final
    check = subprocess.run([sys.executable, "-c", _CHECK_NOTHING_COMPILES], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=COLD_WALL_S,
                           stdin=subprocess.DEVNULL)
    assert check.returncode == 0, check.stderr[-3000:]
    *compiled, count = check.stdout.strip().splitlines()
    assert count == "0", compiled  # every kernel came from the cache precompile filled
