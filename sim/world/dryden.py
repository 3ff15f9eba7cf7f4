"""The Dryden turbulence model of MIL-F-8785C (low altitude) and its exact discretisation.

The formulas and matrices :class:`sim.world.wind.DrydenWind` steps with (its module docstring
covers axes, floors and caching).

Model
-----
Low-altitude turbulence (h < 1000 ft) of MIL-F-8785C [1]_ sec. 3.7.2.3 / MIL-HDBK-1797 [2]_,
with ``h`` and the scale lengths in **feet** inside these formulas only::

    sigma_w = 0.1 W20                              W20: mean wind speed at 20 ft (6.1 m)
    sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4
    L_w = h,   L_u = L_v = h / (0.177 + 0.000823 h)^1.2                     (ft)

W20 is 15, 30 and 45 kt for light, moderate and severe turbulence ([1]_ fig. 11; the same
values as JSBSim's milspec table [5]_). The spectra are mapped to time by Taylor's frozen
turbulence hypothesis (Omega = omega / V) and realised by the forming filters ([2]_)::

    H_u(s) = sigma_u sqrt(2 L_u / (pi V)) / (1 + T_u s)                       T = L / V
    H_v(s) = sigma_v sqrt(L_v / (pi V)) (1 + sqrt(3) T_v s) / (1 + T_v s)^2
    H_w(s) = sigma_w sqrt(L_w / (pi V)) (1 + sqrt(3) T_w s) / (1 + T_w s)^2

The handbook's gains assume the "one-sided" convention in which the spectrum integrates to
the variance over 0 <= omega < inf; driven by *unit-intensity* white noise
(E[n(t) n(t')] = delta(t - t')) the gains carry an extra factor sqrt(pi). This module does not
use the gains at all: it builds each channel from a unit-variance process with the Dryden
autocorrelation and multiplies by sigma, so the steady-state variance is sigma^2 exactly and the
autocorrelations are the Dryden ones::

    R_u(tau) = sigma_u^2 exp(-|tau| / T_u)
    R_v(tau) = sigma_v^2 (1 - |tau| / (2 T_v)) exp(-|tau| / T_v)      (likewise w)

Exact discretisation
--------------------
Each channel runs in normalised time ``t / T``, in which it no longer depends on altitude or
airspeed; one step is ``h = dt / T`` normalised time units.

* u (first order): an Ornstein-Uhlenbeck process, exact for any step [3]_::

      x_{k+1} = exp(-h) x_k + sqrt(1 - exp(-2h)) n_k,         n_k ~ N(0, 1),  u = sigma_u x

* v and w (second order): the cascade of two unit lags driven by unit-intensity white noise,
  ``dx = A x dt + B dW`` with::

      A = [[-1, 0], [1, -1]],  B = [1, 0]^T,  C = [sqrt(3), 1 - sqrt(3)],  y = sigma C x

  whose transfer function is C (sI - A)^-1 B = (1 + sqrt(3) s) / (1 + s)^2, the Dryden form.
  Its stationary covariance solves A P + P A^T + B B^T = 0: P = [[1/2, 1/4], [1/4, 1/4]] and
  C P C^T = 3/2 + (1 - sqrt 3)^2 / 4 + sqrt(3) (1 - sqrt 3) / 2 = 1. The discrete model is
  x_{k+1} = Ad x_k + chol(Qd) n_k with Ad = expm(A h) and the exact process covariance
  Qd = int_0^h expm(A s) B B^T expm(A^T s) ds from Van Loan's method [4]_.

Because the discretisation is exact, Ad P Ad^T + Qd = P for every step: the output variance
does not depend on the step size. Because P is the same for every altitude and airspeed in
normalised coordinates, a change of altitude or airspeed only changes (Ad, Qd) and sigma; the
state stays in its stationary distribution. Every channel starts from a draw of P
(``reset``), so even a short run has the right variance.

References
----------
.. [1] MIL-F-8785C, "Military Specification: Flying Qualities of Piloted Airplanes",
   US Department of Defense, 5 Nov. 1980, sec. 3.7 (atmospheric disturbances).
.. [2] MIL-HDBK-1797, "Flying Qualities of Piloted Aircraft", US Department of Defense,
   19 Dec. 1997, sec. 4.9.
.. [3] D. T. Gillespie, "Exact numerical simulation of the Ornstein-Uhlenbeck process and its
   integral", Phys. Rev. E 54(2), 2084-2091, 1996.
.. [4] C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans.
   Automatic Control 23(3), 395-404, 1978.
.. [5] JSBSim, ``src/models/atmosphere/FGWinds.cpp`` (ttMilspec turbulence: "clip height
   functions at 10 ft"; Yeager, NASA CR-1998-206937).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from flightdata.design_cache import cached_design

FT_TO_M = 0.3048  # m per international foot (exact)
KT_TO_M_S = 1852.0 / 3600.0  # m/s per knot (exact: 1 nmi = 1852 m)
LOW_ALTITUDE_CEILING_M = 1000.0 * FT_TO_M  # m: top of MIL-F-8785C's low-altitude model
GRID_RATIO = 1.01  # v/w normalised steps dt/T are rounded to integer powers of this ratio
GRID_BLOCK = 32  # grid steps per block of coefficients kept on disk (a factor 1.37 of dt/T)
SQRT3 = math.sqrt(3.0)


def dryden_sigmas_m_s(w20_m_s: float, altitude_m: float) -> tuple[float, float, float]:
    """Low-altitude Dryden intensities (sigma_u, sigma_v, sigma_w), m/s.

    MIL-F-8785C sec. 3.7.2.3 [1]_: sigma_w = 0.1 W20 and
    sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4 with h in feet.

    Parameters
    ----------
    w20_m_s : float
        Wind speed at 20 ft, m/s.
    altitude_m : float
        Altitude above ground, m; must lie in (0, 304.8] (the caller clips).

    Returns
    -------
    tuple of float
        (sigma_u, sigma_v, sigma_w), m/s.
    """
    h_ft = altitude_m / FT_TO_M
    sigma_w = 0.1 * w20_m_s
    sigma_u = sigma_w / (0.177 + 0.000823 * h_ft) ** 0.4
    return sigma_u, sigma_u, sigma_w


def dryden_length_scales_m(altitude_m: float) -> tuple[float, float, float]:
    """Low-altitude Dryden scale lengths (L_u, L_v, L_w), m.

    MIL-F-8785C sec. 3.7.2.3 [1]_: L_w = h, L_u = L_v = h / (0.177 + 0.000823 h)^1.2 with h and
    L in feet; the result is converted back to metres.

    Parameters
    ----------
    altitude_m : float
        Altitude above ground, m; must lie in (0, 304.8] (the caller clips).

    Returns
    -------
    tuple of float
        (L_u, L_v, L_w), m.
    """
    h_ft = altitude_m / FT_TO_M
    l_u_ft = h_ft / (0.177 + 0.000823 * h_ft) ** 1.2
    return l_u_ft * FT_TO_M, l_u_ft * FT_TO_M, h_ft * FT_TO_M


def second_order_model() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normalised state-space Dryden v/w forming filter (A, B, C), time in units of T = L/V.

    Returns
    -------
    a : ndarray, shape (2, 2)
        [[-1, 0], [1, -1]]: two unit lags in cascade.
    b : ndarray, shape (2, 1)
        [1, 0]^T, input of unit-intensity white noise.
    c : ndarray, shape (1, 2)
        [sqrt(3), 1 - sqrt(3)]: C (sI - A)^-1 B = (1 + sqrt(3) s) / (1 + s)^2 and the
        stationary output variance is 1 (see the module docstring).
    """
    a = np.array([[-1.0, 0.0], [1.0, -1.0]])
    b = np.array([[1.0], [0.0]])
    c = np.array([[SQRT3, 1.0 - SQRT3]])
    return a, b, c


def van_loan(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of ``dx = A x dt + B dW`` (unit-intensity W) over one step.

    Van Loan's method [4]_: with M = [[-A, B B^T], [0, A^T]] dt and expm(M) = [[F11, F12],
    [0, F22]], Ad = F22^T and Qd = F22^T F12 = int_0^dt expm(A s) B B^T expm(A^T s) ds.
    Ad is taken from its own ``expm(A dt)``, not from F22: M holds both e^(-A dt) and
    e^(A dt), and for long steps (dt = 20 time constants) the scaling and squaring of M can
    spoil the small block (scipy 1.17: Ad 14 % and Qd 38x off at dt = 20; 1e-13 this way).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Drift matrix, 1/time.
    b : ndarray, shape (n, m)
        Noise input matrix.
    dt : float
        Step, same time unit as ``a``.

    Returns
    -------
    ad : ndarray, shape (n, n)
        State transition expm(A dt).
    qd : ndarray, shape (n, n)
        Discrete process-noise covariance (symmetrised).
    """
    from scipy.linalg import expm  # here, not at start-up: only turbulence rediscretises

    n = a.shape[0]
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a * dt
    m[:n, n:] = b @ b.T * dt
    m[n:, n:] = a.T * dt
    f = expm(m)
    ad = expm(a * dt)
    qd = ad @ f[:n, n:]
    return ad, 0.5 * (qd + qd.T)


def _chol2(q: np.ndarray) -> tuple[float, float, float]:
    """Lower Cholesky factor (l11, l21, l22) of a symmetric positive semi-definite 2x2 matrix."""
    q11, q21, q22 = float(q[0, 0]), float(q[1, 0]), float(q[1, 1])
    l11 = math.sqrt(q11)
    l21 = q21 / l11 if l11 > 0.0 else 0.0
    # max(., 0) only guards a last-bit negative from rounding; Van Loan's Qd is accurate to
    # machine precision elementwise for normalised steps from 1e-8 to 2
    # (tests/sim/world/test_wind.py).
    l22 = math.sqrt(max(q22 - l21 * l21, 0.0))
    return l11, l21, l22


def _second_order_step(h: float) -> tuple[float, ...]:
    """(a11, a12, a21, a22, l11, l21, l22) of the v/w channel for a normalised step ``h``."""
    a, b, _ = second_order_model()
    ad, qd = van_loan(a, b, h)
    return (float(ad[0, 0]), float(ad[0, 1]), float(ad[1, 0]), float(ad[1, 1]), *_chol2(qd))


@cached_design
def _second_order_grid_block(first_index: int) -> tuple[np.ndarray]:
    """:func:`_second_order_step` for the normalised steps ``GRID_RATIO ** index``, ``index``
    from ``first_index`` to ``first_index + GRID_BLOCK - 1``: one row each, shape
    (GRID_BLOCK, 7).

    Kept on disk like the autopilot's designs (:mod:`flightdata.design_cache`): a world whose
    wind stays on grid steps met before (the floors every world starts on, a calm flight's
    only ones) reads them back and never imports ``scipy.linalg``. A block rather than a
    point per file, because turbulence walks through hundreds of neighbouring points.
    """
    return (np.array([_second_order_step(GRID_RATIO**index)
                      for index in range(first_index, first_index + GRID_BLOCK)]),)


@functools.lru_cache(maxsize=4096)
def _second_order_step_on_grid(index: int) -> tuple[float, ...]:
    """:func:`_second_order_step` for the normalised step ``GRID_RATIO ** index``, memoised
    (the same floats, read from their cached block)."""
    offset = index % GRID_BLOCK
    row = _second_order_grid_block(index - offset)[0][offset]
    return tuple(float(v) for v in row)


def second_order_coefficients(h: float) -> tuple[tuple[float, ...], float]:
    """Discrete v/w coefficients for a normalised step near ``h`` and the step actually used.

    ``h`` is rounded to the nearest integer power of ``GRID_RATIO`` (a change of T = L/V of at
    most 0.5 %) so that the matrix exponentials of Van Loan's method (~0.3 ms) are
    computed once per grid point (then kept on disk, by blocks), not at every
    rediscretisation. The rounding does not touch the variance: Ad P Ad^T + Qd = P holds
    exactly for every step.

    Parameters
    ----------
    h : float
        Normalised step dt / T, > 0.

    Returns
    -------
    coefficients : tuple of float
        (a11, a12, a21, a22, l11, l21, l22): Ad = expm(A h_used) row-major and the lower
        Cholesky factor of Qd.
    h_used : float
        The grid step the coefficients belong to.
    """
    index = round(math.log(h) / math.log(GRID_RATIO))
    return _second_order_step_on_grid(index), GRID_RATIO**index


# Lower Cholesky factor of the normalised stationary covariance P = [[1/2, 1/4], [1/4, 1/4]].
P_CHOL = (math.sqrt(0.5), 0.25 / math.sqrt(0.5), math.sqrt(0.25 - 0.125))


__all__ = ["FT_TO_M", "GRID_BLOCK", "GRID_RATIO", "KT_TO_M_S", "LOW_ALTITUDE_CEILING_M",
           "P_CHOL", "SQRT3", "dryden_length_scales_m", "dryden_sigmas_m_s",
           "second_order_coefficients", "second_order_model", "van_loan"]
