"""Figures of a fault's effect (flightdata.fault_figures): the spin measures against a known
spin, the comparison drawn from both flights' data; checked through matplotlib's objects."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from flightdata.fault_figures import comparison_figure, spin_figure, spin_series
from flightdata.series import FlightSeries
from sim.scenario_cli import main


def spinning_series(rate_rad_s: float, tilt_deg: float, n: int = 1000,
                    dt_s: float = 0.01) -> FlightSeries:
    """A hover at 0.6 m spinning at ``rate_rad_s`` with the body z axis tilted ``tilt_deg``
    (all of it in roll), yaw wrapping round many times."""
    t = np.arange(n) * dt_s
    pos = np.zeros((n, 3))
    pos[:, 2] = -0.6
    euler = np.zeros((n, 3))
    euler[:, 0] = math.radians(tilt_deg)
    euler[:, 2] = (rate_rad_s * t + math.pi) % (2.0 * math.pi) - math.pi
    flying = np.ones(n, dtype=bool)
    return FlightSeries(
        time_s=t, flying=flying, pos_ned=pos, euler_rad=euler, ref_pos_ned=pos.copy(),
        ref_euler_rad=euler.copy(), pwm_time_s=t, pwm=np.full((n, 4), 0.02), pwm_max=0.05,
        loe_estimate_time_s=(t,) * 4, loe_estimate=(np.zeros(n),) * 4,
        loe_injected=np.zeros((n, 4)), fault_times_s=(2.0,))


def test_spin_rate_and_tilt_of_a_known_spin() -> None:
    # -19.44 rad/s is 0.19 rad a sample at 100 Hz: yaw wraps every 32 samples
    rate, tilt = spin_series(spinning_series(-19.44, 8.5))
    np.testing.assert_allclose(rate, -19.44, rtol=1e-9)  # unwrapped, not the wrap jumps
    np.testing.assert_allclose(tilt, 8.5, rtol=1e-9)


def test_spin_figure_draws_the_rate_the_tilt_and_the_position() -> None:
    fig = spin_figure(spinning_series(12.0, 5.0), "hover")
    rate_ax, tilt_ax, pos_ax = fig.axes
    np.testing.assert_allclose(rate_ax.lines[0].get_ydata(), 12.0, rtol=1e-9)
    np.testing.assert_allclose(tilt_ax.lines[0].get_ydata(), 5.0, rtol=1e-9)
    z_truth = pos_ax.lines[4].get_ydata()  # X, X ref, Y, Y ref, Z: altitude up-positive
    np.testing.assert_allclose(z_truth, 0.6)
    assert fig.get_suptitle() == "hover: spin phase (yaw given up)"
    assert [line.get_xdata()[0] for line in rate_ax.lines[1:]] == [2.0]  # the fault marker


def test_comparison_figure_draws_each_flight_against_the_first_reference() -> None:
    calm, pushed = spinning_series(0.0, 0.0), spinning_series(0.0, 0.0)
    pushed.pos_ned[500:, 2] = -0.5  # 10 cm lower after 5 s
    fig = comparison_figure({"passive": pushed, "active": calm})
    z_ax = fig.axes[2]
    labels = [line.get_label() for line in z_ax.lines]
    assert labels[:3] == ["reference", "passive", "active"]
    np.testing.assert_allclose(z_ax.lines[1].get_ydata()[500:], 0.5)
    np.testing.assert_allclose(z_ax.lines[2].get_ydata(), 0.6)


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_compare_flies_both_and_writes_the_figure(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", "short_square", "short_square", "--seed", "2",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.count("short_square: landed") == 2
    assert (tmp_path / "compare.png").stat().st_size > 0
    assert not list(tmp_path.glob("*_spin.*"))  # no spin in a healthy flight


def test_compare_refuses_an_unknown_scenario_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", "short_square", "no_such_flight", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no_such_flight" in err[0]
