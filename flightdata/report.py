"""Markdown building blocks of the flight reports: numbers, tables, embedded figures.

The chapter-7 report of the headless runs (``sim.thesis_report``) and the ground station's
report of one flight (``gcs.report``) are written with these. Figures are referred to by
paths relative to the report (PNG embedded, PDF linked), captioned from the figure registry
(:data:`flightdata.figures.FIGURES`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from flightdata.figures import FIGURES

__all__ = ["caption", "fmt", "image_lines", "relative_paths", "section_lines", "table_lines"]


def fmt(value: float | None, digits: int = 4) -> str:
    """A number with ``digits`` decimals, ``"-"`` for None."""
    return "-" if value is None else f"{value:.{digits}f}"


def _row(cells: Sequence[str]) -> str:
    return "|" + "|".join(f" {c} " if c else " " for c in cells) + "|"


def table_lines(header: Sequence[str], rows: Iterable[Sequence[str]],
                align: str) -> list[str]:
    """A Markdown table: the header, the alignment row, one line per row.

    ``align`` has one letter per column: ``l`` (left) or ``r`` (right). An empty cell is
    written as a single space.
    """
    if len(align) != len(header) or set(align) - {"l", "r"}:
        raise ValueError(f"align = {align!r}: one of 'l' or 'r' per column "
                         f"({len(header)} columns)")
    rule = "|" + "|".join("---:" if a == "r" else "---" for a in align) + "|"
    return [_row(header), rule, *(_row(r) for r in rows)]


def caption(kind: str) -> str:
    """The report caption of a figure kind (the kind itself if it is not registered)."""
    entry = FIGURES.get(kind)
    return entry.caption if entry is not None else kind


def _pdf_links(figures: Mapping[str, Sequence[str]], kinds: Iterable[str]) -> list[str]:
    return [f"[{k}]({p})" for k in kinds for p in figures[k][1:] if p.endswith(".pdf")]


def image_lines(figures: Mapping[str, Sequence[str]], *, alt_prefix: str = "",
                kinds: Sequence[str] | None = None) -> list[str]:
    """The figures as Markdown images, then one line of PDF links; [] without figures.

    Parameters
    ----------
    figures : mapping
        Kind -> paths relative to the report, the PNG first (:func:`relative_paths`).
    alt_prefix : str
        Put before each caption in the image's alternative text (e.g. ``"run: "``).
    kinds : sequence of str, optional
        Which kinds, in this order (default: every registered kind).
    """
    if not figures:
        return []
    present = [k for k in (kinds if kinds is not None else FIGURES) if k in figures]
    lines = [f"![{alt_prefix}{caption(k)}]({figures[k][0]})" for k in present]
    pdfs = _pdf_links(figures, present)
    if pdfs:
        lines += ["", "PDF: " + ", ".join(pdfs)]
    return [*lines, ""]


def section_lines(figures: Mapping[str, Sequence[str]]) -> list[str]:
    """Every registered figure present in ``figures`` as its own section: a heading with the
    caption, the image, a line of PDF links."""
    lines: list[str] = []
    for kind in FIGURES:
        if kind not in figures:
            continue
        text = caption(kind)
        lines += [f"## {text}", "", f"![{text}]({figures[kind][0]})", ""]
        pdfs = _pdf_links(figures, (kind,))
        if pdfs:
            lines += ["PDF: " + ", ".join(pdfs), ""]
    return lines


def relative_paths(written: Mapping[str, Sequence[Path]], root: Path) -> dict[str, list[str]]:
    """Figure paths (as :func:`flightdata.figures.save_figures` returns them) relative to
    ``root``, POSIX style, for links in a report written there."""
    return {kind: [p.relative_to(root).as_posix() for p in paths]
            for kind, paths in written.items()}
