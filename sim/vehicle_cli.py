"""``ftc-vehicle`` (also ``python -m sim``): a simulated quadrotor that ground stations fly.

Usage::

    ftc-vehicle [--scenario NAME|FILE.toml] [--seed N] [--speedup X|max]
                [--bind HOST:PORT] [--out HOST:PORT ...] [--instance N] [--sysid N]
                [--compid N] [--signing-key KEY] [--home LAT,LON,ALT] [--duration S]
                [--with-faults] [--load-mission] [--start-paused] [--timing-log PATH]
                [--realtime [PRIORITY]] [--boot-delay S]
    ftc-vehicle --precompile

The vehicle boots disarmed in STABILIZE on the ground at home, with the scenario's world and
autopilot configuration (default ``baseline``) but no mission and no faults unless asked, and
waits for a ground station: MAVLink 2 over UDP, listening on ``--bind`` (default
127.0.0.1:14555) and sending telemetry to every ``--out`` (default 127.0.0.1:14550 and
127.0.0.1:14540; ``--out none`` for none) and to whoever writes to it. It runs in real time,
or ``--speedup`` times faster, or as fast as it can (``--speedup max``: no pacing, telemetry
still at simulated-time rates); the same seed flies the same trajectory at any speed-up.

``--instance N`` (0..9) moves those default ports as ArduPilot SITL's ``-I N`` does, by 10 N:
it listens on 14555 + 10 N and sends to 14550 + 10 N, and to the API port 14540 + N (PX4
SITL's convention for instance N); ``--bind`` and ``--out``, when given, are used as given.
Every instance keeps ``--sysid`` (default 1), as ArduPilot keeps SYSID_THISMAV = 1.

``--signing-key KEY`` starts with MAVLink 2 signing on (see :mod:`flightdata.signing` for
KEY: a passphrase hashed as MAVProxy's ``signing setup`` does, or ``hex:`` and 64 hex
digits): every packet sent is signed and unsigned or wrongly signed packets are dropped. A
key installed later over MAVLink (SETUP_SIGNING) lasts until the process ends; only a key on
the command line is there again after a restart.

The socket is bound first and a HEARTBEAT saying ``MAV_STATE_BOOT`` goes out at once (and at
1 Hz) while the autopilot loads (:mod:`fcu.mavlink.transport.boot_beacon`): its compiled
kernels load from numba's cache in about a second, or compile (minutes on a fresh machine
where nothing ran ``ftc-vehicle --precompile``), and a STATUSTEXT
``preparing: N of M kernels compiled, T s`` follows a boot HEARTBEAT every few seconds
meanwhile (also printed on stdout); then one line on stdout says where it listens, and the
HEARTBEATs say STANDBY. ``--boot-delay S`` stays in BOOT, reporting progress, S wall seconds
more: a slow boot on demand, to test a ground station's patience.

``ftc-vehicle --precompile`` flies nothing over MAVLink: it compiles (or loads) every kernel
the project can run (:func:`sim.preparation.precompile`), printing its progress, and exits 0;
``make setup`` runs it. Ctrl-C or SIGTERM stops it cleanly (exit
0). A bad option (or a ``--timing-log`` that cannot be written) prints one line and exits with
status 2 before anything is sent; a bad scenario does the same once loading reaches it (a
boot HEARTBEAT may have gone out); an address that cannot be bound exits with status 1.
"""

from __future__ import annotations

import argparse
import math
import signal
import socket
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, NoReturn

from flightdata.arguments import positive_float

if TYPE_CHECKING:
    from fcu.mavlink.transport.boot_beacon import BootBeacon
    from sim.preparation import Progress
    from sim.vehicle_port import VehicleSetup

PROG = "ftc-vehicle"


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit status 2)."""

    def error(self, message: str) -> NoReturn:
        print(f"{PROG}: error: {message}", file=sys.stderr)
        sys.exit(2)


def _address(text: str, *, allow_port_zero: bool) -> tuple[str, int]:
    host, sep, port_text = text.rpartition(":")
    if not sep or not host:
        raise argparse.ArgumentTypeError(f"{text!r} is not HOST:PORT")
    try:
        port = int(port_text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: port {port_text!r} is not a number") \
            from None
    low = 0 if allow_port_zero else 1
    if not low <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r}: port must be in {low}..65535")
    try:
        ip = socket.gethostbyname(host)
    except OSError:
        raise argparse.ArgumentTypeError(f"{text!r}: unknown host {host!r}") from None
    return ip, port


def _bind(text: str) -> tuple[str, int]:
    return _address(text, allow_port_zero=True)


def _out(text: str) -> tuple[str, int] | None:
    if text == "none":
        return None
    return _address(text, allow_port_zero=False)


def _speedup(text: str) -> float:
    return math.inf if text == "max" else positive_float(text)


def _home(text: str) -> tuple[float, float, float]:
    parts = text.split(",")
    try:
        lat, lon, alt = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not LAT,LON,ALT (degrees, degrees, "
                                         "metres AMSL)") from None
    if not all(math.isfinite(v) for v in (lat, lon, alt)):
        raise argparse.ArgumentTypeError(f"{text!r}: values must be finite")
    if abs(lat) > 89.9 or abs(lon) > 180.0:
        raise argparse.ArgumentTypeError(f"{text!r}: latitude must be in -89.9..89.9 and "
                                         "longitude in -180..180")
    return lat, lon, alt


def _signing_key(text: str) -> bytes:
    from flightdata.signing import key_from_text

    try:
        return key_from_text(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _int_in(low: int, high: int) -> argparse._ActionType:  # noqa: SLF001
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{value}: must be in {low}..{high}")
        return value

    return parse


def build_parser() -> argparse.ArgumentParser:
    """The command line (no heavy imports: bad flags are reported at once)."""
    p = _Parser(prog=PROG, description="A simulated quadrotor that ground stations fly "
                "(MAVLink 2 over UDP).")
    p.add_argument("--scenario", default="baseline", metavar="NAME|FILE",
                   help="scenario whose world and autopilot to fly (default baseline)")
    p.add_argument("--seed", type=_int_in(0, 2**63 - 1), default=None,
                   help="seed of every random stream (default: the scenario's)")
    p.add_argument("--speedup", type=_speedup, default=1.0, metavar="X|max",
                   help="simulated seconds per wall second (default 1, at most 1000); max: "
                   "unthrottled, as fast as the CPU allows, telemetry still at simulated-time "
                   "rates")
    p.add_argument("--bind", type=_bind, default=None, metavar="HOST:PORT",
                   help="local UDP address (default 127.0.0.1:14555 + 10 N for --instance N; "
                   "port 0 = any free)")
    p.add_argument("--out", type=_out, action="append", metavar="HOST:PORT",
                   help="telemetry destination, repeatable (default 127.0.0.1:14550 + 10 N "
                   "and 127.0.0.1:14540 + N for --instance N; 'none' for none)")
    p.add_argument("--instance", type=_int_in(0, 9), default=0, metavar="N",  # MAX_INSTANCE
                   help="vehicle number N (0..9): default ports moved as ArduPilot SITL's "
                   "-I N (default 0)")
    p.add_argument("--sysid", type=_int_in(1, 255), default=1, help="MAVLink system id (1)")
    p.add_argument("--compid", type=_int_in(1, 255), default=1,
                   help="MAVLink component id (1)")
    p.add_argument("--signing-key", type=_signing_key, default=None, metavar="KEY",
                   help="MAVLink 2 signing key: a passphrase (SHA-256, as MAVProxy's 'signing "
                   "setup') or hex: and 64 hex digits; unsigned packets are then dropped")
    p.add_argument("--home", type=_home, default=None, metavar="LAT,LON,ALT",
                   help="home at boot, degrees and metres AMSL (default ArduPilot's CMAC "
                   "-35.363261,149.165230,584)")
    p.add_argument("--duration", "--max-sim-s", dest="duration", type=positive_float, default=None,
                   metavar="S", help="stop after S simulated seconds")
    p.add_argument("--with-faults", action="store_true",
                   help="schedule the scenario's faults (simulated time)")
    p.add_argument("--load-mission", action="store_true",
                   help="load the scenario's mission at boot (not started)")
    p.add_argument("--start-paused", action="store_true",
                   help="hold simulated time at 0 until SIM_PAUSE is set to 0")
    p.add_argument("--timing-log", type=Path, default=None, metavar="PATH",
                   help="write each tick's wall-clock start and busy time (CSV)")
    p.add_argument("--realtime", type=_int_in(1, 99), nargs="?", const=10, default=0,
                   metavar="PRIORITY", help="run the loop at SCHED_FIFO priority (default 10; "
                   "needs CAP_SYS_NICE) for a steady tick period on a busy machine")
    p.add_argument("--boot-delay", type=_non_negative, default=0.0, metavar="S",
                   help="stay in MAV_STATE_BOOT S wall seconds more, reporting progress (to "
                   "test how a ground station waits; default 0)")
    p.add_argument("--precompile", action="store_true",
                   help="compile (or load) every kernel the project can run, then exit")
    return p


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value >= 0.0):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number >= 0")
    return value


def _precompile() -> int:
    """``--precompile``: every kernel compiled or loaded, progress on stdout."""
    from sim.preparation import precompile

    def show(progress: Progress) -> None:
        if progress.elapsed_s < 1.0 and not progress.done:
            return  # (the first report, at the start)
        now = f" (compiling {progress.compiling})" if progress.compiling else ""
        print(f"{PROG}: {progress.line()}{now}", flush=True)

    try:
        precompile(show)
    except RuntimeError as err:
        print(f"{PROG}: {err}", file=sys.stderr)
        return 1
    return 0


def _prepare(beacon: BootBeacon, setup: VehicleSetup, boot_delay_s: float) -> None:
    """Load or compile the vehicle's kernels while the beacon says BOOT, its progress going
    out as STATUSTEXT and on stdout; then hold ``boot_delay_s`` wall seconds more."""
    from sim.preparation import prepare_vehicle, reporting

    def show(progress: Progress) -> None:
        if not (progress.compiled or progress.elapsed_s >= 3.0):
            return  # a boot from a current cache: a second, nothing to report
        line = progress.line()
        beacon.progress_line = line
        now = f" (compiling {progress.compiling})" if progress.compiling else ""
        print(f"{PROG}: {line}{now}", flush=True)

    with reporting(show) as progress:
        prepare_vehicle(setup.world, setup.autopilot, setup.seed)
        end_s = time.monotonic() + boot_delay_s
        while (left_s := end_s - time.monotonic()) > 0:
            time.sleep(min(left_s, 1.0))
            beacon.progress_line = progress.snapshot().line()


def main(argv: Sequence[str] | None = None) -> int:
    """Run the vehicle until signalled or ``--duration``; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.precompile:
        return _precompile()
    from flightdata.outputs import OutputError, check_file_output

    try:
        if args.timing_log is not None:
            check_file_output("--timing-log", args.timing_log)
    except OutputError as err:
        parser.error(str(err))
    stop = [False]

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop[0] = True

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)

    # bind and say we are booting (MAV_STATE_BOOT) before the autopilot loads
    from fcu.mavlink.transport.boot_beacon import BootBeacon
    from fcu.mavlink.transport.codec import Codec
    from fcu.mavlink.transport.udp import UdpLink
    from sim.instances import instance_addresses

    default_bind, default_outs = instance_addresses(args.instance)
    bind = default_bind if args.bind is None else args.bind
    outs = default_outs if args.out is None else tuple(o for o in args.out if o)
    beacon = BootBeacon(UdpLink(bind[0], bind[1], default_peers=outs),
                        Codec(args.sysid, args.compid), signing_key=args.signing_key)
    try:
        beacon.start()
    except OSError as err:
        print(f"{PROG}: cannot listen on {bind[0]}:{bind[1]}: {err.strerror or err}",
              file=sys.stderr)
        return 1

    from fcu.mavlink.port_records import GeoPoint
    from flightdata.config import ConfigError
    from sim.scenario import load_scenario
    from sim.vehicle import DEFAULT_HOME, VehicleOptions, VehicleProcess, build_setup

    try:
        scenario = load_scenario(args.scenario)
        if args.seed is not None:
            scenario = scenario.with_seed(args.seed)
        origin = DEFAULT_HOME if args.home is None else GeoPoint(*args.home)
        options = VehicleOptions(
            scenario=scenario, speedup=args.speedup, sysid=args.sysid, compid=args.compid,
            bind=bind, outs=outs, origin=origin, max_sim_s=args.duration,
            with_faults=args.with_faults, load_mission=args.load_mission,
            start_paused=args.start_paused, timing_log=args.timing_log,
            realtime_priority=args.realtime, signing_key=args.signing_key)
        setup = build_setup(options)
    except (ConfigError, ValueError) as err:
        beacon.handover()
        beacon.link.close()
        parser.error(str(err))
    _prepare(beacon, setup, args.boot_delay)
    process = VehicleProcess(options, beacon, prepared=True)
    host, port = process.open()
    realtime = process.enter_realtime()
    outs_text = ", ".join(f"{h}:{p}" for h, p in outs) or "none"
    print(f"{PROG}: listening on udp {host}:{port} as sysid {args.sysid} compid "
          f"{args.compid}; telemetry to {outs_text}; scenario {scenario.name} seed "
          f"{scenario.seed}; speed-up "
          f"{'max (unthrottled)' if math.isinf(args.speedup) else f'{args.speedup:g}x'}"
          + (f"; instance {args.instance}" if args.instance else "")
          + ("; MAVLink 2 signing on" if args.signing_key is not None else "")
          + ("; paused (set SIM_PAUSE 0 to start)" if args.start_paused else "")
          + (f"; {realtime}" if realtime else ""), flush=True)
    try:
        summary = process.run(lambda: stop[0])
    finally:
        try:
            process.close()
        except OSError as err:  # checked at start; the disk may still fill up or vanish
            print(f"{PROG}: cannot write --timing-log {args.timing_log}: "
                  f"{err.strerror or err}", file=sys.stderr)
            return 1
    speed = (f"({summary.ratio:.2f}x; {summary.cpu_ratio:.1f}x per CPU second)"
             if summary.running_wall_s > 0 else "(never ran: paused throughout)")
    print(f"{PROG}: stopped at {summary.sim_s:.2f} s simulated, {summary.running_wall_s:.2f} s "
          f"running wall time {speed}, "
          f"{summary.ticks} ticks, {summary.malformed} malformed datagrams"
          + (f", {summary.signing_rejected} packets failing the signing check"
             if args.signing_key is not None or summary.signing_rejected else ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
