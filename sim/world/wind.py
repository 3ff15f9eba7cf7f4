"""Mean wind plus Dryden turbulence (MIL-F-8785C low-altitude form), discretised exactly.

The thesis adds a wind force and torque (eq. 3.14/3.15) "with Dryden wind effects" but gives
neither intensity nor implementation. This module produces the wind velocity in NED that
:mod:`sim.world.dynamics` subtracts from the vehicle velocity to get the air-relative velocity.

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

Axes and signs
--------------
The gust is generated in a right-handed "along-wind, left, up" frame and rotated into NED:

* u along the direction the mean wind blows *toward* (north when the mean speed is zero),
* v horizontal, 90 degrees to the left of u (west when u points north),
* w vertical, positive **up** (the thesis's z-up sense), so it enters NED as ``down = -w``.

MIL-F-8785C defines the body-axis gust with w_g along body z (down); for zero-mean,
sign-symmetric and mutually independent channels the sign and handedness conventions do not
change any statistic, only which realisation a seed produces. The mean wind uses the
meteorological convention: ``mean_from_deg`` is where the wind blows FROM, clockwise from
north, so a wind from the north (0 deg) at V m/s is the NED velocity (-V, 0, 0).

Floors
------
* Altitude: the low-altitude curves of [1]_ (figs. 10 and 11) and [2]_ cover 10 ft <= h <=
  1000 ft; ``L_w = h`` goes to zero on the ground, which would make the vertical gust white.
  ``min_altitude_m`` defaults to 10 ft = 3.048 m, the clip JSBSim applies [5]_. Above 1000 ft
  the medium/high-altitude model is not implemented: altitude is clipped to 1000 ft, where
  the low-altitude formulas give sigma_u = sigma_v = sigma_w and L_u = L_v = L_w = 1000 ft.
* Airspeed: T = L / V grows without bound at hover (the frozen field would never move past
  the vehicle). Physically, eddies are still carried past a hovering vehicle by the turbulent
  velocity itself, of the order of sigma (about 1.5 m/s for light turbulence), so V is
  floored at ``airspeed_floor_m_s`` (default 1 m/s). Pass the air-relative speed
  ``|v_vehicle - wind_mean|``; in a hover in a steady wind that is the mean wind speed.

Caching
-------
Sigma, L and the discretisation are recomputed only when the clipped altitude or airspeed
leaves a band of +-2 % around the values they were computed for (sigma changes by under 1 %
and T by 2 % within the band). The v/w matrices (two 4x4 matrix exponentials, ~0.3 ms) are
further memoised on a grid of normalised steps spaced by 1 % (T used within 0.5 % of L/V),
so a recomputation costs a few microseconds; an accelerating vehicle may leave the band
every few tens of steps.

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
import itertools
import math
import operator
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.linalg import expm

from flightdata.config import finite, require

FT_TO_M = 0.3048  # m per international foot (exact)
KT_TO_M_S = 1852.0 / 3600.0  # m/s per knot (exact: 1 nmi = 1852 m)
LOW_ALTITUDE_CEILING_M = 1000.0 * FT_TO_M  # m: top of MIL-F-8785C's low-altitude model
W20_KT = {"none": 0.0, "light": 15.0, "moderate": 30.0, "severe": 45.0}  # kt, MIL-F-8785C
CACHE_BAND = 0.02  # relative change of altitude or airspeed that triggers rediscretisation
GRID_RATIO = 1.01  # v/w normalised steps dt/T are rounded to integer powers of this ratio
BLOCK_STEPS = 4096  # steps of standard normals drawn at a time (5 normals per step)
_NORMALS_PER_STEP = 5  # u: 1, v: 2, w: 2
_SQRT3 = math.sqrt(3.0)
_N_COEF = 26  # length of the coefficient vector shared by step() and the numba kernel


@dataclass(frozen=True, kw_only=True)
class WindConfig:
    """Mean wind and Dryden turbulence settings.

    Loadable from a TOML table with ``from_mapping(WindConfig, table)``.

    Raises
    ------
    ConfigError
        When a value is out of range; the message names the key, the value and what is
        allowed.
    """

    mean_speed_m_s: float = 0.0  # m/s, horizontal mean wind speed, >= 0
    mean_from_deg: float = 0.0  # deg, direction the wind blows FROM, clockwise from north
    turbulence: str = "light"  # "none", "light" (W20 15 kt), "moderate" (30 kt), "severe" (45 kt)
    # m/s, wind speed at 20 ft (6.1 m); overrides the named intensity's W20 when given
    w20_m_s: float | None = None
    # m/s, lower bound on the airspeed V in the scale-length-to-time conversion T = L / V
    airspeed_floor_m_s: float = 1.0
    # m, lower bound on the altitude in the sigma and L formulas: 10 ft, where MIL-F-8785C's
    # low-altitude curves start (and where JSBSim clips them)
    min_altitude_m: float = 10.0 * FT_TO_M

    def __post_init__(self) -> None:
        require(finite(self.mean_speed_m_s) and self.mean_speed_m_s >= 0, "mean_speed_m_s",
                self.mean_speed_m_s, "must be a finite number >= 0 (m/s)")
        require(finite(self.mean_from_deg) and 0.0 <= self.mean_from_deg <= 360.0,
                "mean_from_deg", self.mean_from_deg,
                "must be a number of degrees within [0, 360] (clockwise from north)")
        require(isinstance(self.turbulence, str) and self.turbulence in W20_KT, "turbulence",
                self.turbulence, f"must be one of {', '.join(map(repr, W20_KT))}")
        if self.w20_m_s is not None:
            require(finite(self.w20_m_s) and self.w20_m_s >= 0, "w20_m_s", self.w20_m_s,
                    "must be a finite number >= 0 (m/s) or omitted")
            require(self.turbulence != "none", "w20_m_s", self.w20_m_s,
                    "must be omitted when turbulence = 'none' (W20 sets the intensity; "
                    "choose 'light', 'moderate' or 'severe' to use it)")
        require(finite(self.airspeed_floor_m_s) and self.airspeed_floor_m_s > 0,
                "airspeed_floor_m_s", self.airspeed_floor_m_s, "must be a finite number > 0 (m/s)")
        require(finite(self.min_altitude_m)
                and 0 < self.min_altitude_m <= LOW_ALTITUDE_CEILING_M, "min_altitude_m",
                self.min_altitude_m,
                f"must be a finite number > 0 and <= {LOW_ALTITUDE_CEILING_M} m (1000 ft)")

    @property
    def w20_effective_m_s(self) -> float:
        """W20 in m/s: ``w20_m_s`` when given, else the named intensity's value (0 for none)."""
        if self.w20_m_s is not None:
            return float(self.w20_m_s)
        return W20_KT[self.turbulence] * KT_TO_M_S


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
    c = np.array([[_SQRT3, 1.0 - _SQRT3]])
    return a, b, c


def van_loan(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of ``dx = A x dt + B dW`` (unit-intensity W) over one step.

    Van Loan's method [4]_: with M = [[-A, B B^T], [0, A^T]] dt and expm(M) = [[F11, F12],
    [0, F22]], Ad = F22^T and Qd = F22^T F12 = int_0^dt expm(A s) B B^T expm(A^T s) ds.

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
    n = a.shape[0]
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a * dt
    m[:n, n:] = b @ b.T * dt
    m[n:, n:] = a.T * dt
    f = expm(m)
    ad = f[n:, n:].T
    qd = ad @ f[:n, n:]
    return ad, 0.5 * (qd + qd.T)


def _chol2(q: np.ndarray) -> tuple[float, float, float]:
    """Lower Cholesky factor (l11, l21, l22) of a symmetric positive semi-definite 2x2 matrix."""
    q11, q21, q22 = float(q[0, 0]), float(q[1, 0]), float(q[1, 1])
    l11 = math.sqrt(q11)
    l21 = q21 / l11 if l11 > 0.0 else 0.0
    # max(., 0) only guards a last-bit negative from rounding; Van Loan's Qd is accurate to
    # machine precision elementwise for normalised steps from 1e-8 to 2 (tests/sim/test_wind.py).
    l22 = math.sqrt(max(q22 - l21 * l21, 0.0))
    return l11, l21, l22


def _second_order_step(h: float) -> tuple[float, ...]:
    """(a11, a12, a21, a22, l11, l21, l22) of the v/w channel for a normalised step ``h``."""
    a, b, _ = second_order_model()
    ad, qd = van_loan(a, b, h)
    return (float(ad[0, 0]), float(ad[0, 1]), float(ad[1, 0]), float(ad[1, 1]), *_chol2(qd))


@functools.lru_cache(maxsize=4096)
def _second_order_step_on_grid(index: int) -> tuple[float, ...]:
    """:func:`_second_order_step` for the normalised step ``GRID_RATIO ** index``, memoised."""
    return _second_order_step(GRID_RATIO**index)


def second_order_coefficients(h: float) -> tuple[tuple[float, ...], float]:
    """Discrete v/w coefficients for a normalised step near ``h`` and the step actually used.

    ``h`` is rounded to the nearest integer power of ``GRID_RATIO`` (a change of T = L/V of at
    most 0.5 %) so that the two 4x4 matrix exponentials of Van Loan's method (~0.3 ms) are
    computed once per grid point and process, not at every rediscretisation. The rounding
    does not touch the variance: Ad P Ad^T + Qd = P holds exactly for every step.

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
_P_CHOL = (math.sqrt(0.5), 0.25 / math.sqrt(0.5), math.sqrt(0.25 - 0.125))


@njit(cache=True)
def _dryden_kernel(z: np.ndarray, x: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Advance the five normalised states over ``out.shape[0]`` steps (same maths as ``step``).

    ``z`` holds one row of 5 standard normals per step, ``x`` = (x_u, v1, v2, w1, w2) is
    updated in place, ``c`` is the coefficient vector built by
    :meth:`DrydenWind._rediscretise` and ``out`` receives the NED wind, m/s.
    """
    pu, qu = c[0], c[1]
    av11, av12, av21, av22, kv11, kv21, kv22 = c[2], c[3], c[4], c[5], c[6], c[7], c[8]
    aw11, aw12, aw21, aw22, kw11, kw21, kw22 = c[9], c[10], c[11], c[12], c[13], c[14], c[15]
    gu, gv1, gv2, gw1, gw2 = c[16], c[17], c[18], c[19], c[20]
    cc, sc, mn, me, md = c[21], c[22], c[23], c[24], c[25]
    xu, v1, v2, w1, w2 = x[0], x[1], x[2], x[3], x[4]
    for k in range(out.shape[0]):
        n0, n1, n2, n3, n4 = z[k, 0], z[k, 1], z[k, 2], z[k, 3], z[k, 4]
        # x_u <- exp(-h) x_u + sqrt(1 - exp(-2h)) n      (Ornstein-Uhlenbeck, exact)
        xu = pu * xu + qu * n0
        # x <- Ad x + chol(Qd) n                         (Van Loan, exact)
        t1 = av11 * v1 + av12 * v2 + kv11 * n1
        v2 = av21 * v1 + av22 * v2 + (kv21 * n1 + kv22 * n2)
        v1 = t1
        t1 = aw11 * w1 + aw12 * w2 + kw11 * n3
        w2 = aw21 * w1 + aw22 * w2 + (kw21 * n3 + kw22 * n4)
        w1 = t1
        # y = sigma C x, then (u along-wind, v left, w up) -> NED
        yu = gu * xu
        yv = gv1 * v1 + gv2 * v2
        out[k, 0] = mn + cc * yu + sc * yv
        out[k, 1] = me + sc * yu - cc * yv
        out[k, 2] = md - (gw1 * w1 + gw2 * w2)
    x[0] = xu
    x[1] = v1
    x[2] = v2
    x[3] = w1
    x[4] = w2


class DrydenWind:
    """Mean wind plus MIL-F-8785C low-altitude Dryden turbulence, in NED.

    Parameters
    ----------
    config : WindConfig
        Mean wind and turbulence settings.
    dt_s : float
        Step, s (the plant step, e.g. 0.002 at 500 Hz). Every call to :meth:`step` advances
        the turbulence by exactly this much.
    rng : numpy.random.Generator
        Source of all randomness. Normals are drawn in blocks of ``BLOCK_STEPS`` x 5, so a
        generator of its own (e.g. from ``rng.spawn(1)``) keeps other consumers' streams
        independent of how many wind steps have run.

    Notes
    -----
    Equations, discretisation, axes and floors are in the module docstring. The object is
    complete after construction (which calls :meth:`reset`). A step costs about 1 us of
    Python (two tuple unpacks, ~30 float operations on Python floats, one 3-element array;
    about 1.7 us while climbing and accelerating, with rediscretisations); the
    discretisation is recomputed only when altitude or airspeed leaves its 2 % band.
    """

    __slots__ = ("_config", "_dt_s", "_rng", "_w20_m_s", "_mean_ned", "_cos_chi", "_sin_chi",
                 "_active", "_h_min", "_h_max", "_v_min", "_band", "_coef", "_coef_arr",
                 "_sigma", "_length", "_x", "_block", "_rows", "_next_row")

    def __init__(self, config: WindConfig, dt_s: float, rng: np.random.Generator) -> None:
        require(isinstance(config, WindConfig), "config", config, "must be a WindConfig")
        require(finite(dt_s) and dt_s > 0, "dt_s", dt_s, "must be a finite number > 0 (s)")
        require(isinstance(rng, np.random.Generator), "rng", rng,
                "must be a numpy.random.Generator")
        self._config = config
        self._dt_s = float(dt_s)
        self._rng = rng
        self._w20_m_s = config.w20_effective_m_s
        speed = config.mean_speed_m_s
        from_rad = math.radians(config.mean_from_deg)
        # The air moves toward from + 180 deg: NED velocity = -speed (cos from, sin from, 0).
        self._mean_ned = np.array([-speed * math.cos(from_rad), -speed * math.sin(from_rad), 0.0])
        # u axis: where the wind blows toward; north when there is no mean wind.
        chi = from_rad + math.pi if speed > 0 else 0.0
        self._cos_chi = math.cos(chi)
        self._sin_chi = math.sin(chi)
        self._active = config.turbulence != "none" and self._w20_m_s > 0
        self._h_min = config.min_altitude_m
        self._h_max = LOW_ALTITUDE_CEILING_M
        self._v_min = config.airspeed_floor_m_s
        self.reset()

    # ----------------------------------------------------------------------------------
    def reset(self) -> None:
        """Draw a fresh stationary state and discard pre-drawn normals.

        The state is drawn from the stationary covariance (u ~ N(0, 1); v, w ~ N(0, P)), so
        the first outputs already have variance sigma^2. The discretisation is set for the
        floors (``min_altitude_m``, ``airspeed_floor_m_s``) until the first step. Uses the
        injected generator, which is never rewound: with turbulence on, it advances.
        """
        self._set_block(np.empty((0, _NORMALS_PER_STEP)), 0)
        self._x = [0.0] * 5
        if self._active:
            # Python floats, not numpy scalars (see _rediscretise).
            n = self._rng.standard_normal(5).tolist()
            l11, l21, l22 = _P_CHOL
            self._x = [n[0], l11 * n[1], l21 * n[1] + l22 * n[2],
                       l11 * n[3], l21 * n[3] + l22 * n[4]]
        self._rediscretise(self._h_min, self._v_min)

    # ----------------------------------------------------------------------------------
    def _retune(self, altitude_m: float, airspeed_m_s: float) -> None:
        """Clip altitude and airspeed, then rediscretise (called when they leave the band)."""
        h = float(altitude_m)
        v = float(airspeed_m_s)
        if not (math.isfinite(h) and math.isfinite(v)):
            raise ValueError(f"altitude_m = {altitude_m!r}, airspeed_m_s = {airspeed_m_s!r}: "
                             "must be finite numbers")
        self._rediscretise(min(max(h, self._h_min), self._h_max), max(v, self._v_min))

    def _rediscretise(self, h: float, v: float) -> None:
        """Recompute sigma, L, the exact discretisation and the cache band for clipped h, v."""
        # The band is tested on the *unclipped* inputs: it is open-ended on the side of a
        # floor or ceiling in use, so any input that clips to the same value stays inside it.
        self._band = (
            -math.inf if h <= self._h_min else h * (1.0 - CACHE_BAND),
            math.inf if h >= self._h_max else h * (1.0 + CACHE_BAND),
            -math.inf if v <= self._v_min else v * (1.0 - CACHE_BAND),
            v * (1.0 + CACHE_BAND),
        )
        self._sigma = dryden_sigmas_m_s(self._w20_m_s, h)
        self._length = dryden_length_scales_m(h)
        s_u, s_v, s_w = self._sigma
        l_u, l_v, l_w = self._length
        h_u, h_v, h_w = self._dt_s * v / l_u, self._dt_s * v / l_v, self._dt_s * v / l_w
        # Ornstein-Uhlenbeck: exp(-h) and sqrt(1 - exp(-2h)), the latter via expm1 for small h.
        ou = (math.exp(-h_u), math.sqrt(-math.expm1(-2.0 * h_u)))
        c1, c2 = _SQRT3, 1.0 - _SQRT3
        mean = self._mean_ned
        coef = (*ou, *second_order_coefficients(h_v)[0], *second_order_coefficients(h_w)[0],
                s_u, s_v * c1, s_v * c2, s_w * c1, s_w * c2,
                self._cos_chi, self._sin_chi, float(mean[0]), float(mean[1]), float(mean[2]))
        # Python floats only: step()'s arithmetic is several times slower on numpy scalars.
        assert len(coef) == _N_COEF and all(type(value) is float for value in coef)
        self._coef = coef
        self._coef_arr = np.array(coef)

    def _set_block(self, block: np.ndarray, first_row: int) -> None:
        """Make ``block`` (rows of 5 normals) current, with ``first_row`` the next to use."""
        self._block = block
        self._rows = iter(block[first_row:].tolist())
        self._next_row = self._rows.__next__

    def _preview(self, n_steps: int) -> tuple[np.ndarray, np.ndarray, int]:
        """The winds of the next steps if the discretisation stays (no retune) and no new
        block of normals is needed, without advancing: ``(winds, x_after, n)`` with
        ``winds`` (n, 3), n <= ``n_steps`` limited by the normals left in the block and
        ``x_after`` the states after all n. Take steps with :meth:`_accept`. For
        :class:`sim.world.World`'s compiled stepping; :meth:`step` checks the cache band."""
        if not self._active:
            winds = np.empty((n_steps, 3))
            winds[:] = self._mean_ned
            return winds, np.array(self._x), n_steps
        block = self._block
        row = block.shape[0] - operator.length_hint(self._rows)  # next unused row
        n = min(n_steps, block.shape[0] - row)
        winds = np.empty((n, 3))
        x = np.array(self._x)
        _dryden_kernel(block[row:row + n], x, self._coef_arr, winds)
        return winds, x, n

    def _accept(self, n_steps: int, x_after: np.ndarray, n_previewed: int) -> None:
        """Advance by the first ``n_steps`` steps of the last :meth:`_preview`."""
        if not self._active or n_steps == 0:
            return
        if n_steps != n_previewed:  # recompute the states after the steps taken
            block = self._block
            row = block.shape[0] - operator.length_hint(self._rows)
            x_after = np.array(self._x)
            _dryden_kernel(block[row:row + n_steps], x_after, self._coef_arr,
                           np.empty((n_steps, 3)))
        self._x = x_after.tolist()
        next(itertools.islice(self._rows, n_steps - 1, None))

    @property
    def _cache_band(self) -> tuple[bool, np.ndarray]:
        """(turbulence active, the band (h_lo, h_hi, v_lo, v_hi) of :meth:`step`'s cache)."""
        return self._active, np.array(self._band)

    def _draw_block(self) -> np.ndarray:
        """The next block of standard normals, shape (BLOCK_STEPS, 5); the only draw site."""
        return self._rng.standard_normal((BLOCK_STEPS, _NORMALS_PER_STEP))

    # ----------------------------------------------------------------------------------
    def step(self, altitude_m: float, airspeed_m_s: float) -> np.ndarray:
        """Advance one step and return the wind velocity in NED, m/s (mean + gust), shape (3,).

        Parameters
        ----------
        altitude_m : float
            Altitude above ground, m (up-positive); clipped to [min_altitude_m, 1000 ft].
        airspeed_m_s : float
            Air-relative speed, m/s; floored at ``airspeed_floor_m_s``.

        Returns
        -------
        ndarray, shape (3,)
            Wind velocity (north, east, down), m/s; a new array each call.

        Raises
        ------
        ValueError
            When altitude or airspeed is NaN or infinite (a non-finite value always leaves
            the cache band, where it is checked).
        """
        if not self._active:
            return self._mean_ned.copy()
        h_lo, h_hi, v_lo, v_hi = self._band
        if not (h_lo <= altitude_m <= h_hi and v_lo <= airspeed_m_s <= v_hi):
            self._retune(altitude_m, airspeed_m_s)
        try:
            n0, n1, n2, n3, n4 = self._next_row()
        except StopIteration:
            self._set_block(self._draw_block(), 0)
            n0, n1, n2, n3, n4 = self._next_row()
        (pu, qu, av11, av12, av21, av22, kv11, kv21, kv22, aw11, aw12, aw21, aw22, kw11, kw21,
         kw22, gu, gv1, gv2, gw1, gw2, cc, sc, mn, me, md) = self._coef
        xu, v1, v2, w1, w2 = self._x
        # The same operations in the same order as _dryden_kernel (bit-identical results).
        xu = pu * xu + qu * n0
        t1 = av11 * v1 + av12 * v2 + kv11 * n1
        v2 = av21 * v1 + av22 * v2 + (kv21 * n1 + kv22 * n2)
        v1 = t1
        t1 = aw11 * w1 + aw12 * w2 + kw11 * n3
        w2 = aw21 * w1 + aw22 * w2 + (kw21 * n3 + kw22 * n4)
        w1 = t1
        self._x = [xu, v1, v2, w1, w2]
        yu = gu * xu
        yv = gv1 * v1 + gv2 * v2
        return np.array((mn + cc * yu + sc * yv, me + sc * yu - cc * yv,
                         md - (gw1 * w1 + gw2 * w2)))

    def generate(self, n_steps: int, altitude_m: float, airspeed_m_s: float) -> np.ndarray:
        """Run ``n_steps`` steps at constant altitude and airspeed in bulk (numba).

        The same recursion, coefficients and stream of normals as ``n_steps`` calls to
        :meth:`step` with the same arguments; the object's state advances exactly as if they
        had been made, so calls to both can be mixed.

        Parameters
        ----------
        n_steps : int
            Number of steps, >= 0.
        altitude_m : float
            Altitude above ground, m; clipped as in :meth:`step`.
        airspeed_m_s : float
            Air-relative speed, m/s; floored as in :meth:`step`.

        Returns
        -------
        ndarray, shape (n_steps, 3)
            Wind velocity (north, east, down) per step, m/s.
        """
        if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) \
                or n_steps < 0:
            raise ValueError(f"n_steps = {n_steps!r}: must be an integer >= 0")
        n_steps = int(n_steps)
        out = np.empty((n_steps, 3))
        if not self._active:
            out[:] = self._mean_ned
            return out
        h_lo, h_hi, v_lo, v_hi = self._band
        if not (h_lo <= altitude_m <= h_hi and v_lo <= airspeed_m_s <= v_hi):
            self._retune(altitude_m, airspeed_m_s)
        x = np.array(self._x)
        block = self._block
        k = block.shape[0] - operator.length_hint(self._rows)  # next unused row of block
        done = 0
        while done < n_steps:
            if k >= block.shape[0]:
                block, k = self._draw_block(), 0
            m = min(n_steps - done, block.shape[0] - k)
            _dryden_kernel(block[k:k + m], x, self._coef_arr, out[done:done + m])
            k += m
            done += m
        self._set_block(block, k)
        self._x = x.tolist()
        return out

    # ----------------------------------------------------------------------------------
    @property
    def mean_ned_m_s(self) -> np.ndarray:
        """Mean wind velocity (north, east, down), m/s, shape (3,) (a copy)."""
        return self._mean_ned.copy()

    @property
    def sigma_uvw_m_s(self) -> np.ndarray:
        """Turbulence intensities (sigma_u, sigma_v, sigma_w), m/s, shape (3,).

        For the altitude of the current discretisation: the last step's clipped altitude to
        within the 2 % cache band (``min_altitude_m`` before the first step). Zeros for
        turbulence ``"none"``.
        """
        if not self._active:
            return np.zeros(3)
        return np.array(self._sigma)

    @property
    def length_scale_uvw_m(self) -> np.ndarray:
        """Scale lengths (L_u, L_v, L_w), m, shape (3,), for the same altitude as the sigmas."""
        return np.array(self._length)
