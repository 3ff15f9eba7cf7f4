"""PD attitude law (eq. 5.6), registered as ``"pd"`` in :mod:`fcu.control.registry`.

``U = I (ref_acc + kp e + kd e_dot)`` per axis, ``e = ref - angle`` (eq. 5.1, wrapped), the
torque then through the motor lead (:mod:`fcu.control.motor_lead`). Interface and reference
wiring: :mod:`fcu.control.attitude`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

import fcu.floats
from fcu.control.attitude import LeadFilteredLaw, _euler_rates, check_axes
from fcu.control.motor_lead import lead_tick
from fcu.floats import wrap_pi
from fcu.model import VehicleModel
from jitsupport.cache import drop_stale_kernels

# pd_tick compiles in the kernels of attitude and motor_lead, and fcu.floats' helpers
drop_stale_kernels(__file__, fcu.floats.__file__)


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
        check_axes("kp", self.kp, positive=True)
        check_axes("kd", self.kd, positive=True)


# AttitudePD's parameter vector: the inertia diagonal (kg*m^2), kp (1/s^2), kd (1/s)
_INERTIA, _KP, _KD = 0, 3, 6
PAR_SIZE = 9


@njit(cache=True, error_model="numpy")
def pd_tick(par: np.ndarray, state: np.ndarray, lead_par: np.ndarray, lead_state: np.ndarray,
            euler_rad: np.ndarray, rate_frd: np.ndarray, ref_euler_rad: np.ndarray,
            ref_rate: np.ndarray, ref_acc: np.ndarray, out: np.ndarray) -> None:
    """One tick of :class:`AttitudePD`: torques [U2, U3, U4] (N*m) by eq. 5.6 through the lead
    into ``out`` (``state`` is unused: the PD has none); advances the lead's state."""
    rates = _euler_rates(euler_rad[0], euler_rad[1], rate_frd[0], rate_frd[1], rate_frd[2])
    for i in range(3):
        e = wrap_pi(ref_euler_rad[i] - euler_rad[i])  # eq. 5.1 (rad)
        e_dot = ref_rate[i] - rates[i]  # rad/s
        # eq. 5.6: U = I (ddot_ref + kp e + kd e_dot)
        out[i] = par[_INERTIA + i] * (ref_acc[i] + par[_KP + i] * e + par[_KD + i] * e_dot)
    lead_tick(lead_par, lead_state, out)


class AttitudePD(LeadFilteredLaw):
    """Eq. 5.6: ``U = I (ref_acc + kp e + kd e_dot)`` per axis, ``e = ref - angle`` (wrapped).

    The torque then passes through the :class:`~fcu.control.motor_lead.MotorLead` unless
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

    _tick = pd_tick

    def __init__(self, model: VehicleModel, gains: AttitudePdGains | None = None,
                 dt_s: float = 0.01) -> None:
        self.gains = gains if gains is not None else AttitudePdGains()
        super().__init__(model, dt_s, self.gains.motor_lead_rad_s)
        self._inertia = model.inertia_diag
        self._kp = np.array(self.gains.kp)
        self._kd = np.array(self.gains.kd)
        self._par = np.concatenate([self._inertia, self._kp, self._kd])  # pd_tick's
