"""Thesis-style figures of a headless flight: checked through matplotlib's objects (axes,
labels, line data), not pixels, and written headless as PNG and PDF. The same figures of a
ground-station flight are checked in tests/gcs/test_gcs_recording.py and
tests/integration/test_gcs_views.py."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import cast

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.lines import Line2D
from mpl_toolkits.mplot3d.art3d import Line3D
from mpl_toolkits.mplot3d.axes3d import Axes3D

from flightdata.figures import (
    FIGURES,
    figure,
    figure_kinds,
    loe_figure,
    make_figures,
    pwm_figure,
    rpy_figure,
    save_figures,
    trajectory_figure,
    xyz_figure,
)
from flightdata.geometry import wrap_pi_array
from flightdata.report import section_lines
from flightdata.series import FlightSeries
from flightdata.thesis import thesis_tables
from sim.runner import FlightResult, fly
from sim.scenario import load_scenario
from sim.thesis_report import render_markdown
from sim.world.fault_types import ActuatorFault

REPO = Path(__file__).resolve().parents[2]
FIGURE_KINDS = figure_kinds()
FAULT_AT_S = 6.0  # s, in the hover after the 5 s take-off


@pytest.fixture(scope="module")
def flight() -> FlightResult:
    scenario = replace(load_scenario("lqg_abdob_loe"), duration_s=8.0,
                       faults=(ActuatorFault(motor=3, kind="loe", start_s=FAULT_AT_S, loe=0.3),))
    return fly(scenario)


def data_lines(ax: Axes) -> dict[str, Line2D]:
    """Lines in the legend's sense (helper lines have labels starting with '_')."""
    lines = [ln for ln in ax.get_lines() if not str(ln.get_label()).startswith("_")]
    out = {str(ln.get_label()): ln for ln in lines}
    assert len(out) == len(lines), "two data lines share a label"
    return out


def fault_markers(ax: Axes) -> list[float]:
    return [float(np.asarray(ln.get_xdata())[0]) for ln in ax.get_lines()
            if ln.get_label() == "_fault"]


def ydata(line: Line2D) -> np.ndarray:
    return np.asarray(line.get_ydata(), dtype=float)


def assert_line(line: Line2D, x: np.ndarray, y: np.ndarray) -> None:
    xy = np.asarray(line.get_xydata())
    np.testing.assert_array_equal(xy[:, 0], x)
    np.testing.assert_array_equal(xy[:, 1], y)  # NaN where not flying, on both sides


def test_fault_onsets_come_from_the_started_fault_records(flight: FlightResult) -> None:
    assert [f.time_s for f in flight.faults if f.action == "started"] == [FAULT_AT_S]
    assert flight.log.fault_onsets_s() == [FAULT_AT_S]  # what the figures mark


def test_xyz_figure_has_each_axis_over_its_error(flight: FlightResult) -> None:
    log = flight.log
    fig = xyz_figure(log, "short")  # fault markers from the events
    axes = fig.axes
    assert len(axes) == 6
    top, bottom = axes[:3], axes[3:]
    assert [ax.get_title() for ax in top] == ["X", "Y", "Z"]
    assert [ax.get_ylabel() for ax in top] == ["X = x north (m)", "Y = y east (m)",
                                               "Z = -z altitude (m)"]
    assert [ax.get_ylabel() for ax in bottom] == ["e_X (m)", "e_Y (m)", "e_Z (m)"]
    assert all(ax.get_xlabel() == "time (s)" for ax in bottom)
    ref = np.where(log.flying[:, None], log.ref_pos_ned, np.nan) * [1.0, 1.0, -1.0]
    truth = log.pos_ned * [1.0, 1.0, -1.0]
    for i in range(3):
        lines = data_lines(top[i])
        assert set(lines) == {"reference", "flown"}
        assert_line(lines["reference"], log.time_s, ref[:, i])
        assert_line(lines["flown"], log.time_s, truth[:, i])
        errors = data_lines(bottom[i])
        assert set(errors) == {"error"}
        assert_line(errors["error"], log.time_s, ref[:, i] - truth[:, i])
        assert fault_markers(top[i]) == fault_markers(bottom[i]) == [FAULT_AT_S]
    # altitude is up-positive: just before the fault the vehicle hovers 0.6 m above home
    # (tracking errors in the hover are millimetres; 3 cm leaves room for the wind)
    before = np.searchsorted(log.time_s, FAULT_AT_S) - 1
    assert ydata(data_lines(top[2])["flown"])[before] == pytest.approx(0.6, abs=0.03)


def test_rpy_figure_is_in_degrees_with_wrapped_errors(flight: FlightResult) -> None:
    log = flight.log
    fig = rpy_figure(replace(log, fault_times_s=None))  # as if no fault events were known
    assert len(fig.axes) == 6
    assert [ax.get_title() for ax in fig.axes[:3]] == ["roll", "pitch", "yaw"]
    assert [ax.get_ylabel() for ax in fig.axes[3:]] == ["e_roll (deg)", "e_pitch (deg)",
                                                        "e_yaw (deg)"]
    ref_rad = np.where(log.flying[:, None], log.ref_euler_rad, np.nan)
    for i in range(3):
        lines = data_lines(fig.axes[i])
        assert_line(lines["flown"], log.time_s, np.degrees(log.euler_rad[:, i]))
        assert_line(lines["reference"], log.time_s, np.degrees(ref_rad[:, i]))
        err = np.degrees(wrap_pi_array(ref_rad[:, i] - log.euler_rad[:, i]))
        assert_line(data_lines(fig.axes[3 + i])["error"], log.time_s, err)
    # without events the fault markers come from the change of the injected LOE
    assert fault_markers(fig.axes[0]) == [pytest.approx(FAULT_AT_S, abs=0.011)]


def test_pwm_figure_has_one_panel_per_motor(flight: FlightResult) -> None:
    log = flight.log
    fig = pwm_figure(log)
    assert len(fig.axes) == 4
    for j, ax in enumerate(fig.axes):
        lines = data_lines(ax)
        assert list(lines) == [f"motor {j + 1}"]
        assert_line(lines[f"motor {j + 1}"], log.time_s, log.pwm[:, j])
        assert ax.get_ylabel() == f"u{j + 1} (PWM)"
    assert fig.axes[-1].get_xlabel() == "time (s)"


def test_loe_figure_shows_injected_against_estimated(flight: FlightResult) -> None:
    log = flight.log
    fig = loe_figure(log)
    assert len(fig.axes) == 4
    assert [ax.get_title() for ax in fig.axes] == [f"motor {m}" for m in (1, 2, 3, 4)]
    for j, ax in enumerate(fig.axes):
        lines = data_lines(ax)
        assert set(lines) == {"injected", "estimated"}
        assert_line(lines["injected"], log.time_s, log.loe_injected[:, j])
        assert_line(lines["estimated"], log.time_s, log.loe_estimate[j])
    injected = ydata(data_lines(fig.axes[2])["injected"])
    assert injected.max() == 0.3 and ydata(data_lines(fig.axes[0])["injected"]).max() == 0


def test_trajectory_figure_has_a_3d_and_a_top_view(flight: FlightResult) -> None:
    log = flight.log
    fig = trajectory_figure(log)
    ax3, top = cast(Axes3D, fig.axes[0]), fig.axes[1]
    assert ax3.name == "3d" and top.name == "rectilinear"
    assert (ax3.get_xlabel(), ax3.get_ylabel(), ax3.get_zlabel()) == (
        "east y (m)", "north x (m)", "altitude Z = -z (m)")
    flown = cast(Line3D, {ln.get_label(): ln for ln in ax3.get_lines()}["flown"])
    east, north, alt = flown.get_data_3d()
    np.testing.assert_array_equal(east, log.pos_ned[:, 1])
    np.testing.assert_array_equal(north, log.pos_ned[:, 0])
    np.testing.assert_array_equal(alt, -log.pos_ned[:, 2])
    lines = data_lines(top)
    assert set(lines) == {"reference", "flown"}
    ref = log.ref_pos_ned[log.flying]
    assert_line(lines["reference"], ref[:, 1], ref[:, 0])
    assert (top.get_xlabel(), top.get_ylabel()) == ("east y (m)", "north x (m)")


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_save_figures_writes_non_empty_png_and_pdf(flight: FlightResult, tmp_path: Path) -> None:
    written = save_figures(flight.log, tmp_path / "figs", name="short")
    assert list(written) == list(FIGURE_KINDS)
    for kind, paths in written.items():
        assert [p.name for p in paths] == [f"{kind}.png", f"{kind}.pdf"]
        png, pdf = (p.read_bytes() for p in paths)
        assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 10_000
        assert pdf.startswith(b"%PDF") and len(pdf) > 5_000
    assert make_figures(flight.log)["xyz"].get_suptitle().endswith("(thesis Figures 7.4-7.6)")


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_figures_are_drawn_without_a_display_or_pyplot(tmp_path: Path) -> None:
    code = (
        "import sys\n"
        "from dataclasses import replace\n"
        "from flightdata.figures import save_figures\n"
        "from sim.runner import fly\n"
        "from sim.scenario import load_scenario\n"
        "r = fly(replace(load_scenario('baseline'), duration_s=1.0))\n"
        f"save_figures(r.log, {str(tmp_path)!r}, formats=('png',))\n"
        "import matplotlib\n"
        "print(matplotlib.get_backend())\n"
        "if 'matplotlib.pyplot' in sys.modules:  # filterpy and python-control import it\n"
        "    assert sys.modules['matplotlib.pyplot'].get_fignums() == [], 'figures leaked'\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY",
                                                            "MPLBACKEND")}
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().lower() == "agg"  # no display: the non-interactive backend
    assert len(list(tmp_path.glob("*.png"))) == len(FIGURE_KINDS)


def test_report_embeds_the_figures_next_to_the_table(flight: FlightResult) -> None:
    metrics = dict(flight.metrics, name="lqg_abdob_loe", figures={
        kind: [f"figures/lqg_abdob_loe/{kind}.png", f"figures/lqg_abdob_loe/{kind}.pdf"]
        for kind in FIGURE_KINDS})
    markdown = render_markdown({"lqg_abdob_loe": metrics}, thesis_tables())
    lines = markdown.splitlines()
    table_end = max(i for i, line in enumerate(lines) if line.startswith("| effort |"))
    images = [i for i, line in enumerate(lines)
              if line.startswith("![lqg_abdob_loe: ") and "](figures/lqg_abdob_loe/" in line]
    assert len(images) == len(FIGURE_KINDS)
    assert all(0 < i - table_end <= len(FIGURE_KINDS) + 1 for i in images)
    assert "[xyz](figures/lqg_abdob_loe/xyz.pdf)" in markdown
    without = render_markdown({"lqg_abdob_loe": flight.metrics}, thesis_tables())
    assert "![" not in without


def test_a_registered_figure_is_drawn_saved_and_embedded(flight: FlightResult,
                                                         tmp_path: Path) -> None:
    from matplotlib.figure import Figure

    @figure("altitude", "altitude above home")
    def altitude_figure(series: FlightSeries, name: str | None = None) -> Figure:
        fig = Figure()
        fig.subplots().plot(series.time_s, -series.pos_ned[:, 2], label="flown")
        return fig

    try:
        assert figure_kinds() == (*FIGURE_KINDS, "altitude")
        assert list(make_figures(flight.log)) == [*FIGURE_KINDS, "altitude"]
        written = save_figures(flight.log, tmp_path, formats=("png",))
        assert written["altitude"] == [tmp_path / "altitude.png"]
        assert written["altitude"][0].read_bytes().startswith(b"\x89PNG")
        figures = {kind: [f"figures/{kind}.png", f"figures/{kind}.pdf"] for kind in written}
        # both reports draw every registered kind, with its caption
        thesis = render_markdown({"lqg_abdob_loe": dict(flight.metrics, figures=figures)},
                                 thesis_tables())
        assert "![lqg_abdob_loe: altitude above home](figures/altitude.png)" in thesis
        assert "[altitude](figures/altitude.pdf)" in thesis
        assert section_lines(figures)[-6:] == [
            "## altitude above home", "", "![altitude above home](figures/altitude.png)", "",
            "PDF: [altitude](figures/altitude.pdf)", ""]
    finally:
        del FIGURES["altitude"]
    assert figure_kinds() == FIGURE_KINDS
    with pytest.raises(ValueError, match="'xyz' is registered twice"):
        figure("xyz", "again")(xyz_figure)
