"""Mean wind plus Dryden turbulence (MIL-F-8785C low-altitude form), discretised exactly.

The thesis adds a wind force and torque (eq. 3.14/3.15) "with Dryden wind effects" but gives
neither intensity nor implementation. This module produces the wind velocity in NED that
:mod:`sim.world.dynamics` subtracts from the vehicle velocity to get the air-relative velocity.

The Dryden model itself (MIL-F-8785C formulas, forming filters, exact discretisation) is in
:mod:`sim.world.dryden`; this module adds the mean wind, the axes, the floors, the caching
and the state that the world's compiled stepping advances.

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
* Altitude: the low-altitude curves of MIL-F-8785C (figs. 10 and 11) and MIL-HDBK-1797
  cover 10 ft <= h <= 1000 ft; ``L_w = h`` goes to zero on the ground, which would make the
  vertical gust white.
  ``min_altitude_m`` defaults to 10 ft = 3.048 m, the clip JSBSim applies. Above 1000 ft
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

State
-----
Everything a step changes or reads (the five normalised channel states, the coefficients,
the cache band, the block of pre-drawn normals and the next row to use) lives in one
:data:`WIND_STATE` record, :attr:`DrydenWind.kernel_state`. :meth:`DrydenWind.step` (Python,
the reference) and :func:`dryden_step` (numba, for the world's compiled stepping) advance it
with the same operations in the same order; only :meth:`DrydenWind.step` retunes and draws.

References: those of :mod:`sim.world.dryden` (MIL-F-8785C, MIL-HDBK-1797, Gillespie 1996,
Van Loan 1978, JSBSim).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from flightdata.config import finite, require
from sim.world.dryden import (
    FT_TO_M,
    KT_TO_M_S,
    LOW_ALTITUDE_CEILING_M,
    P_CHOL,
    SQRT3,
    dryden_length_scales_m,
    dryden_sigmas_m_s,
    second_order_coefficients,
)

W20_KT = {"none": 0.0, "light": 15.0, "moderate": 30.0, "severe": 45.0}  # kt, MIL-F-8785C
CACHE_BAND = 0.02  # relative change of altitude or airspeed that triggers rediscretisation
BLOCK_STEPS = 4096  # steps of standard normals drawn at a time (5 normals per step)
_NORMALS_PER_STEP = 5  # u: 1, v: 2, w: 2
_N_COEF = 26  # length of the coefficient vector (_rediscretise)

WIND_STATE = np.dtype([
    ("active", np.bool_),  # turbulence on (off: the wind is the mean wind)
    ("mean_ned", np.float64, (3,)),  # m/s, mean wind velocity
    ("band", np.float64, (4,)),  # (h_lo, h_hi, v_lo, v_hi): m, m/s, the cache band
    ("coef", np.float64, (_N_COEF,)),  # discretisation coefficients (_rediscretise)
    ("x", np.float64, (5,)),  # normalised channel states (x_u, v1, v2, w1, w2)
    ("rows", np.int64),  # rows of block drawn (0 before the first draw)
    ("next_row", np.int64),  # next unused row of block
    ("block", np.float64, (BLOCK_STEPS, _NORMALS_PER_STEP)),  # standard normals, 5 per step
], align=True)
"""What a wind step reads and changes (module docstring, "State")."""


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


@njit(cache=True)
def _advance(c: np.ndarray, x: np.ndarray, z: np.ndarray, out: np.ndarray) -> None:
    """One step of the five normalised states ``x`` (in place) driven by the normals ``z``
    (5,), with the coefficients ``c`` of :meth:`DrydenWind._rediscretise`; the NED wind,
    m/s, into ``out`` (3,). The same operations in the same order as :meth:`DrydenWind.step`.
    """
    xu, v1, v2, w1, w2 = x[0], x[1], x[2], x[3], x[4]
    # x_u <- exp(-h) x_u + sqrt(1 - exp(-2h)) n      (Ornstein-Uhlenbeck, exact)
    xu = c[0] * xu + c[1] * z[0]
    # x <- Ad x + chol(Qd) n                         (Van Loan, exact)
    t1 = c[2] * v1 + c[3] * v2 + c[6] * z[1]
    v2 = c[4] * v1 + c[5] * v2 + (c[7] * z[1] + c[8] * z[2])
    v1 = t1
    t1 = c[9] * w1 + c[10] * w2 + c[13] * z[3]
    w2 = c[11] * w1 + c[12] * w2 + (c[14] * z[3] + c[15] * z[4])
    w1 = t1
    x[0], x[1], x[2], x[3], x[4] = xu, v1, v2, w1, w2
    # y = sigma C x, then (u along-wind, v left, w up) -> NED
    yu = c[16] * xu
    yv = c[17] * v1 + c[18] * v2
    out[0] = c[23] + c[21] * yu + c[22] * yv
    out[1] = c[24] + c[22] * yu - c[21] * yv
    out[2] = c[25] - (c[19] * w1 + c[20] * w2)


@njit(cache=True)
def _dryden_kernel(z: np.ndarray, x: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """:func:`_advance` over ``out.shape[0]`` steps, row ``k`` of ``z`` driving step ``k``."""
    for k in range(out.shape[0]):
        _advance(c, x, z[k], out[k])


WIND_READY, WIND_RETUNE, WIND_DRAW = 0, 1, 2  # what dryden_ready found

# Python's math.hypot may differ from numba's in the last bit: an airspeed this close
# (relative) to a band end counts as outside, so that Python decides.
_HYPOT_MARGIN = 1e-12


@njit(cache=True)
def _inside(value: float, lo: float, hi: float, margin: float) -> bool:
    """``lo <= value <= hi`` with ``value`` at least ``margin`` (relative) inside finite ends."""
    if value != value:  # NaN: Python raises on it
        return False
    if lo > -math.inf and not value >= lo + abs(lo) * margin:
        return False
    return not (hi < math.inf and not value <= hi - abs(hi) * margin)


@njit(cache=True)
def dryden_ready(wind: np.ndarray, altitude_m: float, airspeed_m_s: float) -> int:
    """Whether :func:`dryden_step` can stand in for :meth:`DrydenWind.step` at this altitude
    and airspeed: WIND_READY; WIND_RETUNE when they leave the cache band (or are not finite:
    Python rediscretises, or raises); WIND_DRAW when the block of normals is used up.

    ``airspeed_m_s`` is computed in numba, whose ``hypot`` may differ from Python's
    ``math.hypot`` in the last bit: within 1e-12 (relative) of a band end it counts as out.
    """
    s = wind[0]
    if not s.active:
        return WIND_READY  # the mean wind: no band, no draws
    band = s.band
    if not (_inside(altitude_m, band[0], band[1], 0.0)
            and _inside(airspeed_m_s, band[2], band[3], _HYPOT_MARGIN)):
        return WIND_RETUNE
    if s.next_row >= s.rows:
        return WIND_DRAW
    return WIND_READY


@njit(cache=True)
def dryden_step(wind: np.ndarray, out: np.ndarray) -> None:
    """One step of :meth:`DrydenWind.step` inside its cache band, in numba.

    Parameters
    ----------
    wind : numpy.ndarray
        One :data:`WIND_STATE` record (``DrydenWind.kernel_state``), advanced in place;
        :func:`dryden_ready` must have found it ready for this step's altitude and airspeed
        (else :meth:`DrydenWind.step` retunes or draws).
    out : numpy.ndarray
        Receives the wind velocity (north, east, down), m/s, shape (3,).
    """
    s = wind[0]
    if not s.active:
        for i in range(3):
            out[i] = s.mean_ned[i]
        return
    _advance(s.coef, s.x, s.block[s.next_row], out)
    s.next_row += 1


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

    Attributes
    ----------
    kernel_state : numpy.ndarray
        One :data:`WIND_STATE` record: what a step reads and changes (module docstring). The
        world's compiled stepping advances it with :func:`dryden_step`; nothing else should
        write it.

    Notes
    -----
    Equations, discretisation, axes and floors are in the module docstring. The object is
    complete after construction (which calls :meth:`reset`). A Python step costs a few
    microseconds; the discretisation is recomputed only when altitude or airspeed leaves its
    2 % band.
    """

    __slots__ = ("_config", "_dt_s", "_rng", "_w20_m_s", "_mean_ned", "_cos_chi", "_sin_chi",
                 "_active", "_h_min", "_h_max", "_v_min", "_band", "_coef", "_sigma",
                 "_length", "kernel_state", "_s", "_x", "_block", "_coef_view", "_band_view")

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
        self.kernel_state = np.zeros(1, dtype=WIND_STATE)
        self._s = self.kernel_state[0]  # a view: writes go to the array
        self._s["active"] = self._active
        self._s["mean_ned"] = self._mean_ned
        self._x = self.kernel_state["x"][0]  # (5,) view
        self._block = self.kernel_state["block"][0]  # (BLOCK_STEPS, 5) view
        self._coef_view = self.kernel_state["coef"][0]
        self._band_view = self.kernel_state["band"][0]
        self.reset()

    # ----------------------------------------------------------------------------------
    def reset(self) -> None:
        """Draw a fresh stationary state and discard pre-drawn normals.

        The state is drawn from the stationary covariance (u ~ N(0, 1); v, w ~ N(0, P)), so
        the first outputs already have variance sigma^2. The discretisation is set for the
        floors (``min_altitude_m``, ``airspeed_floor_m_s``) until the first step. Uses the
        injected generator, which is never rewound: with turbulence on, it advances.
        """
        self._s["rows"] = 0
        self._s["next_row"] = 0
        self._x[:] = 0.0
        if self._active:
            # Python floats, not numpy scalars (see _rediscretise).
            n = self._rng.standard_normal(5).tolist()
            l11, l21, l22 = P_CHOL
            self._x[:] = (n[0], l11 * n[1], l21 * n[1] + l22 * n[2],
                          l11 * n[3], l21 * n[3] + l22 * n[4])
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
        c1, c2 = SQRT3, 1.0 - SQRT3
        mean = self._mean_ned
        coef = (*ou, *second_order_coefficients(h_v)[0], *second_order_coefficients(h_w)[0],
                s_u, s_v * c1, s_v * c2, s_w * c1, s_w * c2,
                self._cos_chi, self._sin_chi, float(mean[0]), float(mean[1]), float(mean[2]))
        # Python floats only: step()'s arithmetic is several times slower on numpy scalars.
        assert len(coef) == _N_COEF and all(type(value) is float for value in coef)
        self._coef = coef
        self._coef_view[:] = coef
        self._band_view[:] = self._band

    def draw_block(self) -> None:
        """Draw the next block of standard normals (BLOCK_STEPS x 5) and start at its first
        row; the only draw site after :meth:`reset`. A step draws when the block is used up
        (the world's compiled stepping calls this when it finds it so)."""
        self._block[:] = self._rng.standard_normal((BLOCK_STEPS, _NORMALS_PER_STEP))
        self._s["rows"] = BLOCK_STEPS
        self._s["next_row"] = 0

    def refill(self) -> None:
        """Draw the next block if turbulence is on and the current block is used up (the
        world's compiled stepping asks for this before a step it cannot take without)."""
        if self._active and self._s["next_row"] >= self._s["rows"]:
            self.draw_block()

    def _next_normals(self) -> list[float]:
        """The next row of 5 standard normals (drawing a block when the current one is used)."""
        row = int(self._s["next_row"])
        if row >= self._s["rows"]:
            self.draw_block()
            row = 0
        self._s["next_row"] = row + 1
        normals: list[float] = self._block[row].tolist()
        return normals

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
        n0, n1, n2, n3, n4 = self._next_normals()
        (pu, qu, av11, av12, av21, av22, kv11, kv21, kv22, aw11, aw12, aw21, aw22, kw11, kw21,
         kw22, gu, gv1, gv2, gw1, gw2, cc, sc, mn, me, md) = self._coef
        xu, v1, v2, w1, w2 = self._x.tolist()
        # The same operations in the same order as _advance (bit-identical results).
        xu = pu * xu + qu * n0
        t1 = av11 * v1 + av12 * v2 + kv11 * n1
        v2 = av21 * v1 + av22 * v2 + (kv21 * n1 + kv22 * n2)
        v1 = t1
        t1 = aw11 * w1 + aw12 * w2 + kw11 * n3
        w2 = aw21 * w1 + aw22 * w2 + (kw21 * n3 + kw22 * n4)
        w1 = t1
        self._x[:] = (xu, v1, v2, w1, w2)
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
        coef = self.kernel_state["coef"][0]
        done = 0
        while done < n_steps:
            k = int(self._s["next_row"])
            if k >= self._s["rows"]:
                self.draw_block()
                k = 0
            m = min(n_steps - done, BLOCK_STEPS - k)
            _dryden_kernel(self._block[k:k + m], self._x, coef, out[done:done + m])
            self._s["next_row"] = k + m
            done += m
        return out

    # ----------------------------------------------------------------------------------
    @property
    def active(self) -> bool:
        """True when turbulence is on (off: every step returns the mean wind)."""
        return self._active

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


__all__ = ["BLOCK_STEPS", "CACHE_BAND", "W20_KT", "WIND_DRAW", "WIND_READY", "WIND_RETUNE",
           "WIND_STATE", "DrydenWind", "WindConfig", "dryden_ready", "dryden_step"]
