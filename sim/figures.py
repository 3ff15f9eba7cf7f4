"""Thesis-style figures of a headless flight, drawn headless with matplotlib (Agg).

One function per figure, each taking a :class:`sim.runner.FlightLog` and returning a
:class:`matplotlib.figure.Figure` (built without pyplot, so no display, no global state):

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
References and errors are drawn only over the ticks flown (``FlightLog.flying``): elsewhere
they are NaN, i.e. gaps. Fault onsets, when known, are dotted vertical lines.

Every data line carries a label (``"reference"``, ``"flown"``, ``"error"``, ``"motor 1"``,
``"injected"``, ``"estimated"``...); helper lines (fault markers, zero lines) have labels
starting with ``_``, matplotlib's convention for "not in the legend".

:func:`save_figures` writes them all as PNG and PDF and returns the paths.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from sim.metrics import wrap_angle_rad
from sim.runner import FlightLog

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


def fault_onsets_s(events: Iterable[tuple[float, str, str]]) -> list[float]:
    """Times (s) at which injected faults started acting, from ``FlightResult.events``."""
    return sorted({t for t, source, text in events
                   if source == "sim" and text.startswith("started:")})


def _loe_change_times_s(log: FlightLog) -> list[float]:
    """Times (s) at which the injected LOE of any motor changed (fallback fault markers)."""
    truth = np.nan_to_num(log.loe_true, nan=-1.0)
    if len(truth) < 2:
        return []
    changed = np.any(np.abs(np.diff(truth, axis=0)) > 1e-9, axis=1)
    return [float(t) for t in log.time_s[1:][changed]]


def _only_flying(values: np.ndarray, flying: np.ndarray) -> np.ndarray:
    out = np.array(values, dtype=float)
    out[~flying] = np.nan
    return out


def _mark_faults(ax: Axes, fault_times_s: Sequence[float]) -> None:
    for t in fault_times_s:
        ax.axvline(t, label="_fault", **_FAULT_STYLE)


def _title(fig: Figure, text: str, name: str | None) -> None:
    fig.suptitle(text if not name else f"{name}: {text}")


def position_series(log: FlightLog) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(reference, truth, error) per thesis axis X, Y, Z (m), as drawn by :func:`xyz_figure`.

    The reference and the error are NaN where the vehicle was not flying.
    """
    sign = np.array([1.0, 1.0, -1.0])  # x_NED, y_NED, altitude = -z_NED
    ref = _only_flying(log.ref_pos_ned * sign, log.flying)
    truth = log.pos_ned * sign
    err = ref - truth
    return {axis: (ref[:, i], truth[:, i], err[:, i]) for i, axis in enumerate("XYZ")}


def attitude_series(log: FlightLog) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(reference, truth, error) in degrees for roll, pitch, yaw, as drawn by :func:`rpy_figure`.

    The reference and the error are NaN where the vehicle was not flying; errors are wrapped.
    """
    ref_rad = _only_flying(log.ref_euler_rad, log.flying)
    err = np.degrees(wrap_angle_rad(ref_rad - log.euler_rad))
    ref, truth = np.degrees(ref_rad), np.degrees(log.euler_rad)
    return {axis: (ref[:, i], truth[:, i], err[:, i])
            for i, axis in enumerate(("roll", "pitch", "yaw"))}


def trajectory_figure(log: FlightLog, name: str | None = None) -> Figure:
    """Figure 7.3: the reference and the flown path, in 3-D (left) and from above (right).

    Both panels use east (y_NED) horizontally and north (x_NED) in depth or vertically, so
    that the 3-D panel (east, north, altitude) is right-handed and the top view reads as a
    map. The reference is drawn over the flying ticks only.
    """
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    top = fig.add_subplot(1, 2, 2)
    fly = log.flying
    ref = log.ref_pos_ned[fly]
    pos = log.pos_ned
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


def _tracking_figure(log: FlightLog,
                     series: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
                     labels: Sequence[str], error_labels: Sequence[str], title: str,
                     name: str | None, fault_times_s: Sequence[float]) -> Figure:
    fig = Figure(figsize=(12.0, 5.6), layout="constrained")
    axes = fig.subplots(2, 3, sharex=True)
    t = log.time_s
    for col, (axis, (ref, truth, err)) in enumerate(series.items()):
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
            _mark_faults(ax, fault_times_s)
    axes[0, 0].legend(loc="best")
    _title(fig, title, name)
    return fig


def xyz_figure(log: FlightLog, name: str | None = None,
               fault_times_s: Sequence[float] | None = None) -> Figure:
    """Figures 7.4-7.6: X, Y, Z (m) against their reference (top), errors below (bottom)."""
    faults = _loe_change_times_s(log) if fault_times_s is None else fault_times_s
    return _tracking_figure(log, position_series(log),
                            ("X = x north (m)", "Y = y east (m)", "Z = -z altitude (m)"),
                            ("e_X (m)", "e_Y (m)", "e_Z (m)"),
                            "position and tracking error (thesis Figures 7.4-7.6)", name,
                            faults)


def rpy_figure(log: FlightLog, name: str | None = None,
               fault_times_s: Sequence[float] | None = None) -> Figure:
    """Figures 7.7-7.8: roll, pitch, yaw (deg) against their reference, errors below."""
    faults = _loe_change_times_s(log) if fault_times_s is None else fault_times_s
    return _tracking_figure(log, attitude_series(log),
                            ("roll (deg)", "pitch (deg)", "yaw (deg)"),
                            ("e_roll (deg)", "e_pitch (deg)", "e_yaw (deg)"),
                            "attitude and tracking error (thesis Figures 7.7-7.8)", name,
                            faults)


def pwm_figure(log: FlightLog, name: str | None = None,
               fault_times_s: Sequence[float] | None = None) -> Figure:
    """Figure 7.9: the PWM commanded to motors 1..4 (unit duty), one panel each."""
    faults = _loe_change_times_s(log) if fault_times_s is None else fault_times_s
    fig = Figure(figsize=(8.0, 7.0), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True)
    for j, ax in enumerate(axes):
        ax.plot(log.time_s, log.pwm[:, j], label=f"motor {j + 1}", color=_MOTOR_COLORS[j],
                linewidth=0.9)
        ax.set_ylabel(f"u{j + 1} (PWM)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower left")
        _mark_faults(ax, faults)
    axes[-1].set_xlabel("time (s)")
    _title(fig, "motor commands (thesis Figure 7.9)", name)
    return fig


def loe_figure(log: FlightLog, name: str | None = None,
               fault_times_s: Sequence[float] | None = None) -> Figure:
    """Figure 6.2: per-motor loss of effectiveness, injected (truth) against the TSKF estimate.

    Lock and hard-over faults have no effectiveness (NaN in ``loe_true``): gaps.
    """
    faults = _loe_change_times_s(log) if fault_times_s is None else fault_times_s
    fig = Figure(figsize=(10.0, 6.0), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True, sharey=True)
    for j, ax in enumerate(axes.flat):
        ax.plot(log.time_s, log.loe_true[:, j], label="injected", **_REF_STYLE)
        ax.plot(log.time_s, log.loe_estimate[:, j], label="estimated", **_EST_STYLE)
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


def make_figures(log: FlightLog, name: str | None = None,
                 events: Iterable[tuple[float, str, str]] | None = None) -> dict[str, Figure]:
    """All :data:`FIGURE_KINDS` of one flight (fault markers from ``events`` when given)."""
    faults = fault_onsets_s(events) if events is not None else _loe_change_times_s(log)
    makers: dict[str, Callable[[], Figure]] = {
        "trajectory": lambda: trajectory_figure(log, name),
        "xyz": lambda: xyz_figure(log, name, faults),
        "rpy": lambda: rpy_figure(log, name, faults),
        "pwm": lambda: pwm_figure(log, name, faults),
        "loe": lambda: loe_figure(log, name, faults),
    }
    return {kind: makers[kind]() for kind in FIGURE_KINDS}


def save_figures(log: FlightLog, out_dir: str | Path, *, name: str | None = None,
                 events: Iterable[tuple[float, str, str]] | None = None,
                 formats: Sequence[str] = FORMATS, dpi: float = 100.0,
                 prefix: str = "") -> dict[str, list[Path]]:
    """Draw :data:`FIGURE_KINDS` and write each as ``out_dir/{prefix}{kind}.{format}``.

    Parameters
    ----------
    log : FlightLog
        The flight.
    out_dir : path
        Directory (created if missing).
    name : str, optional
        Scenario name, put in each figure's title.
    events : iterable of (time_s, source, text), optional
        ``FlightResult.events``: fault onsets are marked from them (else from LOE changes).
    formats : sequence of str
        Any matplotlib output format; PNG and PDF by default.
    dpi : float
        Resolution of raster formats, dots per inch.
    prefix : str
        Prepended to each file name.

    Returns
    -------
    dict
        Kind -> the paths written, in ``formats`` order.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, list[Path]] = {}
    for kind, fig in make_figures(log, name, events).items():
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
