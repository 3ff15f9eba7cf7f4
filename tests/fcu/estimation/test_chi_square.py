"""The innovation gates' chi-square quantiles against scipy's."""

from __future__ import annotations

import math

import pytest
from scipy.special import chdtr, chdtri

from fcu.estimation.chi_square import chi_square_isf, chi_square_sf


@pytest.mark.parametrize("dof", [1, 2, 3, 4, 5, 6, 9])
@pytest.mark.parametrize("x", [1e-4, 0.3, 1.0, 2.5, 7.0, 16.0, 40.0])
def test_survival_function_matches_scipy(dof, x):
    assert chi_square_sf(x, dof) == pytest.approx(1.0 - chdtr(dof, x), rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("dof", [1, 2, 3, 4, 5, 6, 9])
@pytest.mark.parametrize("probability", [1e-9, 1e-6, 1e-3, 0.01, 0.05, 0.5, 0.9])
def test_quantile_matches_scipy(dof, probability):
    assert chi_square_isf(probability, dof) == pytest.approx(chdtri(dof, probability), rel=1e-10)


def test_known_values():
    # the 95 % point of one degree of freedom is 1.96^2; two: -2 ln 0.05
    assert chi_square_isf(0.05, 1) == pytest.approx(1.959963984540054 ** 2, rel=1e-12)
    assert chi_square_isf(0.05, 2) == pytest.approx(-2.0 * math.log(0.05), rel=1e-12)


@pytest.mark.parametrize("probability", [0.0, 1.0, -0.1, math.nan])
def test_bad_probability_is_refused(probability):
    with pytest.raises(ValueError, match="probability"):
        chi_square_isf(probability, 2)


def test_bad_dof_is_refused():
    with pytest.raises(ValueError, match="dof"):
        chi_square_sf(1.0, 0)
