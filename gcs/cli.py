"""``ftc-gcs`` (also ``python -m gcs``): fly the thesis mission over MAVLink and report on it.

Usage::

    ftc-gcs fly    [--connect URL | --spawn-vehicle [--speedup X] [--seed N] [--scenario S]]
                   [--signing-key KEY] [--reboot]
                   [--mission thesis|FILE] [--faults table7.3|FILE] [--fault SPEC ...]
                   [--inject-via command|param]
                   [--attitude pd|lqg] [--estimator ekf|tskf] [--dob none|vbdob|abdob]
                   [--param NAME=VALUE ...]
                   [--out-dir DIR] [--tlog PATH] [--event-log PATH] [--json PATH] [--quiet]
                   [--rerun [URL]] [--rrd PATH] [--figures DIR] [--report DIR]
                   [--connect-timeout S] [--ready-timeout S] [--link-timeout S]
                   [--max-flight-s S] [--timeout S]
    ftc-gcs demo   [--speedup X] [--seed N] [--out-dir DIR] [...fly options]
    ftc-gcs report FLIGHT.tlog [--json PATH] [--rrd PATH] [--figures DIR] [--report DIR]

``fly`` connects to a running vehicle (default: listen on UDP 14550, where ``ftc-vehicle``
sends its telemetry), or with ``--spawn-vehicle`` starts ``python -m sim`` itself on loopback.
``demo`` is ``fly --spawn-vehicle --faults table7.3`` with the Table 7.4 configuration (LQG
attitude, EKF feedback, no DOB) at speed-up 10: the one-command demonstration.
``report`` recomputes the table from any recorded flight.

Flights back to back: before arming, ``fly`` puts a vehicle found in a mode that does not
allow arming (AUTO after a mission, LAND, RTL) in STABILIZE and waits for a HEARTBEAT in it;
a vehicle found armed is refused (``ftc-gcs: vehicle busy: ...``, exit status 4), never taken
over. A vehicle that arms only after a restart (it declared a motor failed in an earlier
flight; ``MAV_CMD_RUN_PREARM_CHECKS`` gives the reason) is refused in one line
(``ftc-gcs: restart needed: ...``, exit status 4) unless ``--reboot`` is given, which restarts
its autopilot (``MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN``), waits for it and flies; ``demo``
always may. The faults a flight injected are cleared when it ends (motor faults with
``INJECT_FAILURE`` type OK, ``SIM_*`` parameters back to their value before the flight).

Views of a flight: ``--rerun`` streams it live to a rerun viewer it starts (``--rerun URL``:
to a viewer or server already running, e.g. ``rerun+http://127.0.0.1:9876/proxy``);
``--rrd PATH`` saves a rerun recording, ``--figures DIR`` the thesis-style figures (PNG and
PDF), ``--report DIR`` a Markdown report embedding them next to the table. The last three are
made from the .tlog after the flight (also after a failed one), the same way ``report``
makes them from any .tlog (:mod:`flightdata.recording`, :mod:`flightdata.figures`,
:mod:`gcs.report`).

``--signing-key KEY`` signs everything sent with MAVLink 2 signing and accepts only packets
signed with the same key (KEY: a passphrase, hashed with SHA-256 as MAVProxy's ``signing
setup`` does, or ``hex:`` and 64 hex digits; :mod:`flightdata.signing`); a vehicle started
here gets the same key. A vehicle whose signing does not match (another key, or none) ends
the flight with ``ftc-gcs: signing: <why>`` (exit status 3).

Fault specs: ``MOTOR:LOE@AT_S`` (``--fault 3:0.20@22``) or ``PARAM=VALUE@AT_S``
(``--fault SIM_BARO_GLITCH=0.1@30``); times are simulated seconds after the mission start.

Exit status: 0 flown and landed; 1 crash (or disarmed without flying); 2 bad usage or input
file; 3 vehicle not found (or its signing does not match); 4 command refused; 5 mission
rejected; 6 timeout (no answer, link lost, mission not finished); 130 interrupted. A failed
flight prints one line ``ftc-gcs: <kind>: <reason>`` on stderr (and the table of what was
recorded, on stdout).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import Any, NoReturn

from flightdata import vocabulary
from flightdata.arguments import positive_float
from flightdata.outputs import OutputError, check_file_output, check_folder_output
from flightdata.signing import key_from_text
from flightdata.steps import Steps
from gcs.analysis import replay_tlog
from gcs.errors import EXIT_INTERRUPTED, EXIT_USAGE, FlightError
from gcs.faults import (
    TABLE_7_3,
    FaultScheduleError,
    FaultSpec,
    load_schedule,
    parse_fault_flag,
    sorted_schedule,
)
from gcs.flight import FlightOutcome, FlightPlan, config_params, fly
from gcs.mavlink import check_url
from gcs.mission import MissionFileError, PlanSections, load_mission, load_plan, thesis_mission
from gcs.spawn import SpawnedVehicle, VehicleSpec
from gcs.station import GroundStation
from gcs.table import format_report

PROG = "ftc-gcs"
DEFAULT_URL = "udpin:0.0.0.0:14550"
_SLOW_TLOG_BYTES = 1 << 20  # a .tlog this big takes seconds to read: say so
DEFAULT_CONNECT_TIMEOUT_S = 60.0  # s wall: a vehicle started meanwhile compiles its plant
TABLE_TITLE = "flight"  # the same for fly, demo and report: report reprints the table exactly


class _Parser(argparse.ArgumentParser):
    """Argument errors on one line, exit status 2."""

    def error(self, message: str) -> NoReturn:
        print(f"{PROG}: error: {message}", file=sys.stderr)
        sys.exit(EXIT_USAGE)


def _param(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    try:
        number = float(value)
    except ValueError:
        number = math.nan
    if not sep or not name or not math.isfinite(number) or len(name) > 16:
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=VALUE (name of at most 16 "
                                         "characters, finite value)")
    return name.upper(), number


def _signing_key(text: str) -> bytes:
    try:
        return key_from_text(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _add_fly_options(p: argparse.ArgumentParser, *, demo: bool) -> None:
    link = p.add_argument_group("vehicle")
    if not demo:
        link.add_argument("--connect", default=None, metavar="URL",
                          help=f"pymavlink connection string (default {DEFAULT_URL}; "
                          "udpout:HOST:PORT to reach a vehicle's --bind)")
        link.add_argument("--spawn-vehicle", action="store_true",
                          help="start 'python -m sim' on loopback and fly it")
    link.add_argument("--speedup", type=positive_float, default=10.0,
                      help="spawned vehicle: simulated s per wall s (default 10)")
    link.add_argument("--seed", type=int, default=None, help="spawned vehicle: seed")
    link.add_argument("--scenario", default=None, metavar="NAME|FILE",
                      help="spawned vehicle: scenario whose world and configuration it "
                      "simulates (faults are sent by the ground station)")
    link.add_argument("--no-pause", action="store_true",
                      help="spawned vehicle: do not hold simulated time at 0 while the "
                      "flight is prepared")
    link.add_argument("--vehicle-arg", action="append", default=[], metavar="ARG",
                      help="spawned vehicle: extra ftc-vehicle option (repeatable)")
    if demo:
        link.set_defaults(reboot=True)  # a fresh vehicle: nothing to restart, never a prompt
    else:
        link.add_argument("--reboot", action="store_true",
                          help="when the vehicle arms only after a restart (a failure it "
                          "detected in an earlier flight), restart its autopilot "
                          "(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN) and fly")
    link.add_argument("--signing-key", type=_signing_key, default=None, metavar="KEY",
                      help="MAVLink 2 signing key: a passphrase (SHA-256, as MAVProxy's "
                      "'signing setup') or hex: and 64 hex digits; a spawned vehicle gets it "
                      "too")
    what = p.add_argument_group("flight")
    what.add_argument("--mission", default="thesis", metavar="thesis|FILE",
                      help="the thesis mission (default), a QGC WPL 110 or TOML file, or a "
                      "QGroundControl .plan (mission, geofence, rally points)")
    what.add_argument("--faults", default=None if not demo else "table7.3",
                      metavar="table7.3|FILE",
                      help="fault schedule: Table 7.3 or a TOML file" +
                      (" (default table7.3)" if demo else " (default: none)"))
    what.add_argument("--fault", action="append", default=[], metavar="SPEC",
                      help="one more fault, MOTOR:LOE@AT_S or PARAM=VALUE@AT_S (repeatable)")
    what.add_argument("--inject-via", choices=("command", "param"), default="command",
                      help="motor faults as MAV_CMD_INJECT_FAILURE scheduled on the "
                      "vehicle's clock (default: exact timing) or as PARAM_SET SIM_MOTn_LOE "
                      "sent ahead (ArduPilot-SITL style)")
    what.add_argument("--attitude", choices=vocabulary.ATTITUDE_LAWS,
                      default="lqg" if demo else None,
                      help="ATT_CTRL" + (" (default lqg)" if demo else ""))
    what.add_argument("--estimator", choices=vocabulary.ESTIMATORS, default="ekf" if demo else None,
                      help="EST_TYPE" + (" (default ekf)" if demo else ""))
    what.add_argument("--dob", choices=vocabulary.DISTURBANCE_OBSERVERS,
                      default="none" if demo else None,
                      help="DOB_TYPE" + (" (default none)" if demo else ""))
    what.add_argument("--param", type=_param, action="append", default=[],
                      metavar="NAME=VALUE", help="set a parameter before arming (repeatable)")
    rec = p.add_argument_group("records")
    rec.add_argument("--out-dir", type=Path, default=Path("out"),
                     help="where the .tlog and event log go (default out/)")
    rec.add_argument("--tlog", type=Path, default=None, help="the .tlog path")
    rec.add_argument("--event-log", type=Path, default=None, help="the event log path")
    rec.add_argument("--json", type=Path, default=None, help="also write the table as JSON")
    rec.add_argument("--quiet", action="store_true", help="no event lines on stderr")
    rec.add_argument("--rerun", nargs="?", const="spawn", default=None, metavar="URL",
                     help="stream the flight live to a rerun viewer: one started here, or "
                     "the viewer/server at URL (rerun+http://HOST:PORT/proxy)")
    _add_view_options(rec)
    lim = p.add_argument_group("time limits")
    lim.add_argument("--connect-timeout", type=positive_float, default=None, metavar="S",
                     help=f"wall s to wait for the vehicle's first HEARTBEAT (default "
                     f"{DEFAULT_CONNECT_TIMEOUT_S:g}: a vehicle started at the same time "
                     "needs its start-up)")
    lim.add_argument("--ready-timeout", type=positive_float, default=30.0, metavar="S",
                     help="wall s to wait for the vehicle to report ready to arm (pre-arm "
                     "checks) before trying to arm anyway (default 30)")
    lim.add_argument("--link-timeout", type=positive_float, default=5.0, metavar="S",
                     help="wall s of silence in flight before giving up (default 5)")
    lim.add_argument("--max-flight-s", type=positive_float, default=120.0, metavar="S",
                     help="simulated s after the mission start (default 120)")
    lim.add_argument("--timeout", type=positive_float, default=900.0, metavar="S",
                     help="wall s for the whole flight (default 900)")


def _add_view_options(group: Any) -> None:
    group.add_argument("--rrd", type=Path, default=None, metavar="PATH",
                       help="write a rerun recording of the flight (.rrd)")
    group.add_argument("--figures", type=Path, default=None, metavar="DIR",
                       help="write the thesis-style figures (PNG and PDF) there")
    group.add_argument("--report", type=Path, default=None, metavar="DIR",
                       help="write DIR/report.md with the table and its figures")


def build_parser() -> argparse.ArgumentParser:
    """The command line."""
    p = _Parser(prog=PROG, description="Fly the thesis mission over MAVLink and report on "
                "it (see the module docstring of gcs.cli).")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    fly_p = sub.add_parser("fly", help="fly a mission with a vehicle and print the table")
    _add_fly_options(fly_p, demo=False)
    demo_p = sub.add_parser("demo", help="start a vehicle, fly the thesis mission with the "
                            "Table 7.3 faults, print the table")
    _add_fly_options(demo_p, demo=True)
    rep = sub.add_parser("report", help="the table of a recorded flight (.tlog)")
    rep.add_argument("tlog", type=Path)
    rep.add_argument("--json", type=Path, default=None, help="also write it as JSON")
    _add_view_options(rep)
    return p


def _schedule(args: argparse.Namespace) -> list[FaultSpec]:
    faults: list[FaultSpec] = []
    if args.faults is not None:
        key = args.faults.lower().replace(" ", "")
        if key in ("table7.3", "table-7.3", "7.3", "thesis"):
            faults += list(TABLE_7_3)
        else:
            faults += load_schedule(args.faults)
    faults += [parse_fault_flag(text) for text in args.fault]
    return sorted_schedule(faults)


def _mission(args: argparse.Namespace) -> PlanSections:
    if args.mission == "thesis":
        return PlanSections(thesis_mission(), [], [])
    if Path(args.mission).suffix.lower() == ".plan":
        return load_plan(args.mission)
    return PlanSections(load_mission(args.mission), [], [])


def _write_json(path: Path, data: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, allow_nan=False, default=_json_default) + "\n")


def _json_default(value: object) -> object:
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _clean(data: Any) -> Any:
    """NaN/inf become null (JSON has neither)."""
    if isinstance(data, float) and not math.isfinite(data):
        return None
    if isinstance(data, dict):
        return {k: _clean(v) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [_clean(v) for v in data]
    return data


def _timing_lines(outcome: FlightOutcome) -> list[str]:
    lines = []
    for t in outcome.timing:
        if t.error_s is None:
            continue
        lines.append(f"injection {t.fault.describe()} at mission +{t.fault.at_s:g} s: "
                     f"took effect at vehicle t = {t.achieved_s:.3f} s, "
                     f"timing error {t.error_s:+.3f} s")
    for d in outcome.report.detections:
        lat = "-" if d.latency_s is None else f"{d.latency_s:.2f} s"
        lines.append(f"detection motor {d.motor} ({d.percent:g} %) at vehicle t = "
                     f"{d.time_s:.2f} s, latency {lat}")
    return lines


def _check_outputs(args: argparse.Namespace, files: Sequence[str]) -> None:
    """Refuse unwritable outputs before any work (:mod:`flightdata.outputs`)."""
    for option in files:
        path = getattr(args, option.removeprefix("--").replace("-", "_"))
        if path is not None:
            check_file_output(option, path)
    for option in ("--figures", "--report"):
        path = getattr(args, option.removeprefix("--"))
        if path is not None:
            check_folder_output(option, path)


def _missing_folders(path: Path) -> list[Path]:
    """The folders of ``path`` that do not exist yet, deepest first."""
    out = []
    while not path.exists() and path != path.parent:
        out.append(path)
        path = path.parent
    return out


def _claim_stem(out_dir: Path, stem: str) -> str:
    """``stem``, or ``stem-2``, ``stem-3``... : the first whose tlog did not exist, created
    here (empty) so that a ground station started in the same second takes the next one."""
    out_dir.mkdir(parents=True, exist_ok=True)
    claimed, n = stem, 1
    while True:
        try:
            with open(out_dir / f"{claimed}.tlog", "xb"):
                return claimed
        except FileExistsError:
            n += 1
            claimed = f"{stem}-{n}"


def _remove_empty_records(paths: Sequence[Path | None], folders: Sequence[Path]) -> None:
    """A flight that never found its vehicle leaves nothing: its records hold only our own
    packets and lines; folders created for them go too when empty."""
    for path in paths:
        if path is not None and path.exists():
            path.unlink()
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            break  # not empty (or not ours): keep it and everything above it


def cmd_fly(args: argparse.Namespace, *, demo: bool) -> int:
    spawn = demo or args.spawn_vehicle
    url = "udpin:127.0.0.1:0" if spawn else (args.connect or DEFAULT_URL)
    try:
        faults = _schedule(args)
        mission = _mission(args)
        params = config_params(attitude=args.attitude, estimator=args.estimator, dob=args.dob)
        params.update(dict(args.param))
        plan = FlightPlan(mission=mission.mission, fence=mission.fence, rally=mission.rally,
                          faults=faults, params=params,
                          inject_via=args.inject_via, max_flight_s=args.max_flight_s,
                          connect_timeout_s=args.connect_timeout or DEFAULT_CONNECT_TIMEOUT_S,
                          ready_timeout_s=args.ready_timeout,
                          link_timeout_s=args.link_timeout, wall_timeout_s=args.timeout,
                          reboot=args.reboot)
    except (FaultScheduleError, MissionFileError, ValueError) as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    try:
        check_url(url)
    except ValueError as err:
        print(f"{PROG}: error: --connect {url!r}: {err}", file=sys.stderr)
        return EXIT_USAGE
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    stem = f"{'demo' if demo else 'flight'}-{stamp}"
    tlog = args.tlog or args.out_dir / f"{stem}.tlog"
    event_log = args.event_log or tlog.with_suffix(".events.log")
    try:
        if args.tlog is None or args.event_log is None:
            check_folder_output("--out-dir", args.out_dir)
        _check_outputs(args, ("--tlog", "--event-log", "--json", "--rrd"))
    except OutputError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    new_folders = sorted({f for p in (tlog, event_log, tlog.with_suffix(".vehicle.log"))
                          for f in _missing_folders(p.parent)},
                         key=lambda f: len(f.parts), reverse=True)
    if args.tlog is None:
        try:
            stem = _claim_stem(args.out_dir, stem)
        except OSError as err:
            print(f"{PROG}: error: --out-dir {args.out_dir}: cannot write there: "
                  f"{err.strerror or err}", file=sys.stderr)
            return EXIT_USAGE
        tlog = args.out_dir / f"{stem}.tlog"
        event_log = args.event_log or tlog.with_suffix(".events.log")
    vehicle_log = tlog.with_suffix(".vehicle.log")
    try:
        gs = GroundStation.open(url, tlog=tlog, event_log=event_log,
                                echo=None if args.quiet else sys.stderr,
                                signing_key=args.signing_key)
    except (OSError, ValueError) as err:
        reason = err.strerror if isinstance(err, OSError) and err.strerror else err
        print(f"{PROG}: error: cannot open {url}: {reason}", file=sys.stderr)
        return EXIT_USAGE
    steps = Steps(None if args.quiet else sys.stderr, prog=PROG)
    vehicle: SpawnedVehicle | None = None
    live = _live_recorder(args.rerun, gs, stem) if args.rerun is not None else None
    try:
        if spawn:
            port = int(gs.conn.port.getsockname()[1])
            spec = VehicleSpec(speedup=args.speedup, seed=args.seed, scenario=args.scenario,
                               start_paused=not args.no_pause,
                               max_sim_s=args.max_flight_s + 120.0,
                               extra_args=tuple(args.vehicle_arg), signing_key=args.signing_key)
            vehicle = SpawnedVehicle(spec, port, log_path=vehicle_log)
            vehicle.start()
            gs.log("LINK", f"started vehicle pid {vehicle.pid}: {spec.shown(port)}")
        outcome = fly(gs, plan, vehicle_gone=None if vehicle is None else vehicle.why_gone,
                      steps=steps)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; records kept in {tlog} and {event_log}", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        gs.close()
        if vehicle is not None:
            vehicle.stop()
        if live is not None:
            live.close()
    if not gs.vehicle_ready:  # nothing flown: no table, no records of nothing
        empty_vehicle_log = vehicle is None or not vehicle.output().strip()
        _remove_empty_records([tlog, event_log, vehicle_log if empty_vehicle_log else None],
                              new_folders)
        error = outcome.error or FlightError("no vehicle")
        print(f"{PROG}: {error.one_line()}", file=sys.stderr)
        return error.exit_code
    print(format_report(outcome.report, title=TABLE_TITLE))
    for line in _timing_lines(outcome):
        print(line)
    print(f"records: {outcome.tlog} (tlog), {outcome.event_log} (events)")
    if args.json is not None:
        _write_json(args.json, _clean(outcome.to_json()))
    if outcome.replayed is not None and outcome.tlog is not None:
        try:
            _write_views(args, outcome.tlog, outcome.report, outcome.replayed, steps)
        except OSError as err:  # the flight's own result stands; say what was not written
            print(f"{PROG}: error: cannot write the views of the flight: {err}",
                  file=sys.stderr)
    if outcome.error is not None:
        print(f"{PROG}: {outcome.error.one_line()}", file=sys.stderr)
    return outcome.exit_code


def cmd_report(args: argparse.Namespace) -> int:
    if not args.tlog.is_file():
        print(f"{PROG}: error: {args.tlog}: no such file", file=sys.stderr)
        return EXIT_USAGE
    try:
        _check_outputs(args, ("--json", "--rrd"))
    except OutputError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    steps = Steps(sys.stderr, prog=PROG)
    slow = args.tlog.stat().st_size >= _SLOW_TLOG_BYTES
    with (steps if slow else Steps(None)).step(f"reading {args.tlog}") as step:
        analyzer = replay_tlog(args.tlog, on_packet=step.advance)
    if analyzer.packets == 0:
        print(f"{PROG}: error: {args.tlog}: not a .tlog (no MAVLink packets in it)",
              file=sys.stderr)
        return EXIT_USAGE
    if analyzer.vehicle is None:
        print(f"{PROG}: error: {args.tlog}: no flight in it (no HEARTBEAT from an autopilot "
              f"among its {analyzer.packets} packets)", file=sys.stderr)
        return EXIT_USAGE
    report = analyzer.report()
    print(format_report(report, title=TABLE_TITLE))
    for d in report.detections:
        lat = "-" if d.latency_s is None else f"{d.latency_s:.2f} s"
        print(f"detection motor {d.motor} ({d.percent:g} %) at vehicle t = {d.time_s:.2f} s, "
              f"latency {lat}")
    if args.json is not None:
        _write_json(args.json, _clean(report.to_json()))
    try:
        _write_views(args, args.tlog, report, analyzer, steps)
    except OSError as err:
        print(f"{PROG}: error: cannot write the views of {args.tlog}: {err}", file=sys.stderr)
        return EXIT_USAGE
    return 0


def _live_recorder(target: str, gs: GroundStation, name: str) -> Any:
    """A :class:`flightdata.recording.LiveRecorder` on the ground station's clock (None:
    failed).

    It sends :meth:`gcs.analysis.FlightAnalyzer.series` of what has arrived every second of
    vehicle time, at most every 0.5 s of wall time (the series is rebuilt each time), the
    newest 0.1 s held back. Its north/east positions are the velocity-aided truth anchored to
    the geodetic mean of the samples so far, which may move by a few mm as more arrive; the
    recording written from the .tlog after the flight (``--rrd``) is exact.
    """
    from flightdata.recording import LiveRecorder, open_stream

    try:
        stream = open_stream(name, spawn=target == "spawn",
                             connect_url=None if target == "spawn" else target)
    except Exception as err:  # a viewer that cannot start must not stop the flight
        print(f"{PROG}: warning: no live rerun stream ({target}): {err}", file=sys.stderr)
        return None
    live = LiveRecorder(stream, gs.analyzer.series, owns_stream=True)
    gs.on_clock(live.on_clock)
    return live


def _write_views(args: argparse.Namespace, tlog: Path, report: Any, analyzer: Any,
                 steps: Steps) -> None:
    """The --rrd, --figures and --report outputs of a recorded flight (``analyzer``: its
    .tlog read back)."""
    if args.rrd is None and args.figures is None and args.report is None:
        return
    series = analyzer.series()
    if args.rrd is not None:
        from flightdata.recording import open_stream, write_recording

        with steps.step(f"writing the recording {args.rrd}"):
            stream = open_stream(tlog.stem, rrd_path=args.rrd)
            try:
                write_recording(series, stream)
            finally:
                stream.disconnect()
        print(f"recording: {args.rrd}")
    drawn = None
    if args.figures is not None or args.report is not None:
        from flightdata.figures import FIGURES, FORMATS, save_figures

        kinds = f"{len(FIGURES)} kinds, {' and '.join(f.upper() for f in FORMATS)}"
    if args.figures is not None:
        with steps.step(f"writing figures ({kinds}) in {args.figures}",
                        total=len(FIGURES)) as step:
            drawn = save_figures(series, args.figures, on_figure=lambda _: step.advance())
        print(f"figures: {args.figures}")
    if args.report is not None:
        from gcs.report import write_report

        doing = "copying" if drawn is not None else "writing"
        with steps.step(f"writing the report in {args.report} ({doing} its figures: {kinds})",
                        total=len(FIGURES)) as step:
            path = write_report(args.report, report, series, title=f"Flight {tlog.stem}",
                                source=str(tlog), drawn=drawn,
                                on_figure=lambda _: step.advance())
        print(f"report: {path}")


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``ftc-gcs``; returns the exit status."""
    args = build_parser().parse_args(argv)
    if args.command == "report":
        return cmd_report(args)
    return cmd_fly(args, demo=args.command == "demo")


if __name__ == "__main__":
    sys.exit(main())
