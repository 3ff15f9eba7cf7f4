"""Start a simulated vehicle (``python -m sim``, i.e. ``ftc-vehicle``) as a child process.

The ground station never imports the simulator: it runs it as a separate program, exactly as
a researcher would in another terminal, and talks to it over loopback UDP. Used by
``ftc-gcs fly --spawn-vehicle``, ``ftc-gcs demo`` and the pytest plugin.

The child gets its own process session (Ctrl-C in the terminal reaches the ground station,
which then stops the vehicle itself), writes its output to a log file, binds a free port
(``--bind 127.0.0.1:0``), sends telemetry only to the ground station's port (``--out``), and
carries a simulated-time limit (``--max-sim-s``) so that it ends by itself even if nobody
stops it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

__all__ = ["SpawnedVehicle", "VehicleSpec"]

_STOP_WAIT_S = 10.0  # s wall, between SIGTERM and SIGKILL


@dataclass(frozen=True, kw_only=True)
class VehicleSpec:
    """How to start the vehicle.

    Attributes
    ----------
    speedup : float
        Simulated seconds per wall second.
    seed : int or None
        Seed (None: the scenario's).
    scenario : str or None
        Scenario name or file whose world and autopilot the vehicle simulates (None: its
        default).
    start_paused : bool
        Hold simulated time at 0 until the ground station sets SIM_PAUSE = 0 (the flight
        then follows the headless runner's timeline exactly).
    max_sim_s : float
        The vehicle stops by itself after this much simulated time.
    extra_args : sequence of str
        More ``ftc-vehicle`` options, passed through.
    signing_key : bytes or None
        MAVLink 2 signing key the vehicle starts with (32 bytes; None: unsigned).
    python : str
        Interpreter to run ``-m sim`` with.
    """

    speedup: float = 10.0
    seed: int | None = None
    scenario: str | None = None
    start_paused: bool = True
    max_sim_s: float = 600.0  # s simulated
    extra_args: Sequence[str] = field(default_factory=tuple)
    signing_key: bytes | None = field(default=None, repr=False)  # never shown in a repr
    python: str = sys.executable

    def command(self, gcs_port: int) -> list[str]:
        """The command line for a ground station listening on 127.0.0.1:``gcs_port``."""
        cmd = [self.python, "-m", "sim", "--speedup", f"{self.speedup:g}",
               "--bind", "127.0.0.1:0", "--out", f"127.0.0.1:{gcs_port}",
               "--max-sim-s", f"{self.max_sim_s:g}"]
        if self.seed is not None:
            cmd += ["--seed", str(self.seed)]
        if self.scenario is not None:
            cmd += ["--scenario", self.scenario]
        if self.start_paused:
            cmd.append("--start-paused")
        if self.signing_key is not None:
            cmd += ["--signing-key", "hex:" + self.signing_key.hex()]
        cmd += list(self.extra_args)
        return cmd

    def shown(self, gcs_port: int) -> str:
        """:meth:`command` as one line for logs, the signing key left out."""
        cmd = self.command(gcs_port)
        return " ".join("hex:<key>" if prev == "--signing-key" else word
                        for prev, word in zip(["", *cmd], cmd, strict=False))


class SpawnedVehicle:
    """A vehicle child process (context manager: stopped on exit).

    Parameters
    ----------
    spec : VehicleSpec
    gcs_port : int
        The ground station's UDP port on 127.0.0.1.
    log_path : path or None
        Where the vehicle's output goes (None: discarded).
    cwd : path or None
        Working directory (default: the current one).
    """

    def __init__(self, spec: VehicleSpec, gcs_port: int, *, log_path: str | Path | None = None,
                 cwd: str | Path | None = None) -> None:
        self.spec = spec
        self.gcs_port = gcs_port
        self.log_path = None if log_path is None else Path(log_path)
        self.cwd = cwd
        self.process: subprocess.Popen[bytes] | None = None
        self._log: IO[bytes] | None = None

    def start(self) -> SpawnedVehicle:
        """Start the child (idempotent)."""
        if self.process is not None:
            return self
        out: IO[bytes] | int = subprocess.DEVNULL
        if self.log_path is not None:
            self.log_path.parent.mkdir(parents=True, exist_ok=True)
            self._log = open(self.log_path, "wb")
            out = self._log
        env = dict(os.environ)
        env.setdefault("PYTHONUNBUFFERED", "1")
        self.process = subprocess.Popen(self.spec.command(self.gcs_port), stdout=out,
                                        stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                        cwd=self.cwd, env=env, start_new_session=True)
        return self

    @property
    def pid(self) -> int | None:
        """The child's process id."""
        return None if self.process is None else self.process.pid

    def running(self) -> bool:
        """The child has not exited."""
        return self.process is not None and self.process.poll() is None

    def exit_status(self) -> int | None:
        """The child's exit status (None while it runs)."""
        return None if self.process is None else self.process.poll()

    def output(self) -> str:
        """What the child has written so far (its log file)."""
        if self.log_path is None or not self.log_path.exists():
            return ""
        return self.log_path.read_text(errors="replace")

    def why_gone(self) -> str | None:
        """None while the child runs; else its exit status and last line of output."""
        status = self.exit_status()
        if status is None:
            return None
        lines = [ln for ln in self.output().splitlines() if ln.strip()]
        last = lines[-1].strip() if lines else "no output"
        return f"the vehicle process exited with status {status}: {last}"

    def kill(self) -> None:
        """SIGKILL the child at once (tests use it to lose the vehicle mid-flight)."""
        if self.running():
            assert self.process is not None
            self.process.kill()
            self.process.wait(timeout=_STOP_WAIT_S)

    def stop(self) -> int | None:
        """SIGTERM, wait, SIGKILL if needed; returns the exit status."""
        proc = self.process
        if proc is not None and proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=_STOP_WAIT_S)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=_STOP_WAIT_S)
        if self._log is not None:
            self._log.close()
            self._log = None
        return None if proc is None else proc.returncode

    def wait_exit(self, timeout_s: float) -> int | None:
        """Wait up to ``timeout_s`` wall seconds for the child to exit by itself."""
        deadline = time.monotonic() + timeout_s
        while self.running() and time.monotonic() < deadline:
            time.sleep(0.05)
        return self.exit_status()

    def __enter__(self) -> SpawnedVehicle:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
