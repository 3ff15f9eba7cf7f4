"""A campaign's figures, drawn headless from its rows (matplotlib Agg, no pyplot).

Each function takes rows (:mod:`sim.campaign.rows`) grouped by configuration
(:func:`sim.campaign.summary.configurations`) and returns a figure, or None when the rows
hold nothing to draw. Figures are built on :func:`flightdata.figures.new_figure` and written
with :func:`flightdata.figures.save_figure`, like every figure of the project.

- :func:`envelope_figure`: the survival envelope, one panel per configuration: each run a
  marker at (fault magnitude, start time or motor), coloured by outcome;
- :func:`latency_figure`: detection latency per configuration (box plots);
- :func:`false_alarm_figure`: how many runs had 0, 1, 2, 3 or more false alarms;
- :func:`estimate_error_figure`: the settled estimate error per configuration (box plots);
- :func:`active_passive_figure`: survival against magnitude, and the worst height error of
  runs flown both ways, for passive and active FTC.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from flightdata.figures import new_figure
from sim.campaign.summary import (
    OUTCOME_ORDER,
    Group,
    Row,
    by_value,
    fault_latencies,
    ok_rows,
    outcome,
    share,
    survived,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

OUTCOME_COLORS = {"landed": "tab:green", "airborne": "tab:blue", "crashed": "tab:red",
                  "flyaway": "tab:purple", "error": "black"}
OUTCOME_MARKERS = {"landed": "o", "airborne": "s", "crashed": "X", "flyaway": "^",
                   "error": "x"}
_PANEL_COLUMNS = 3  # envelope panels per row
_JITTER = 0.6  # share of the smallest spacing of x over which runs of one cell are spread
_FALSE_ALARM_BINS = ("0", "1", "2", "3+")
_FALSE_ALARM_COLORS = ("tab:green", "gold", "tab:orange", "tab:red")


def _spacing(values: Sequence[float]) -> float:
    distinct = sorted(set(values))
    gaps = np.diff(distinct)
    return float(gaps.min()) if gaps.size else 1.0


def _spread_x(points: Sequence[tuple[float, float]]) -> list[float]:
    """x of each point, the points sharing a cell spread side by side (in input order)."""
    width = _JITTER * _spacing([x for x, _ in points])
    cells: dict[tuple[float, float], int] = {}
    for p in points:
        cells[p] = cells.get(p, 0) + 1
    seen: dict[tuple[float, float], int] = {}
    out = []
    for p in points:
        k, m = seen.get(p, 0), cells[p]
        seen[p] = k + 1
        out.append(p[0] + (0.0 if m == 1 else width * ((k + 0.5) / m - 0.5)))
    return out


def envelope_figure(groups: Sequence[Group], x_column: str, y_column: str,
                    x_label: str, y_label: str, x_scale: float = 1.0) -> Figure | None:
    """Survival envelope: per configuration, each run at (x, y) coloured by its outcome.

    Parameters
    ----------
    groups : sequence of Group
        The configurations.
    x_column, y_column : str
        Result columns of the axes (``fault_magnitude``; ``fault_start_s`` or
        ``fault_motor``).
    x_label, y_label : str
        Axis labels, with units.
    x_scale : float
        Factor on x (100: a loss of effectiveness in percent).
    """
    drawn = [g for g in groups
             if any(r.get(x_column) is not None and r.get(y_column) is not None
                    for r in g.rows)]
    if not drawn:
        return None
    cols = min(_PANEL_COLUMNS, len(drawn))
    rows_n = math.ceil(len(drawn) / cols)
    fig = new_figure(4.2 * cols + 1.0, 3.4 * rows_n + 0.6)
    axes = np.atleast_1d(fig.subplots(rows_n, cols, sharex=True, sharey=True, squeeze=False))
    for ax, group in zip(axes.flat, drawn, strict=False):
        runs = sorted((r for r in group.rows
                       if r.get(x_column) is not None and r.get(y_column) is not None),
                      key=lambda r: r.get("index", 0))
        points = [(x_scale * float(r[x_column]), float(r[y_column])) for r in runs]
        xs = _spread_x(points)
        for kind in OUTCOME_ORDER:
            chosen = [i for i, r in enumerate(runs) if outcome(r) == kind]
            if chosen:
                ax.scatter([xs[i] for i in chosen], [points[i][1] for i in chosen], s=22,
                           color=OUTCOME_COLORS[kind], marker=OUTCOME_MARKERS[kind],
                           label=kind)
        ax.set_title(group.label, fontsize=8)
        ax.grid(True, alpha=0.3)
    for ax in axes.flat[len(drawn):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel(x_label)
    for ax in axes[:, 0]:
        ax.set_ylabel(y_label)
    if y_column == "fault_motor":
        axes[0, 0].set_yticks([1, 2, 3, 4])
    handles: dict[str, Any] = {}
    for ax in axes.flat[:len(drawn)]:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
    ordered = [k for k in OUTCOME_ORDER if k in handles]
    fig.legend([handles[k] for k in ordered], ordered, loc="outside right upper")
    fig.suptitle("survival envelope: outcome of each run")
    return fig


def _box_figure(labels: Sequence[str], data: Sequence[Sequence[float]], x_label: str,
                title: str) -> Figure | None:
    kept = [(lab, d) for lab, d in zip(labels, data, strict=True) if len(d)]
    if not kept:
        return None
    fig = new_figure(8.0, 1.4 + 0.38 * len(kept))
    ax: Axes = fig.subplots()
    ax.boxplot([d for _, d in kept], orientation="horizontal", widths=0.6)
    ax.set_yticks(range(1, len(kept) + 1), [f"{lab} (n={len(d)})" for lab, d in kept],
                  fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel(x_label)
    ax.grid(True, axis="x", alpha=0.3)
    ax.set_title(title)
    return fig


def excursion_figure(labelled: Sequence[tuple[str, Sequence[Row]]]) -> Figure | None:
    """Largest horizontal distance from the fault point after the fault (m), per group of
    runs (a label and its rows)."""
    return _box_figure([label for label, _ in labelled],
                       [[r["excursion_m"] for r in ok_rows(rows)
                         if r.get("excursion_m") is not None] for _, rows in labelled],
                       "largest horizontal distance from where the fault struck (m)",
                       "excursion after the fault")


def latency_figure(groups: Sequence[Group], n_faults: int) -> Figure | None:
    """Detection latency of every detected fault, per configuration (s)."""
    return _box_figure([g.label for g in groups],
                       [[v for r in ok_rows(g.rows) for v in fault_latencies(r, n_faults)]
                        for g in groups],
                       "detection latency after the fault started (s)",
                       "detection latency, per configuration")


def estimate_error_figure(groups: Sequence[Group]) -> Figure | None:
    """Largest settled error of the effectiveness estimate per run, per configuration."""
    return _box_figure([g.label for g in groups],
                       [[r["loe_settled_error_max"] for r in ok_rows(g.rows)
                         if r.get("loe_settled_error_max") is not None] for g in groups],
                       "largest |estimated - injected| loss of effectiveness, settled",
                       "estimate error, per configuration")


def false_alarm_figure(groups: Sequence[Group]) -> Figure | None:
    """Share of runs with 0, 1, 2 and 3 or more false alarms, per configuration."""
    counted = [(g.label, [int(r["false_alarms"]) for r in ok_rows(g.rows)
                          if r.get("false_alarms") is not None]) for g in groups]
    counted = [(lab, c) for lab, c in counted if c]
    if not counted:
        return None
    fig = new_figure(8.0, 1.6 + 0.38 * len(counted))
    ax: Axes = fig.subplots()
    y = np.arange(len(counted))
    left = np.zeros(len(counted))
    for b, (name, color) in enumerate(zip(_FALSE_ALARM_BINS, _FALSE_ALARM_COLORS,
                                          strict=True)):
        share_b = np.array([sum(1 for v in c if min(v, 3) == b) / len(c) for _, c in counted])
        ax.barh(y, share_b, left=left, color=color, label=f"{name} false alarms")
        left += share_b
    ax.set_yticks(y, [f"{lab} (n={len(c)})" for lab, c in counted], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlim(0.0, 1.0)
    ax.set_xlabel("share of runs")
    fig.legend(loc="outside lower center", ncols=len(_FALSE_ALARM_BINS), fontsize=8)
    ax.set_title("false alarms per run, per configuration")
    return fig


def active_passive_figure(rows: Sequence[Row], paired: Sequence[tuple[Row, Row]],
                          x_column: str | None, x_label: str,
                          x_scale: float = 1.0) -> Figure | None:
    """Passive against active FTC: survival against ``x_column`` (when given) and the
    largest height error of each pair of runs flown both ways (m)."""
    if not paired:
        return None
    panels = 2 if x_column is not None else 1
    fig = new_figure(5.0 * panels, 4.2)
    axes = np.atleast_1d(fig.subplots(1, panels))
    if x_column is not None:
        ax = axes[0]
        for mode, style in (("passive", "--"), ("active", "-")):
            mine = [r for r in rows if r.get("ftc") == mode and r.get(x_column) is not None]
            levels = by_value(mine, x_column)
            ax.plot([x_scale * v for v in levels], [share(g, survived) for g in levels.values()],
                    style, marker="o", label=mode)
        ax.set_xlabel(x_label)
        ax.set_ylabel("share of runs that survived")
        ax.set_ylim(-0.05, 1.05)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best")
    ax = axes[-1]
    both = [(p, a) for p, a in paired if p.get("max_z") is not None and a.get("max_z") is not None]
    colors = [OUTCOME_COLORS[outcome(a)] for _, a in both]
    ax.scatter([p["max_z"] for p, _ in both], [a["max_z"] for _, a in both], s=18, c=colors)
    top = max([max(p["max_z"], a["max_z"]) for p, a in both] or [1.0])
    ax.plot([0.0, top], [0.0, top], color="0.5", linewidth=0.8, label="equal")
    ax.set_xlabel("passive: largest height error (m)")
    ax.set_ylabel("active: largest height error (m)")
    ax.set_title("the same runs flown both ways (colour: active outcome)", fontsize=9)
    ax.grid(True, alpha=0.3)
    fig.suptitle("active against passive fault-tolerant control")
    return fig
