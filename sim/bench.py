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
                                   ``_write_bytecode``)
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

Each figure is the median of ``--repeat`` runs (machines are shared and noisy), with the
spread, measured with the process's CPU time as well as the wall clock. Numba kernels are
compiled (or loaded from the cache) before timing starts.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import select
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from flightdata.kernel_calls import KernelCall
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
    ("fcu.monitoring.motor_faults", "_detector_tick_call", "motor fault detector"),
    ("fcu.control.chain", "_control_tick", "control chain and crash check"),
)


def _timed(kernel: Callable[..., object], label: str, spent: dict[str, float],
           calls: dict[str, int], clock_s: float) -> Callable[..., object]:
    """``kernel``, its calls counted in ``calls[label]`` and their time (s, less the
    ``clock_s`` a clock read costs) added up in ``spent[label]``."""
    clock = time.perf_counter

    def timed(*args: object) -> object:
        start = clock()
        out = kernel(*args)
        spent[label] += clock() - start - clock_s
        calls[label] += 1
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
    spent = {label: 0.0 for _, _, label in TICK_KERNELS}
    calls = dict.fromkeys(spent, 0)
    # (a KernelCall is timed by its call, the entry the warm-up flight left there)
    places = [(kernel, "call") if isinstance(kernel, KernelCall) else (module, name)
              for module, name, kernel in originals]
    untimed = [getattr(owner, attribute) for owner, attribute in places]
    try:
        for (owner, attribute), call, (_, _, label) in zip(places, untimed, TICK_KERNELS,
                                                            strict=True):
            setattr(owner, attribute, _timed(call, label, spent, calls, clock_s))
        for _ in range(repeat):
            fly(scenario)
    finally:
        for (owner, attribute), call in zip(places, untimed, strict=True):
            setattr(owner, attribute, call)
    n = repeat * ticks
    print(f"a tick of the full stack ({STACK_SCENARIO}, {SIM_SECONDS:.0f} s, "
          f"{ticks} ticks, {repeat} runs): {whole * 1e6:.1f} us (median)")
    print("  compiled calls, timed where the stack makes them (kernel and dispatch), per tick:")
    for label, seconds in spent.items():
        print(f"    {label:42s} {seconds / n * 1e6:6.2f} us  ({calls[label] / n:.2f} calls)")
    compiled = sum(spent.values()) / n
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


@dataclass
class _VehicleRun:
    """What a client saw of one vehicle-process flight."""

    sim_s: float  # s, simulated time covered by the telemetry after the start
    wall_s: float  # s, wall time over which it arrived
    messages: int  # messages parsed by the client
    vehicle_line: str  # the vehicle's own summary line

    @property
    def ratio(self) -> float:
        return self.sim_s / self.wall_s


def _fly_vehicle(speedup: float, sim_s: float, timing_log: Path | None = None,
                 extra: Sequence[str] = ()) -> _VehicleRun:
    """Start ``python -m sim``, fly the thesis mission from a client, read every message.

    The vehicle boots paused with the mission loaded; the client arms, switches to AUTO,
    starts the mission and sets SIM_PAUSE 0, sending GCS heartbeats at 1 Hz (wall) and
    parsing all telemetry until the vehicle stops after ``sim_s`` simulated seconds.
    """
    from pymavlink.dialects.v20 import ardupilotmega as mav

    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    sock.bind(("127.0.0.1", 0))
    args = [sys.executable, "-m", "sim", "--bind", "127.0.0.1:0", "--out",
            f"127.0.0.1:{sock.getsockname()[1]}", "--speedup", _speedup_text(speedup), "--duration",
            f"{sim_s:g}", "--load-mission", "--start-paused"]
    if timing_log is not None:
        args += ["--timing-log", str(timing_log)]
    args += list(extra)
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    codec = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    try:
        line = proc.stdout.readline()
        match = re.search(r"listening on udp ([\d.]+):(\d+)", line)
        if match is None:
            raise RuntimeError(f"vehicle did not start: {line!r}")
        vehicle = (match.group(1), int(match.group(2)))

        def send(msg: object) -> None:
            sock.sendto(msg.pack(codec), vehicle)  # type: ignore[attr-defined]
            codec.seq = (codec.seq + 1) % 256

        send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0,
                                           0, 3))
        for command, p1, p2 in ((mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 0),
                                (mav.MAV_CMD_DO_SET_MODE, 1, 3),
                                (mav.MAV_CMD_MISSION_START, 0, 0)):
            send(mav.MAVLink_command_long_message(1, 1, command, 0, p1, p2, 0, 0, 0, 0, 0))
        send(mav.MAVLink_param_set_message(1, 1, b"SIM_PAUSE", 0.0, mav.MAV_PARAM_TYPE_REAL32))
        first: tuple[float, float] | None = None  # (wall, simulated) of the first sample
        last = (0.0, 0.0)
        count = 0
        last_heartbeat = time.monotonic()
        while proc.poll() is None or select.select([sock], [], [], 0.2)[0]:
            if not select.select([sock], [], [], 0.2)[0]:
                continue
            data = sock.recv(65535)
            now = time.monotonic()
            parser = mav.MAVLink(None)
            parser.robust_parsing = True
            for msg in parser.parse_buffer(data) or []:
                count += 1
                time_ms = getattr(msg, "time_boot_ms", None)
                if time_ms is not None and time_ms > 0:
                    if first is None:
                        first = (now, time_ms / 1000.0)
                    last = (now, time_ms / 1000.0)
            if now - last_heartbeat >= 1.0:
                last_heartbeat = now
                send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID,
                                                   0, 0, 0, 3))
        summary = proc.stdout.read().strip().splitlines()
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            proc.wait(30)
        sock.close()
    if first is None:
        raise RuntimeError("no telemetry received")
    return _VehicleRun(sim_s=last[1] - first[1], wall_s=last[0] - first[0], messages=count,
                       vehicle_line=summary[-1] if summary else "")


def _speedup_text(speedup: float) -> str:
    """The vehicle's ``--speedup`` argument for ``speedup`` (inf: ``max``, unthrottled)."""
    return "max" if math.isinf(speedup) else f"{speedup:g}"


def _report_vehicle_speedup(speedup: float, repeat: int, realtime: bool) -> None:
    extra = ["--realtime"] if realtime else []
    for chosen in (speedup, math.inf):
        runs = [_fly_vehicle(chosen, SIM_SECONDS, extra=extra) for _ in range(repeat)]
        ratios = [r.ratio for r in runs]
        rates = [r.messages / r.wall_s for r in runs]
        print(f"vehicle process at --speedup {_speedup_text(chosen)}"
              f"{' --realtime' if realtime else ''}, thesis mission, {SIM_SECONDS:.0f} s "
              f"simulated, pymavlink client reading all telemetry, {repeat} runs")
        print(f"  simulated / wall time (client): median {statistics.median(ratios):.1f}x  "
              f"min {min(ratios):.1f}x  max {max(ratios):.1f}x")
        print(f"  messages received: median {statistics.median(rates):.0f}/s (wall), "
              f"{statistics.median(r.messages / r.sim_s for r in runs):.0f} per simulated s")
        cpu_ratios = [float(m.group(1)) for r in runs
                      if (m := re.search(r"([\d.]+)x per CPU second", r.vehicle_line))]
        if cpu_ratios:  # what a busy machine's share of the CPU does not change
            print(f"  simulated / CPU time (vehicle): median "
                  f"{statistics.median(cpu_ratios):.1f}x")
        for run in runs:
            print(f"  vehicle: {run.vehicle_line}")


def _report_vehicle_jitter(seconds: float, realtime: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        log_path = Path(tmp) / "timing.csv"
        run = _fly_vehicle(1.0, seconds, timing_log=log_path,
                           extra=["--realtime"] if realtime else [])
        table = np.loadtxt(log_path, delimiter=",", skiprows=1, ndmin=2)
    start_s, busy_s = table[:, 1], table[:, 2]
    period_ms = np.diff(start_s) * 1e3
    deviation_ms = np.abs(period_ms - 10.0)
    print(f"vehicle process in real time (--speedup 1{' --realtime' if realtime else ''}), "
          f"thesis mission, {seconds:g} s, pymavlink client connected: {len(period_ms)} tick "
          "periods")
    print(f"  period: mean {period_ms.mean():.3f} ms, |period - 10 ms|: p50 "
          f"{np.percentile(deviation_ms, 50):.3f} ms  p99 {np.percentile(deviation_ms, 99):.3f} "
          f"ms  max {deviation_ms.max():.3f} ms")
    busy_ms = busy_s * 1e3
    print(f"  busy per tick (plant + autopilot + MAVLink): p50 {np.percentile(busy_ms, 50):.3f} "
          f"ms  p99 {np.percentile(busy_ms, 99):.3f} ms  max {busy_ms.max():.3f} ms")
    print(f"  client: {run.ratio:.3f}x real time, {run.messages / run.wall_s:.0f} messages/s")
    print(f"  vehicle: {run.vehicle_line}")


# A bare pymavlink process: the floor of any process that speaks MAVLink with pymavlink's
# codec (interpreter start, the dialect's import, one datagram).
_BARE_HEARTBEAT_SENDER = """\
import socket, sys
from pymavlink.dialects.v20 import ardupilotmega as mav
codec = mav.MAVLink(None, srcSystem=1, srcComponent=1)
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
heartbeat = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_GENERIC,
                                          0, 0, mav.MAV_STATE_STANDBY, 3)
sock.sendto(heartbeat.pack(codec), ("127.0.0.1", int(sys.argv[1])))
"""


def _cpu_s(pid: int) -> float:
    """CPU seconds (user + system) process ``pid`` has used so far (Linux /proc; else NaN)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except OSError:
        return math.nan
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


def _first_heartbeat_s(command: Callable[[int], list[str]],
                       timeout_s: float = 60.0) -> tuple[float, float, float, float]:
    """Wall and CPU seconds from launching ``command(port)`` to the first HEARTBEAT parsed
    (pymavlink) on a loopback UDP socket at ``port``, then to the first that is not
    ``MAV_STATE_BOOT`` (ready: the autopilot is up); the process is then stopped (SIGTERM).
    The CPU time is the process's own, read as the HEARTBEAT arrives: unlike the wall time
    it hardly depends on the machine's load.

    Returns
    -------
    first_wall_s, first_cpu_s, ready_wall_s, ready_cpu_s
    """
    from pymavlink.dialects.v20 import ardupilotmega as mav

    first: tuple[float, float] | None = None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        parser = mav.MAVLink(None)
        parser.robust_parsing = True
        start_s = time.perf_counter()
        proc = subprocess.Popen(command(sock.getsockname()[1]), stdout=subprocess.DEVNULL,
                                stdin=subprocess.DEVNULL)
        try:
            while time.perf_counter() - start_s < timeout_s:
                if not select.select([sock], [], [], 0.5)[0]:
                    if proc.poll() not in (None, 0):
                        raise RuntimeError(f"{command(0)[0]} exited with {proc.returncode}")
                    continue
                msgs = parser.parse_buffer(sock.recv(65535)) or []
                for msg in msgs:
                    if msg.get_type() != "HEARTBEAT":
                        continue
                    now = time.perf_counter() - start_s, _cpu_s(proc.pid)
                    first = first or now
                    if int(msg.system_status) != mav.MAV_STATE_BOOT:
                        return (*first, *now)
            raise RuntimeError(f"no ready HEARTBEAT within {timeout_s:g} s")
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
            proc.wait(30)


def _script(name: str, module: str) -> list[str]:
    """How to launch this install's console script ``name`` (else ``python -m module``)."""
    script = Path(sys.executable).with_name(name)
    return [str(script)] if script.exists() else [sys.executable, "-m", module]


def _vehicle_command(port: int) -> list[str]:
    return _script("ftc-vehicle", "sim") + ["--bind", "127.0.0.1:0", "--out", f"127.0.0.1:{port}"]


def _scenario_overhead_s(name: str) -> tuple[float, float]:
    """``ftc-scenario run name``: (launch to exit, the flight's own wall time), s."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.json"
        start_s = time.perf_counter()
        subprocess.run(_script("ftc-scenario", "sim.scenario_cli")
                       + ["run", name, "--json", str(out)], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        total_s = time.perf_counter() - start_s
        flight_s = float(json.loads(out.read_text())["wall_s"])
    return total_s, flight_s


def _median(runs: Sequence[tuple[float, ...]], column: int) -> float:
    return statistics.median(run[column] for run in runs)


def _spread(runs: Sequence[tuple[float, ...]]) -> str:
    """Median, min and max of the wall times, median of the CPU times, of ``runs``."""
    return (f"wall median {_median(runs, 0):.2f} s  min {min(r[0] for r in runs):.2f} s  "
            f"max {max(r[0] for r in runs):.2f} s;  CPU median {_median(runs, 1):.2f} s")


def _write_bytecode() -> list[str]:
    """Write the bytecode (``__pycache__/*.pyc``) of this project's packages where it is
    missing or stale; returns the packages whose bytecode could not all be written.

    Python writes it on a first import, unless ``PYTHONDONTWRITEBYTECODE`` is set (or the
    folder is read-only); without it every start compiles every module from source again,
    about 0.2 s of CPU for an entry point here. A warm start has it, as an installed package
    has from its installation, so the start-up figures are taken with it.
    """
    import compileall

    root = Path(__file__).resolve().parents[1]
    return [name for name in ("sim", "fcu", "gcs", "flightdata")
            if (root / name).is_dir() and not compileall.compile_dir(root / name, quiet=2)]


def _report_startup(repeat: int) -> None:
    """Median time to the first HEARTBEAT of ``ftc-vehicle`` and of a bare pymavlink sender,
    launched alternately (so both see the same machine load), and their ratio; then the
    start-up overhead of ``ftc-scenario run``."""
    failed = _write_bytecode()
    print("startup: bytecode of sim, fcu, gcs, flightdata written where missing or stale"
          + (f" (could not write all of {', '.join(failed)})" if failed else ""))
    _first_heartbeat_s(_vehicle_command)  # warm-up: design and numba caches, page cache
    vehicle: list[tuple[float, float, float, float]] = []
    bare: list[tuple[float, float, float, float]] = []
    for _ in range(repeat):
        vehicle.append(_first_heartbeat_s(_vehicle_command))
        bare.append(_first_heartbeat_s(
            lambda port: [sys.executable, "-c", _BARE_HEARTBEAT_SENDER, str(port)]))
    print(f"startup: launch of ftc-vehicle to its first HEARTBEAT seen by a pymavlink client "
          f"(loopback), {repeat} runs; wall time, and the process's CPU time by then")
    print("  ftc-vehicle, first HEARTBEAT (MAV_STATE_BOOT while the autopilot loads): "
          + _spread(vehicle))
    ready = [(wall, cpu) for _, _, wall, cpu in vehicle]
    print("  ftc-vehicle, first HEARTBEAT of the autopilot (STANDBY, ready): " + _spread(ready))
    print("  reference, a bare pymavlink process sending one HEARTBEAT (interpreter, dialect "
          "import, one datagram), in the same runs:")
    print("  bare sender: " + _spread(bare))
    print(f"  ratio of the medians, first HEARTBEAT: {_median(vehicle, 0) / _median(bare, 0):.1f}x "
          f"(wall)  {_median(vehicle, 1) / _median(bare, 1):.1f}x (CPU); ready: "
          f"{_median(ready, 0) / _median(bare, 0):.1f}x (wall)  "
          f"{_median(ready, 1) / _median(bare, 1):.1f}x (CPU)")
    runs = [_scenario_overhead_s(STACK_SCENARIO) for _ in range(repeat)]
    overhead = [total - flight for total, flight in runs]
    print(f"ftc-scenario run {STACK_SCENARIO} ({SIM_SECONDS:.0f} s flight), {repeat} runs: "
          f"launch to exit median {statistics.median(t for t, _ in runs):.2f} s, the flight "
          f"itself {statistics.median(f for _, f in runs):.2f} s")
    print(f"  start-up overhead (launch to exit minus the flight): median "
          f"{statistics.median(overhead):.2f} s  min {min(overhead):.2f} s  "
          f"max {max(overhead):.2f} s")

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
        _report_vehicle_speedup(args.speedup, args.repeat or 3, args.realtime)
        return 0
    if args.what == "vehicle-jitter":
        _report_vehicle_jitter(args.seconds, args.realtime)
        return 0
    if args.what == "startup":
        _report_startup(args.repeat or 5)
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
