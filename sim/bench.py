"""``ftc-bench``: speed figures, printed (never asserted in tests).

    ftc-bench plant [--repeat N]   real-time factor of 60 s of plant + Dryden wind + sensors
                                   under a hover command at the default plant rate (500 Hz)
    ftc-bench stack [--repeat N]   real-time factor of the full stack over a 60 s thesis
                                   flight: plant + wind + sensors + EKF + TSKF + LQG + AbDOB

Each figure is the median of ``--repeat`` runs (machines are shared and noisy), with the
spread, measured with the process's CPU time as well as the wall clock. Numba kernels are
compiled (or loaded from the cache) before timing starts.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from sim.scenario import DEFAULT_WIND, load_scenario
from sim.world import World, WorldConfig

SIM_SECONDS = 60.0


def _plant_once() -> tuple[float, float]:
    world = World(WorldConfig(wind=DEFAULT_WIND), seed=1)
    hover_pwm = world.config.airframe.hover_pwm
    hover_thrust = hover_pwm * world.config.airframe.thrust_gain
    world.plant.reset(pos_ned=(0.0, 0.0, -0.6), thrust_n=np.full(4, hover_thrust))
    pwm = np.full(4, hover_pwm)
    steps_per_call = 5  # as the autopilot loop calls it: 100 Hz ticks of 5 plant steps
    n_calls = int(SIM_SECONDS * world.config.plant_rate_hz / steps_per_call)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for _ in range(n_calls):
        world.step(pwm, steps_per_call)
    return time.perf_counter() - wall0, time.process_time() - cpu0


def _stack_once() -> tuple[float, float]:
    from sim.runner import fly

    scenario = replace(load_scenario("lqg_abdob_loe"), duration_s=SIM_SECONDS)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    fly(scenario)
    return time.perf_counter() - wall0, time.process_time() - cpu0


def _report(label: str, once: Callable[[], tuple[float, float]], repeat: int) -> None:
    once()  # warm-up: numba compile or cache load, imports, LQR design
    walls, cpus = [], []
    for _ in range(repeat):
        wall, cpu = once()
        walls.append(wall)
        cpus.append(cpu)
    rtf = [SIM_SECONDS / w for w in walls]
    rtf_cpu = [SIM_SECONDS / c for c in cpus]
    print(f"{label}: {SIM_SECONDS:.0f} s simulated, {repeat} runs")
    print(f"  real-time factor (wall): median {statistics.median(rtf):.1f}x  "
          f"min {min(rtf):.1f}x  max {max(rtf):.1f}x")
    print(f"  real-time factor (CPU):  median {statistics.median(rtf_cpu):.1f}x")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="ftc-bench", description=__doc__.split("\n")[0])
    parser.add_argument("what", choices=("plant", "stack", "all"), nargs="?", default="all")
    parser.add_argument("--repeat", type=int, default=5, help="timed runs (default 5)")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat {args.repeat}: must be >= 1")
    if args.what in ("plant", "all"):
        _report("plant + wind + sensors, hover command, 500 Hz", _plant_once, args.repeat)
    if args.what in ("stack", "all"):
        _report("full stack (plant 500 Hz, EKF + TSKF + LQG + AbDOB at 100 Hz, wind, sensors,"
                " Table 7.3 faults)", _stack_once, args.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
