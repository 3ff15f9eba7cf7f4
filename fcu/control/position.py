"""Position control (eq. 5.1-5.4): PID with acceleration feed-forward, then thrust and tilt.

Virtual inputs (eq. 5.3), per NED axis, with ``e = ref_pos - pos`` (eq. 5.1)::

    mu = ref_acc + kp e + kd (ref_vel - vel) + ki int e dt          (m/s^2, NED)

``mu`` is the acceleration the vehicle should have. The plant (eq. 3.5 in NED/FRD,
docs/design.md) accelerates as ``a = g e3 - (U1/m) R e3``, so the required specific force
is ``f = mu - g e3`` and::

    (U1/m) R e3 = -f    =>    U1 = m |f|,    R e3 = -f/|f|          (thrust axis, eq. 5.4)

Attitude inversion (replaces eq. 5.4's roll/pitch, derived for R = Rz(psi) Ry(theta) Rx(phi))::

    R e3 = Rz(psi) [cos(phi) sin(theta), -sin(phi), cos(phi) cos(theta)]^T

Rotating the desired body z axis ``b = -f/|f|`` back by the yaw reference,
``v = Rz(psi)^T b``, leaves ``v = [c_phi s_theta, -s_phi, c_phi c_theta]``, hence::

    phi_d   = asin(-v_y)        = asin((-s_psi f_x + c_psi f_y) / |f|)
    theta_d = atan2(v_x, v_z)   = atan2(-(c_psi f_x + s_psi f_y), -f_z)

(``f_x = mu_x``, ``f_y = mu_y``, ``-f_z = g - mu_z``). The usual textbook form is
``theta_d = asin(-(c_psi f_x + s_psi f_y) / (c_phi |f|))`` (the same angle while
``cos(theta) > 0``; the test checks it); in the thesis's z-up frame its numerator reads
``c_psi mu_x + s_psi mu_y``, whereas the printed eq. 5.4 has ``c_psi mu_x - s_psi mu_y``
over ``c_psi |f|``, which does not invert its own rotation once psi != 0. ``atan2`` needs
no ``cos(phi)`` division and is exact for any ``phi``. By construction the
commanded (phi_d, theta_d, psi) and U1 reproduce ``mu`` exactly through
``a = g e3 - (U1/m) R e3`` (tests/fcu/test_position_control.py checks it).

Thrust: U1 = m |f| (not the projection of f onto the current body z). The projection would
shave the vertical overshoot of tilt transients, but it ties U1 to the attitude estimate and
its noise; with attitude errors below a degree, 1 - cos(1 deg) = 1.5e-4 of thrust is lost
either way.

Limits, in the order applied (vertical before horizontal: altitude is the safety-critical
axis near the ground):

1. the vertical specific force ``-f_z = g - mu_z`` is clamped to the thrust range
   [thrust_min, thrust_max cos(horizontal_reserve)] / m (no reserve by default);
2. the horizontal part of ``f`` is scaled down so the tilt ``atan(|f_xy| / -f_z)`` stays at
   most ``tilt_max_rad``, and further so that ``m |f| <= thrust_max``;
``accel_cmd_ned`` reports the ``mu`` actually commanded after these limits.

Anti-windup: the integral is clamped per axis so that ``|ki int e| <= integral_limit`` (m/s^2),
and on an axis whose ``mu`` was limited it does not grow in the direction that deepens the
limit (conditional integration).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

import fcu.floats
from fcu.floats import clip, floats, py_max, py_min
from fcu.model import VehicleModel
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import OneStatePart

drop_stale_kernels(__file__, fcu.floats.__file__)  # the kernels compile in fcu.floats' helpers


@dataclass(frozen=True, kw_only=True)
class PositionGains:
    """Gains and limits of eq. 5.3/5.4, per NED axis (north, east, down).

    Horizontal: kp = 8 1/s^2, kd = 6 1/s, ki = 3 1/s^3, i.e.
    ``s^3 + kd s^2 + kp s + ki = (s + 4.3)(s + 1)(s + 0.7)`` on an ideal attitude loop. With
    the real inner loop (the default PD or LQR with its motor lead, with or without a DOB,
    the 15 rad/s motors and the 100 Hz hold) and the attitude reference fed through
    :class:`fcu.control.attitude.AttitudeReferenceFilter` at its default 15 rad/s, the
    sensitivity peak at the acceleration command is at most 1.9 over the six inner
    configurations (1.8 with one more sample of delay; 1.6 at kp = 5, 2.2 at kp = 10). A
    10 rad/s reference filter raises it to 2.9: keep the filter at 15 rad/s with these
    gains. The stiffness is for wind: over the thesis mission with Dryden wind and sensor
    noise, kp = 8 halves the horizontal RMS error of kp = 5 (about 4 mm instead of 7 mm).
    Without the reference filter, or with an attitude loop without the motor lead, these
    gains are far too stiff: use about kp = 1, kd = 1.6, ki = 0.2 there.

    Vertical: thrust acts through the 15 rad/s motor lag only: kp = 9, kd = 5.5, ki = 3
    (closed-loop poles near -2.5 +/- 0.6j and -0.44 rad/s; crossover 5.3 rad/s, 52 deg of
    phase margin).

    ``integral_limit`` bounds the integral's acceleration share at 4 m/s^2: the vertical trim
    after the 300 g mass drop needs 2.1 m/s^2 (the model mass stays 1.42 kg) and a PD
    attitude loop (no integral) leaves a standing tilt error of several degrees under motor
    faults, which the horizontal integral must trim (g tan(20 deg) = 3.6 m/s^2). Tilt at
    most 30 deg; thrust between 5 % and 90 % of the four motors' 35 N (the top 10 % kept for
    attitude torques).
    """

    kp: tuple[float, float, float] = (8.0, 8.0, 9.0)  # 1/s^2, m error -> m/s^2
    kd: tuple[float, float, float] = (6.0, 6.0, 5.5)  # 1/s, m/s error -> m/s^2
    ki: tuple[float, float, float] = (3.0, 3.0, 3.0)  # 1/s^3, m*s error -> m/s^2
    integral_limit: tuple[float, float, float] = (4.0, 4.0, 4.0)  # m/s^2, |ki int e|
    tilt_max_rad: float = float(np.radians(30.0))  # rad, max angle of thrust from vertical
    thrust_min_fraction: float = 0.05  # of 4 K pwm_max (N), lowest U1 commanded
    thrust_max_fraction: float = 0.90  # of 4 K pwm_max (N), highest U1 commanded
    # rad, tilt the horizontal axes keep at full vertical demand: the vertical specific force
    # stops at cos(reserve) of the top, so that a falling vehicle still steers
    horizontal_reserve_rad: float = 0.0
    # the touchdown: in a landing below ``touchdown_below_m`` (m, estimated) the tilt is at
    # most ``touchdown_tilt_max_rad``, so that a vehicle leaning into the gusts near the
    # ground touches down on its skids, not on a rotor's tip (30 deg, sim.outcome); it
    # gives up holding its place against them meanwhile (PositionController.touchdown;
    # the relaxed hover's loop does not apply it, fcu.control.reduced_attitude)
    touchdown_tilt_max_rad: float = float(np.radians(20.0))
    touchdown_below_m: float = 1.0

    def __post_init__(self) -> None:
        for name in ("kp", "kd", "ki", "integral_limit"):
            value = getattr(self, name)
            if len(value) != 3 or not all(np.isfinite(v) and v >= 0 for v in value):
                raise ValueError(f"{name} = {value!r}: must be three finite numbers >= 0")
        if not 0.0 < self.tilt_max_rad < np.pi / 2:
            raise ValueError(f"tilt_max_rad = {self.tilt_max_rad!r}: must be in (0, pi/2)")
        if not 0.0 < self.touchdown_tilt_max_rad <= self.tilt_max_rad:
            raise ValueError(f"touchdown_tilt_max_rad = {self.touchdown_tilt_max_rad!r}: must "
                             "be in (0, tilt_max_rad]")
        if not (np.isfinite(self.touchdown_below_m) and self.touchdown_below_m >= 0.0):
            raise ValueError(f"touchdown_below_m = {self.touchdown_below_m!r}: must be a "
                             "finite number >= 0")
        if not 0.0 <= self.horizontal_reserve_rad <= self.tilt_max_rad:
            raise ValueError(f"horizontal_reserve_rad = {self.horizontal_reserve_rad!r}: must "
                             "be in [0, tilt_max_rad]")
        if not 0.0 <= self.thrust_min_fraction < self.thrust_max_fraction <= 1.0:
            raise ValueError(
                f"thrust_min_fraction, thrust_max_fraction = {self.thrust_min_fraction!r}, "
                f"{self.thrust_max_fraction!r}: need 0 <= min < max <= 1")


@dataclass(frozen=True, slots=True)
class PositionCommand:
    """Output of the position loop for one tick.

    Attributes
    ----------
    thrust_n : float
        Collective thrust U1, N.
    roll_ref_rad, pitch_ref_rad : float
        Desired roll phi_d and pitch theta_d (ZYX), rad.
    accel_cmd_ned : numpy.ndarray
        Virtual input mu after the limits, m/s^2 NED, shape (3,).
    """

    thrust_n: float
    roll_ref_rad: float
    pitch_ref_rad: float
    accel_cmd_ned: np.ndarray


def attitude_from_specific_force(force_ned: np.ndarray, yaw_rad: float
                                 ) -> tuple[float, float]:
    """Roll and pitch (rad) that point the thrust along ``force_ned`` at yaw ``yaw_rad``.

    ``force_ned`` is the specific force the thrust must produce (``mu - g e3``, m/s^2); the
    body z axis is placed on ``-force/|force|`` (derivation in the module docstring).
    """
    f0, f1, f2 = floats(force_ned, 3)
    return _attitude_from_force(f0, f1, f2, float(yaw_rad))


@njit(cache=True, error_model="numpy")
def _attitude_from_force(f0: float, f1: float, f2: float, yaw_rad: float
                         ) -> tuple[float, float]:
    """:func:`attitude_from_specific_force` on plain floats (the per-tick path)."""
    # |f| (the sum of squares in the order numpy's norm of a 3-vector adds them)
    norm = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    if norm <= 0.0:
        return 0.0, 0.0
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    b0, b1, b2 = -f0 / norm, -f1 / norm, -f2 / norm  # desired body z axis in NED
    v_x, v_y, v_z = c * b0 + s * b1, -s * b0 + c * b1, b2  # v = Rz(psi)^T b
    roll = np.arcsin(clip(-v_y, -1.0, 1.0))  # v_y = -sin(phi)
    pitch = np.arctan2(v_x, v_z)  # v_x/v_z = tan(theta)
    return roll, pitch


# PositionController's parameter vector (``_par``), as the kernels read it
_KP, _KD, _KI, _Z_LIMIT = 0, 3, 6, 9  # three each, per NED axis
_MASS, _GRAVITY, _DT, _UP_MIN, _UP_MAX, _TAN_TILT_MAX = 12, 13, 14, 15, 16, 17
_UP_HOLD = 18  # the vertical clamp, thrust_max cos(horizontal_reserve) / m
PAR_SIZE = 19
PAR_TAN_TILT_MAX = _TAN_TILT_MAX  # the tilt limit's tangent (PositionController.touchdown)
# the kernel's output vector: U1 (N), roll_d, pitch_d (rad), mu after the limits (m/s^2, NED)
OUT_THRUST, OUT_ROLL, OUT_PITCH, OUT_MU = 0, 1, 2, 3
OUT_SIZE = 6


@njit(cache=True, error_model="numpy")
def limit_accel(par: np.ndarray, mu0: float, mu1: float, mu2: float
                ) -> tuple[float, float, float]:
    """Apply the vertical, tilt and total-thrust limits to mu (m/s^2, NED) (module
    docstring, "Limits")."""
    up_max = par[_UP_MAX]
    # 1. vertical specific force (up) -f_z = g - mu_z within the thrust range (short of its
    # top by the horizontal reserve)
    g = par[_GRAVITY]
    up = clip(g - mu2, par[_UP_MIN], par[_UP_HOLD])
    out2 = g - up
    # 2. horizontal: tilt limit, then the remaining thrust budget
    horiz = np.hypot(mu0, mu1)
    budget = up * par[_TAN_TILT_MAX]
    # (thrust_max / m)^2 - up^2 (x**2 and x*x round alike)
    budget = py_min(budget, math.sqrt(py_max(up_max * up_max - up * up, 0.0)))
    if horiz > budget:
        scale = budget / horiz
        return mu0 * scale, mu1 * scale, out2
    return mu0, mu1, out2


@njit(cache=True, error_model="numpy")
def position_tick(par: np.ndarray, integral: np.ndarray, pos_ned: np.ndarray,
                  vel_ned: np.ndarray, ref_pos: np.ndarray, ref_vel: np.ndarray,
                  ref_acc: np.ndarray, yaw_ref: float, out: np.ndarray) -> None:
    """One tick of eq. 5.3/5.4: writes ``out`` (``OUT_*``) and advances ``integral`` (m*s)."""
    dt = par[_DT]
    e = np.empty(3)
    z = np.empty(3)
    mu_free = np.empty(3)
    for i in range(3):
        e[i] = ref_pos[i] - pos_ned[i]  # eq. 5.1
        e_dot = ref_vel[i] - vel_ned[i]  # eq. 5.2
        z_lim = par[_Z_LIMIT + i]
        z[i] = clip(integral[i] + e[i] * dt, -z_lim, z_lim)
        # eq. 5.3: mu = ref_acc + kp e + kd e_dot + ki int e
        mu_free[i] = (ref_acc[i] + par[_KP + i] * e[i] + par[_KD + i] * e_dot
                      + par[_KI + i] * z[i])
    mu0, mu1, mu2 = limit_accel(par, mu_free[0], mu_free[1], mu_free[2])
    mu = (mu0, mu1, mu2)
    # conditional integration: where limited, do not integrate deeper into the limit
    for i in range(3):
        limited = abs(mu[i] - mu_free[i]) > 1e-12
        deeper = limited and np.sign(e[i]) == np.sign(mu_free[i] - mu[i])
        if not deeper:
            integral[i] = z[i]
    # f = mu - g e3; U1 = m |f|; body z along -f (eq. 5.4, module docstring)
    f0, f1, f2 = mu0 - 0.0, mu1 - 0.0, mu2 - par[_GRAVITY]
    out[OUT_THRUST] = par[_MASS] * math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    out[OUT_ROLL], out[OUT_PITCH] = _attitude_from_force(f0, f1, f2, yaw_ref)
    out[OUT_MU], out[OUT_MU + 1], out[OUT_MU + 2] = mu0, mu1, mu2


class PositionController(OneStatePart):
    """PID position controller with feed-forward (eq. 5.3) and thrust/tilt inversion (eq. 5.4).

    The per-tick arithmetic is the compiled :func:`position_tick` on the parameter vector
    ``_par`` and the integral state, which :mod:`fcu.control.chain` also drives directly.

    Parameters
    ----------
    model : VehicleModel
        Mass (kg), gravity (m/s^2) and the thrust range (4 K pwm_max, N).
    gains : PositionGains
        Gains and limits.
    dt_s : float
        Control period, s.
    """

    def __init__(self, model: VehicleModel, gains: PositionGains | None = None,
                 dt_s: float = 0.01) -> None:
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be > 0")
        self.model = model
        self.gains = gains if gains is not None else PositionGains()
        self.dt_s = float(dt_s)
        g = self.gains
        self._kp, self._kd, self._ki = np.array(g.kp), np.array(g.kd), np.array(g.ki)
        full_thrust_n = 4.0 * model.thrust_gain * model.pwm_max
        self.thrust_min_n = g.thrust_min_fraction * full_thrust_n
        self.thrust_max_n = g.thrust_max_fraction * full_thrust_n
        # |ki z| <= limit  <=>  |z| <= limit / ki (unbounded where ki = 0: z stays 0 there)
        with np.errstate(divide="ignore"):
            self._z_limit = np.where(self._ki > 0, np.array(g.integral_limit) / self._ki, 0.0)
        m = model.mass
        par = np.empty(PAR_SIZE)
        par[_KP:_KP + 3], par[_KD:_KD + 3], par[_KI:_KI + 3] = self._kp, self._kd, self._ki
        par[_Z_LIMIT:_Z_LIMIT + 3] = self._z_limit
        par[_MASS], par[_GRAVITY], par[_DT] = m, model.gravity, self.dt_s
        par[_UP_MIN], par[_UP_MAX] = self.thrust_min_n / m, self.thrust_max_n / m
        # the tilt limit's tangent in flight and in the touchdown (touchdown)
        self._tan_tilt = float(np.tan(self.gains.tilt_max_rad))
        self._tan_touchdown_tilt = float(np.tan(self.gains.touchdown_tilt_max_rad))
        par[_TAN_TILT_MAX] = self._tan_tilt
        par[_UP_HOLD] = par[_UP_MAX] * math.cos(self.gains.horizontal_reserve_rad)
        self.par = par
        self.state = np.zeros(3)  # m*s, int (ref_pos - pos) dt

    @property
    def integral(self) -> np.ndarray:
        """Integral of the position error, m*s, NED, shape (3,)."""
        return self.state.copy()

    def reset(self) -> None:
        """Zero the integrator."""
        self.state[:] = 0.0

    @property
    def trim_accel(self) -> np.ndarray:
        """The integral's share of the acceleration command, ``ki z`` (m/s^2, NED): the
        trim that holds against a steady wind or a thrust deficit."""
        return self._ki * self.state

    def take_trim(self, trim_accel: np.ndarray) -> None:
        """Start the integrator at the trim ``trim_accel`` (m/s^2, NED) that another
        position controller had reached (a bumpless switch; the limits apply)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(self._ki > 0, np.asarray(trim_accel, dtype=float) / self._ki, 0.0)
        self.state[:] = np.clip(z, -self._z_limit, self._z_limit)

    def touchdown(self, on: bool) -> None:
        """The tilt limit of the next steps: ``touchdown_tilt_max_rad`` when ``on`` (the
        autopilot's call: in a landing below ``touchdown_below_m``), else ``tilt_max_rad``.
        (:class:`fcu.control.chain.ControlChain` keeps its own copy of the parameters: set
        it through the chain.)"""
        self.par[_TAN_TILT_MAX] = self._tan_touchdown_tilt if on else self._tan_tilt

    def step(self, pos_ned: np.ndarray, vel_ned: np.ndarray, ref_pos: np.ndarray,
             ref_vel: np.ndarray, ref_acc: np.ndarray, yaw_ref: float) -> PositionCommand:
        """One tick of eq. 5.3/5.4.

        Parameters
        ----------
        pos_ned, vel_ned : numpy.ndarray
            Estimated position (m) and velocity (m/s), NED, shape (3,).
        ref_pos, ref_vel, ref_acc : numpy.ndarray
            Reference position (m), velocity (m/s), acceleration (m/s^2), NED, shape (3,).
        yaw_ref : float
            Yaw reference psi_d, rad (used to resolve the tilt into roll and pitch).
        """
        out = np.empty(OUT_SIZE)
        position_tick(self.par, self.state, _vec(pos_ned), _vec(vel_ned), _vec(ref_pos),
                      _vec(ref_vel), _vec(ref_acc), float(yaw_ref), out)
        return PositionCommand(thrust_n=float(out[OUT_THRUST]),
                               roll_ref_rad=float(out[OUT_ROLL]),
                               pitch_ref_rad=float(out[OUT_PITCH]),
                               accel_cmd_ned=out[OUT_MU:OUT_MU + 3])

    def _limit(self, mu: np.ndarray) -> np.ndarray:
        """Apply the vertical, tilt and total-thrust limits to mu (m/s^2, NED)."""
        mu0, mu1, mu2 = floats(mu, 3)
        return np.array(limit_accel(self.par, mu0, mu1, mu2))


def _vec(value: np.ndarray) -> np.ndarray:
    """A float64 3-vector the kernels accept (the array itself when it already is one)."""
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (3,):
        return value
    return np.ascontiguousarray(value, dtype=float).reshape(3)
