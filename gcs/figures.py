"""Thesis-style figures of a flight from its telemetry, drawn headless (matplotlib, Agg).

The ground station's counterpart of ``sim/figures.py``, from the aligned arrays of
:meth:`gcs.analysis.FlightAnalyzer.series` (the ones behind the table) instead of the
simulator's log. Each function returns a :class:`matplotlib.figure.Figure` built without
pyplot (no display, no global state):

==============  ============================================================================
``trajectory``  Figure 7.3: reference and flown path, in 3-D and seen from above
``xyz``         Figures 7.4-7.6: X, Y, Z with reference, each with its error below
``rpy``         Figures 7.7-7.8: roll, pitch, yaw with reference, each with its error below
``pwm``         Figure 7.9: the commanded PWM of the four motors (SERVO_OUTPUT_RAW)
``loe``         Figure 6.2: loss of effectiveness per motor, injected (the simulator's
                STATUSTEXT) against estimated (NAMED_VALUE_FLOAT LOEn)
==============  ============================================================================

Axes follow the thesis: X = north = x_NED, Y = east = y_NED, Z = altitude = -z_NED. Errors are
reference minus truth in those axes; attitude errors are wrapped to +-180 deg. References and
errors are drawn over the samples the table counts (``FlightSeries.flying``) only, NaN (gaps)
elsewhere. Injection times are dotted vertical lines. Data lines are labelled ("reference",
"flown", "error", "motor 1", "injected", "estimated"); helper lines start with ``_``.
Times on the x axes are the vehicle clock, s.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from gcs.analysis import FlightSeries

__all__ = ["FIGURE_KINDS", "FORMATS", "attitude_series", "loe_figure", "make_figures",
           "position_series", "pwm_figure", "rpy_figure", "save_figures",
           "trajectory_figure", "xyz_figure"]

#: Figure kinds in the order :func:`save_figures` writes them.
FIGURE_KINDS = ("trajectory", "xyz", "rpy", "pwm", "loe")
#: Output formats of :func:`save_figures`.
FORMATS = ("png", "pdf")

_REF_STYLE: dict[str, Any] = {"color": "black", "linestyle": "--", "linewidth": 1.0}
_TRUTH_STYLE: dict[str, Any] = {"color": "tab:blue", "linewidth": 1.2}
_ERROR_STYLE: dict[str, Any] = {"color": "tab:red", "linewidth": 1.0}
_EST_STYLE: dict[str, Any] = {"color": "tab:orange", "linewidth": 1.2}
_MOTOR_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red")
_FAULT_STYLE: dict[str, Any] = {"color": "0.5", "linestyle": ":", "linewidth": 0.9}


def fault_times_s(series: FlightSeries) -> list[float]:
    """Vehicle times (s) at which an injected fault took effect (not the clearings)."""
    return sorted({i.time_s for i in series.injections if i.loe != 0.0})


def _only_flying(values: np.ndarray, flying: np.ndarray) -> np.ndarray:
    out = np.array(values, dtype=float)
    out[~flying] = np.nan
    return out


def _mark_faults(ax: Axes, times_s: Sequence[float]) -> None:
    for t in times_s:
        ax.axvline(t, label="_fault", **_FAULT_STYLE)


def _title(fig: Figure, text: str, name: str | None) -> None:
    fig.suptitle(text if not name else f"{name}: {text}")


def position_series(series: FlightSeries) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(reference, truth, error) per thesis axis X, Y, Z (m), as :func:`xyz_figure` draws them.

    Reference and error are NaN outside the flying samples.
    """
    sign = np.array([1.0, 1.0, -1.0])  # x_NED, y_NED, altitude = -z_NED
    ref = _only_flying(series.ref_pos_ned * sign, series.flying)
    truth = series.pos_ned * sign
    err = ref - truth
    return {axis: (ref[:, i], truth[:, i], err[:, i]) for i, axis in enumerate("XYZ")}


def attitude_series(series: FlightSeries) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(reference, truth, error) in degrees for roll, pitch, yaw, as :func:`rpy_figure` draws.

    Reference and error are NaN outside the flying samples; errors are wrapped to +-180.
    """
    ref_rad = _only_flying(series.ref_euler_rad, series.flying)
    err = np.degrees((ref_rad - series.euler_rad + np.pi) % (2.0 * np.pi) - np.pi)
    ref, truth = np.degrees(ref_rad), np.degrees(series.euler_rad)
    return {axis: (ref[:, i], truth[:, i], err[:, i])
            for i, axis in enumerate(("roll", "pitch", "yaw"))}


def trajectory_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figure 7.3: reference and flown path, 3-D (east, north, altitude) and from above."""
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
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
    _title(fig, "trajectory (thesis Figure 7.3)", name)
    return fig


def _tracking_figure(series: FlightSeries,
                     data: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
                     labels: Sequence[str], error_labels: Sequence[str], title: str,
                     name: str | None) -> Figure:
    fig = Figure(figsize=(12.0, 5.6), layout="constrained")
    axes = fig.subplots(2, 3, sharex=True)
    t = series.time_s
    faults = fault_times_s(series)
    for col, (axis, (ref, truth, err)) in enumerate(data.items()):
        top, bottom = axes[0, col], axes[1, col]
        top.plot(t, ref, label="reference", **_REF_STYLE)
        top.plot(t, truth, label="flown", **_TRUTH_STYLE)
        top.set_ylabel(labels[col])
        top.set_title(axis)
        bottom.plot(t, err, label="error", **_ERROR_STYLE)
        bottom.set_ylabel(error_labels[col])
        bottom.set_xlabel("time (s)")
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3)
            _mark_faults(ax, faults)
    axes[0, 0].legend(loc="best")
    _title(fig, title, name)
    return fig


def xyz_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figures 7.4-7.6: X, Y, Z (m) against their reference (top), errors (bottom)."""
    return _tracking_figure(series, position_series(series),
                            ("X = x north (m)", "Y = y east (m)", "Z = -z altitude (m)"),
                            ("e_X (m)", "e_Y (m)", "e_Z (m)"),
                            "position and tracking error (thesis Figures 7.4-7.6)", name)


def rpy_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figures 7.7-7.8: roll, pitch, yaw (deg) against their reference, errors below."""
    return _tracking_figure(series, attitude_series(series),
                            ("roll (deg)", "pitch (deg)", "yaw (deg)"),
                            ("e_roll (deg)", "e_pitch (deg)", "e_yaw (deg)"),
                            "attitude and tracking error (thesis Figures 7.7-7.8)", name)


def pwm_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figure 7.9: the PWM commanded to motors 1..4 (unit duty), one panel each."""
    fig = Figure(figsize=(8.0, 7.0), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True)
    faults = fault_times_s(series)
    for j, ax in enumerate(axes):
        ax.plot(series.pwm_time_s, series.pwm[:, j], label=f"motor {j + 1}",
                color=_MOTOR_COLORS[j], linewidth=0.9)
        ax.set_ylabel(f"u{j + 1} (PWM)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower left")
        _mark_faults(ax, faults)
    axes[-1].set_xlabel("time (s)")
    _title(fig, "motor commands (thesis Figure 7.9)", name)
    return fig


def loe_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """Figure 6.2: per-motor loss of effectiveness, injected against estimated.

    Injected: the LOE in force on the SIM_STATE samples (NaN, a gap, for lock or hard-over);
    estimated: NAMED_VALUE_FLOAT LOEn at its own times (no line without a TSKF).
    """
    fig = Figure(figsize=(10.0, 6.0), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True, sharey=True)
    faults = fault_times_s(series)
    for j, ax in enumerate(axes.flat):
        ax.plot(series.time_s, series.injected_loe[:, j], label="injected", **_REF_STYLE)
        ax.plot(series.loe_estimate_time_s[j], series.loe_estimate[j], label="estimated",
                **_EST_STYLE)
        ax.set_title(f"motor {j + 1}")
        ax.set_ylabel("loss of effectiveness")
        ax.grid(True, alpha=0.3)
        _mark_faults(ax, faults)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    axes[0, 0].set_ylim(bottom=-0.05)
    axes[0, 0].legend(loc="upper left")
    _title(fig, "effectiveness, injected and estimated (thesis Figure 6.2)", name)
    return fig


def make_figures(series: FlightSeries, name: str | None = None) -> dict[str, Figure]:
    """All :data:`FIGURE_KINDS` of one flight."""
    makers: dict[str, Callable[[FlightSeries, str | None], Figure]] = {
        "trajectory": trajectory_figure, "xyz": xyz_figure, "rpy": rpy_figure,
        "pwm": pwm_figure, "loe": loe_figure}
    return {kind: makers[kind](series, name) for kind in FIGURE_KINDS}


def save_figures(series: FlightSeries, out_dir: str | Path, *, name: str | None = None,
                 formats: Sequence[str] = FORMATS, dpi: float = 100.0,
                 prefix: str = "") -> dict[str, list[Path]]:
    """Draw :data:`FIGURE_KINDS` and write each as ``out_dir/{prefix}{kind}.{format}``.

    Returns
    -------
    dict
        Kind -> the paths written, in ``formats`` order (PNG, then PDF by default).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, list[Path]] = {}
    for kind, fig in make_figures(series, name).items():
        paths[kind] = []
        for fmt in formats:
            path = out / f"{prefix}{kind}.{fmt}"
            fig.savefig(path, dpi=dpi, metadata=_metadata(fmt))
            paths[kind].append(path)
    return paths


def _metadata(fmt: str) -> dict[str, str | None]:
    """Reproducible files: no creation date in PDF, a fixed Software tag in PNG."""
    if fmt == "pdf":
        return {"CreationDate": None, "Creator": "quadftc"}
    if fmt == "png":
        return {"Software": "quadftc (matplotlib)"}
    return {}
