"""PD attitude law (eq. 5.6), registered as ``"pd"`` in :mod:`fcu.control.registry`.

``U = I (ref_acc + kp e + kd e_dot)`` per axis, ``e = ref - angle`` (eq. 5.1, wrapped), the
torque then through the motor lead (:mod:`fcu.control.motor_lead`). Interface and reference
wiring: :mod:`fcu.control.attitude`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fcu.control.attitude import LeadFilteredLaw, check_axes
from fcu.floats import wrap_pi
from fcu.model import VehicleModel


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

    def __init__(self, model: VehicleModel, gains: AttitudePdGains | None = None,
                 dt_s: float = 0.01) -> None:
        self.gains = gains if gains is not None else AttitudePdGains()
        super().__init__(model, dt_s, self.gains.motor_lead_rad_s)
        self._inertia = model.inertia_diag
        self._kp = np.array(self.gains.kp)
        self._kd = np.array(self.gains.kd)
        self._inertia_f, self._kp_f, self._kd_f = (self._inertia.tolist(), self._kp.tolist(),
                                                   self._kd.tolist())

    def _torque(self, euler: list[float], rates: tuple[float, float, float],
                ref: list[float], ref_rate: list[float], ref_acc: list[float]) -> list[float]:
        """Torques [U2, U3, U4] (N*m) by eq. 5.6, before the lead."""
        inertia, kp, kd = self._inertia_f, self._kp_f, self._kd_f
        torque = []
        for i in range(3):
            e = wrap_pi(ref[i] - euler[i])  # eq. 5.1 (rad)
            e_dot = ref_rate[i] - rates[i]  # rad/s
            # eq. 5.6: U = I (ddot_ref + kp e + kd e_dot)
            torque.append(inertia[i] * (ref_acc[i] + kp[i] * e + kd[i] * e_dot))
        return torque
