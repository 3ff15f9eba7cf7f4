"""Attitude control: PD (eq. 5.6) and LQR with integral action (eq. 5.7-5.10).

Both controllers share one interface, :class:`AttitudeController`::

    step(euler_rad, rate_frd, ref_euler_rad, ref_rate, ref_acc) -> torque_nm (3,)

* ``euler_rad``: measured [roll phi, pitch theta, yaw psi] (ZYX, rad);
* ``rate_frd``: measured body rates [p, q, r] (FRD, rad/s), converted to Euler-angle rates
  with the ZYX kinematics (:func:`euler_rates`), so the derivative term acts on the same
  coordinates as the angle error;
* ``ref_euler_rad``, ``ref_rate``, ``ref_acc``: reference angles, Euler-angle rates (rad/s)
  and accelerations (rad/s^2);
* returns [U2 roll, U3 pitch, U4 yaw] torque commands, N*m (eq. 3.2).

References from the position loop (:mod:`fcu.control.position`): its roll/pitch come every
tick without derivatives. Two ways are supported:

1. pass them through :class:`AttitudeReferenceFilter` (the intended wiring, and what the
   default gains are tuned for): a critically damped second-order state-variable filter,
   15 rad/s, whose states are a smoothed reference and its exact first and second
   derivatives. Feeding those forward makes the attitude loop follow the filter closely,
   so the position loop sees a short lag and can be stiff. Raw numerical differences
   (1/dt, 1/dt^2 noise gains) are never used;
2. pass zero rate and acceleration: the loop treats the reference as piecewise constant and
   the derivative term acts on the measured rate only (no derivative kick); the attitude
   response to a reference step is then ``kp / (s^2 + kd s + kp)``, a lag of ``kd/kp``
   that the outer loop has to tolerate (see :class:`fcu.control.position.PositionGains`).

Motor lag. The rotors follow their commands with a 15 rad/s first-order lag (eq. 3.1) that
eq. 5.6/5.10 leave out. With PD alone the three closed-loop poles of
``s^3 + w s^2 + w kd s + w kp`` always sum to ``-w = -15 rad/s``, which caps a well damped
attitude loop at about 5 rad/s and makes a motor fault (a 0.14-0.21 N*m torque step) tilt
the vehicle by 10-17 deg. Both controllers therefore pass their torque through a
:class:`MotorLead` (on by default, ``motor_lead_rad_s``): the discrete lead
``c2d(w_d/(s+w_d)) / c2d(w/(s+w))`` that cancels the (known, nominal) motor pole and puts a
60 rad/s one in its place, so the lag-free model of eq. 5.10 becomes nearly true and the
gains can be six to twelve times stiffer. It multiplies a torque step by 3.2 at first and
high-frequency noise by up to 3.9: fed the raw sensor noise of docs/design.md (0.002 rad,
0.003 rad/s) the motor PWM jitters by about 2.5 % (PD) or 5.5 % (LQR) of its hover value,
less behind an estimator; the mean, hence the control effort, is unchanged. The loop
stays stable with a motor 33 % slower than nominal plus a 10 ms measurement delay
(tests/fcu/test_attitude_control.py).

Per-axis model (eq. 5.10, hover, small angles): ``I_i * angle_ddot_i = U_{i+1}``; the
gyroscopic coupling ``omega x I omega`` and the Euler-rate kinematics are second order at
the small rates of the mission and are left to the feedback (and to the DOB).

Yaw errors are wrapped to [-pi, pi] (roll and pitch too, harmlessly).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import control
import numpy as np

from fcu.floats import clip, floats, wrap_pi
from fcu.model import VehicleModel


def wrap_angle(angle_rad: np.ndarray | float) -> np.ndarray:
    """Wrap angles to [-pi, pi), rad."""
    return (np.asarray(angle_rad, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def euler_rates(euler_rad: np.ndarray, rate_frd: np.ndarray) -> np.ndarray:
    """ZYX Euler-angle rates [phi_dot, theta_dot, psi_dot] (rad/s) from body rates [p, q, r].

    ``eta_dot = W(phi, theta) omega`` with, for R = Rz(psi) Ry(theta) Rx(phi)::

        phi_dot   = p + sin(phi) tan(theta) q + cos(phi) tan(theta) r
        theta_dot =     cos(phi) q            - sin(phi) r
        psi_dot   =    (sin(phi) q + cos(phi) r) / cos(theta)
    """
    phi, theta = float(euler_rad[0]), float(euler_rad[1])
    p, q, r = (float(v) for v in rate_frd)
    return np.array(_euler_rates(phi, theta, p, q, r))


def _euler_rates(phi: float, theta: float, p: float, q: float, r: float
                 ) -> tuple[float, float, float]:
    """:func:`euler_rates` on plain floats (the per-tick path)."""
    # numpy's tan (math.tan may differ in the last bit); sin and cos agree
    sp, cp, ct, tt = math.sin(phi), math.cos(phi), math.cos(theta), float(np.tan(theta))
    return p + sp * tt * q + cp * tt * r, cp * q - sp * r, (sp * q + cp * r) / ct


class AttitudeController(Protocol):
    """What the autopilot needs from an attitude controller."""

    def reset(self) -> None:
        """Forget internal state (integrators)."""
        ...

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray, ref_euler_rad: np.ndarray,
             ref_rate: np.ndarray, ref_acc: np.ndarray) -> np.ndarray:
        """Torques [U2, U3, U4] (N*m), shape (3,), for one control tick."""
        ...


def _triple(name: str, value: tuple[float, float, float], *, positive: bool) -> None:
    """Check a per-axis (roll, pitch, yaw) tuple; raise ValueError naming the key."""
    if len(value) != 3 or not all(np.isfinite(v) for v in value):
        raise ValueError(f"{name} = {value!r}: must be three finite numbers (roll, pitch, yaw)")
    if any((v <= 0) if positive else (v < 0) for v in value):
        bound = "> 0" if positive else ">= 0"
        raise ValueError(f"{name} = {value!r}: each must be {bound}")


# --------------------------------------------------------------------------------------------
# Motor-lag lead
# --------------------------------------------------------------------------------------------
class MotorLead:
    """Discrete lead that swaps the motors' lag for a faster one, per axis.

    ``C(z) = c2d(w_d/(s + w_d)) / c2d(w/(s + w))`` (both ZOH at the loop rate), i.e.
    ``C(z) = G (z - a)/(z - b)`` with ``a = exp(-w dt)``, ``b = exp(-w_d dt)`` and
    ``G = (1 - b)/(1 - a)``: in series with the motors' ZOH-sampled lag it leaves exactly
    the target lag ``w_d``. DC gain 1, step gain G (3.2 for 15 -> 60 rad/s at 100 Hz),
    Nyquist gain ``G (1 + a)/(1 + b)`` (3.9). Because the mixer of eq. 3.2
    is linear and all four motors share the lag, the lead can act on the torques instead of
    on each motor.

    Parameters
    ----------
    motor_bandwidth_rad_s : float
        w, the nominal motor lag (VehicleModel.motor_bandwidth), rad/s.
    target_bandwidth_rad_s : float
        w_d, rad/s, > w.
    dt_s : float
        Loop period, s.
    """

    def __init__(self, motor_bandwidth_rad_s: float, target_bandwidth_rad_s: float,
                 dt_s: float) -> None:
        if not target_bandwidth_rad_s > motor_bandwidth_rad_s:
            raise ValueError(f"motor_lead_rad_s = {target_bandwidth_rad_s!r}: must exceed the "
                             f"motor bandwidth ({motor_bandwidth_rad_s} rad/s) or be None")
        # discrete, first order over first order (designed once per configuration)
        self.transfer_function, self._a, self._b, self._c, self._d = _lead_design(
            float(motor_bandwidth_rad_s), float(target_bandwidth_rad_s), float(dt_s))
        self._x = [0.0, 0.0, 0.0]  # filter state per axis

    @property
    def high_frequency_gain(self) -> float:
        """Gain at the Nyquist frequency, |C(-1)| (noise amplification)."""
        return float(abs(np.squeeze(self.transfer_function(-1.0))))

    def reset(self) -> None:
        """Zero the filter state."""
        self._x = [0.0, 0.0, 0.0]

    def step(self, torque_nm: np.ndarray) -> np.ndarray:
        """Lead-filtered torque (N*m), shape (3,)."""
        return np.array(self._step(floats(torque_nm, 3)))

    def _step(self, u: list[float]) -> list[float]:
        """:meth:`step` on plain floats."""
        a, b, c, d, x = self._a, self._b, self._c, self._d, self._x
        y = [c * x[i] + d * u[i] for i in range(3)]  # y[k] = C x[k] + D u[k]
        self._x = [a * x[i] + b * u[i] for i in range(3)]  # x[k+1] = A x[k] + B u[k]
        return y


# The designs of this module (_lead_design, _shared_axis_lqr, _reference_filter_design) call
# python-control's c2d and dlqr, hence scipy's expm and solve, which wake OpenBLAS's worker
# threads; those then spin for about 0.1 s of CPU time. Each design is a pure function of
# its (hashable) parameters, so it is made once per process and configuration: a process
# that builds many controllers (a batch of flights, a benchmark, the tests) pays that once.
# Cached arrays are read-only.
@functools.lru_cache(maxsize=16)
def _lead_design(w: float, wd: float, dt_s: float
                 ) -> tuple[control.TransferFunction, float, float, float, float]:
    """:class:`MotorLead`'s ``C(z)`` and its first-order realisation (A, B, C, D)."""
    target = control.c2d(control.tf([wd], [1.0, wd]), dt_s, method="zoh")
    motor = control.c2d(control.tf([w], [1.0, w]), dt_s, method="zoh")
    transfer_function = target / motor  # discrete, first order over first order
    realised = control.ss(transfer_function)
    return (transfer_function, float(np.asarray(realised.A)[0, 0]),
            float(np.asarray(realised.B)[0, 0]), float(np.asarray(realised.C)[0, 0]),
            float(np.asarray(realised.D)[0, 0]))


def _make_lead(model: VehicleModel, motor_lead_rad_s: float | None,
               dt_s: float) -> MotorLead | None:
    if motor_lead_rad_s is None:
        return None
    return MotorLead(model.motor_bandwidth, motor_lead_rad_s, dt_s)


def _check_dt(dt_s: float) -> None:
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s = {dt_s!r}: must be > 0")


# --------------------------------------------------------------------------------------------
# PD, eq. 5.6
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class AttitudePdGains:
    """Gains of eq. 5.6, per axis (roll, pitch, yaw), and the motor lead they assume.

    With the 60 rad/s lead, roll/pitch kp = 100 1/s^2, kd = 16 1/s (natural frequency
    10 rad/s, damping 0.8 on the ideal double integrator) keep the input sensitivity peak
    at 1.6 with the motors, the 100 Hz hold and the position loop closed (2.2 with one
    extra sample of measurement delay), and leave a 2.7 deg standing error for a
    0.14 N*m motor-fault torque (the PD has no integral: eq. 5.6; that is what the DOBs
    are for). Yaw is kept soft, kp = 16, kd = 7: its torque authority is small (K K_psi,
    about +/-0.16 N*m at hover), so every N*m of yaw torque costs 4.3 times the PWM of a
    roll torque and sensor noise on yaw would dominate the motor commands. Without the lead
    (``motor_lead_rad_s=None``) the three closed-loop poles sum to -15 rad/s: use about
    kp = 16, kd = 7 on every axis there.
    """

    kp: tuple[float, float, float] = (100.0, 100.0, 16.0)  # 1/s^2, angle error -> ang. accel
    kd: tuple[float, float, float] = (16.0, 16.0, 7.0)  # 1/s, rate error -> ang. accel
    motor_lead_rad_s: float | None = 60.0  # rad/s, MotorLead target; None = plain eq. 5.6

    def __post_init__(self) -> None:
        _triple("kp", self.kp, positive=True)
        _triple("kd", self.kd, positive=True)


class AttitudePD:
    """Eq. 5.6: ``U = I (ref_acc + kp e + kd e_dot)`` per axis, ``e = ref - angle`` (wrapped).

    The torque then passes through the :class:`MotorLead` unless
    ``gains.motor_lead_rad_s`` is None.

    Parameters
    ----------
    model : VehicleModel
        Supplies the inertia diagonal I (kg*m^2) and the motor bandwidth (rad/s).
    gains : AttitudePdGains
        kp (1/s^2) and kd (1/s) per axis, and the lead.
    dt_s : float
        Control period, s (used by the lead only).
    """

    def __init__(self, model: VehicleModel, gains: AttitudePdGains | None = None,
                 dt_s: float = 0.01) -> None:
        _check_dt(dt_s)
        self.model = model
        self.gains = gains if gains is not None else AttitudePdGains()
        self.dt_s = float(dt_s)
        self._inertia = model.inertia_diag
        self._kp = np.array(self.gains.kp)
        self._kd = np.array(self.gains.kd)
        self._inertia_f, self._kp_f, self._kd_f = (self._inertia.tolist(), self._kp.tolist(),
                                                   self._kd.tolist())
        self.lead = _make_lead(model, self.gains.motor_lead_rad_s, self.dt_s)

    def reset(self) -> None:
        """Zero the lead filter (the PD itself has no state)."""
        if self.lead is not None:
            self.lead.reset()

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray, ref_euler_rad: np.ndarray,
             ref_rate: np.ndarray, ref_acc: np.ndarray) -> np.ndarray:
        """Torques [U2, U3, U4] (N*m) by eq. 5.6; arguments as in the module docstring."""
        # per axis in plain floats (3-vectors: numpy's overhead would dominate)
        euler, ref = floats(euler_rad, 3), floats(ref_euler_rad, 3)
        ref_rate_f, ref_acc_f = floats(ref_rate, 3), floats(ref_acc, 3)
        p, q, r = floats(rate_frd, 3)
        rates = _euler_rates(euler[0], euler[1], p, q, r)
        inertia, kp, kd = self._inertia_f, self._kp_f, self._kd_f
        torque = []
        for i in range(3):
            e = wrap_pi(ref[i] - euler[i])  # eq. 5.1 (rad)
            e_dot = ref_rate_f[i] - rates[i]  # rad/s
            # eq. 5.6: U = I (ddot_ref + kp e + kd e_dot)
            torque.append(inertia[i] * (ref_acc_f[i] + kp[i] * e + kd[i] * e_dot))
        return np.array(torque if self.lead is None else self.lead._step(torque))


# --------------------------------------------------------------------------------------------
# LQR with integral action, eq. 5.7-5.10
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class LqrWeights:
    """Q = diag(q_integral, q_angle, q_rate) and R = r_torque per axis, anti-windup, lead.

    State per axis ``x = [int (angle - ref) dt, angle - ref, rate - ref_rate]``, input the
    torque deviation from ``I * ref_acc`` (N*m). Read as Bryson's rule (q = 1/x_max^2): roll
    and pitch accept 0.052 deg of angle error, 0.81 deg/s of rate error and 5.8e-4 rad*s of
    integrated error per 5 mN*m of torque. The resulting gains K/I = [256 1/s^3, 195 1/s^2,
    22 1/s] put the discrete closed-loop poles near -11 +/- 7.5j rad/s and -1.6 rad/s (the
    integral, a 0.63 s time constant), stiffer than the PD, as the thesis ranks them. With
    the 60 rad/s :class:`MotorLead` and the real 15 rad/s motors the input sensitivity peak
    is 1.6 (2.5-2.7 with one extra sample of measurement delay). That stiffness is what the
    motor faults ask for: in the shipped scenario lqg_vbdob_loe (seed 1, EKF feedback, wind,
    15 rad/s reference filter) LQR + VbDOB keeps the roll/pitch error under 2 deg and the
    position error under 17 mm (the thesis's Table 7.7: 2.3 deg, 17 mm); the softer
    q = (1e6, 6e5, 3e3) gives 2.6 deg and 25 mm with a peak of 1.5.
    Yaw (I = 0.04, torque authority +/-0.16 N*m): K/I = [37, 47, 11], peak 1.25.

    ``integral_torque_limit_nm`` clamps the integral's share of the torque (``|k_int z|``),
    sized for faults: a 30 % loss of effectiveness on one motor needs about 0.2-0.25 N*m of
    steady roll/pitch torque, while a hovering Qball-X4 has about +/-0.7 N*m of roll/pitch
    authority and +/-0.16 N*m of yaw.
    """

    q_integral: tuple[float, float, float] = (3.0e6, 3.0e6, 1.0e5)  # 1/(rad*s)^2
    q_angle: tuple[float, float, float] = (1.2e6, 1.2e6, 1.0e5)  # 1/rad^2
    q_rate: tuple[float, float, float] = (5000.0, 5000.0, 1500.0)  # 1/(rad/s)^2
    r_torque: tuple[float, float, float] = (4.0e4, 4.0e4, 4.0e4)  # 1/(N*m)^2
    integral_torque_limit_nm: tuple[float, float, float] = (0.5, 0.5, 0.15)  # N*m, |k_int z|
    motor_lead_rad_s: float | None = 60.0  # rad/s, MotorLead target; None = no lead

    def __post_init__(self) -> None:
        _triple("q_integral", self.q_integral, positive=False)
        _triple("q_angle", self.q_angle, positive=True)
        _triple("q_rate", self.q_rate, positive=False)
        _triple("r_torque", self.r_torque, positive=True)
        _triple("integral_torque_limit_nm", self.integral_torque_limit_nm, positive=True)


@dataclass(frozen=True)
class AxisLqrDesign:
    """The discrete design of one axis, kept for inspection and tests.

    Attributes
    ----------
    a, b : numpy.ndarray
        Discrete augmented model x[k+1] = a x[k] + b u[k], shapes (3, 3) and (3, 1).
    q, r : numpy.ndarray
        Weights, (3, 3) and (1, 1).
    gain : numpy.ndarray
        K, shape (1, 3): u = -K x, units [N*m/(rad*s), N*m/rad, N*m/(rad/s)].
    riccati : numpy.ndarray
        P, (3, 3), the stabilising solution of the discrete algebraic Riccati equation
        P = a'Pa - a'Pb (r + b'Pb)^-1 b'Pa + q.
    closed_loop_poles : numpy.ndarray
        Eigenvalues of a - b K (z-plane), shape (3,).
    """

    a: np.ndarray
    b: np.ndarray
    q: np.ndarray
    r: np.ndarray
    gain: np.ndarray
    riccati: np.ndarray
    closed_loop_poles: np.ndarray


def design_axis_lqr(inertia_kgm2: float, dt_s: float, q_diag: tuple[float, float, float],
                    r_torque: float) -> AxisLqrDesign:
    """Discrete LQR with integral action for one axis (eq. 5.7-5.10).

    The continuous double integrator of eq. 5.10, ``d/dt [e, e_dot] = [[0, 1], [0, 0]] x +
    [0, 1/I] u`` (e = angle - ref), is discretised with a zero-order hold at the loop rate
    (``control.c2d``; exact for the held torque), then augmented with the discrete integral
    the controller actually runs, ``z[k+1] = z[k] + dt e[k]``. ``control.dlqr`` then minimises
    eq. 5.8 for the sampled loop itself. A continuous ``lqr`` design would ignore the hold,
    which at 100 Hz costs ``wc dt / 2`` of phase (about 3 deg at a 10 rad/s crossover) that
    the motors have already spent; the discrete one is exact for the sampled plant.
    """
    # eq. 5.10 per axis, states [e, e_dot], input torque deviation (N*m)
    plant = control.ss([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0 / inertia_kgm2]], np.eye(2),
                       np.zeros((2, 1)))
    plant_d = control.c2d(plant, dt_s, method="zoh")
    a = np.zeros((3, 3))
    a[0, 0], a[0, 1] = 1.0, dt_s  # z[k+1] = z[k] + dt e[k]
    a[1:, 1:] = plant_d.A
    b = np.vstack([[0.0], plant_d.B])
    q = np.diag(np.asarray(q_diag, dtype=float))
    r = np.array([[float(r_torque)]])
    gain, riccati, poles = control.dlqr(a, b, q, r)
    return AxisLqrDesign(a=a, b=b, q=q, r=r, gain=np.asarray(gain),
                         riccati=np.asarray(riccati), closed_loop_poles=np.asarray(poles))


@functools.lru_cache(maxsize=32)
def _shared_axis_lqr(inertia_kgm2: float, dt_s: float, q_diag: tuple[float, float, float],
                     r_torque: float) -> AxisLqrDesign:
    """:func:`design_axis_lqr`, made once per configuration (read-only arrays)."""
    design = design_axis_lqr(inertia_kgm2, dt_s, q_diag, r_torque)
    for arr in (design.a, design.b, design.q, design.r, design.gain, design.riccati,
                design.closed_loop_poles):
        arr.setflags(write=False)
    return design


@dataclass
class _LqrState:
    integral: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # rad*s per axis


class AttitudeLQR:
    """LQR with integral action per axis, gains designed at construction (eq. 5.9).

    ``U = I ref_acc - K [z, angle - ref, rate - ref_rate]`` with ``z`` the running integral
    of ``angle - ref`` (clamped so ``|k_int z| <= weights.integral_torque_limit_nm``: the
    anti-windup), updated after each output, ``z += dt (angle - ref)``, exactly as in the
    design model. The torque then passes through the :class:`MotorLead` unless
    ``weights.motor_lead_rad_s`` is None.

    Parameters
    ----------
    model : VehicleModel
        Supplies the inertia diagonal I (kg*m^2) and the motor bandwidth (rad/s).
    weights : LqrWeights
        Q, R, the integral clamp and the lead.
    dt_s : float
        Control period, s (0.01 at 100 Hz).
    """

    def __init__(self, model: VehicleModel, weights: LqrWeights | None = None,
                 dt_s: float = 0.01) -> None:
        _check_dt(dt_s)
        self.model = model
        self.weights = weights if weights is not None else LqrWeights()
        self.dt_s = float(dt_s)
        w = self.weights
        self.designs: tuple[AxisLqrDesign, ...] = tuple(
            _shared_axis_lqr(float(model.inertia[i]), self.dt_s,
                             (float(w.q_integral[i]), float(w.q_angle[i]),
                              float(w.q_rate[i])), float(w.r_torque[i]))
            for i in range(3))
        self._inertia = model.inertia_diag
        self._k = np.vstack([d.gain for d in self.designs])  # (3, 3)
        # |k_int z| <= torque limit  <=>  |z| <= limit / k_int (z stays 0 where k_int = 0)
        k_int = self._k[:, 0]
        with np.errstate(divide="ignore"):
            self._z_limit = np.where(k_int > 0, np.array(w.integral_torque_limit_nm) / k_int,
                                     0.0)
        self.lead = _make_lead(model, w.motor_lead_rad_s, self.dt_s)
        # the same as plain floats, for the per-tick path
        self._k_f = self._k.tolist()
        self._inertia_f = self._inertia.tolist()
        self._z_limit_f = self._z_limit.tolist()
        self._state = _LqrState()

    @property
    def gain(self) -> np.ndarray:
        """K per axis, shape (3, 3): row i = [k_int, k_angle, k_rate] of axis i."""
        return self._k.copy()

    @property
    def riccati(self) -> np.ndarray:
        """Riccati solutions P per axis, shape (3, 3, 3)."""
        return np.stack([d.riccati for d in self.designs])

    @property
    def integral(self) -> np.ndarray:
        """Current integral states z (rad*s), shape (3,)."""
        return np.array(self._state.integral)

    def reset(self) -> None:
        """Zero the integrators and the lead."""
        self._state = _LqrState()
        if self.lead is not None:
            self.lead.reset()

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray, ref_euler_rad: np.ndarray,
             ref_rate: np.ndarray, ref_acc: np.ndarray) -> np.ndarray:
        """Torques [U2, U3, U4] (N*m) by eq. 5.9; arguments as in the module docstring."""
        # per axis in plain floats (3-vectors: numpy's overhead would dominate)
        euler, ref = floats(euler_rad, 3), floats(ref_euler_rad, 3)
        ref_rate_f, ref_acc_f = floats(ref_rate, 3), floats(ref_acc, 3)
        p, q, r = floats(rate_frd, 3)
        rates = _euler_rates(euler[0], euler[1], p, q, r)
        k, inertia, z_lim, dt = self._k_f, self._inertia_f, self._z_limit_f, self.dt_s
        z = self._state.integral
        torque, z_next = [], []
        for i in range(3):
            err = wrap_pi(euler[i] - ref[i])  # angle - ref, rad
            err_dot = rates[i] - ref_rate_f[i]  # rad/s
            # eq. 5.9: u = r - K x, r = I ref_acc, x = [z, e, e_dot]
            torque.append(inertia[i] * ref_acc_f[i]
                          - (k[i][0] * z[i] + k[i][1] * err + k[i][2] * err_dot))
            # z[k+1] = z[k] + dt e[k], clamped (anti-windup)
            z_next.append(clip(z[i] + dt * err, -z_lim[i], z_lim[i]))
        self._state.integral = z_next
        return np.array(torque if self.lead is None else self.lead._step(torque))


# --------------------------------------------------------------------------------------------
# Reference shaping between the position and attitude loops
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class AttitudeReference:
    """A smoothed attitude reference and its derivatives, ZYX Euler.

    Attributes
    ----------
    euler_rad : numpy.ndarray
        Reference [roll, pitch, yaw], rad, shape (3,).
    rate : numpy.ndarray
        Its time derivative, rad/s, shape (3,).
    acc : numpy.ndarray
        Its second derivative, rad/s^2, shape (3,).
    """

    euler_rad: np.ndarray
    rate: np.ndarray
    acc: np.ndarray


@functools.lru_cache(maxsize=16)
def _reference_filter_design(dt_s: float, wf: float, zf: float
                             ) -> tuple[control.StateSpace, control.StateSpace]:
    """:class:`AttitudeReferenceFilter`'s continuous model and its ZOH discretisation."""
    continuous = control.ss([[0.0, 1.0], [-wf * wf, -2.0 * zf * wf]], [[0.0], [wf * wf]],
                            np.eye(2), np.zeros((2, 1)))
    return continuous, control.c2d(continuous, dt_s, method="zoh")


class AttitudeReferenceFilter:
    """Second-order state-variable filter giving a reference with consistent derivatives.

    Per axis ``theta_f'' = w_f^2 (theta_r - theta_f) - 2 zeta w_f theta_f'``, i.e.
    ``theta_f = w_f^2 / (s^2 + 2 zeta w_f s + w_f^2) theta_r``; its states (theta_f,
    theta_f') and the acceleration computed from them are handed to the attitude controller
    as (ref_euler, ref_rate, ref_acc). Discretised with ``control.c2d`` (ZOH: the raw
    reference is held between ticks). The outputs at tick k are the filter's state at k (so
    the error ``theta_f - theta`` compares the same instant) and the acceleration at the
    start of the interval; the state then advances with the new input.

    The input difference is wrapped to [-pi, pi] so a yaw reference crossing +/-pi does not
    spin the filter round; the output angle is wrapped too.

    Parameters
    ----------
    dt_s : float
        Control period, s.
    bandwidth_rad_s : float
        w_f, rad/s. 15 rad/s: about the attitude loop's own bandwidth, so the shaped
        reference is one the loop can follow, with a short lag (2 zeta / w_f = 0.13 s) for
        the position loop; the acceleration output amplifies reference noise by
        w_f^2 = 225.
    damping : float
        zeta, 1 = critically damped (no overshoot of the tilt reference).
    """

    def __init__(self, dt_s: float = 0.01, bandwidth_rad_s: float = 15.0,
                 damping: float = 1.0) -> None:
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be > 0")
        if not (np.isfinite(bandwidth_rad_s) and 0 < bandwidth_rad_s < np.pi / dt_s):
            raise ValueError(f"bandwidth_rad_s = {bandwidth_rad_s!r}: must be in (0, pi/dt_s)")
        if not (np.isfinite(damping) and damping > 0):
            raise ValueError(f"damping = {damping!r}: must be > 0")
        self.dt_s = float(dt_s)
        self.bandwidth_rad_s = float(bandwidth_rad_s)
        self.damping = float(damping)
        wf, zf = self.bandwidth_rad_s, self.damping
        # states [theta_f, theta_f'], input theta_r - (wrapped offset handled in step)
        self.continuous, self.discrete = _reference_filter_design(self.dt_s, wf, zf)
        self._a = np.asarray(self.discrete.A)
        self._b = np.asarray(self.discrete.B)[:, 0]
        self._a_f, self._b_f = self._a.tolist(), self._b.tolist()
        self._angle: list[float] | None = None  # theta_f per axis, rad (unwrapped)
        self._rate = [0.0, 0.0, 0.0]  # theta_f', rad/s

    def reset(self, euler_rad: np.ndarray | None = None) -> None:
        """Forget the state; start at rest on ``euler_rad`` (else on the next input)."""
        self._angle = None if euler_rad is None else floats(euler_rad, 3)
        self._rate = [0.0, 0.0, 0.0]

    def step(self, ref_euler_rad: np.ndarray | Sequence[float]) -> AttitudeReference:
        """Filter one raw reference [roll, pitch, yaw] (rad); see the class docstring."""
        raw = floats(ref_euler_rad, 3)
        if self._angle is None:
            self._angle = list(raw)
        wf, zf = self.bandwidth_rad_s, self.damping
        (a00, a01), (a10, a11) = self._a_f
        b0, b1 = self._b_f
        angle, rate = self._angle, self._rate
        out_angle, acc, new_angle, new_rate = [], [], [], []
        for i in range(3):  # per axis, in plain floats
            th, th_dot = angle[i], rate[i]
            # work in coordinates relative to the filter angle: input offset wrapped
            offset = wrap_pi(raw[i] - th)  # theta_r - theta_f, rad
            # theta_f'' at the start of the interval
            acc.append(wf * wf * offset - 2.0 * zf * wf * th_dot)
            out_angle.append(wrap_pi(th))
            # [theta_f, theta_f'][k+1] = A [theta_f, theta_f'][k] + B theta_r[k]  (ZOH), with
            # theta_r[k] = theta_f[k] + offset so a 2 pi jump of the raw yaw is not followed;
            # the dynamics are shift-invariant in the angle (A[:, 0] + B = [1, 0]): keep it
            # wrapped
            new_angle.append(wrap_pi(a00 * th + a01 * th_dot + b0 * (th + offset)))
            new_rate.append(a10 * th + a11 * th_dot + b1 * (th + offset))
        out = AttitudeReference(euler_rad=np.array(out_angle), rate=np.array(rate),
                                acc=np.array(acc))
        self._angle, self._rate = new_angle, new_rate
        return out
