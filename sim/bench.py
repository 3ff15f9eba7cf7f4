"""``ftc-bench``: speed figures, printed (never asserted in tests).

    ftc-bench plant [--repeat N]   real-time factor of 60 s of plant + Dryden wind + sensors
                                   under a hover command at the default plant rate (500 Hz),
                                   called in 5-step chunks as the autopilot does; beside it,
                                   in the same runs, a plain-numpy RK4 of the same plant
                                   equations alone (no numba, no wind, no sensors) and the
                                   ratio of the two medians
    ftc-bench stack [--repeat N]   real-time factor of the full stack over a 60 s thesis
                                   flight: plant + wind + sensors + EKF + TSKF + LQG + AbDOB;
                                   beside it, in the same runs, RotorPy's simulator (SE3
                                   controller, 100 Hz, 60 s; the optional ``bench`` extra)
                                   when installed, else the plain-numpy RK4 plant, named in
                                   the printout, and the ratio of the two medians
    ftc-bench tick [--repeat N]    where the full stack's tick goes: its whole cost (the
                                   ``stack`` flight, medians), then each compiled call timed
                                   where the stack makes it (kernel and numba's dispatch, per
                                   tick), and the rest, the Python around them
    ftc-bench vehicle-speedup [--repeat N] [--speedup X] [--realtime]
                                   the vehicle process (``python -m sim``) at ``--speedup``
                                   (default 20), then unthrottled (``--speedup max``), flying
                                   the thesis mission for 60 s simulated, a pymavlink client
                                   reading every message: simulated time / wall time, seen by
                                   the client from the telemetry's clock, and the messages
                                   per simulated second (the same at both: simulated-time
                                   rates)
    ftc-bench vehicle-jitter [--seconds S] [--realtime]
                                   the vehicle process in real time (--speedup 1) flying the
                                   thesis mission with a client connected: the control-loop
                                   tick period from the vehicle's ``--timing-log``, its
                                   deviation from 10 ms (p50, p99, max) and the busy time
                                   (``--realtime``: the vehicle runs at SCHED_FIFO priority)
    ftc-bench startup [--repeat N]  launch of ``ftc-vehicle`` to the first HEARTBEAT a pymavlink
                                   client sees (loopback), beside a bare pymavlink process
                                   sending one HEARTBEAT (interpreter + dialect import), run
                                   alternately, and the ratio; then the start-up overhead of
                                   ``ftc-scenario run lqg_abdob_loe``: launch to exit minus
                                   the flight's own wall time (start-up designs and numba
                                   kernels come from their caches: a warm-up run fills them;
                                   the packages' bytecode is written first, see
                                   :mod:`sim.startup_bench`)
    ftc-bench campaign [--repeat N] [--campaign NAME|FILE]
                                   a campaign (default ``smoke``) flown by ftc-campaign's
                                   engine on local Dask clusters of 1 and 2 workers:
                                   runs per minute, the scaling, and the per-run overhead over
                                   the bare flight time (:mod:`sim.campaign.bench`)
    ftc-bench compile [--repeat N] the cold build of every kernel (``ftc-vehicle --precompile``
                                   on empty caches), beside the warm load of the same, then
                                   the first ``ftc-scenario run baseline`` and the first
                                   ``ftc-vehicle`` to STANDBY after it (default 1 round:
                                   :mod:`sim.compile_bench`)
    ftc-bench [all]                plant, then stack

The vehicle figures are :mod:`sim.vehicle_bench`'s, the start-up ones
:mod:`sim.startup_bench`'s. Each figure is the median of ``--repeat`` runs (machines are
shared and noisy), with the spread, measured with the process's CPU time as well as the wall
clock. Numba kernels are
compiled (or loaded from the cache) before timing starts.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from jitsupport.calls import KernelCall
from sim.scenario import DEFAULT_WIND, load_scenario
from sim.world import World, WorldConfig
from sim.world.airframe import Airframe

SIM_SECONDS = 60.0
STACK_SCENARIO = "lqg_abdob_loe"  # the 60 s thesis flight of the stack and start-up figures


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


def _numpy_rk4_once() -> tuple[float, float]:
    """60 s of the plant alone at 500 Hz in plain numpy: hover thrust, no wind (a reference).

    The equations of sim/world/dynamics.py (eq. 3.1, 3.5, 3.6, 3.17, the drag model of
    sim/world/airframe.py), written with numpy arrays, one RK4 step of four derivative
    evaluations per plant step, PWM saturation and the quaternion renormalised.
    """
    af = Airframe()
    dt = 1.0 / WorldConfig().plant_rate_hz
    inertia = np.array(af.inertia)
    drag = np.array([af.drag_coeff_xy, af.drag_coeff_xy, af.drag_coeff_z])
    r_cp = np.array([0.0, 0.0, af.cp_offset_z])
    e3 = np.array([0.0, 0.0, 1.0])
    wind = np.zeros(3)

    def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:  # np.cross costs ~10x more
        return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]])

    def derivative(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        q, vel, omega, thrust = x[6:10], x[3:6], x[10:13], x[13:17]
        w, qx, qy, qz = q / np.sqrt(q @ q)
        rot = np.array([  # R(q), body FRD -> NED (eq. 3.9)
            [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - w * qz), 2 * (qx * qz + w * qy)],
            [2 * (qx * qy + w * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - w * qx)],
            [2 * (qx * qz - w * qy), 2 * (qy * qz + w * qx), 1 - 2 * (qx * qx + qy * qy)]])
        v_b = rot.T @ (vel - wind)  # air-relative velocity, body
        f_drag = -(drag + af.drag_quad_coeff * np.sqrt(v_b @ v_b)) * v_b
        f_b = f_drag + np.array([0.0, 0.0, -thrust.sum()])  # thrust along -z_body
        t1, t2, t3, t4 = thrust
        tau = np.array([af.arm_length * (t3 - t4), af.arm_length * (t1 - t2),
                        af.yaw_gain * (t1 + t2 - t3 - t4)]) + cross(r_cp, f_drag)  # eq. 3.17
        dq = 0.5 * np.array([-qx * omega[0] - qy * omega[1] - qz * omega[2],
                             w * omega[0] + qy * omega[2] - qz * omega[1],
                             w * omega[1] + qz * omega[0] - qx * omega[2],
                             w * omega[2] + qx * omega[1] - qy * omega[0]])
        return np.concatenate((
            vel,  # dp/dt = v
            af.gravity * e3 + rot @ f_b / af.mass,  # eq. 3.5
            dq,  # dq/dt = q (x) (0, omega) / 2
            (tau - cross(omega, inertia * omega)) / inertia,  # eq. 3.6
            af.motor_bandwidth * (af.thrust_gain * u - thrust)))  # eq. 3.1

    x = np.zeros(17)
    x[2], x[6] = -0.6, 1.0
    x[13:17] = af.hover_pwm * af.thrust_gain
    pwm = np.full(4, af.hover_pwm)
    n_steps = int(SIM_SECONDS / dt)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for _ in range(n_steps):
        u = np.clip(pwm, af.pwm_min, af.pwm_max)
        k1 = derivative(x, u)
        k2 = derivative(x + 0.5 * dt * k1, u)
        k3 = derivative(x + 0.5 * dt * k2, u)
        k4 = derivative(x + dt * k3, u)
        x = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        x[6:10] /= np.sqrt(x[6:10] @ x[6:10])
    return time.perf_counter() - wall0, time.process_time() - cpu0


def _stack_once() -> tuple[float, float]:
    from sim.runner import fly

    scenario = replace(load_scenario(STACK_SCENARIO), duration_s=SIM_SECONDS)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    fly(scenario)
    return time.perf_counter() - wall0, time.process_time() - cpu0


# the compiled calls of a tick, timed where the stack makes them: (module, the global the
# module calls, a kernel or its KernelCall, what it does)
TICK_KERNELS = (
    ("sim.world.world", "_world_steps", "world: plant, wind, sensors, faults"),
    ("sim.world.battery", "_battery_step", "world: battery and power module"),
    ("fcu.estimation.state", "group_sample_arrays", "sample grouping"),
    ("fcu.monitoring.watched_pair", "_pair_watch_tick", "EKF + TSKF, sensor watch"),
    ("fcu.monitoring.motor_faults", "detector_tick_call", "motor fault detector"),
    ("fcu.control.chain", "_control_tick", "control chain and crash check"),
)


def _timed(kernel: Callable[..., object], label: str, spent: dict[str, list[float]],
           clock_s: float) -> Callable[..., object]:
    """``kernel``, the time of each of its calls (s, less the ``clock_s`` a clock read
    costs) appended to ``spent[label]``."""
    clock = time.perf_counter
    durations = spent[label]

    def timed(*args: object) -> object:
        start = clock()
        out = kernel(*args)
        durations.append(clock() - start - clock_s)
        return out

    return timed


def _report_tick(repeat: int) -> None:
    """``ftc-bench tick``: the stack flight's cost per tick, and each compiled call's."""
    import importlib

    from sim.runner import fly

    # every kernel found before any is wrapped: a missing one leaves the stack untouched
    originals = []
    for module_name, name, _ in TICK_KERNELS:
        module = importlib.import_module(module_name)
        kernel = getattr(module, name, None)
        if kernel is None:
            raise RuntimeError(f"ftc-bench tick: {module_name}.{name} is gone: update "
                               "sim.bench.TICK_KERNELS")
        originals.append((module, name, kernel))
    scenario = replace(load_scenario(STACK_SCENARIO), duration_s=SIM_SECONDS)
    ticks = round(SIM_SECONDS * scenario.autopilot.loop_rate_hz)
    fly(scenario)  # warm-up: kernels loaded, designs cached
    whole = statistics.median(_stack_once()[0] for _ in range(repeat)) / ticks
    # the same flights with every compiled call timed (a clock read either side: its own
    # cost, measured here, is taken off)
    clock = time.perf_counter
    reads = 100_000
    t0 = clock()
    for _ in range(reads):
        clock()
    clock_s = (clock() - t0) / reads
    spent: dict[str, list[float]] = {label: [] for _, _, label in TICK_KERNELS}
    # (a KernelCall is timed by its call, the entry the warm-up flight left there)
    places = [(kernel, "call") if isinstance(kernel, KernelCall) else (module, name)
              for module, name, kernel in originals]
    untimed = [getattr(owner, attribute) for owner, attribute in places]
    try:
        for (owner, attribute), call, (_, _, label) in zip(places, untimed, TICK_KERNELS,
                                                            strict=True):
            setattr(owner, attribute, _timed(call, label, spent, clock_s))
        for _ in range(repeat):
            fly(scenario)
    finally:
        for (owner, attribute), call in zip(places, untimed, strict=True):
            setattr(owner, attribute, call)
    n = repeat * ticks
    print(f"a tick of the full stack ({STACK_SCENARIO}, {SIM_SECONDS:.0f} s, "
          f"{ticks} ticks, {repeat} runs): {whole * 1e6:.1f} us (median)")
    print("  compiled calls, timed where the stack makes them (kernel and dispatch), per tick;"
          " then one call's 20th percentile (the figure a loaded machine moves least):")
    for label, durations in spent.items():
        p20 = float(np.percentile(durations, 20)) if durations else math.nan
        print(f"    {label:42s} {sum(durations) / n * 1e6:6.2f} us  "
              f"({len(durations) / n:.2f} calls)  p20 {p20 * 1e6:6.2f} us")
    compiled = sum(sum(d) for d in spent.values()) / n
    print(f"  compiled calls in all: {compiled * 1e6:.1f} us; the rest (Python: the "
          f"autopilot's glue, navigator, log, ...): {(whole - compiled) * 1e6:.1f} us")


def _rotorpy_reference() -> tuple[str, Callable[[], tuple[float, float]]] | None:
    """RotorPy's ``simulate`` over the same 60 s at 100 Hz, if RotorPy is installed (the
    ``bench`` extra): its Multirotor (hummingbird parameters) flown by its SE3 controller
    round a 1 m circle, with its IMU and motion-capture models; Dryden wind when its Dryden
    model imports (it needs torch), else its sinusoidal wind."""
    try:
        from importlib.metadata import version

        from rotorpy.controllers.quadrotor_control import SE3Control
        from rotorpy.estimators.nullestimator import NullEstimator
        from rotorpy.sensors.external_mocap import MotionCapture
        from rotorpy.sensors.imu import Imu
        from rotorpy.simulate import simulate
        from rotorpy.trajectories.circular_traj import ThreeDCircularTraj
        from rotorpy.vehicles.hummingbird_params import quad_params
        from rotorpy.vehicles.multirotor import Multirotor
        from rotorpy.world import World as RotorpyWorld
    except ImportError:
        return None
    rate_hz = 100.0
    try:
        from rotorpy.wind.dryden_winds import DrydenGust

        def wind() -> object:
            return DrydenGust(dt=1.0 / rate_hz, sig_wind=np.array([0.75, 0.75, 0.3]))
        wind_text = "Dryden wind"
    except ImportError:
        from rotorpy.wind.default_winds import SinusoidWind

        def wind() -> object:
            return SinusoidWind(amplitudes=np.array([1.0, 1.0, 0.2]),
                                frequencies=np.array([0.5, 0.3, 0.7]))
        wind_text = "sinusoidal wind (its Dryden model needs torch, not installed)"

    def once() -> tuple[float, float]:
        np.random.seed(1)  # noqa: NPY002  (RotorPy draws its sensor noise from numpy's global generator)
        vehicle = Multirotor(quad_params)
        mocap = MotionCapture(sampling_rate=rate_hz, with_artifacts=False, mocap_params={
            "pos_noise_density": np.full(3, 0.0005), "vel_noise_density": np.full(3, 0.001),
            "att_noise_density": np.full(3, 0.0005), "rate_noise_density": np.full(3, 0.0005),
            "vel_artifact_max": 5, "vel_artifact_prob": 0.001, "rate_artifact_max": 1,
            "rate_artifact_prob": 0.0002})
        args = (RotorpyWorld.empty((-5.0, 5.0, -5.0, 5.0, -5.0, 5.0)), vehicle.initial_state,
                vehicle, SE3Control(quad_params),
                ThreeDCircularTraj(radius=np.array([1.0, 1.0, 0.0]),
                                   freq=np.array([0.1, 0.1, 0.0])),
                wind(), Imu(p_BS=np.zeros(3), R_BS=np.eye(3), sampling_rate=rate_hz), mocap,
                NullEstimator(), SIM_SECONDS, 1.0 / rate_hz, 0.25, False)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        simulate(*args, terminate=False)
        return time.perf_counter() - wall0, time.process_time() - cpu0

    return (f"RotorPy {version('rotorpy')} simulate(): Multirotor + SE3 controller, 100 Hz, "
            f"IMU and mocap models, {wind_text}", once)


def _report(label: str, once: Callable[[], tuple[float, float]], repeat: int,
            reference: tuple[str, Callable[[], tuple[float, float]]] | None = None) -> None:
    """Median real-time factors of ``once``; with a ``reference``, of that too, each of its
    runs right after one of ``once`` (so both see the same machine load), and the ratio."""
    once()  # warm-up: numba compile or cache load, imports, LQR design
    runs: list[tuple[float, float]] = []
    ref_runs: list[tuple[float, float]] = []
    for _ in range(repeat):
        runs.append(once())
        if reference is not None:
            ref_runs.append(reference[1]())
    print(f"{label}: {SIM_SECONDS:.0f} s simulated, {repeat} runs")
    wall, cpu = _print_factors(runs)
    if reference is not None:
        print(f"  reference, {reference[0]}, in the same runs:")
        ref_wall, ref_cpu = _print_factors(ref_runs)
        print(f"  ratio of the medians: {wall / ref_wall:.1f}x (wall)  {cpu / ref_cpu:.1f}x (CPU)")


def _print_factors(runs: list[tuple[float, float]]) -> tuple[float, float]:
    """Print the real-time factors of ``(wall_s, cpu_s)`` runs; return the medians."""
    rtf = [SIM_SECONDS / wall for wall, _ in runs]
    rtf_cpu = [SIM_SECONDS / cpu for _, cpu in runs]
    print(f"  real-time factor (wall): median {statistics.median(rtf):.1f}x  "
          f"min {min(rtf):.1f}x  max {max(rtf):.1f}x")
    print(f"  real-time factor (CPU):  median {statistics.median(rtf_cpu):.1f}x")
    return statistics.median(rtf), statistics.median(rtf_cpu)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="ftc-bench", description=__doc__.split("\n")[0])
    parser.add_argument("what", choices=("plant", "stack", "tick", "vehicle-speedup",
                                         "vehicle-jitter", "startup", "campaign", "compile",
                                         "all"),
                        nargs="?",
                        default="all")
    parser.add_argument("--repeat", type=int, default=None, help="timed runs (default 5; "
                        "vehicle-speedup and campaign: 3; compile: 1)")
    parser.add_argument("--speedup", type=float, default=20.0,
                        help="vehicle-speedup: the vehicle's --speedup (default 20)")
    parser.add_argument("--seconds", type=float, default=30.0,
                        help="vehicle-jitter: simulated = wall seconds flown (default 30)")
    parser.add_argument("--realtime", action="store_true",
                        help="vehicle-*: run the vehicle with --realtime (SCHED_FIFO)")
    parser.add_argument("--campaign", default="smoke",
                        help="campaign: the campaign flown (default smoke)")
    args = parser.parse_args(argv)
    if args.repeat is not None and args.repeat < 1:
        parser.error(f"--repeat {args.repeat}: must be >= 1")
    if not 0 < args.speedup <= 1000:
        parser.error(f"--speedup {args.speedup}: must be in (0, 1000]")
    if not 1 <= args.seconds <= 600:
        parser.error(f"--seconds {args.seconds}: must be in [1, 600]")
    if args.what == "vehicle-speedup":
        from sim.vehicle_bench import report_vehicle_speedup

        report_vehicle_speedup(args.speedup, args.repeat or 3, args.realtime)
        return 0
    if args.what == "vehicle-jitter":
        from sim.vehicle_bench import report_vehicle_jitter

        report_vehicle_jitter(args.seconds, args.realtime)
        return 0
    if args.what == "startup":
        from sim.startup_bench import report_startup

        report_startup(args.repeat or 5)
        return 0
    if args.what == "tick":
        _report_tick(args.repeat or 5)
        return 0
    if args.what == "compile":
        from sim.compile_bench import report_compile

        report_compile(args.repeat or 1)
        return 0
    if args.what == "campaign":
        from flightdata.config import ConfigError
        from sim.campaign.bench import report as report_campaign

        try:
            report_campaign(args.campaign, args.repeat or 3)
        except ConfigError as exc:
            parser.error(str(exc))
        return 0
    args.repeat = args.repeat or 5
    if args.what in ("plant", "all"):
        _report("plant + wind + sensors, hover command, 500 Hz, 5-step calls", _plant_once,
                args.repeat, ("plain-numpy RK4 of the plant alone (no numba, no wind, no "
                              "sensors), 500 Hz hover", _numpy_rk4_once))
    if args.what in ("stack", "all"):
        reference = _rotorpy_reference() or (
            "plain-numpy RK4 of the plant alone, 500 Hz hover (RotorPy is not installed: "
            "make bench installs it)", _numpy_rk4_once)
        _report("full stack (plant 500 Hz, EKF + TSKF + LQG + AbDOB at 100 Hz, wind, sensors,"
                " Table 7.3 faults)", _stack_once, args.repeat, reference)
    return 0


if __name__ == "__main__":
    sys.exit(main())
