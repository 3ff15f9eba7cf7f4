"""A Markdown report of one flight: the thesis table with its figures next to it.

``ftc-gcs fly --report DIR`` and ``ftc-gcs report FLIGHT.tlog --report DIR`` write
``DIR/report.md`` and every figure of :mod:`flightdata.figures` (PNG embedded, PDF linked)
in ``DIR/figures/``, all from the flight's .tlog.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from flightdata.figures import save_figures
from flightdata.report import relative_paths, section_lines, table_lines
from flightdata.series import FlightSeries
from gcs.table import FlightReport, format_report

__all__ = ["render_markdown", "write_report"]


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
        lines += table_lines(
            ("motor", "detected at (s)", "estimated loss (%)", "latency (s)"),
            ([str(d.motor), f"{d.time_s:.2f}", f"{d.percent:g}",
              "-" if d.latency_s is None else f"{d.latency_s:.2f}"] for d in report.detections),
            "rrrr")
        lines.append("")
    lines += section_lines(figures)
    return "\n".join(lines)


def write_report(out_dir: str | Path, report: FlightReport, series: FlightSeries, *,
                 title: str = "Flight report", source: str | None = None,
                 drawn: Mapping[str, Sequence[Path]] | None = None,
                 on_figure: Callable[[str], None] | None = None) -> Path:
    """Write ``out_dir/report.md`` and its figures in ``out_dir/figures``; returns the .md.

    ``drawn``: the same figures already written elsewhere (``save_figures`` of this series,
    untitled), copied instead of drawn again. ``on_figure`` is called with each kind written.
    """
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    if drawn is None:
        written = save_figures(series, root / "figures", name=None, on_figure=on_figure)
    else:
        written = _copy_figures(drawn, root / "figures", on_figure)
    path = root / "report.md"
    path.write_text(render_markdown(report, relative_paths(written, root), title=title,
                                    source=source) + "\n")
    return path


def _copy_figures(drawn: Mapping[str, Sequence[Path]], folder: Path,
                  on_figure: Callable[[str], None] | None) -> dict[str, list[Path]]:
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, list[Path]] = {}
    for kind, paths in drawn.items():
        out[kind] = [Path(shutil.copyfile(p, folder / Path(p).name)) for p in paths]
        if on_figure is not None:
            on_figure(kind)
    return out
