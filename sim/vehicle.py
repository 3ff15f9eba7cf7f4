"""Vehicle process (composition root): one simulated quadrotor on MAVLink 2 over UDP.

The loop is the headless runner's (:mod:`sim.runner`), paced against the wall clock::

    vehicle.first_tick()                          # autopilot.step(0.0, []) at t = 0
    every tick (loop_rate_hz simulated, 1 / (loop_rate_hz * speedup) wall):
        sleep until the tick's wall-clock due time
        vehicle.tick()                            # world.step(pwm, n); autopilot.step(t, samples)
        endpoint.tick(time_s=t, wall_time_s=time.monotonic())   # commands, telemetry

Commands, parameter changes and injections are handled by ``endpoint.tick`` between two
autopilot ticks, so the simulation never reads the wall clock: the same seed, configuration
and commands arriving at the same ticks fly the same trajectory at any speed-up (and as the
headless runner, whose mission starts right after the boot tick; ``--start-paused`` lets a
ground station do the same over MAVLink before simulated time starts).

Pacing: tick ``k`` is due ``k`` wall periods after an anchor. A vehicle that falls behind
(a slow machine, a stall) runs ticks back to back to catch up, and gives up a backlog longer
than :data:`MAX_LAG_S` by moving the anchor (simulated time then lags; it never skips a
tick). Unthrottled (``speedup`` infinite, ``--speedup max``) every tick is due at once: the
ticks run back to back, the endpoint serviced after each, so telemetry keeps its simulated-time
rates and only the wall-clock parts (HEARTBEAT floor, GCS failsafe) see time differently. While
waiting, paused (``SIM_PAUSE``) or behind, the endpoint is serviced at least
every :data:`SERVICE_PERIOD_S` of wall time, so the HEARTBEAT floor, command answers and the
wall-clock GCS failsafe keep working. SIGINT/SIGTERM end the loop at the next tick boundary;
the socket is closed and the summary (and the optional timing log) written.
"""

from __future__ import annotations

import gc
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fcu.mavlink.autopilot_port import vehicle_autopilot_config
from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.endpoint_config import EndpointConfig
from fcu.mavlink.enums import Severity
from fcu.mavlink.port_records import GeoPoint
from fcu.mavlink.transport.boot_beacon import BootBeacon
from fcu.mavlink.transport.link import Address
from fcu.mavlink.transport.udp import DEFAULT_PEERS, UdpLink
from fcu.monitoring.vibration import VibrationMonitor
from sim.instances import DEFAULT_BIND
from sim.scenario import Scenario
from sim.stack import warm_up
from sim.vehicle_port import SimVehicle, VehicleSetup

__all__ = ["DEFAULT_HOME", "MAX_LAG_S", "SERVICE_PERIOD_S", "RunSummary", "VehicleOptions",
           "VehicleProcess", "build_setup"]

DEFAULT_HOME = GeoPoint(-35.363261, 149.165230, 584.0)
"""ArduPilot SITL's default location (CMAC, Canberra): deg, deg, m AMSL."""
SERVICE_PERIOD_S = 0.02  # wall s, longest gap between endpoint services while waiting
MAX_LAG_S = 0.25  # wall s, longest backlog caught up before the schedule is re-anchored


@dataclass(frozen=True, kw_only=True)
class VehicleOptions:
    """Everything the ``ftc-vehicle`` command line chooses."""

    scenario: Scenario  # world and autopilot configuration, seed (faults/mission optional)
    speedup: float = 1.0  # simulated s per wall s; math.inf = unthrottled (as fast as it can)
    sysid: int = 1  # MAVLink system id
    compid: int = 1  # MAVLink component id (1 = MAV_COMP_ID_AUTOPILOT1)
    bind: Address = DEFAULT_BIND  # local UDP address; port 0 picks a free one
    outs: tuple[Address, ...] = DEFAULT_PEERS  # telemetry always goes there
    origin: GeoPoint = DEFAULT_HOME  # home at boot
    max_sim_s: float | None = None  # s simulated, stop after; None = run until signalled
    with_faults: bool = False  # schedule the scenario's faults (simulated time)
    load_mission: bool = False  # load the scenario's mission at boot (not started)
    start_paused: bool = False  # boot with SIM_PAUSE = 1
    timing_log: Path | None = None  # per-tick wall-clock timing, CSV
    realtime_priority: int = 0  # SCHED_FIFO priority of the loop (1..99); 0 = normal
    signing_key: bytes | None = field(default=None, repr=False)  # MAVLink 2 signing key
    # (32 bytes; None: unsigned); never shown in a repr

    def __post_init__(self) -> None:
        if not (0.0 < self.speedup <= 1000.0 or self.speedup == math.inf):
            raise ValueError(f"speedup = {self.speedup!r}: must be in (0, 1000] or inf "
                             "(unthrottled)")
        if not 1 <= self.sysid <= 255:
            raise ValueError(f"sysid = {self.sysid!r}: must be in 1..255")
        if not 1 <= self.compid <= 255:
            raise ValueError(f"compid = {self.compid!r}: must be in 1..255")
        if not 0 <= self.realtime_priority <= 99:
            raise ValueError(f"realtime_priority = {self.realtime_priority!r}: must be in 0..99")
        if self.max_sim_s is not None and not (math.isfinite(self.max_sim_s)
                                               and self.max_sim_s > 0):
            raise ValueError(f"max_sim_s = {self.max_sim_s!r}: must be > 0 s")


def build_setup(options: VehicleOptions) -> VehicleSetup:
    """The simulated vehicle an options set describes (no faults unless asked; the boot
    mission is loaded by :meth:`VehicleProcess.open`)."""
    sc = options.scenario
    return VehicleSetup(world=sc.world, autopilot=vehicle_autopilot_config(sc.autopilot),
                        seed=sc.seed, origin=options.origin, speedup=options.speedup,
                        faults=sc.faults if options.with_faults else (),
                        start_paused=options.start_paused)


@dataclass
class RunSummary:
    """How a run went (printed at exit; benchmarks read it)."""

    sim_s: float = 0.0  # s simulated
    running_wall_s: float = 0.0  # s of wall time while not paused
    running_cpu_s: float = 0.0  # s of this process's CPU time while not paused
    ticks: int = 0
    reanchors: int = 0  # backlogs given up (see MAX_LAG_S)
    malformed: int = 0  # datagrams the endpoint could not parse
    signing_rejected: int = 0  # packets dropped by the MAVLink 2 signing check
    tick_starts_s: list[float] = field(default_factory=list)  # wall, per tick (timing log)
    tick_busy_s: list[float] = field(default_factory=list)  # wall, tick + endpoint

    @property
    def ratio(self) -> float:
        """Simulated s per running wall s."""
        return self.sim_s / self.running_wall_s if self.running_wall_s > 0 else math.nan

    @property
    def cpu_ratio(self) -> float:
        """Simulated s per CPU s while running: the speed-up this machine could sustain."""
        return self.sim_s / self.running_cpu_s if self.running_cpu_s > 0 else math.nan


class VehicleProcess:
    """The vehicle, its UDP link and its MAVLink endpoint, driven by :meth:`run`.

    Parameters
    ----------
    options : VehicleOptions
    beacon : BootBeacon or None
        The boot HEARTBEATs sent while this process loaded (``ftc-vehicle``): stopped here,
        its bound link and packer carry on (their addresses and ids must be ``options``').
        None: a new link, bound by :meth:`open`.
    prepared : bool
        The kernels this vehicle flies are loaded in this process already
        (:func:`sim.preparation.prepare_vehicle`, run by ``ftc-vehicle`` while its beacon
        says BOOT): :meth:`run` does not warm up again.
    """

    def __init__(self, options: VehicleOptions, beacon: BootBeacon | None = None, *,
                 prepared: bool = False) -> None:
        self.options = options
        self.prepared = prepared
        self.vehicle = SimVehicle(build_setup(options))
        codec = None
        if beacon is None:
            self.link = UdpLink(options.bind[0], options.bind[1], default_peers=options.outs)
        else:
            beacon.handover()
            self.link, codec = beacon.link, beacon.codec
        model = self.vehicle.config.model
        self.endpoint = MavlinkEndpoint(
            self.vehicle.port, self.link,
            config=EndpointConfig(sysid=options.sysid, compid=options.compid,
                                  pwm_max=model.pwm_max, boot_unix_time_s=time.time(),
                                  signing_key=options.signing_key,
                                  max_stream_rate_hz=1.0 / self.vehicle.tick_s),
            injector=self.vehicle, extra_params=[self.vehicle.sim_params], codec=codec)
        self.summary = RunSummary()

    def open(self) -> Address:
        """Bind the socket, run the boot tick and send the first HEARTBEAT; returns the bound
        address. :meth:`run` warms up before it flies.

        Raises
        ------
        OSError
            The address cannot be bound.
        """
        self.link.open()
        self.vehicle.first_tick()
        if self.options.load_mission:
            self._load_boot_mission()
        self.endpoint.tick(time_s=self.vehicle.time_s, wall_time_s=time.monotonic())
        return self.link.local_address

    def _load_boot_mission(self) -> None:
        """The scenario's mission, through the mission protocol (so that a ground station's
        download and MISSION_CURRENT see it); a refusal is announced, the vehicle boots."""
        result = self.endpoint.mission.load(self.options.scenario.mission)
        if not result.accepted:
            reason = result.reason.removeprefix("Mission refused: ")
            self.vehicle.port.post(Severity.WARNING, f"Boot mission refused: {reason}")

    def _warm_up(self) -> None:
        """Load the numba code (unless :attr:`prepared`) by flying a throwaway copy of the
        vehicle, the endpoint answering between its ticks."""
        vehicle, endpoint = self.vehicle, self.endpoint
        if not self.prepared:
            setup = vehicle.setup
            warm_up(setup.world, setup.autopilot, setup.seed,
                    between_ticks=lambda: endpoint.tick(time_s=vehicle.time_s,
                                                        wall_time_s=time.monotonic()))
            # the vibration filter of RAW_IMU/VIBRATION is numba code the flight does not
            # run: loaded here rather than at the first of those messages, in flight
            VibrationMonitor().update(np.zeros(1), np.zeros((1, 3)))
        gc.collect()
        gc.freeze()  # start-up objects are never collected: shorter collections in flight

    def enter_realtime(self) -> str:
        """Run this process at SCHED_FIFO ``realtime_priority`` if asked and allowed.

        Returns what happened, for the startup line. A real-time priority keeps the tick
        period steady on a busy machine (the loop sleeps between ticks, so it takes little
        CPU; at a speed-up it cannot reach it runs flat out on one core).
        """
        priority = self.options.realtime_priority
        if priority == 0:
            return ""
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        except (AttributeError, OSError) as err:
            return f"real-time priority refused ({err}); running at normal priority"
        return f"SCHED_FIFO priority {priority}"

    def close(self) -> None:
        """Release the socket and write the timing log (if asked)."""
        self.link.close()
        self.summary.malformed = self.endpoint.stats.malformed
        self.summary.signing_rejected = self.endpoint.signing.stats.rejected
        path = self.options.timing_log
        if path is not None:
            s = self.summary
            lines = ["tick,start_wall_s,busy_s"]
            t0 = s.tick_starts_s[0] if s.tick_starts_s else 0.0
            lines += [f"{k + 1},{start - t0:.6f},{busy:.6f}"
                      for k, (start, busy) in enumerate(zip(s.tick_starts_s, s.tick_busy_s,
                                                            strict=True))]
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text("\n".join(lines) + "\n")

    def run(self, should_stop: Callable[[], bool]) -> RunSummary:
        """Warm up, then fly until ``should_stop()`` or ``max_sim_s``; call :meth:`open`
        first."""
        self._warm_up()
        vehicle, endpoint, summary = self.vehicle, self.endpoint, self.summary
        clock, sleep, cpu = time.monotonic, time.sleep, time.process_time
        period_s = vehicle.tick_s / self.options.speedup
        max_sim_s = self.options.max_sim_s
        keep_timing = self.options.timing_log is not None
        endpoint.tick(time_s=vehicle.time_s, wall_time_s=clock())
        anchor_s = clock()
        n = 0  # ticks since the anchor
        running_since: float | None = None
        cpu_since = 0.0
        while not should_stop():
            if max_sim_s is not None and vehicle.time_s >= max_sim_s - 1e-9:
                break
            now = clock()
            if vehicle.paused:
                if running_since is not None:
                    summary.running_wall_s += now - running_since
                    summary.running_cpu_s += cpu() - cpu_since
                    running_since = None
                endpoint.tick(time_s=vehicle.time_s, wall_time_s=now)
                sleep(SERVICE_PERIOD_S)
                anchor_s, n = clock(), 0
                continue
            if running_since is None:
                running_since, cpu_since = now, cpu()
            due_s = anchor_s + (n + 1) * period_s
            wait_s = due_s - now
            if wait_s > SERVICE_PERIOD_S:
                sleep(SERVICE_PERIOD_S)
                endpoint.tick(time_s=vehicle.time_s, wall_time_s=clock())
                continue
            if wait_s > 0.0:
                sleep(wait_s)
            elif -wait_s > MAX_LAG_S and period_s > 0.0:  # unthrottled: no schedule to keep
                anchor_s, n = now - period_s, 0  # give the backlog up
                summary.reanchors += 1
            start_s = clock()
            vehicle.tick()
            n += 1
            endpoint.tick(time_s=vehicle.time_s, wall_time_s=clock())
            if keep_timing:
                summary.tick_starts_s.append(start_s)
                summary.tick_busy_s.append(clock() - start_s)
        if running_since is not None:
            summary.running_wall_s += clock() - running_since
            summary.running_cpu_s += cpu() - cpu_since
        summary.sim_s = vehicle.time_s
        summary.ticks = vehicle.ticks
        return summary

