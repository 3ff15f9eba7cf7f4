"""``ftc-bench startup``: how long the vehicle and a headless flight take to start.

:func:`first_heartbeat_s` launches a process and times it (wall and its own CPU) to the first
HEARTBEAT a pymavlink client sees on loopback, and to the first of an autopilot that is
ready; :func:`report_startup` compares ``ftc-vehicle`` with a bare pymavlink process sending
one HEARTBEAT, launched alternately, then measures the start-up overhead of
``ftc-scenario run`` (launch to exit minus the flight). :mod:`sim.compile_bench` times its
first vehicle with the same helpers.
"""

from __future__ import annotations

import json
import math
import os
import select
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from sim.bench import SIM_SECONDS, STACK_SCENARIO

__all__ = ["first_heartbeat_s", "report_startup", "script_command", "vehicle_command"]


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


def first_heartbeat_s(command: Callable[[int], list[str]],
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


def script_command(name: str, module: str) -> list[str]:
    """How to launch this install's console script ``name`` (else ``python -m module``)."""
    script = Path(sys.executable).with_name(name)
    return [str(script)] if script.exists() else [sys.executable, "-m", module]


def vehicle_command(port: int) -> list[str]:
    """How to launch ``ftc-vehicle`` sending to a ground station at loopback ``port``."""
    return script_command("ftc-vehicle", "sim") + ["--bind", "127.0.0.1:0", "--out",
                                                   f"127.0.0.1:{port}"]


def _scenario_overhead_s(name: str) -> tuple[float, float]:
    """``ftc-scenario run name``: (launch to exit, the flight's own wall time), s."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.json"
        start_s = time.perf_counter()
        subprocess.run(script_command("ftc-scenario", "sim.scenario_cli")
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


def report_startup(repeat: int) -> None:
    """Median time to the first HEARTBEAT of ``ftc-vehicle`` and of a bare pymavlink sender,
    launched alternately (so both see the same machine load), and their ratio; then the
    start-up overhead of ``ftc-scenario run``."""
    failed = _write_bytecode()
    print("startup: bytecode of sim, fcu, gcs, flightdata written where missing or stale"
          + (f" (could not write all of {', '.join(failed)})" if failed else ""))
    first_heartbeat_s(vehicle_command)  # warm-up: design and numba caches, page cache
    vehicle: list[tuple[float, float, float, float]] = []
    bare: list[tuple[float, float, float, float]] = []
    for _ in range(repeat):
        vehicle.append(first_heartbeat_s(vehicle_command))
        bare.append(first_heartbeat_s(
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
