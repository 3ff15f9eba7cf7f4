"""Reduced-attitude control of a quadrotor that has lost one rotor (relaxed hover).

With one rotor lost the yaw is given up (Mueller and D'Andrea, ICRA 2014): the vehicle spins
about a primary axis ``n`` fixed in the body, and only the direction of ``n`` in the world is
controlled, by the two body rates p, q and the torques of the three remaining rotors. The
equilibrium (thrusts, ``n_bar``, body rates) is :func:`fcu.control.relaxed_hover.relaxed_hover`;
this controller holds ``n_bar`` on a commanded world direction ``d`` (unit, NED, the way the
mean thrust must point) by LQR on the linearisation about that equilibrium.

Model (body FRD; n is the body vector that should point along d, ``n = R^T d``)::

    Ixx dp/dt = tau_x - g_x p + (Iyy - Izz) q r          (eq. 3.6 with the rate damping)
    Iyy dq/dt = tau_y - g_y q + (Izz - Ixx) r p
    dn/dt     = n x omega                                (d fixed in the world)
    dtau/dt   = w (tau_cmd - tau)                        (the motors' lag, eq. 3.1)

Linearised about (p_bar, q_bar, r_bar, n_bar, tau_bar), with r held at r_bar (its own
dynamics are the slow yaw damping, Izz / g_z = 4 s) and ``dn_z = -(n_x dn_x + n_y dn_y) /
n_z`` (|n| = 1), the state ``x = [dp, dq, dn_x, dn_y, dtau_x, dtau_y]`` and the input
``v = [dtau_x_cmd, dtau_y_cmd]``::

    dp'   = (-g_x dp + (Iyy - Izz) r dq + dtau_x) / Ixx
    dq'   = (-g_y dq + (Izz - Ixx) r dp + dtau_y) / Iyy
    dn_x' =  r dn_y - n_z dq - q dn_z
    dn_y' = -r dn_x + n_z dp + p dn_z
    dtau' =  w (v - dtau)

It is discretised (zero-order hold at the control period, ``control.c2d``) and the gain comes
from ``control.dlqr`` at construction (weights :class:`ReducedAttitudeWeights`). The torque
state is the autopilot's own model of its motors: each motor's thrust follows its command
through the 15 rad/s lag (eq. 3.1), the lost motor's is taken as zero.

Collective thrust: the mean force along n is ``U1 (-n_z)``, so ``U1 = m (f . n_s) / (-n_s,z)``
for a requested specific force ``f`` (m/s^2) and the primary axis ``n_s`` the schedule has
reached (body z before the spin, ``n_bar`` at the equilibrium spin): only the part of ``f``
along the axis is asked for, so that an axis tipped far from where it should point does not
push the vehicle harder the wrong way. With (U1, tau_x, tau_y) the three remaining motors'
thrusts follow from eq. 3.17 restricted to them, torques first when they saturate (the
opposite motor alone makes the torque about the lost pair's axis; the pair on the other axis
makes the other torque, then shares the collective); the yaw torque is what it is, and the
spin follows from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fcu.control.position import PositionGains
from fcu.control.relaxed_hover import (
    RelaxedHoverEquilibrium,
    failed_motor_equilibrium,
    relaxed_hover,
    torque_matrix,
)
from fcu.model import VehicleModel
from flightdata.design_cache import cached_design

SCHEDULE = np.linspace(0.0, 1.0, 11)  # fractions of the equilibrium spin with a design
# with two opposite rotors lost the axis of the lost pair has no torque: only the spin's
# coupling steers it, so the schedule starts where there is spin to couple
TWO_ROTOR_SCHEDULE = np.linspace(0.15, 1.0, 11)
MIN_SCHEDULE_SPIN_RAD_S = 5.0  # rad/s, the least spin the schedule spans

SPINNING_POSITION_GAINS = PositionGains(
    kp=(4.0, 4.0, 9.0), kd=(4.0, 4.0, 5.5), ki=(1.0, 1.0, 3.0),
    tilt_max_rad=math.radians(30.0), thrust_max_fraction=0.6,
    horizontal_reserve_rad=math.radians(10.0))
"""Position loop gains in relaxed hover: the vertical axis as in normal flight (thrust acts
directly), the horizontal ones half as stiff (``s^3 + 4 s^2 + 4 s + 1``: poles near -2.6,
-1 and -0.4 rad/s) because the primary axis answers through the spin (a quarter turn, 80 ms,
before a torque about one body axis tilts the other) and its loop is slower than the full
attitude loop's; tilt of the primary axis at most 30 deg (three motors at up to two thirds
of full thrust allow it: braking from the cruise and holding against 8 m/s of wind need it);
the thrust of three motors (60 % of four), 10 deg of tilt kept at full vertical demand. The
touchdown's lower tilt (``touchdown_tilt_max_rad``) is not applied in relaxed hover: the
spinning vehicle lands at 0.5 m/s with less authority and, held to 15 or 20 deg below 1 m,
drifted with the gusts near the ground (a loss in the outdoor descent in 8 m/s of severe
turbulence touched down at 2.6-2.9 m/s in 16 of 16 and 9 of 16 runs, against 6 of 16 tilted
past 30 deg without)."""


@dataclass(frozen=True, kw_only=True)
class ReducedAttitudeWeights:
    """LQR weights, Bryson's rule (q = 1 / x_max^2), and the equilibrium's thrust split.

    The primary axis may be off by 0.02 (1.1 deg) and the rates by 0.5 rad/s per 0.2 N*m of
    torque; the lagged torque states carry a small weight so the design prefers smooth
    commands.
    """

    q_axis: float = 2500.0  # 1/(unit vector component)^2, on dn_x and dn_y
    q_rate: float = 4.0  # 1/(rad/s)^2, on dp and dq
    q_torque: float = 1.0  # 1/(N*m)^2, on the lagged torques
    q_integral: float = 1.0e4  # 1/(unit*s)^2, on the integrals of dn_x and dn_y
    integral_limit: float = 0.2  # unit*s, |int dn dt| per axis (anti-windup)
    r_torque: float = 25.0  # 1/(N*m)^2, on the commanded torques
    # rho, fcu.control.relaxed_hover; None: chosen by the failed motor's thrust
    # (failed_motor_equilibrium)
    opposite_ratio: float | None = None

    def __post_init__(self) -> None:
        for name in ("q_axis", "q_rate", "q_torque", "r_torque", "q_integral",
                     "integral_limit"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} = {value!r}: must be a finite number > 0")
        if self.opposite_ratio is not None and not 0.0 <= self.opposite_ratio <= 1.0:
            raise ValueError(f"opposite_ratio = {self.opposite_ratio!r}: must lie in [0, 1]")


def linearisation(model: VehicleModel, rate_frd: np.ndarray, axis_frd: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Continuous (A, B), shapes (6, 6) and (6, 2), of the module docstring's model about the
    body rates ``rate_frd`` (rad/s) and primary axis ``axis_frd`` (unit, body FRD)."""
    ixx, iyy, izz = model.inertia
    gx, gy, _ = model.rate_damping
    p, q, r = (float(v) for v in rate_frd)
    nx, ny, nz = (float(v) for v in axis_frd)
    w = model.motor_bandwidth
    # dn_z = cx dn_x + cy dn_y
    cx, cy = -nx / nz, -ny / nz
    a = np.zeros((6, 6))
    a[0, 0], a[0, 1], a[0, 4] = -gx / ixx, (iyy - izz) * r / ixx, 1.0 / ixx
    a[1, 0], a[1, 1], a[1, 5] = (izz - ixx) * r / iyy, -gy / iyy, 1.0 / iyy
    a[2, 1], a[2, 2], a[2, 3] = -nz, -q * cx, r - q * cy
    a[3, 0], a[3, 2], a[3, 3] = nz, -r + p * cx, p * cy
    a[4, 4], a[5, 5] = -w, -w
    b = np.zeros((6, 2))
    b[4, 0], b[5, 1] = w, w
    return a, b


def scheduled_axis(eq: RelaxedHoverEquilibrium, fraction: float) -> np.ndarray:
    """Primary axis at a fraction s in [0, 1] of the equilibrium spin: the unit vector along
    ``s^2 n_bar + (1 - s^2) (0, 0, -1)`` (the tilt that balances the opposite rotor's torque
    grows with the gyroscopic term, as w^2), the thrust axis at s = 0, n_bar at s = 1."""
    s2 = fraction * fraction
    v = s2 * eq.axis_frd + (1.0 - s2) * np.array([0.0, 0.0, -1.0])
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class ReducedAttitudeCommand:
    """One tick's output.

    Attributes
    ----------
    thrust_n : numpy.ndarray
        Thrust per motor 1..4, N, shape (4,), within [0, K pwm_max]; 0 for the lost motor.
    pwm : numpy.ndarray
        The PWM commands giving them, shape (4,).
    collective_n : float
        U1 = sum of thrust_n, N.
    axis_error : float
        |n - n_bar| of the primary axis, dimensionless (sin of the angle for small errors).
    """

    thrust_n: np.ndarray
    pwm: np.ndarray
    collective_n: float
    axis_error: float


class ReducedAttitudeController:
    """Holds the primary axis of a spinning, one-rotor-down quadrotor on a world direction.

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe (with its rate damping).
    lost_motor : int
        1..4: the motor that no longer follows its command.
    dt_s : float
        Control period, s.
    weights : ReducedAttitudeWeights, optional
        LQR weights and the thrust split.
    fixed_thrust_n : float
        What the failed motor makes whatever it is told, N: 0 when lost (the default), its
        thrust when stuck, full thrust when hard-over; the equilibrium and the gains are
        designed for it, and :meth:`step` may be told its latest estimate.
    opposite_lost : bool
        The motor opposite ``lost_motor`` is lost too: the vehicle flies on the other pair
        (Mueller and D'Andrea's two-propeller relaxed hover, the rho = 0 equilibrium with
        both at zero), and the torque about the lost pair's axis is not an input.

    Attributes
    ----------
    equilibrium : RelaxedHoverEquilibrium
        The relaxed hover it is designed about.
    gain : numpy.ndarray
        Discrete LQR gain at the equilibrium spin, shape (2, 8), v = -gain x with x the
        module docstring's state plus the integrals of dn_x and dn_y.
    """

    def __init__(self, model: VehicleModel, lost_motor: int, dt_s: float,
                 weights: ReducedAttitudeWeights | None = None,
                 fixed_thrust_n: float = 0.0, opposite_lost: bool = False) -> None:
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be > 0")
        self.model = model
        self.lost_motor = lost_motor
        self.dt_s = float(dt_s)
        self.weights = weights if weights is not None else ReducedAttitudeWeights()
        wts = self.weights
        self.fixed_thrust_n = float(fixed_thrust_n)
        self.opposite_lost = bool(opposite_lost)
        if self.opposite_lost:
            # both at zero: rho = 0, no fixed thrust
            self.fixed_thrust_n = 0.0
            self.equilibrium = relaxed_hover(model, lost_motor, 0.0, 0.0)
        elif wts.opposite_ratio is None:
            self.equilibrium = failed_motor_equilibrium(model, lost_motor, self.fixed_thrust_n)
        else:
            self.equilibrium = relaxed_hover(model, lost_motor, wts.opposite_ratio,
                                             self.fixed_thrust_n)
        eq = self.equilibrium
        # the spin the gain schedule spans: the equilibrium's, or at least MIN_SCHEDULE_SPIN
        # (a motor stuck near a quarter of the weight leaves almost no spin to schedule on)
        self._schedule_spin = math.copysign(max(abs(eq.spin_rad_s), MIN_SCHEDULE_SPIN_RAD_S),
                                            eq.spin_rad_s if eq.spin_rad_s != 0.0 else 1.0)
        q = np.diag([wts.q_rate, wts.q_rate, wts.q_axis, wts.q_axis, wts.q_torque,
                     wts.q_torque, wts.q_integral, wts.q_integral])
        lost = lost_motor - 1
        self._lost_row = 1 if lost in (0, 1) else 0
        # with the opposite motor lost too, the one torque input: that of the pair flying
        inputs = [1 - self._lost_row]
        self._schedule = TWO_ROTOR_SCHEDULE if self.opposite_lost else SCHEDULE
        gains = []
        for fraction in self._schedule:
            axis = scheduled_axis(eq, float(fraction))
            a6, b6 = linearisation(model, fraction * self._schedule_spin * axis, axis)
            # integral action on the axis error: d/dt int dn = dn (removes the steady
            # offset the unmodelled terms leave, e.g. the yaw rate's own deviation)
            a = np.zeros((8, 8))
            a[:6, :6] = a6
            a[6, 2] = a[7, 3] = 1.0
            b = np.vstack([b6, np.zeros((2, 2))])
            gain = np.zeros((2, 8))
            if self.opposite_lost:
                # one torque: the body-fixed integrals of the axis error turn with the spin
                # and are out of its reach, so the design goes without them
                (used,) = _discrete_lqr_gain(a6, b6[:, inputs], q[:6, :6],
                                             wts.r_torque * np.eye(1), self.dt_s)
                gain[inputs, :6] = used
            else:
                (gain,) = _discrete_lqr_gain(a, b, q, wts.r_torque * np.eye(2), self.dt_s)
            gains.append(gain)
        self.gains = np.array(gains)  # (len(SCHEDULE), 2, 8)
        self.gain = self.gains[-1]
        self._torque = torque_matrix(model)  # (3, 4), N*m per N
        # the motor opposite the lost one makes the torque about their common axis (row 0:
        # roll, motors 3 and 4; row 1: pitch, motors 1 and 2); the pair on the other axis
        # makes the other torque (eq. 3.2)
        self._opposite = (1, 0, 3, 2)[lost]
        self._pair = (2, 3) if lost in (0, 1) else (0, 1)
        self._decay = math.exp(-model.motor_bandwidth * self.dt_s)
        self._max_thrust_n = model.thrust_gain * model.pwm_max
        self.reset()

    def reset(self, thrust_n: np.ndarray | None = None) -> None:
        """Start the motor model at ``thrust_n`` (N, shape (4,); default the equilibrium's)."""
        start = self.equilibrium.thrust_n if thrust_n is None else np.asarray(thrust_n, float)
        self._thrust_model = np.array(start, dtype=float)
        self._thrust_model[self.lost_motor - 1] = self.fixed_thrust_n
        if self.opposite_lost:
            self._thrust_model[self._opposite] = 0.0
        self._integral = np.zeros(2)  # unit*s, int (n - n_bar)_xy dt

    @property
    def thrust_model(self) -> np.ndarray:
        """N, the controller's model of what each motor makes now (a copy), shape (4,)."""
        return self._thrust_model.copy()

    def spin_fraction(self, rate_frd: np.ndarray) -> float:
        """The spin reached, ``w = r / n_z``, as a fraction in [0, 1] of the one the schedule
        spans (the equilibrium's, at least MIN_SCHEDULE_SPIN_RAD_S), from body rates
        ``rate_frd`` (rad/s)."""
        spin = float(rate_frd[2]) / float(self.equilibrium.axis_frd[2])
        return min(max(spin / self._schedule_spin, 0.0), 1.0)

    def _allocate(self, collective: float, tau_x: float, tau_y: float, fixed_n: float
                  ) -> np.ndarray:
        """Thrusts (N, shape (4,)) of the three remaining motors for U1 and (tau_x, tau_y),
        the failed motor making ``fixed_n`` (N; its entry is that).

        Exact when it fits the range [0, K pwm_max]. Otherwise the torques come first, as in
        the full allocator (a primary axis that points the wrong way turns the collective
        into a sideways push): the opposite motor alone makes the torque about the lost
        pair's axis (clipped to what it can make), the pair on the other axis makes the
        other torque (clipped to the largest difference two motors can make) and then
        shares what it can of the collective."""
        top = self._max_thrust_n
        torques = (tau_x, tau_y)
        thrust = np.zeros(4)
        j, o, row = self.lost_motor - 1, self._opposite, self._lost_row
        thrust[j] = fixed_n
        if not self.opposite_lost:
            thrust[o] = min(max((torques[row] - self._torque[row, j] * fixed_n)
                                / self._torque[row, o], 0.0), top)
        a, b = self._pair
        other = 1 - row
        # tau = arm_a (T_a - T_b): the pair's arms are opposite
        delta = min(max(torques[other] / self._torque[other, a], -top), top)
        share = min(max(collective - thrust[o] - fixed_n, abs(delta)),
                    2.0 * top - abs(delta))
        thrust[a] = 0.5 * (share + delta)
        thrust[b] = 0.5 * (share - delta)
        return thrust

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray, force_ned: np.ndarray,
             max_collective_n: float | None = None, fixed_thrust_n: float | None = None
             ) -> ReducedAttitudeCommand:
        """One tick.

        Parameters
        ----------
        euler_rad : numpy.ndarray
            Estimated roll, pitch, yaw (ZYX), rad, shape (3,).
        rate_frd : numpy.ndarray
            Estimated body rates, rad/s, shape (3,).
        force_ned : numpy.ndarray
            Specific force the mean thrust must give, ``mu - g e3`` (m/s^2, NED), shape (3,):
            what the position loop asks for.
        max_collective_n : float, optional
            The most U1 may be, N (touching down).
        fixed_thrust_n : float, optional
            The latest estimate of what the failed motor makes, N (default: the thrust the
            controller was designed for).
        """
        fixed = self.fixed_thrust_n if fixed_thrust_n is None else float(fixed_thrust_n)
        eq = self.equilibrium
        f = np.asarray(force_ned, dtype=float)
        if not (np.isfinite(f).all() and np.isfinite(euler_rad).all()
                and np.isfinite(rate_frd).all()):
            # a failed estimate (a tumbling vehicle): the equilibrium's thrusts, open loop,
            # until the estimate is finite again (the autopilot judges it unhealthy)
            thrust = np.array(eq.thrust_n, dtype=float)
            self._thrust_model = thrust + self._decay * (self._thrust_model - thrust)
            return ReducedAttitudeCommand(thrust_n=thrust, pwm=thrust / self.model.thrust_gain,
                                          collective_n=float(np.sum(thrust)),
                                          axis_error=math.nan)
        f_norm = float(np.linalg.norm(f))
        direction = f / f_norm if f_norm > 0.0 else np.array([0.0, 0.0, -1.0])
        n = rotation_zyx(euler_rad).T @ direction  # the body vector that must point along d
        # gain scheduling on the spin reached (module docstring)
        fraction = self.spin_fraction(rate_frd)
        axis = scheduled_axis(eq, fraction)
        omega = fraction * self._schedule_spin * axis
        inertia = self.model.inertia_diag
        # the torque that holds omega steady: tau = diag(g) omega + omega x I omega
        tau_ff = (np.asarray(self.model.rate_damping) * omega
                  + np.cross(omega, inertia * omega))[:2]
        schedule = self._schedule
        k = (min(max(fraction, schedule[0]), 1.0) - schedule[0]) / (
            schedule[1] - schedule[0])
        i = min(int(k), len(schedule) - 2)
        gain = self.gains[i] + (k - i) * (self.gains[i + 1] - self.gains[i])
        tau_model = self._torque[:2] @ self._thrust_model
        dn = n[:2] - axis[:2]
        limit = self.weights.integral_limit
        self._integral = np.clip(self._integral + dn * self.dt_s, -limit, limit)
        x = np.concatenate([np.asarray(rate_frd, dtype=float)[:2] - omega[:2], dn,
                            tau_model - tau_ff, self._integral])
        tau_cmd = tau_ff - gain @ x
        # the part of the requested force along the primary axis: a vehicle whose axis is
        # far from where it should point does not push harder the wrong way
        along = max(float(n @ axis), 0.0)
        collective = self.model.mass * f_norm * along / -float(axis[2])
        if max_collective_n is not None:
            collective = min(collective, max_collective_n)
        thrust = self._allocate(collective, float(tau_cmd[0]), float(tau_cmd[1]), fixed)
        # the motors' lag (eq. 3.1), exact over the period; the failed one makes what it makes
        self._thrust_model = thrust + self._decay * (self._thrust_model - thrust)
        self._thrust_model[self.lost_motor - 1] = fixed
        if self.opposite_lost:
            self._thrust_model[self._opposite] = 0.0
        return ReducedAttitudeCommand(thrust_n=thrust, pwm=thrust / self.model.thrust_gain,
                                      collective_n=float(np.sum(thrust)),
                                      axis_error=float(np.linalg.norm(n - axis)))


@cached_design
def _discrete_lqr_gain(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray,
                       dt_s: float) -> tuple[np.ndarray, ...]:
    """Gain of the discrete LQR (``control.dlqr``) of ``x' = a x + b u`` held at ``dt_s`` (s)
    (``control.c2d``, zero-order hold), as a one-element tuple."""
    import control

    n, m = b.shape
    sysd = control.c2d(control.ss(a, b, np.eye(n), np.zeros((n, m))), dt_s, "zoh")
    gain, _, _ = control.dlqr(sysd.A, sysd.B, q, r)
    return (np.asarray(gain),)


def rotation_zyx(euler_rad: np.ndarray) -> np.ndarray:
    """R = Rz(psi) Ry(theta) Rx(phi), body FRD to NED, shape (3, 3)."""
    phi, theta, psi = (float(v) for v in euler_rad)
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    return np.array([
        [cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
        [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
        [-st, ct * sf, ct * cf],
    ])


__all__ = ["ReducedAttitudeCommand", "ReducedAttitudeController", "ReducedAttitudeWeights",
           "linearisation", "rotation_zyx"]
