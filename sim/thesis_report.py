"""Chapter 7 beside ours: run every thesis configuration and case, write a Markdown report.

The thesis figures come from :func:`flightdata.thesis.thesis_tables`.
Errors are reference minus truth, RMS and maximum over the flight (m and deg); control effort
is the time mean of the sum of the four PWM commands.

With an output directory, each run's thesis-style figures (:mod:`flightdata.figures`, PNG and
PDF) are drawn in the worker process that flew it, into ``DIR/figures/<run>/``, and the report
embeds them next to the tables with relative links (:mod:`flightdata.report`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from flightdata.figures import FIGURES
from flightdata.metrics import attitude_rms_norm
from flightdata.report import fmt, image_lines, table_lines
from flightdata.thesis import AXES, EXTRA_RUNS, THESIS_CASES, THESIS_RUNS, thesis_tables
from sim.batch import fly_many


@dataclass
class ThesisReport:
    """Metrics of every run (keyed by scenario name) and the Markdown report."""

    metrics: dict[str, dict[str, Any]]
    markdown: str


def _thesis_attitude_norm(row: dict[str, Any]) -> float:
    return attitude_rms_norm({axis: row[f"e_{axis}"][0] for axis in ("roll", "pitch", "yaw")})


def render_markdown(metrics: dict[str, dict[str, Any]], tables: dict[str, Any]) -> str:
    """The side-by-side report."""
    lines = ["# Chapter 7 of the thesis beside this emulator", "",
             "Errors are reference minus true state over the flight (m, deg); effort is the "
             "time mean of the sum of the four PWM commands. Thesis figures from its tables; "
             "ours from one seeded run each (wind and sensor noise on).", ""]
    airframe = tables["airframe"]
    hover = airframe["mass"] * airframe["gravity"] / airframe["thrust_gain"]
    dropped = (airframe["mass"] - 0.3) * airframe["gravity"] / airframe["thrust_gain"]
    lines += [f"Physics fixes the hover effort at m g / K = {hover:.4f} "
              f"({dropped:.4f} after the 300 g drop).", ""]
    for name in THESIS_RUNS:
        if name in metrics:
            lines += _run_section(name, metrics[name], tables["runs"][name])
    if all(n in metrics for n in ("pd_loe", "pd_vbdob_loe", "pd_abdob_loe")):
        lines += _dob_section(metrics, tables)
    cases = [c for c in THESIS_CASES if c in metrics]
    if cases:
        lines += _cases_section({c: metrics[c] for c in cases}, tables)
    if "tskf_step" in metrics:
        ours = metrics["tskf_step"]
        final = ours["loe_estimate"]["final"]
        lines += ["## TSKF, Table 6.1 step profile", ""]
        lines += table_lines(
            ("motor", "fault at (s)", "injected", "within 0.05 for good after (s)",
             "final estimate"),
            ([str(conv["motor"]), f"{conv['time_s']:.2f}", f"{conv['loe']:.2f}",
              fmt(conv["settled_after_s"], 2), f"{final[conv['motor'] - 1]:.3f}"]
             for conv in ours["loe_estimate"]["convergence"]), "lrrrr")
        lines.append("")
        lines += image_lines(ours.get("figures") or {}, alt_prefix="tskf_step: ",
                             kinds=("loe",))
    lines += detection_section(metrics)
    return "\n".join(lines)


def _outcome_note(ours: dict[str, Any]) -> str:
    outcome = ours["outcome"]
    if outcome["kind"] == "landed":
        return ""
    return f"  ({outcome['kind'].upper()} at {outcome['time_s']:.2f} s: {outcome['reason']}; " \
        "the errors cover the part flown)"


def detection_section(metrics: dict[str, dict[str, Any]]) -> list[str]:
    """Per run: outcome, each detection with its latency after the injection it is about,
    and the false alarms (detections no injection explains)."""
    cells = []
    for name, m in metrics.items():
        found = [d for d in m["detections"] if d["action"] == "detected"]
        latencies = ", ".join(
            f"{d.get('motor') or d.get('sensor') or 'mass'} {d['kind']} "
            + ("-" if d["latency_s"] is None else f"{d['latency_s']:.2f} s")
            for d in found if not d["false_alarm"])
        false_alarms = sum(1 for d in found if d["false_alarm"])
        outcome = m["outcome"]
        cells.append([name, f"{outcome['kind']} ({outcome['time_s']:.1f} s)",
                      latencies or "none", str(false_alarms)])
    return ["## Detection and outcome", "",
            "Latency: from the injection to the detection it explains (simulated s); a false "
            "alarm is a fault detection no injection explains. Outcome from simulator truth "
            "(sim/outcome.py).", "",
            *table_lines(("run", "outcome", "detections (latency)", "false alarms"), cells,
                         "lllr"), ""]


def _run_section(name: str, ours: dict[str, Any], row: dict[str, Any]) -> list[str]:
    """One thesis run: its errors and effort beside the thesis's, then its figures."""
    lines = [f"## {name}: {row['attitude'].upper()} + {row['estimator'].upper()}"
             f" + DOB {row['dob']}, faults: {row['faults']}"
             + _outcome_note(ours), ""]
    cells = [[f"{axis} ({unit})", f"{row[f'e_{axis}'][0]:.4f}", f"{ours['rms'][axis]:.4f}",
              f"{row[f'e_{axis}'][1]:.4f}", f"{ours['max'][axis]:.4f}"] for axis, unit in AXES]
    cells.append(["effort", fmt(row.get("effort"), 5), f"{ours['control_effort']:.5f}", "",
                  ""])
    lines += table_lines(("error", "thesis RMS", "ours RMS", "thesis max", "ours max"), cells,
                         "lrrrr")
    lines.append("")
    return lines + image_lines(ours.get("figures") or {}, alt_prefix=f"{name}: ")


def _dob_section(metrics: dict[str, dict[str, Any]], tables: dict[str, Any]) -> list[str]:
    """The disturbance observers on PD: combined attitude error against PD alone."""
    pd = attitude_rms_norm(metrics["pd_loe"]["rms"])
    t_pd = _thesis_attitude_norm(tables["runs"]["pd_loe"])
    cells = [["PD", f"{t_pd:.3f}", "1.00", f"{pd:.3f}", "1.00"]]
    for name, thesis_name in (("pd_vbdob_loe", "pd_vbdob_loe"),
                              ("pd_abdob_loe", "tskf_pd_abdob_loe")):
        t = _thesis_attitude_norm(tables["runs"][thesis_name])
        o = attitude_rms_norm(metrics[name]["rms"])
        cells.append([name, f"{t:.3f}", f"{t / t_pd:.2f}", f"{o:.3f}", f"{o / pd:.2f}"])
    return ["## Disturbance observers on PD under the Table 7.3 faults", "",
            "Combined RMS attitude error sqrt(roll^2 + pitch^2 + yaw^2), deg, and its "
            "ratio to PD alone (the thesis has AbDOB on PD only with TSKF feedback, "
            "Table 7.9).", "",
            *table_lines(("configuration", "thesis", "ratio", "ours", "ratio"), cells, "lrrrr"),
            ""]


def _cases_section(cases: dict[str, dict[str, Any]], tables: dict[str, Any]) -> list[str]:
    """Table 7.11 / 7.12: the effort of each fault case, then links to its figures."""
    cells = []
    for case, ours in cases.items():
        row = tables["cases"][case.removeprefix("case")]
        diff = 100.0 * (ours["control_effort"] - row["effort"]) / row["effort"]
        cells.append([case, row["attitude"].upper(), " + ".join(row["faults"]),
                      f"{row['effort']:.5f}", f"{ours['control_effort']:.5f}",
                      f"{diff:+.1f} %", ours["outcome"]["kind"]])
    lines = ["## Table 7.11 / 7.12: fault types (EKF feedback, AbDOB)", "",
             *table_lines(("case", "controller", "faults", "thesis effort", "ours",
                           "difference", "outcome"), cells, "lllrrrl"), ""]
    linked = {c: m["figures"] for c, m in cases.items() if "figures" in m}
    if linked:
        lines += ["Figures of each case (PNG):", ""]
        lines += [f"- {case}: " + ", ".join(f"[{kind}]({figures[kind][0]})"
                                           for kind in FIGURES if kind in figures)
                  for case, figures in linked.items()]
        lines.append("")
    return lines


def run_thesis(out_dir: Path | None = None, seed: int | None = None, jobs: int = 2,
               progress: IO[str] | None = None,
               names: Sequence[str] | None = None) -> ThesisReport:
    """Run the chapter-7 set and render the report (written to ``out_dir/report.md``)."""
    names = list(names) if names is not None else [*THESIS_RUNS, *EXTRA_RUNS, *THESIS_CASES]
    flown = fly_many([(name, seed) for name in names], jobs=jobs, progress=progress,
                     out_dir=out_dir)
    metrics = dict(zip(names, flown, strict=True))
    markdown = render_markdown(metrics, thesis_tables())
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "report.md").write_text(markdown + "\n")
    return ThesisReport(metrics, markdown)
