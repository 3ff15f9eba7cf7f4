"""``ftc-scenario``: fly scenarios headless, list them, reproduce the thesis's chapter 7.

Usage::

    ftc-scenario list
    ftc-scenario run NAME|FILE.toml [--seed N] [--json PATH] [--rrd PATH] [--rerun]
                                    [--figures DIR]
    ftc-scenario thesis [--out DIR] [--json PATH] [--seed N] [--jobs N]
    ftc-scenario seeds NAME|FILE.toml --seeds 1-30 [--jobs N] [--json PATH]
    ftc-scenario compare NAME|FILE.toml NAME|FILE.toml ... --out DIR [--seed N]

``run`` shows a live progress line on stderr when it is a terminal (simulated time, real-time
factor, flight phase) and a final line otherwise. ``--rrd`` records the flight, with truth, to
a rerun ``.rrd`` file, ``--rerun`` streams it to a rerun viewer it starts
(:func:`sim.runner.open_recording`, :mod:`flightdata.recording`) and ``--figures`` writes the
thesis-style figures as PNG and PDF (:mod:`flightdata.figures`).

``seeds`` flies one scenario over many seeds and counts outcomes, detections and false
alarms (a detection that matches no injected fault, :func:`flightdata.metrics.score_detection`):
the figures the fault-detection claims rest on. ``compare`` flies several scenarios (passive
against active FTC, say) and draws their positions through the faults in one figure, plus the
spin phase of any flight that gave up yaw (:mod:`flightdata.fault_figures`).

Bad input (unknown scenario, bad file, bad value, an output that cannot be written) prints one
line naming what was wrong and exits with status 2, before anything is flown; a crash of the
simulated vehicle exits with status 1. Ctrl-C ends a run early: what was flown so far is still
recorded, drawn and summarised, and the exit status is 130. Slow steps after a run (writing
the recording, the figures) each say what they do on stderr (:mod:`flightdata.steps`).
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from flightdata.arguments import run_subcommand
from flightdata.outputs import check_file_output, check_folder_output
from sim.scenario import load_scenario, shipped_names


def _unsafe(metrics: dict[str, Any]) -> bool:
    """The flight crashed or flew away (simulator truth, :mod:`sim.outcome`)."""
    return metrics["outcome"]["kind"] in ("crashed", "flyaway")


def _print_run(metrics: dict[str, Any]) -> None:
    rms, mx = metrics["rms"], metrics["max"]
    outcome = metrics["outcome"]
    print(f"scenario {metrics['name']} (seed {metrics['seed']}): "
          f"{metrics['sim_s']:.1f} s simulated in {metrics['wall_s']:.2f} s "
          f"({metrics['sim_s'] / max(metrics['wall_s'], 1e-9):.1f}x real time)")
    print(f"outcome: {outcome['kind'].upper()} at {outcome['time_s']:.2f} s: "
          f"{outcome['reason']}")
    window = metrics["window"]
    if window["samples"] == 0:
        print("no flight: no tracking errors")
    else:
        caveat = "" if outcome["kind"] == "landed" else \
            f"; NOT a result: the flight ended {outcome['kind']}"
        print(f"errors over the flight, {window['start_s']:.2f} - {window['end_s']:.2f} s"
              f"{caveat}")
    print(f"{'error':<8}{'RMS':>10}{'max':>10}")
    for axis, unit in (("x", "m"), ("y", "m"), ("z", "m"), ("roll", "deg"), ("pitch", "deg"),
                       ("yaw", "deg")):
        print(f"{axis + ' ' + unit:<8}{rms[axis]:>10.4f}{mx[axis]:>10.4f}")
    print(f"control effort {metrics['control_effort']:.5f}")
    est = metrics["loe_estimate"]["final"]
    print("final LOE estimate " + ", ".join(f"m{i + 1} {v:.3f}" for i, v in enumerate(est)))
    for det in metrics["detections"]:
        latency = "" if det["latency_s"] is None else f" ({det['latency_s']:.2f} s after " \
            "the injection)"
        alarm = "  FALSE ALARM" if det["false_alarm"] else ""
        print(f"  {det['time_s']:7.2f} s  {det['text']}{latency}{alarm}")


def _write_json(path: str, data: Any) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(data, indent=2) + "\n")


def _check_outputs(files: Sequence[tuple[str, str | None]],
                   folders: Sequence[tuple[str, str | None]] = ()) -> None:
    """Refuse unwritable outputs before flying (:mod:`flightdata.outputs`)."""
    for option, path in files:
        if path:
            check_file_output(option, path)
    for option, path in folders:
        if path:
            check_folder_output(option, path)


def cmd_run(args: argparse.Namespace) -> int:
    from flightdata.steps import Steps
    from sim.progress import ProgressLine
    from sim.runner import fly, open_recording

    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        scenario = scenario.with_seed(args.seed)
    _check_outputs([("--json", args.json), ("--rrd", args.rrd)], [("--figures", args.figures)])
    steps = Steps(sys.stderr, prog="ftc-scenario")
    progress = ProgressLine(sys.stderr, scenario.name, scenario.duration_s,
                            live=sys.stderr.isatty())
    recorder = None
    if args.rrd or args.rerun:
        recorder = open_recording(scenario, rrd_path=args.rrd, spawn=args.rerun)
    ticks = [progress.on_tick] if recorder is None else [recorder.on_tick, progress.on_tick]

    def on_tick(world: Any, autopilot: Any) -> None:
        for tick in ticks:
            tick(world, autopilot)

    try:
        result = fly(scenario, on_tick=on_tick,
                     on_event=None if recorder is None else recorder.on_event,
                     interruptible=True)
    except BaseException as err:
        if isinstance(err, KeyboardInterrupt):  # before the first tick: nothing flown
            progress.finish(note="interrupted")
        if recorder is not None:
            recorder.close()
        raise
    progress.finish(result.sim_s, result.wall_s, note="interrupted" if result.interrupted else "")
    if recorder is not None:
        what = f"writing the recording {args.rrd}" if args.rrd else "sending the recording"
        with steps.step(what):
            recorder.close()
    _print_run(result.metrics)
    if args.json:
        _write_json(args.json, result.metrics)
    if args.figures:
        from flightdata.figures import FIGURES, FORMATS, save_figures

        formats = " and ".join(f.upper() for f in FORMATS)
        with steps.step(f"writing figures ({len(FIGURES)} kinds, {formats}) in {args.figures}",
                        total=len(FIGURES)) as step:
            written = save_figures(result.log, args.figures, name=scenario.name,
                                   on_figure=lambda _: step.advance())
        print(f"figures: {len(written)} kinds as PNG and PDF in {args.figures}")
    if args.rrd:
        print(f"recording: {args.rrd} (open it with: rerun {args.rrd})")
    if result.interrupted:
        print(f"ftc-scenario: interrupted at t = {result.sim_s:.2f} s; the outputs cover the "
              "flight so far", file=sys.stderr)
        return 130
    return 1 if _unsafe(result.metrics) else 0


def cmd_list(_: argparse.Namespace) -> int:
    for name in shipped_names():
        print(f"{name:<22}{load_scenario(name).description}")
    return 0


def cmd_thesis(args: argparse.Namespace) -> int:
    from sim.thesis_report import run_thesis

    _check_outputs([("--json", args.json)], [("--out", args.out)])
    report = run_thesis(out_dir=Path(args.out) if args.out else None, seed=args.seed,
                        jobs=args.jobs, progress=sys.stderr)
    print(report.markdown)
    if args.json:
        _write_json(args.json, report.metrics)
    return 1 if any(_unsafe(m) for m in report.metrics.values()) else 0


SPIN_RATE_RAD_S = 5.0  # rad/s: a flight that spun faster than this gets a spin figure


def cmd_compare(args: argparse.Namespace) -> int:
    """Fly each scenario and draw them against each other through their faults; a flight
    that gave up yaw (spun faster than SPIN_RATE_RAD_S) gets its spin figure too."""
    import numpy as np

    from flightdata.fault_figures import comparison_figure, spin_figure, spin_series
    from flightdata.figures import save_figure
    from sim.runner import fly

    scenarios = [load_scenario(name) for name in args.scenarios]  # bad input fails here
    if args.seed is not None:
        scenarios = [s.with_seed(args.seed) for s in scenarios]
    _check_outputs([], [("--out", args.out)])
    out = Path(args.out)
    flights = {}
    for scenario in scenarios:
        result = fly(scenario)
        flights[scenario.name] = result.log
        print(f"{scenario.name}: {result.metrics['outcome']['kind']}")
    written = save_figure(comparison_figure(flights), out / "compare")
    for name, series in flights.items():
        rate, _ = spin_series(series)
        if np.nanmax(np.abs(rate)) > SPIN_RATE_RAD_S:
            written += save_figure(spin_figure(series, name), out / f"{name}_spin")
    for path in written:
        print(f"wrote {path}")
    return 0


def cmd_seeds(args: argparse.Namespace) -> int:
    from sim.batch import fly_many

    scenario = load_scenario(args.scenario)  # bad input fails here, before any flight
    _check_outputs([("--json", args.json)])
    flown = fly_many([(args.scenario, seed) for seed in args.seeds], jobs=args.jobs,
                     progress=sys.stderr)
    print(f"scenario {scenario.name} over {len(flown)} seeds "
          f"({args.seeds[0]}..{args.seeds[-1]})")
    print(f"{'seed':>6}  {'outcome':<9}{'at s':>8}  {'false':>5}  detections")
    for m in flown:
        dets = ", ".join(
            ("" if d["action"] == "detected" else "cleared ")
            + f"{d['kind']} {d.get('motor') or d.get('sensor') or ''}@{d['time_s']:.2f}"
            + ("!" if d["false_alarm"] else "") for d in m["detections"])
        false = sum(1 for d in m["detections"] if d["false_alarm"])
        print(f"{m['seed']:>6}  {m['outcome']['kind']:<9}{m['outcome']['time_s']:>8.2f}  "
              f"{false:>5}  {dets}")
    summary = seed_summary(flown)
    print("outcomes: " + ", ".join(f"{k} {v}" for k, v in summary["outcomes"].items()))
    print(f"false detections: {summary['false_detections']} in "
          f"{summary['runs_with_false_detections']} of {len(flown)} runs "
          "(! marks them above)")
    if summary["latency_s"]["median"] is not None:
        lat = summary["latency_s"]
        print(f"detection latency: median {lat['median']:.2f} s, max {lat['max']:.2f} s "
              f"over {lat['count']} detections of injected faults")
    if args.json:
        _write_json(args.json, {"summary": summary, "runs": flown})
    return 1 if any(_unsafe(m) for m in flown) else 0


def seed_summary(flown: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Outcome counts, false detections and detection latency over runs' metrics."""
    import statistics

    outcomes: dict[str, int] = {}
    for m in flown:
        outcomes[m["outcome"]["kind"]] = outcomes.get(m["outcome"]["kind"], 0) + 1
    false = [sum(1 for d in m["detections"] if d["false_alarm"]) for m in flown]
    latencies = [d["latency_s"] for m in flown for d in m["detections"]
                 if d["latency_s"] is not None]
    return {
        "runs": len(flown),
        "outcomes": dict(sorted(outcomes.items())),
        "false_detections": sum(false),
        "runs_with_false_detections": sum(1 for f in false if f),
        "latency_s": {"count": len(latencies),
                      "median": statistics.median(latencies) if latencies else None,
                      "max": max(latencies) if latencies else None},
    }


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="ftc-scenario", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="fly one scenario headless")
    run.add_argument("scenario", help="a shipped scenario name or a scenario .toml file")
    run.add_argument("--seed", type=_seed, help="override the scenario's seed")
    run.add_argument("--json", metavar="PATH", help="write the run's metrics as JSON")
    run.add_argument("--rrd", metavar="PATH",
                     help="record the flight (with truth) to a rerun .rrd file")
    run.add_argument("--rerun", action="store_true",
                     help="start a rerun viewer and stream the flight to it live")
    run.add_argument("--figures", metavar="DIR",
                     help="write the thesis-style figures (PNG and PDF) into DIR")
    run.set_defaults(func=cmd_run)
    lst = sub.add_parser("list", help="name the shipped scenarios")
    lst.set_defaults(func=cmd_list)
    thesis = sub.add_parser("thesis", help="run the chapter-7 configurations and cases")
    thesis.add_argument("--out", metavar="DIR", help="write report.md (and figures) here")
    thesis.add_argument("--json", metavar="PATH", help="write every run's metrics as JSON")
    thesis.add_argument("--seed", type=_seed, help="override every scenario's seed")
    thesis.add_argument("--jobs", type=_jobs, default=2, help="parallel runs (default 2)")
    thesis.set_defaults(func=cmd_thesis)
    compare = sub.add_parser("compare", help="fly scenarios and draw them against each other "
                             "through their faults (and the spin of any that gave up yaw)")
    compare.add_argument("scenarios", nargs="+", metavar="scenario",
                         help="shipped scenario names or scenario .toml files")
    compare.add_argument("--out", metavar="DIR", required=True,
                         help="write compare.png/.pdf (and NAME_spin.png/.pdf) here")
    compare.add_argument("--seed", type=_seed, help="override every scenario's seed")
    compare.set_defaults(func=cmd_compare)
    seeds = sub.add_parser("seeds", help="fly one scenario over many seeds, count outcomes "
                           "and false alarms")
    seeds.add_argument("scenario", help="a shipped scenario name or a scenario .toml file")
    seeds.add_argument("--seeds", type=_seed_range, required=True, metavar="A-B|A,B,..",
                       help="the seeds: a range A-B (both included) or a comma list")
    seeds.add_argument("--jobs", type=_jobs, default=2, help="parallel runs (default 2)")
    seeds.add_argument("--json", metavar="PATH", help="write the summary and every run's "
                       "metrics as JSON")
    seeds.set_defaults(func=cmd_seeds)
    return parser


def _int_at_least(option: str, least: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``least``, refused in one line naming ``option``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = least - 1
        if value < least:
            raise argparse.ArgumentTypeError(f"{option} {text!r}: must be an integer >= {least}")
        return value
    return parse


_seed = _int_at_least("--seed", 0)
_jobs = _int_at_least("--jobs", 1)


def _seed_range(text: str) -> list[int]:
    """``A-B`` (both included) or ``A,B,...``: distinct integers >= 0."""
    try:
        if "-" in text:
            first, last = (_seed(part) for part in text.split("-", 1))
            seeds = list(range(first, last + 1))
        else:
            seeds = [_seed(part) for part in text.split(",")]
    except argparse.ArgumentTypeError:
        seeds = []
    if not seeds or len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(
            f"--seeds {text!r}: must be a range A-B or a comma list of integers >= 0")
    return seeds


def _exit_at_once(status: int) -> NoReturn:
    """End the process with ``status`` after the exit work that matters here (the ``atexit``
    handlers, the standard streams flushed), skipping the interpreter's teardown of every
    module and object: with numpy, numba and its compiled kernels loaded that teardown is
    about 0.4 s of wall time, a fifth of a whole run of a one-minute flight."""
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    status = run_subcommand("ftc-scenario", args)
    # As a program (no argv given: the console script, python -m) a plain ``run`` ends at
    # once; not with a recording (the recorder flushes as the interpreter stops), with
    # another thread still running (a normal exit joins it) or under a profiler or tracer
    # (pyinstrument, cProfile, coverage write their results after the program returns).
    if (argv is None and getattr(args, "func", None) is cmd_run and args.rrd is None
            and not args.rerun and threading.active_count() == 1
            and sys.getprofile() is None and sys.gettrace() is None):
        _exit_at_once(status)
    return status


if __name__ == "__main__":
    sys.exit(main())
