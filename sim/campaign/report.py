"""``ftc-campaign report DIR``: a campaign's tables and figures as one Markdown page.

Written from what ``DIR`` holds (:mod:`sim.campaign.store`), a campaign in progress too:
``DIR/report.md`` and ``DIR/figures/*.png``, linked relatively. Sections, each present when
the campaign's rows allow it:

1. what was flown: the base scenario, the swept axes and their values, runs done;
2. outcomes per configuration (:mod:`sim.campaign.summary`) and the survival share;
3. the survival envelope (magnitude against start time, or against motor), per configuration,
   and for each the largest magnitude every run survived;
4. detection latency and false alarms per configuration;
5. the settled error of the effectiveness estimate per configuration;
6. the response to the fault (``response`` metrics): survival, soft landings, excursion from
   the fault point and the motor named, by phase of flight and kind, by attitude law and
   estimator, by wind;
7. active against passive FTC over the runs flown both ways;
8. the runs that raised, with their error.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from flightdata.figures import save_figure
from flightdata.report import fmt, table_lines
from sim.campaign import figures
from sim.campaign.axes import AXES, AXIS_COLUMNS
from sim.campaign.store import read_manifest, read_rows
from sim.campaign.summary import (
    OUTCOME_ORDER,
    Group,
    Row,
    configuration_columns,
    configurations,
    fault_latencies,
    ok_rows,
    outcome_counts,
    pairs,
    share,
    spread,
    survived,
)

REPORT = "report.md"
FIGURES_DIR = "figures"


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100.0 * value:.0f} %"


def _values(rows: Sequence[Row], column: str) -> str:
    distinct = sorted({r[column] for r in rows if r.get(column) is not None})
    text = [f"{v:g}" if isinstance(v, float) else str(v) for v in distinct]
    if len(text) > 8:
        return f"{len(text)} values, {text[0]} .. {text[-1]}"
    return ", ".join(text)


class _Page:
    """The report being written: Markdown lines and its figures."""

    def __init__(self, out_dir: Path) -> None:
        self.out_dir = out_dir
        self.lines: list[str] = []

    def add(self, *lines: str) -> None:
        self.lines += lines

    def section(self, title: str, intro: str = "") -> None:
        """A ``##`` heading, and under it the paragraph ``intro`` when there is one."""
        self.add(f"## {title}", "")
        if intro:
            self.add(intro, "")

    def table(self, header: Sequence[str], rows: Sequence[Sequence[str]], align: str) -> None:
        self.lines += [*table_lines(header, rows, align), ""]

    def figure(self, fig: Any, name: str, caption: str) -> None:
        if fig is None:
            return
        png = save_figure(fig, self.out_dir / FIGURES_DIR / name, formats=("png",))[0]
        self.add(f"![{caption}]({png.relative_to(self.out_dir).as_posix()})", "")


def _header(page: _Page, manifest: Mapping[str, Any], rows: Sequence[Row]) -> None:
    runs = manifest["runs"]
    errors = sum(1 for r in rows if r["status"] == "error")
    page.add(f"# Campaign {manifest['campaign']}", "")
    if manifest.get("description"):
        page.add(manifest["description"], "")
    page.add(f"Base scenario `{manifest['scenario']}` (its own faults: "
             f"{manifest['base_faults']}); {len(rows)} of {len(runs)} runs done"
             f"{f', {errors} raised' if errors else ''}. Results: `runs/` (Parquet, one row "
             "per run). A run *survived* when it landed or was still flying at the end "
             "(not crashed, not flown away); outcomes are judged from simulator truth.", "")
    swept = [AXES[name] for name in manifest["swept"]]
    if swept:
        page.table(("swept axis", "values"),
                   [[f"`{a.name}`", _values(runs, a.column)] for a in swept], "ll")


def _per_configuration(groups: Sequence[Group],
                       cells: Callable[[list[Row]], list[str]]) -> list[list[str]]:
    """Table rows, one per configuration: its label, then ``cells`` of its runs that flew
    without error."""
    return [[g.label, *cells(ok_rows(g.rows))] for g in groups]


def _outcomes(page: _Page, groups: Sequence[Group]) -> None:
    page.section("Outcomes")
    cells = []
    for g in groups:
        counts = outcome_counts(g.rows)
        cells.append([g.label, str(len(g.rows)), *(str(counts[k]) for k in OUTCOME_ORDER),
                      _pct(share(g.rows, survived))])
    page.table(("configuration", "runs", *OUTCOME_ORDER, "survived"), cells, "lrrrrrrr")


def _envelope(page: _Page, manifest: Mapping[str, Any], rows: Sequence[Row],
              groups: Sequence[Group]) -> None:
    swept = manifest["swept"]
    if "fault.magnitude" not in swept:
        return
    y = "fault_start_s" if "fault.start_s" in swept else (
        "fault_motor" if "fault.motor" in swept else None)
    loe = all(r.get("fault_kind") == "loe" for r in rows)
    x_label = "loss of effectiveness (%)" if loe else "fault magnitude"
    unit = " (%)" if loe else ""
    scale = 100.0 if loe else 1.0
    page.section("Survival envelope")
    if y is not None:
        y_label = "fault start (s)" if y == "fault_start_s" else "motor"
        page.figure(figures.envelope_figure(groups, "fault_magnitude", y, x_label, y_label,
                                            scale), "envelope",
                    f"survival envelope: {x_label} against {y_label}")
    cells = []
    for g in groups:
        kept = [r for r in g.rows if r.get("fault_magnitude") is not None]
        failed = [r["fault_magnitude"] for r in kept if not survived(r)]
        first_fail = min(failed) if failed else None
        held = [r["fault_magnitude"] for r in kept
                if first_fail is None or r["fault_magnitude"] < first_fail]
        cells.append([g.label, fmt(scale * max(held), 1) if held else "-",
                      fmt(scale * first_fail, 1) if first_fail is not None else "none"])
    page.table(("configuration", f"every run survived up to{unit}",
                f"smallest magnitude that failed{unit}"), cells, "lrr")


def _detection(page: _Page, manifest: Mapping[str, Any], groups: Sequence[Group]) -> None:
    if "detection" not in manifest["metrics"]:
        return
    n_faults = int(manifest["n_faults"])
    page.section("Detection latency and false alarms",
                 "Latency: from a fault's start to its first detection (simulated s); a false "
                 "alarm is a fault detection that no injected fault explains.")

    def cells(ok: list[Row]) -> list[str]:
        lat = spread(v for r in ok for v in fault_latencies(r, n_faults))
        started = sum(r.get("faults_started") or 0 for r in ok)
        detected = sum(r.get("faults_detected") or 0 for r in ok)
        false = [r.get("false_alarms") or 0 for r in ok]
        return [str(started), str(detected), fmt(lat.median, 2), fmt(lat.p90, 2),
                fmt(lat.max, 2), str(sum(false)), f"{sum(1 for f in false if f)} of {len(ok)}"]

    page.table(("configuration", "faults started", "detected", "median (s)", "p90 (s)",
                "max (s)", "false alarms", "runs with one"), _per_configuration(groups, cells),
               "lrrrrrrr")
    page.figure(figures.latency_figure(groups, n_faults), "latency",
                "detection latency per configuration")
    page.figure(figures.false_alarm_figure(groups), "false_alarms",
                "false alarms per run, per configuration")


def _estimate(page: _Page, manifest: Mapping[str, Any], groups: Sequence[Group]) -> None:
    if "estimate" not in manifest["metrics"]:
        return
    page.section("Estimate error",
                 "The largest |estimated - injected| loss of effectiveness over the motors while "
                 "flying, 3 s after each change (settled), and at the end of the run.")

    def cells(ok: list[Row]) -> list[str]:
        settled = spread(r.get("loe_settled_error_max") for r in ok)
        final = spread(r.get("loe_final_error_max") for r in ok)
        return [fmt(settled.median, 3), fmt(settled.p90, 3), fmt(settled.max, 3),
                fmt(final.median, 3), fmt(final.max, 3)]

    page.table(("configuration", "settled median", "settled p90", "settled max",
                "final median", "final max"), _per_configuration(groups, cells), "lrrrrr")
    page.figure(figures.estimate_error_figure(groups), "estimate_error",
                "estimate error per configuration")


SOFT_TOUCHDOWN_M_S = 1.0  # m/s, the most a soft landing may touch down at
SOFT_TILT_DEG = 30.0  # deg, the most a soft landing may be tilted at touchdown


def soft_landing(row: Row) -> bool:
    """Landed at under 1 m/s and 30 deg of tilt."""
    return (row.get("outcome") == "landed"
            and (row.get("impact_speed_m_s") or 0.0) < SOFT_TOUCHDOWN_M_S
            and (row.get("tilt_deg") or 0.0) < SOFT_TILT_DEG)


def _response_cells(rows: Sequence[Row]) -> list[str]:
    ok = ok_rows(rows)
    excursion = spread(r.get("excursion_m") for r in ok)
    end = spread(r.get("end_from_fault_m") for r in ok if survived(r))
    named = share(ok, lambda r: r.get("named_motor") == r.get("fault_motor"))
    other = sum(1 for r in ok if r.get("other_motor_lost"))
    # a fly-away verdict is final, but the physics flies on: how many ended near the fault
    flyaways = [r for r in ok if r.get("outcome") == "flyaway"]
    back = sum(1 for r in flyaways if r.get("end_from_fault_m") is not None
               and r["end_from_fault_m"] <= FLYAWAY_BACK_WITHIN_M)
    return [str(len(rows)), _pct(share(rows, survived)), _pct(share(ok, soft_landing)),
            fmt(excursion.median, 1), fmt(excursion.max, 1), fmt(end.median, 1),
            _pct(named), str(other), f"{back} of {len(flyaways)}" if flyaways else "-"]


FLYAWAY_BACK_WITHIN_M = 2.0  # m from the fault point at the end of the run
_RESPONSE_HEADER = ("runs", "survived", "landed soft", "excursion median (m)",
                    "excursion max (m)", "end from fault, survivors, median (m)",
                    "right motor named first", "another motor declared lost",
                    f"fly-away verdicts back within {FLYAWAY_BACK_WITHIN_M:g} m at the end")


def _response(page: _Page, manifest: Mapping[str, Any], rows: Sequence[Row]) -> None:
    faulted = [r for r in rows if r.get("fault_phase") is not None]
    if "response" not in manifest["metrics"] or not faulted:
        return
    page.section("Response to the fault",
                 "Phase of flight when the fault struck (from simulator truth: climb or descent "
                 "beyond 0.5 m/s vertically, else cruise beyond 1 m/s horizontally, else hover). "
                 f"*Landed soft*: touchdown under {SOFT_TOUCHDOWN_M_S:g} m/s and "
                 f"{SOFT_TILT_DEG:g} deg of tilt. *Excursion*: the largest horizontal distance "
                 "from where the fault struck, afterwards; *end from fault*: that distance at "
                 "the end of the run. *Right motor named first*: the first motor detection "
                 "after the fault names the faulted motor. A fly-away verdict is final; "
                 "the last column counts those runs that ended near the fault point all "
                 "the same (the drift came back).")
    for title, columns in (("phase, kind", ("fault_phase", "fault_kind")),
                           ("attitude law, estimator", ("attitude", "estimator")),
                           ("wind", ("wind", "mean_wind_m_s"))):
        groups = configurations(faulted, columns)
        if len(groups) < 2 and title != "phase, kind":
            continue
        page.add(f"By {title}:", "")
        page.table((title, *_RESPONSE_HEADER), [[g.label, *_response_cells(g.rows)]
                                                 for g in groups], "l" + "r" * 9)
    by_phase = configurations(faulted, ("fault_phase",))
    page.figure(figures.excursion_figure([(g.label, g.rows) for g in by_phase]), "excursion",
                "excursion after the fault, by phase of flight")


def _active_passive(page: _Page, manifest: Mapping[str, Any], rows: Sequence[Row]) -> None:
    paired = pairs(rows, "ftc", "passive", "active", AXIS_COLUMNS)
    if not paired:
        return
    page.section("Active against passive FTC",
                 f"{len(paired)} runs were flown both ways (every other axis and the seed equal).")
    passive = [p for p, _ in paired]
    active = [a for _, a in paired]
    cells = [["survived", _pct(share(passive, survived)), _pct(share(active, survived))]]
    if "tracking" in manifest["metrics"]:
        for column, what in (("max_z", "largest height error, median (m)"),
                             ("rms_z", "RMS height error, median (m)"),
                             ("rms_x", "RMS x error, median (m)")):
            cells.append([what, fmt(spread(r.get(column) for r in ok_rows(passive)).median),
                          fmt(spread(r.get(column) for r in ok_rows(active)).median)])
    page.table(("", "passive", "active"), cells, "lrr")
    magnitude = "fault.magnitude" in manifest["swept"]
    loe = all(r.get("fault_kind") == "loe" for r in rows)
    page.figure(figures.active_passive_figure(
        rows, paired, "fault_magnitude" if magnitude else None,
        "loss of effectiveness (%)" if loe else "fault magnitude", 100.0 if loe else 1.0),
        "active_passive", "active against passive FTC")


def _errors(page: _Page, manifest: Mapping[str, Any], rows: Sequence[Row]) -> None:
    failed = [r for r in rows if r["status"] == "error"]
    if not failed:
        return
    columns = [AXES[name].column for name in manifest["swept"]]
    page.section("Runs that raised",
                 "Each is recorded with its error; `ftc-campaign run ... --retry-errors` flies "
                 "them again, `ftc-campaign export` writes their scenario files.")
    page.table(("run", *columns, "error"),
               [[f"`{r['run_id']}`", *(str(r.get(c)) for c in columns),
                 str(r["error"]).splitlines()[0].replace("|", "\\|")] for r in failed],
               "l" * (len(columns) + 2))


def render(out_dir: Path) -> str:
    """The report of the campaign in ``out_dir`` as Markdown (figures written on the way)."""
    manifest = read_manifest(out_dir)
    ids = {r["run_id"] for r in manifest["runs"]}
    rows = [r for r in read_rows(out_dir) if r["run_id"] in ids]
    page = _Page(out_dir)
    _header(page, manifest, rows)
    if not rows:
        page.add("No run has finished yet.", "")
        return "\n".join(page.lines)
    groups = configurations(rows, configuration_columns(manifest["swept"]))
    _outcomes(page, groups)
    _envelope(page, manifest, rows, groups)
    _detection(page, manifest, groups)
    _estimate(page, manifest, groups)
    _response(page, manifest, rows)
    _active_passive(page, manifest, rows)
    _errors(page, manifest, rows)
    return "\n".join(page.lines)


def write_report(out_dir: Path) -> Path:
    """Write ``DIR/report.md`` (and ``DIR/figures/``); returns the report's path.

    Raises
    ------
    ConfigError
        ``out_dir`` holds no campaign.
    """
    text = render(out_dir)
    path = out_dir / REPORT
    path.write_text(text + "\n")
    return path
