"""What the attitude laws share: their interface, the measured Euler-angle rates and the
per-tick frame around each law's torque.

Every attitude law (PD, eq. 5.6, :mod:`fcu.control.attitude_pd`; LQR with integral action,
eq. 5.7-5.10, :mod:`fcu.control.attitude_lqr`) has the interface of
:class:`fcu.control.registry.AttitudeLaw`::

    step(euler_rad, rate_frd, ref_euler_rad, ref_rate, ref_acc) -> torque_nm (3,)

* ``euler_rad``: measured [roll phi, pitch theta, yaw psi] (ZYX, rad);
* ``rate_frd``: measured body rates [p, q, r] (FRD, rad/s), converted to Euler-angle rates
  with the ZYX kinematics (:func:`euler_rates`, eq. 3.10), so the derivative term acts on
  the same coordinates as the angle error;
* ``ref_euler_rad``, ``ref_rate``, ``ref_acc``: reference angles, Euler-angle rates (rad/s)
  and accelerations (rad/s^2);
* returns [U2 roll, U3 pitch, U4 yaw] torque commands, N*m (eq. 3.2).

References from the position loop (:mod:`fcu.control.position`): its roll/pitch come every
tick without derivatives. Two ways are supported:

1. pass them through :class:`~fcu.control.attitude_reference.AttitudeReferenceFilter` (the
   intended wiring, and what the default gains are tuned for): a critically damped
   second-order state-variable filter, 15 rad/s, whose states are a smoothed reference and
   its exact first and second derivatives. Feeding those forward makes the attitude loop
   follow the filter closely, so the position loop sees a short lag and can be stiff. Raw
   numerical differences (1/dt, 1/dt^2 noise gains) are never used;
2. pass zero rate and acceleration: the loop treats the reference as piecewise constant and
   the derivative term acts on the measured rate only (no derivative kick); the attitude
   response to a reference step is then ``kp / (s^2 + kd s + kp)``, a lag of ``kd/kp``
   that the outer loop has to tolerate (see :class:`fcu.control.position.PositionGains`).

Both laws pass their torque through a :class:`~fcu.control.motor_lead.MotorLead` (on by
default) that cancels the motors' 15 rad/s lag (eq. 3.1); :class:`LeadFilteredLaw` is the
frame that does it. Per-axis model (eq. 5.10, hover, small angles):
``I_i * angle_ddot_i = U_{i+1}``; the gyroscopic coupling ``omega x I omega`` and the
Euler-rate kinematics are second order at the small rates of the mission and are left to the
feedback (and to the DOB). Yaw errors are wrapped to [-pi, pi] (roll and pitch too,
harmlessly).

A new attitude law is its own module (a :class:`LeadFilteredLaw` subclass, or any class with
the interface above) plus one line in :mod:`fcu.control.registry`, under a name appended to
``flightdata.vocabulary.ATTITUDE_LAWS``. The per-tick arithmetic of each law is a compiled
kernel of its module (``pd_tick``, ``lqr_tick``) on the law's parameter and state vectors;
:mod:`fcu.control.chain` calls them inside the autopilot's one compiled control tick and runs
any other law through its ``step``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numba import njit

from fcu.control.motor_lead import PAR_SIZE as LEAD_PAR_SIZE
from fcu.control.motor_lead import MotorLead
from fcu.model import VehicleModel
from jitsupport.layout import hold


def wrap_angle(angle_rad: np.ndarray | float) -> np.ndarray:
    """Wrap angles to [-pi, pi), rad."""
    return (np.asarray(angle_rad, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def euler_rates(euler_rad: np.ndarray, rate_frd: np.ndarray) -> np.ndarray:
    """ZYX Euler-angle rates [phi_dot, theta_dot, psi_dot] (rad/s) from body rates [p, q, r].

    ``eta_dot = W(phi, theta) omega`` (eq. 3.10) with, for R = Rz(psi) Ry(theta) Rx(phi)::

        phi_dot   = p + sin(phi) tan(theta) q + cos(phi) tan(theta) r
        theta_dot =     cos(phi) q            - sin(phi) r
        psi_dot   =    (sin(phi) q + cos(phi) r) / cos(theta)
    """
    phi, theta = float(euler_rad[0]), float(euler_rad[1])
    p, q, r = (float(v) for v in rate_frd)
    return np.array(_euler_rates(phi, theta, p, q, r))


@njit(cache=True, error_model="numpy")
def _euler_rates(phi: float, theta: float, p: float, q: float, r: float
                 ) -> tuple[float, float, float]:
    """:func:`euler_rates` on plain floats (the per-tick path, compiled)."""
    sp, cp, ct, tt = math.sin(phi), math.cos(phi), math.cos(theta), np.tan(theta)
    # eq. 3.10: eta_dot = W(phi, theta) omega
    return p + sp * tt * q + cp * tt * r, cp * q - sp * r, (sp * q + cp * r) / ct


def check_axes(name: str, value: tuple[float, float, float], *, positive: bool) -> None:
    """Check a per-axis (roll, pitch, yaw) tuple; raise ValueError naming the key."""
    if len(value) != 3 or not all(np.isfinite(v) for v in value):
        raise ValueError(f"{name} = {value!r}: must be three finite numbers (roll, pitch, yaw)")
    if any((v <= 0) if positive else (v < 0) for v in value):
        bound = "> 0" if positive else ">= 0"
        raise ValueError(f"{name} = {value!r}: each must be {bound}")


def check_period(dt_s: float) -> None:
    """Raise ValueError unless the control period ``dt_s`` (s) is finite and > 0."""
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s = {dt_s!r}: must be > 0")


LawTick = Callable[..., None]
"""A law's compiled tick: ``(par, state, lead_par, lead_state, euler_rad, rate_frd,
ref_euler_rad, ref_rate, ref_acc, out)``, writes the torque (N*m) after the lead to ``out``."""


class LeadFilteredLaw:
    """The frame of an attitude law: its kernel's torque through the lead.

    A law subclasses it, names its compiled tick (:data:`LawTick`) in ``_tick`` and fills
    ``_par`` (gains) and ``_state`` (integrators; may stay empty). The tick converts the
    body rates to Euler-angle rates (eq. 3.10, :func:`_euler_rates`), computes the law's
    torque and passes it through the :class:`MotorLead` (:func:`~fcu.control.motor_lead.
    lead_tick`) unless ``motor_lead_rad_s`` is None.

    Parameters
    ----------
    model : VehicleModel
        Supplies the motor bandwidth (rad/s) the lead cancels.
    dt_s : float
        Control period, s.
    motor_lead_rad_s : float or None
        Target bandwidth of the lead, rad/s; None = no lead.
    """

    _tick: LawTick

    def __init__(self, model: VehicleModel, dt_s: float, motor_lead_rad_s: float | None
                 ) -> None:
        check_period(dt_s)
        self.model = model
        self.dt_s = float(dt_s)
        self.lead = (None if motor_lead_rad_s is None
                     else MotorLead(model.motor_bandwidth, motor_lead_rad_s, self.dt_s))
        # the lead's parameters and state as the kernels read them (all zeros: no lead)
        self._lead_par = self.lead.par if self.lead is not None else np.zeros(LEAD_PAR_SIZE)
        self._lead_state = self.lead.state if self.lead is not None else np.zeros(3)
        self._par = np.zeros(0)
        self._state = np.zeros(0)

    # ---- the compiled chain's view (fcu.control.chain.CompiledPart) -----------------------
    def kernel_params(self) -> tuple[np.ndarray, ...]:
        """What the compiled tick reads: the law's gains, then the motor lead's coefficients."""
        return (self._par, self._lead_par)

    def kernel_states(self) -> tuple[np.ndarray, ...]:
        """What the compiled tick updates: the law's integrators (may be empty), then the
        lead's state (3)."""
        return (self._state, self._lead_state)

    def hold_states_in(self, views: Sequence[np.ndarray]) -> None:
        """Keep :meth:`kernel_states` in ``views`` (same sizes) from now on."""
        self._state, self._lead_state = (hold(v, s) for v, s in zip(
            views, self.kernel_states(), strict=True))
        if self.lead is not None:  # the lead's own step works on the same state
            self.lead.state = self._lead_state

    def reset(self) -> None:
        """Zero the law's integrators and the lead filter."""
        self._state[:] = 0.0
        if self.lead is not None:
            self.lead.reset()

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray, ref_euler_rad: np.ndarray,
             ref_rate: np.ndarray, ref_acc: np.ndarray) -> np.ndarray:
        """Torques [U2, U3, U4] (N*m), shape (3,); arguments as in the module docstring."""
        out = np.empty(3)
        type(self)._tick(self._par, self._state, self._lead_par, self._lead_state,
                         _vec3(euler_rad), _vec3(rate_frd), _vec3(ref_euler_rad),
                         _vec3(ref_rate), _vec3(ref_acc), out)
        return out


def _vec3(value: np.ndarray) -> np.ndarray:
    """A float64 3-vector the kernels accept (the array itself when it already is one)."""
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (3,):
        return value
    return np.ascontiguousarray(value, dtype=float).reshape(3)
