"""``ftc-campaign``: fly fault campaigns as Dask tasks, resume them, report on them.

Usage::

    ftc-campaign list
    ftc-campaign run NAME|FILE.toml --out DIR [--workers N | --scheduler tcp://HOST:PORT]
                                    [--retry-errors] [--report] [--open]
    ftc-campaign report DIR [--open]
    ftc-campaign export NAME|FILE.toml --out DIR

``run`` flies every run of the campaign not yet in ``DIR`` (:mod:`sim.campaign.store`) on a
local cluster of ``--workers`` processes (default: one per CPU) or on the running Dask
cluster at ``--scheduler``, writing rows as runs finish; the same command after a Ctrl-C or
a lost worker flies only what is missing. ``--retry-errors`` flies the runs that raised
again; ``--report`` writes the report at the end, ``--open`` opens it. On a terminal a
progress bar is drawn on stderr; elsewhere only the summary lines are printed.

``report`` writes ``DIR/report.md`` and its figures from what ``DIR`` holds (a campaign in
progress too). ``export`` writes each run's scenario as ``DIR/<run id>.toml``: any run can be
flown alone, recorded and drawn with ``ftc-scenario run``.

Exit status: 0 every run flown without error, 1 some runs raised (their rows say why),
2 bad input (one line naming the file, key and value), 3 runs left unflown (a worker was lost
or the scheduler could not be reached: run the same command again), 130 Ctrl-C.
"""

from __future__ import annotations

import argparse
import re
import sys
import webbrowser
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from flightdata.arguments import EXIT_INTERRUPTED, EXIT_USAGE, run_subcommand
from sim.campaign.expand import RunSpec, expand, largest_fault_count
from sim.campaign.spec import load_campaign, shipped_campaigns

if TYPE_CHECKING:
    from sim.campaign.engine import Summary
    from sim.campaign.store import ResultStore
    from sim.preparation import Progress

EXIT_ERRORS = 1
EXIT_UNFLOWN = 3


def cmd_list(_: argparse.Namespace) -> int:
    for name in shipped_campaigns():
        campaign = load_campaign(name)
        runs = len(campaign.levels())
        print(f"{name:<16}{runs:>7} runs  {campaign.description}")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from sim.campaign.rows import columns
    from sim.campaign.store import ResultStore, finished_runs, write_manifest

    campaign = load_campaign(args.campaign)
    runs = expand(campaign)  # every bad value fails here, before anything is started
    n_faults = largest_fault_count(runs)
    out = Path(args.out)
    summary = None
    cols = columns(campaign.metrics, n_faults)
    with ResultStore(out, cols) as store:
        write_manifest(out, campaign, runs, n_faults)
        done = finished_runs(out, retry_errors=args.retry_errors,
                             required=[name for name, _ in cols])
        todo = [r for r in runs if r.run_id not in done]
        print(f"campaign {campaign.name}: {len(runs)} runs, {len(runs) - len(todo)} already "
              f"in {out}, {len(todo)} to fly")
        if todo:
            summary = _fly(args, campaign.name, todo, store, n_faults)
            if summary is None:
                return EXIT_UNFLOWN
    ids = {r.run_id for r in runs}
    rows_done = len(finished_runs(out) & ids)
    print(f"{rows_done} of {len(runs)} runs done; results in {out / 'runs'}")
    status = 0
    if summary is not None and summary.interrupted:
        print(f"ftc-campaign: interrupted; run the same command again to fly the remaining "
              f"{len(runs) - rows_done}", file=sys.stderr)
        status = EXIT_INTERRUPTED
    elif summary is not None and summary.unflown:
        print(f"ftc-campaign: {summary.unflown} runs not flown ({summary.first_failure}); run "
              "the same command again to fly them", file=sys.stderr)
        status = EXIT_UNFLOWN
    if args.report:
        _report(out, args.open)
    errors = _errors(out, ids)
    if status == 0 and errors:
        print(f"ftc-campaign: {errors} runs raised; their rows hold the error "
              f"(ftc-campaign report {out} lists them)", file=sys.stderr)
        status = EXIT_ERRORS
    return status


def _fly(args: argparse.Namespace, name: str, todo: list[RunSpec], store: ResultStore,
         n_faults: int) -> Summary | None:
    """Fly ``todo`` on the cluster the arguments name; None when it cannot be reached."""
    from sim.campaign.engine import (
        SchedulerUnreachable,
        dashboard_link,
        fly_runs,
        open_client,
        progress_stream,
    )

    try:
        with open_client(workers=args.workers, scheduler=args.scheduler,
                         report=_show_preparation) as client:
            workers = len(client.scheduler_info()["workers"])
            where = (f"the scheduler at {args.scheduler} ({workers} workers now)"
                     if args.scheduler else f"a local cluster of {workers} workers")
            print(f"flying on {where}", flush=True)
            progress = progress_stream()
            link = dashboard_link(client) if progress is not None else None
            if link is not None:
                print(f"dashboard: {link}", file=progress)
            summary = fly_runs(client, name, todo, store, n_faults, progress=progress)
    except SchedulerUnreachable as exc:
        print(f"ftc-campaign: {exc}", file=sys.stderr)
        return None
    rate = 60.0 * summary.flown / summary.wall_s if summary.wall_s > 0 else 0.0
    print(f"flown {summary.flown} runs in {summary.wall_s:.1f} s ({rate:.1f} runs/min), "
          f"{summary.errors} raised")
    return summary


def _errors(out: Path, ids: set[str]) -> int:
    from sim.campaign.store import read_rows

    return sum(1 for r in read_rows(out) if r["run_id"] in ids and r["status"] == "error")


def _report(out: Path, open_it: bool) -> Path:
    from sim.campaign.report import write_report

    path = write_report(out)
    print(f"report: {path}")
    if open_it:
        webbrowser.open(path.resolve().as_uri())
    return path


def cmd_report(args: argparse.Namespace) -> int:
    _report(Path(args.dir), args.open)
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    import tomli_w

    campaign = load_campaign(args.campaign)
    runs = expand(campaign)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for run in runs:
        (out / f"{run.run_id}.toml").write_text(tomli_w.dumps(dict(run.scenario)))
    print(f"{len(runs)} scenario files in {out} (fly one: ftc-scenario run "
          f"{out / (runs[0].run_id + '.toml') if runs else 'FILE'})")
    return 0


def _workers(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= 1024:
        raise argparse.ArgumentTypeError(f"{text!r}: must be an integer in 1..1024")
    return value


_ADDRESS = re.compile(r"^(tcp|tls)://(\[[0-9a-fA-F:]+\]|[A-Za-z0-9.\-]+):(\d{1,5})$")


def _scheduler(text: str) -> str:
    match = _ADDRESS.match(text)
    if match is None or not 1 <= int(match.group(3)) <= 65535:
        raise argparse.ArgumentTypeError(
            f"{text!r}: must be a Dask scheduler address tcp://HOST:PORT "
            "(or tls://HOST:PORT), port 1..65535")
    return text


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (``ftc-campaign: ...``), status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"ftc-campaign: {message} (ftc-campaign {self._sub_name()}--help "
                  "for usage)\n")

    def _sub_name(self) -> str:
        words = self.prog.split()[1:]
        return " ".join(words) + " " if words else ""


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="ftc-campaign", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    lst = sub.add_parser("list", help="name the shipped campaigns")
    lst.set_defaults(func=cmd_list)
    run = sub.add_parser("run", help="fly a campaign's missing runs (Dask)")
    run.add_argument("campaign", help="a shipped campaign name or a campaign .toml file")
    run.add_argument("--out", required=True, metavar="DIR", help="results directory")
    where = run.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_workers, metavar="N",
                       help="local worker processes (default: one per CPU)")
    where.add_argument("--scheduler", type=_scheduler, metavar="tcp://HOST:PORT",
                       help="fly on this running Dask cluster instead")
    run.add_argument("--retry-errors", action="store_true",
                     help="fly again the runs whose rows hold an error")
    run.add_argument("--report", action="store_true", help="write DIR/report.md at the end")
    run.add_argument("--open", action="store_true", help="with --report: open the report")
    run.set_defaults(func=cmd_run)
    report = sub.add_parser("report", help="write DIR/report.md and its figures")
    report.add_argument("dir", metavar="DIR", help="a campaign's results directory")
    report.add_argument("--open", action="store_true", help="open the report when written")
    report.set_defaults(func=cmd_report)
    export = sub.add_parser("export", help="write every run's scenario file")
    export.add_argument("campaign", help="a shipped campaign name or a campaign .toml file")
    export.add_argument("--out", required=True, metavar="DIR", help="where the files go")
    export.set_defaults(func=cmd_export)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if getattr(args, "open", False) and args.command == "run" and not args.report:
        print("ftc-campaign: --open opens the report: give --report too", file=sys.stderr)
        return EXIT_USAGE
    return run_subcommand("ftc-campaign", args)


if __name__ == "__main__":
    sys.exit(main())


def _show_preparation(progress: Progress) -> None:
    """Kernel preparation before the runs fan out: shown only when it takes a while (a first
    compile), on stderr."""
    if progress.compiled and (progress.elapsed_s >= 1.0 or progress.done):
        print(f"ftc-campaign: {progress.line()}", file=sys.stderr, flush=True)
