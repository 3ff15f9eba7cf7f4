"""Figures of a fault's effect: one flight against another through the fault (passive against
active fault-tolerant control), and the spin phase of a flight that gave up yaw.

Both draw on the flights' :class:`~flightdata.series.FlightSeries` (the headless runner's or the
ground station's) with the conventions of :mod:`flightdata.figures` (X north, Y east, Z altitude;
dotted lines at the faults' onsets).

Spin: the yaw rate is the time derivative of the unwrapped true yaw (rad/s, ZYX Euler angles:
a good measure of the spin while roll and pitch stay small), and the tilt of the body z axis
from the vertical is ``acos(cos(roll) cos(pitch))`` (deg): in relaxed hover the primary axis
stands vertical and the thrust axis circles it at a constant tilt (``docs/rotor-loss.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from flightdata.figures import figure_title, mark_faults, new_figure, position_series
from flightdata.series import FlightSeries

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["comparison_figure", "spin_figure", "spin_series"]


def spin_series(series: FlightSeries) -> tuple[np.ndarray, np.ndarray]:
    """Yaw rate (rad/s, at the samples' times) and tilt of the body z axis from the vertical
    (deg) of a flight (module docstring)."""
    yaw = np.unwrap(series.euler_rad[:, 2])
    rate = np.gradient(yaw, series.time_s) if len(yaw) > 1 else np.zeros_like(yaw)
    roll, pitch = series.euler_rad[:, 0], series.euler_rad[:, 1]
    tilt = np.degrees(np.arccos(np.clip(np.cos(roll) * np.cos(pitch), -1.0, 1.0)))
    return rate, tilt


def comparison_figure(flights: dict[str, FlightSeries], name: str | None = None) -> Figure:
    """Position X, Y and altitude Z of each flight (label -> series) against time, the
    first flight's reference dashed, the first flight's fault onsets dotted: how far each
    configuration was pushed off its track by the same faults."""
    fig = new_figure(8.0, 7.0)
    axes = fig.subplots(3, 1, sharex=True)
    first = next(iter(flights.values()))
    ref = position_series(first)
    labels = ("X = x north (m)", "Y = y east (m)", "Z = altitude (m)")
    for i, axis in enumerate("XYZ"):
        ax = axes[i]
        ax.plot(first.time_s, ref[axis][0], "k--", linewidth=0.8, label="reference")
        for label, series in flights.items():
            ax.plot(series.time_s, position_series(series)[axis][1], linewidth=1.0, label=label)
        mark_faults(ax, first.fault_onsets_s())
        ax.set_ylabel(labels[i])
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    figure_title(fig, "position through the faults, " + " against ".join(flights), name)
    return fig


def spin_figure(series: FlightSeries, name: str | None = None) -> Figure:
    """The spin phase: yaw rate (rad/s), tilt of the body z axis (deg), and the horizontal
    and vertical position against their references (m)."""
    rate, tilt = spin_series(series)
    pos = position_series(series)
    fig = new_figure(8.0, 7.0)
    axes = fig.subplots(3, 1, sharex=True)
    t = series.time_s
    axes[0].plot(t, rate, linewidth=1.0)
    axes[0].set_ylabel("yaw rate (rad/s)")
    axes[1].plot(t, tilt, linewidth=1.0)
    axes[1].set_ylabel("body z tilt (deg)")
    for axis, style in (("X", "tab:blue"), ("Y", "tab:orange"), ("Z", "tab:green")):
        axes[2].plot(t, pos[axis][1], color=style, linewidth=1.0, label=axis)
        axes[2].plot(t, pos[axis][0], color=style, linestyle="--", linewidth=0.8)
    axes[2].set_ylabel("position (m), reference dashed")
    axes[2].legend(loc="best", fontsize=8)
    for ax in axes:
        mark_faults(ax, series.fault_onsets_s())
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    figure_title(fig, "spin phase (yaw given up)", name)
    return fig
