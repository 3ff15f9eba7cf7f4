"""Thesis-style figures of a flight, drawn headless with matplotlib (Agg, no pyplot).

Each figure is a function of a :class:`~flightdata.series.FlightSeries` (and an optional
run name for the title) returning a :class:`matplotlib.figure.Figure`, registered with
:func:`figure` under a kind and a caption. :data:`FIGURES` holds them in drawing order;
:func:`make_figures`, :func:`save_figures` and the reports (``sim.thesis_report``,
``gcs.report``) draw every registered kind, so a new figure is one decorated function here.

==============  ============================================================================
``trajectory``  Figure 7.3: reference and flown path, in 3-D and seen from above
``xyz``         Figures 7.4-7.6: X, Y, Z with reference, each with its error below
``rpy``         Figures 7.7-7.8: roll, pitch, yaw with reference, each with its error below
``pwm``         Figure 7.9: the commanded PWM of the four motors
``loe``         Figure 6.2: loss of effectiveness per motor, injected against estimated
==============  ============================================================================

Frames and signs follow the thesis's figures, not the code's NED: X = north = x_NED,
Y = east = y_NED, Z = altitude = -z_NED (up-positive). Errors are reference minus truth in
those axes (so e_Z = -(z_ref_NED - z_NED)); attitude errors are wrapped to +-180 deg.
References and errors are drawn only over the samples flown (``FlightSeries.flying``):
elsewhere they are NaN, i.e. gaps. Fault onsets (:meth:`FlightSeries.fault_onsets_s`) are
dotted vertical lines. Times on the x axes are the vehicle's simulated clock, s.

Every data line carries a label (``"reference"``, ``"flown"``, ``"error"``, ``"motor 1"``,
``"injected"``, ``"estimated"``...); helper lines (fault markers) have labels starting with
``_``, matplotlib's convention for "not in the legend".

matplotlib is imported when a figure is drawn, not with this module. Figures are built
without pyplot, on an Agg canvas: no display, no global state.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from flightdata.geometry import wrap_pi_array
from flightdata.series import FlightSeries

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["FIGURES", "FORMATS", "FigureKind", "attitude_series", "figure", "figure_kinds",
           "loe_figure", "make_figures", "new_figure", "position_series", "pwm_figure",
           "rpy_figure", "save_figure", "save_figures", "trajectory_figure", "xyz_figure"]

#: Output formats of :func:`save_figures`.
FORMATS = ("png", "pdf")

_REF_STYLE: dict[str, Any] = {"color": "black", "linestyle": "--", "linewidth": 1.0}
_TRUTH_STYLE: dict[str, Any] = {"color": "tab:blue", "linewidth": 1.2}
_ERROR_STYLE: dict[str, Any] = {"color": "tab:red", "linewidth": 1.0}
_EST_STYLE: dict[str, Any] = {"color": "tab:orange", "linewidth": 1.2}
_MOTOR_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red")
_FAULT_STYLE: dict[str, Any] = {"color": "0.5", "linestyle": ":", "linewidth": 0.9}

FigureMaker = Callable[[FlightSeries, str | None], "Figure"]
_Maker = TypeVar("_Maker", bound=FigureMaker)


@dataclass(frozen=True)
class FigureKind:
    """A registered figure: its kind (file name), its caption in reports, how to draw it."""

    kind: str
    caption: str
    draw: FigureMaker


#: Every registered figure by kind, in drawing order (:func:`figure` adds to it).
FIGURES: dict[str, FigureKind] = {}


def figure(kind: str, caption: str) -> Callable[[_Maker], _Maker]:
    """Register the decorated function as figure ``kind`` with a report ``caption``."""
    def register(draw: _Maker) -> _Maker:
        if kind in FIGURES:
            raise ValueError(f"figure kind {kind!r} is registered twice")
        FIGURES[kind] = FigureKind(kind, caption, draw)
        return draw
    return register


def new_figure(width_in: float, height_in: float) -> Figure:
    """An empty figure on an Agg canvas (matplotlib imported here, not with the module);
    width and height in inches. Every figure of the project is drawn on one of these."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _only_flying(values: np.ndarray, flying: np.ndarray) -> np.ndarray:
    out = np.array(values, dtype=float)
    out[~flying] = np.nan
    return out


def mark_faults(ax: Axes, fault_times_s: Sequence[float]) -> None:
    for t in fault_times_s:
        ax.axvline(t, label="_fault", **_FAULT_STYLE)


def figure_title(fig: Figure, text: str, name: str | None) -> None:
    fig.suptitle(text if not name else f"{name}: {text}")


def position_series(series: FlightSeries) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(reference, truth, error) per thesis axis X, Y, Z (m), as drawn by :func:`xyz_figure`.

    The reference and the error are NaN where the vehicle was not flying.
    """
    sign = np.array([1.0, 1.0, -1.0])  # x_NED, y_NED, altitude = -z_NED
    ref = _only_flying(series.ref_pos_ned * sign, series.flying)
    truth = series.pos_ned * sign
    err = ref - truth
    return {axis: (ref[:, i], truth[:, i], err[:, i]) for i, axis in enumerate("XYZ")}


def attitude_series(series: FlightSeries) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(reference, truth, error) in degrees for roll, pitch, yaw, as drawn by :func:`rpy_figure`.

    The reference and the error are NaN where the vehicle was not flying; errors are wrapped.
    """
    ref_rad = _only_flying(series.ref_euler_rad, series.flying)
    err = np.degrees(wrap_pi_array(ref_rad - series.euler_rad))
    ref, truth = np.degrees(ref_rad), np.degrees(series.euler_rad)
    return {axis: (ref[:, i], truth[:, i], err[:, i])
            for i, axis in enumerate(("roll", "pitch", "yaw"))}


@figure("trajectory", "trajectory (Fig. 7.3)")
def trajectory_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figure 7.3: the reference and the flown path, in 3-D (left) and from above (right).

    Both panels use east (y_NED) horizontally and north (x_NED) in depth or vertically, so
    that the 3-D panel (east, north, altitude) is right-handed and the top view reads as a
    map. The reference is drawn over the flying samples only.
    """
    fig = new_figure(11.0, 4.8)
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    top = fig.add_subplot(1, 2, 2)
    ref = series.ref_pos_ned[series.flying]
    pos = series.pos_ned
    ax3.plot(ref[:, 1], ref[:, 0], -ref[:, 2], label="reference", **_REF_STYLE)
    ax3.plot(pos[:, 1], pos[:, 0], -pos[:, 2], label="flown", **_TRUTH_STYLE)
    ax3.set_xlabel("east y (m)")
    ax3.set_ylabel("north x (m)")
    ax3.set_zlabel("altitude Z = -z (m)")
    ax3.legend(loc="upper left")
    top.plot(ref[:, 1], ref[:, 0], label="reference", **_REF_STYLE)
    top.plot(pos[:, 1], pos[:, 0], label="flown", **_TRUTH_STYLE)
    top.set_xlabel("east y (m)")
    top.set_ylabel("north x (m)")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True, alpha=0.3)
    top.legend(loc="best")
    top.set_title("seen from above")
    figure_title(fig, "trajectory (thesis Figure 7.3)", name)
    return fig


@dataclass(frozen=True)
class _TrackingLabels:
    values: tuple[str, str, str]  # y labels of the top row
    errors: tuple[str, str, str]  # y labels of the error row
    title: str


_XYZ = _TrackingLabels(("X = x north (m)", "Y = y east (m)", "Z = -z altitude (m)"),
                       ("e_X (m)", "e_Y (m)", "e_Z (m)"),
                       "position and tracking error (thesis Figures 7.4-7.6)")
_RPY = _TrackingLabels(("roll (deg)", "pitch (deg)", "yaw (deg)"),
                       ("e_roll (deg)", "e_pitch (deg)", "e_yaw (deg)"),
                       "attitude and tracking error (thesis Figures 7.7-7.8)")


def _tracking_figure(series: FlightSeries,
                     data: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
                     labels: _TrackingLabels, name: str | None) -> Figure:
    """Three panels of (reference, truth) over their errors, fault onsets marked."""
    fig = new_figure(12.0, 5.6)
    axes = fig.subplots(2, 3, sharex=True)
    t = series.time_s
    faults = series.fault_onsets_s()
    for col, (axis, (ref, truth, err)) in enumerate(data.items()):
        top, bottom = axes[0, col], axes[1, col]
        top.plot(t, ref, label="reference", **_REF_STYLE)
        top.plot(t, truth, label="flown", **_TRUTH_STYLE)
        top.set_ylabel(labels.values[col])
        top.set_title(axis)
        bottom.plot(t, err, label="error", **_ERROR_STYLE)
        bottom.set_ylabel(labels.errors[col])
        bottom.set_xlabel("time (s)")
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3)
            mark_faults(ax, faults)
    axes[0, 0].legend(loc="best")
    figure_title(fig, labels.title, name)
    return fig


@figure("xyz", "X, Y, Z and errors (Fig. 7.4-7.6)")
def xyz_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figures 7.4-7.6: X, Y, Z (m) against their reference (top), errors below (bottom)."""
    return _tracking_figure(series, position_series(series), _XYZ, name)


@figure("rpy", "roll, pitch, yaw and errors (Fig. 7.7-7.8)")
def rpy_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figures 7.7-7.8: roll, pitch, yaw (deg) against their reference, errors below."""
    return _tracking_figure(series, attitude_series(series), _RPY, name)


@figure("pwm", "motor PWM (Fig. 7.9)")
def pwm_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figure 7.9: the PWM commanded to motors 1..4 (unit duty), one panel each."""
    fig = new_figure(8.0, 7.0)
    axes = fig.subplots(4, 1, sharex=True)
    faults = series.fault_onsets_s()
    for j, ax in enumerate(axes):
        ax.plot(series.pwm_time_s, series.pwm[:, j], label=f"motor {j + 1}",
                color=_MOTOR_COLORS[j], linewidth=0.9)
        ax.set_ylabel(f"u{j + 1} (PWM)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower left")
        mark_faults(ax, faults)
    axes[-1].set_xlabel("time (s)")
    figure_title(fig, "motor commands (thesis Figure 7.9)", name)
    return fig


@figure("loe", "effectiveness, injected and estimated (Fig. 6.2)")
def loe_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figure 6.2: per-motor loss of effectiveness, injected (truth) against estimated.

    Injected: the LOE in force on the truth samples (NaN, a gap, for lock or hard-over);
    estimated: at its own times (no line without an estimate).
    """
    fig = new_figure(10.0, 6.0)
    axes = fig.subplots(2, 2, sharex=True, sharey=True)
    faults = series.fault_onsets_s()
    for j, ax in enumerate(axes.flat):
        ax.plot(series.time_s, series.loe_injected[:, j], label="injected", **_REF_STYLE)
        ax.plot(series.loe_estimate_time_s[j], series.loe_estimate[j], label="estimated",
                **_EST_STYLE)
        ax.set_title(f"motor {j + 1}")
        ax.set_ylabel("loss of effectiveness")
        ax.grid(True, alpha=0.3)
        mark_faults(ax, faults)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    axes[0, 0].set_ylim(bottom=-0.05)
    axes[0, 0].legend(loc="upper left")
    figure_title(fig, "effectiveness, injected and estimated (thesis Figure 6.2)", name)
    return fig


def figure_kinds() -> tuple[str, ...]:
    """Every registered figure kind, in the order :func:`save_figures` writes them."""
    return tuple(FIGURES)


def make_figures(series: FlightSeries, name: str | None = None) -> dict[str, Figure]:
    """Every registered figure of one flight, by kind."""
    return {kind: entry.draw(series, name) for kind, entry in FIGURES.items()}


def save_figures(series: FlightSeries, out_dir: str | Path, *, name: str | None = None,
                 formats: Sequence[str] = FORMATS, dpi: float = 100.0,
                 prefix: str = "",
                 on_figure: Callable[[str], None] | None = None) -> dict[str, list[Path]]:
    """Draw every registered figure and write each as ``out_dir/{prefix}{kind}.{format}``.

    Parameters
    ----------
    series : FlightSeries
        The flight.
    out_dir : path
        Directory (created if missing).
    name : str, optional
        Run name, put in each figure's title.
    formats : sequence of str
        Any matplotlib output format; PNG and PDF by default.
    dpi : float
        Resolution of raster formats, dots per inch.
    prefix : str
        Prepended to each file name.
    on_figure : callable or None
        Called with each kind once its files are written (a progress counter).

    Returns
    -------
    dict
        Kind -> the paths written, in ``formats`` order.
    """
    out = Path(out_dir)
    paths: dict[str, list[Path]] = {}
    for kind, entry in FIGURES.items():
        paths[kind] = save_figure(entry.draw(series, name), out / f"{prefix}{kind}",
                                  formats=formats, dpi=dpi)
        if on_figure is not None:
            on_figure(kind)
    return paths


def save_figure(fig: Figure, stem: str | Path, *, formats: Sequence[str] = FORMATS,
                dpi: float = 100.0) -> list[Path]:
    """Write ``fig`` as ``{stem}.{format}`` for each format (the folder is created), as
    reproducible files (no creation date); returns the paths in ``formats`` order.

    The layout worked out for the first format is kept for the others (the figure's layout
    engine is set again afterwards): working out the constrained layout again took half of
    each further file's writing time, for the same axes positions."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    engine = fig.get_layout_engine()
    try:
        for fmt in formats:
            path = stem.with_name(f"{stem.name}.{fmt}")
            fig.savefig(path, dpi=dpi, metadata=_metadata(fmt))
            paths.append(path)
            fig.set_layout_engine("none")  # the axes keep the positions just laid out
    finally:
        fig.set_layout_engine(engine)
    return paths


def _metadata(fmt: str) -> dict[str, str | None]:
    """Reproducible files: no creation date in PDF, a fixed Software tag in PNG."""
    if fmt == "pdf":
        return {"CreationDate": None, "Creator": "quadftc"}
    if fmt == "png":
        return {"Software": "quadftc (matplotlib)"}
    return {}
