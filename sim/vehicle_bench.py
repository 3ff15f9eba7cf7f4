"""``ftc-bench vehicle-speedup`` and ``vehicle-jitter``: the vehicle process's speed, seen
from a client.

:func:`fly_vehicle` starts ``python -m sim`` with the thesis mission loaded and paused, flies
it from a pymavlink client that reads every message, and returns what the client saw
(:class:`VehicleRun`). :func:`report_vehicle_speedup` prints the ratio of simulated to wall
time at a chosen ``--speedup`` and unthrottled, :func:`report_vehicle_jitter` the control
loop's tick periods in real time from the vehicle's ``--timing-log`` (see :mod:`sim.bench`).
"""

from __future__ import annotations

import math
import re
import select
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.bench import SIM_SECONDS

__all__ = ["VehicleRun", "fly_vehicle", "report_vehicle_jitter", "report_vehicle_speedup",
           "speedup_text"]


@dataclass
class VehicleRun:
    """What a client saw of one vehicle-process flight."""

    sim_s: float  # s, simulated time covered by the telemetry after the start
    wall_s: float  # s, wall time over which it arrived
    messages: int  # messages parsed by the client
    vehicle_line: str  # the vehicle's own summary line

    @property
    def ratio(self) -> float:
        return self.sim_s / self.wall_s


def fly_vehicle(speedup: float, sim_s: float, timing_log: Path | None = None,
                 extra: Sequence[str] = ()) -> VehicleRun:
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
            f"127.0.0.1:{sock.getsockname()[1]}", "--speedup", speedup_text(speedup), "--duration",
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
    return VehicleRun(sim_s=last[1] - first[1], wall_s=last[0] - first[0], messages=count,
                       vehicle_line=summary[-1] if summary else "")


def speedup_text(speedup: float) -> str:
    """The vehicle's ``--speedup`` argument for ``speedup`` (inf: ``max``, unthrottled)."""
    return "max" if math.isinf(speedup) else f"{speedup:g}"


def report_vehicle_speedup(speedup: float, repeat: int, realtime: bool) -> None:
    """``ftc-bench vehicle-speedup``: the vehicle process at ``speedup``, then unthrottled,
    ``repeat`` flights each (module docstring)."""
    extra = ["--realtime"] if realtime else []
    for chosen in (speedup, math.inf):
        runs = [fly_vehicle(chosen, SIM_SECONDS, extra=extra) for _ in range(repeat)]
        ratios = [r.ratio for r in runs]
        rates = [r.messages / r.wall_s for r in runs]
        print(f"vehicle process at --speedup {speedup_text(chosen)}"
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


def report_vehicle_jitter(seconds: float, realtime: bool) -> None:
    """``ftc-bench vehicle-jitter``: the control-loop tick periods of ``seconds`` flown in real
    time (module docstring)."""
    with tempfile.TemporaryDirectory() as tmp:
        log_path = Path(tmp) / "timing.csv"
        run = fly_vehicle(1.0, seconds, timing_log=log_path,
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
