"""LQR attitude law with integral action (eq. 5.7-5.10), registered as ``"lqg"`` in
:mod:`fcu.control.registry` (fed by an estimator, the thesis's LQG).

Gains come from a discrete design per axis at start-up (:func:`design_axis_lqr`,
``control.dlqr``), the torque then passes through the motor lead
(:mod:`fcu.control.motor_lead`). Interface and reference wiring: :mod:`fcu.control.attitude`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

import fcu.floats
from fcu.control.attitude import LeadFilteredLaw, _euler_rates, check_axes
from fcu.control.motor_lead import lead_tick
from fcu.floats import clip, wrap_pi
from fcu.model import VehicleModel
from flightdata.design_cache import cached_design
from jitsupport.cache import drop_stale_kernels

# lqr_tick compiles in the kernels of attitude and motor_lead, and fcu.floats' helpers
drop_stale_kernels(__file__, fcu.floats.__file__)


@dataclass(frozen=True, kw_only=True)
class LqrWeights:
    """Q = diag(q_integral, q_angle, q_rate) and R = r_torque per axis, anti-windup, lead.

    State per axis ``x = [int (angle - ref) dt, angle - ref, rate - ref_rate]``, input the
    torque deviation from ``I * ref_acc`` (N*m). Read as Bryson's rule (q = 1/x_max^2): roll
    and pitch accept 0.052 deg of angle error, 0.81 deg/s of rate error and 5.8e-4 rad*s of
    integrated error per 5 mN*m of torque. The resulting gains K/I = [256 1/s^3, 195 1/s^2,
    22 1/s] put the discrete closed-loop poles near -11 +/- 7.5j rad/s and -1.6 rad/s (the
    integral, a 0.63 s time constant), stiffer than the PD, as the thesis ranks them. With
    the 60 rad/s :class:`~fcu.control.motor_lead.MotorLead` and the real 15 rad/s motors the
    input sensitivity peak is 1.6 (2.5-2.7 with one extra sample of measurement delay). That
    stiffness is what the motor faults ask for: in the shipped scenario lqg_vbdob_loe (seed
    1, EKF feedback, wind, 15 rad/s reference filter) LQR + VbDOB keeps the roll/pitch error
    under 2 deg and the position error under 17 mm (the thesis's Table 7.7: 2.3 deg, 17 mm);
    the softer q = (1e6, 6e5, 3e3) gives 2.6 deg and 25 mm with a peak of 1.5.
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
        check_axes("q_integral", self.q_integral, positive=False)
        check_axes("q_angle", self.q_angle, positive=True)
        check_axes("q_rate", self.q_rate, positive=False)
        check_axes("r_torque", self.r_torque, positive=True)
        check_axes("integral_torque_limit_nm", self.integral_torque_limit_nm, positive=True)


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

    Made once per configuration and kept (:mod:`flightdata.design_cache`); the arrays are read-only.
    """
    return AxisLqrDesign(*_axis_lqr_arrays(float(inertia_kgm2), float(dt_s),
                                           tuple(float(q) for q in q_diag), float(r_torque)))


@cached_design
def _axis_lqr_arrays(inertia_kgm2: float, dt_s: float, q_diag: tuple[float, ...],
                     r_torque: float) -> tuple[np.ndarray, ...]:
    """:func:`design_axis_lqr`'s arrays, in :class:`AxisLqrDesign`'s order."""
    import control

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
    return a, b, q, r, np.asarray(gain), np.asarray(riccati), np.asarray(poles)


# AttitudeLQR's parameter vector: K per axis (row i = [k_int, k_angle, k_rate]), the inertia
# diagonal (kg*m^2), the integral clamps |z| <= limit/k_int (rad*s), the period (s)
_K, _INERTIA, _Z_LIMIT, _DT = 0, 9, 12, 15
PAR_SIZE = 16


@njit(cache=True, error_model="numpy")
def lqr_tick(par: np.ndarray, z: np.ndarray, lead_par: np.ndarray, lead_state: np.ndarray,
             euler_rad: np.ndarray, rate_frd: np.ndarray, ref_euler_rad: np.ndarray,
             ref_rate: np.ndarray, ref_acc: np.ndarray, out: np.ndarray) -> None:
    """One tick of :class:`AttitudeLQR`: torques [U2, U3, U4] (N*m) by eq. 5.9 through the
    lead into ``out``; advances the integrals ``z`` (rad*s) and the lead's state."""
    rates = _euler_rates(euler_rad[0], euler_rad[1], rate_frd[0], rate_frd[1], rate_frd[2])
    dt = par[_DT]
    for i in range(3):
        err = wrap_pi(euler_rad[i] - ref_euler_rad[i])  # angle - ref, rad
        err_dot = rates[i] - ref_rate[i]  # rad/s
        k = _K + 3 * i
        # eq. 5.9: u = r - K x, r = I ref_acc, x = [z, e, e_dot]
        out[i] = (par[_INERTIA + i] * ref_acc[i]
                  - (par[k] * z[i] + par[k + 1] * err + par[k + 2] * err_dot))
        # z[k+1] = z[k] + dt e[k], clamped (anti-windup)
        z_lim = par[_Z_LIMIT + i]
        z[i] = clip(z[i] + dt * err, -z_lim, z_lim)
    lead_tick(lead_par, lead_state, out)


class AttitudeLQR(LeadFilteredLaw):
    """LQR with integral action per axis, gains designed at construction (eq. 5.9).

    ``U = I ref_acc - K [z, angle - ref, rate - ref_rate]`` with ``z`` the running integral
    of ``angle - ref`` (clamped so ``|k_int z| <= weights.integral_torque_limit_nm``: the
    anti-windup), updated after each output, ``z += dt (angle - ref)``, exactly as in the
    design model. The torque then passes through the
    :class:`~fcu.control.motor_lead.MotorLead` unless ``weights.motor_lead_rad_s`` is None.

    Parameters
    ----------
    model : VehicleModel
        Supplies the inertia diagonal I (kg*m^2) and the motor bandwidth (rad/s).
    weights : LqrWeights
        Q, R, the integral clamp and the lead.
    dt_s : float
        Control period, s (0.01 at 100 Hz).
    """

    _tick = lqr_tick

    def __init__(self, model: VehicleModel, weights: LqrWeights | None = None,
                 dt_s: float = 0.01) -> None:
        self.weights = weights if weights is not None else LqrWeights()
        w = self.weights
        super().__init__(model, dt_s, w.motor_lead_rad_s)
        self.designs: tuple[AxisLqrDesign, ...] = tuple(
            design_axis_lqr(float(model.inertia[i]), self.dt_s,
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
        # the parameters and integrals (rad*s) as lqr_tick reads them
        self._par = np.concatenate([self._k.reshape(9), self._inertia, self._z_limit,
                                    [self.dt_s]])
        self._state = np.zeros(3)

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
        return self._state.copy()
