"""Chi-square tail quantiles for the innovation gates, in plain ``math`` (no scipy at start-up).

The survival function of a chi-square variable with ``k`` degrees of freedom has closed forms
(Abramowitz & Stegun 26.4.4-26.4.5)::

    k even:  Q(x) = exp(-x/2) sum_{j=0}^{k/2-1} (x/2)^j / j!
    k odd:   Q(x) = erfc(sqrt(x/2))
                    + sqrt(2x/pi) exp(-x/2) sum_{j=1}^{(k-1)/2} x^{j-1} / (1 3 ... (2j-1))

:func:`chi_square_isf` inverts it by bisection to the last bit (it is strictly decreasing).
"""

from __future__ import annotations

import functools
import math

__all__ = ["chi_square_isf", "chi_square_sf"]


def chi_square_sf(x: float, dof: int) -> float:
    """``P(X > x)`` for ``X`` chi-square with ``dof`` degrees of freedom (module formulas)."""
    if dof < 1:
        raise ValueError(f"dof = {dof!r}: must be >= 1")
    if x <= 0.0:
        return 1.0
    half = 0.5 * x
    if dof % 2 == 0:
        # exp(-x/2) sum_{j<k/2} (x/2)^j / j!
        term, total = 1.0, 1.0
        for j in range(1, dof // 2):
            term *= half / j
            total += term
        return math.exp(-half) * total
    # erfc(sqrt(x/2)) + sqrt(2x/pi) exp(-x/2) sum_{j=1}^{(k-1)/2} x^{j-1} / (2j-1)!!
    term, total = 1.0, 0.0
    for j in range(1, (dof - 1) // 2 + 1):
        term = 1.0 if j == 1 else term * x / (2 * j - 1)
        total += term
    return math.erfc(math.sqrt(half)) + math.sqrt(2.0 * x / math.pi) * math.exp(-half) * total


@functools.lru_cache(maxsize=256)
def chi_square_isf(probability: float, dof: int) -> float:
    """The ``x`` with ``P(X > x) = probability`` (scipy's ``chdtri(dof, probability)``);
    remembered by its arguments (every estimator built asks for the same few gates)."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"probability = {probability!r}: must be in (0, 1)")
    low, high = 0.0, 1.0
    while chi_square_sf(high, dof) > probability:
        low, high = high, 2.0 * high
    for _ in range(200):  # bisection down to adjacent floats
        mid = 0.5 * (low + high)
        if mid in (low, high):
            break
        if chi_square_sf(mid, dof) > probability:
            low = mid
        else:
            high = mid
    return high
