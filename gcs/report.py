"""A Markdown report of one flight: the thesis table with its figures next to it.

``ftc-gcs fly --report DIR`` and ``ftc-gcs report FLIGHT.tlog --report DIR`` write
``DIR/report.md`` and the figures of :mod:`gcs.figures` (PNG embedded, PDF linked) in
``DIR/figures/``, all from the flight's .tlog.
"""

from __future__ import annotations

from pathlib import Path

from gcs.analysis import FlightReport, FlightSeries, format_report
from gcs.figures import FIGURE_KINDS, save_figures

__all__ = ["FIGURE_CAPTIONS", "render_markdown", "write_report"]

FIGURE_CAPTIONS = {
    "trajectory": "trajectory (Fig. 7.3)",
    "xyz": "X, Y, Z and errors (Fig. 7.4-7.6)",
    "rpy": "roll, pitch, yaw and errors (Fig. 7.7-7.8)",
    "pwm": "motor PWM (Fig. 7.9)",
    "loe": "effectiveness, injected and estimated (Fig. 6.2)",
}


def render_markdown(report: FlightReport, figures: dict[str, list[str]], *, title: str,
                    source: str | None = None) -> str:
    """The report: the table (as ``ftc-gcs`` prints it), detections, then the figures.

    ``figures`` maps a kind to its paths relative to the report (PNG first, then PDF).
    """
    lines = [f"# {title}", ""]
    if source is not None:
        lines += [f"From `{source}`. Errors are reference minus truth over the samples "
                  "flown (m, deg); control effort is the mean sum of the four PWM commands; "
                  "times are the vehicle's simulated clock.", ""]
    lines += ["```text", format_report(report, title="flight"), "```", ""]
    if report.detections:
        lines += ["| motor | detected at (s) | estimated loss (%) | latency (s) |",
                  "|---:|---:|---:|---:|"]
        for d in report.detections:
            lat = "-" if d.latency_s is None else f"{d.latency_s:.2f}"
            lines.append(f"| {d.motor} | {d.time_s:.2f} | {d.percent:g} | {lat} |")
        lines.append("")
    for kind in FIGURE_KINDS:
        if kind not in figures:
            continue
        paths = figures[kind]
        caption = FIGURE_CAPTIONS[kind]
        lines += [f"## {caption}", "", f"![{caption}]({paths[0]})", ""]
        pdfs = [p for p in paths[1:] if p.endswith(".pdf")]
        if pdfs:
            lines += ["PDF: " + ", ".join(f"[{kind}]({p})" for p in pdfs), ""]
    return "\n".join(lines)


def write_report(out_dir: str | Path, report: FlightReport, series: FlightSeries, *,
                 title: str = "Flight report", source: str | None = None) -> Path:
    """Write ``out_dir/report.md`` and its figures in ``out_dir/figures``; returns the .md."""
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    written = save_figures(series, root / "figures", name=None)
    rel = {kind: [p.relative_to(root).as_posix() for p in paths]
           for kind, paths in written.items()}
    path = root / "report.md"
    path.write_text(render_markdown(report, rel, title=title, source=source) + "\n")
    return path
