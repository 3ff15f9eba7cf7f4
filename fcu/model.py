"""The autopilot's own nominal model of the airframe (Table 7.1, Qball-X4).

The autopilot never reads the simulator's airframe: like real firmware it is configured with
nominal values, which the composition roots keep equal to the simulated airframe unless a
study wants a model mismatch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, kw_only=True)
class VehicleModel:
    """Nominal quadrotor parameters used by estimators, controllers and allocation."""

    thrust_gain: float = 175.0  # K, N per unit PWM (eq. 3.1)
    motor_bandwidth: float = 15.0  # w, rad/s, first-order motor lag (eq. 3.1)
    arm_length: float = 0.2  # L, m
    yaw_gain: float = 0.023  # K_psi, N*m of yaw per N of thrust (eq. 3.2)
    mass: float = 1.42  # m, kg
    gravity: float = 9.81  # g, m/s^2
    inertia: tuple[float, float, float] = (0.03, 0.03, 0.04)  # Ixx, Iyy, Izz, kg*m^2
    pwm_min: float = 0.0  # PWM command at no power
    pwm_max: float = 0.05  # PWM command at full power
    # aerodynamic damping of the body rates, tau_d = -diag(g) omega: the rotor drag at the
    # moving hubs (d_z L^2 / 2 in roll and pitch, d_xy L^2 in yaw); it sets the spin rate
    # after the loss of a rotor (fcu.control.relaxed_hover)
    rate_damping: tuple[float, float, float] = (0.007, 0.007, 0.010)  # N*m per rad/s, x y z
    # body z of the centre of pressure (FRD: negative = above the centre of gravity): the
    # in-plane drag, which the accelerometer's x and y read, turns the body about it
    # (fcu.monitoring.rotor_watch)
    cp_offset_z: float = -0.05  # m

    def __post_init__(self) -> None:
        for name in ("thrust_gain", "motor_bandwidth", "arm_length", "yaw_gain", "mass",
                     "gravity"):
            value = getattr(self, name)
            if not value > 0:
                raise ValueError(f"{name} = {value!r}: must be > 0")
        if not all(i > 0 for i in self.inertia):
            raise ValueError(f"inertia = {self.inertia!r}: each moment must be > 0")
        if len(self.rate_damping) != 3 or not all(g >= 0 for g in self.rate_damping):
            raise ValueError(f"rate_damping = {self.rate_damping!r}: must be three numbers "
                             ">= 0 (N*m per rad/s)")
        if not (math.isfinite(self.cp_offset_z) and abs(self.cp_offset_z) <= 1.0):
            raise ValueError(f"cp_offset_z = {self.cp_offset_z!r}: must lie in [-1, 1] m")
        if not self.pwm_max > self.pwm_min:
            raise ValueError(f"pwm_max = {self.pwm_max!r}: must be > pwm_min ({self.pwm_min})")

    @property
    def hover_pwm(self) -> float:
        """PWM per motor that holds the nominal mass in hover: m g / (4 K)."""
        return self.mass * self.gravity / (4.0 * self.thrust_gain)

    @property
    def inertia_diag(self) -> np.ndarray:
        """Diagonal of the inertia matrix, kg*m^2, shape (3,)."""
        return np.array(self.inertia, dtype=float)

    def mixer(self) -> np.ndarray:
        """Eq. 3.2: maps PWM u[4] to [U1 (N), U2, U3, U4 (N*m)], shape (4, 4)."""
        k, kl, kk = self.thrust_gain, self.thrust_gain * self.arm_length, \
            self.thrust_gain * self.yaw_gain
        return np.array([
            [k, k, k, k],
            [0.0, 0.0, kl, -kl],
            [kl, -kl, 0.0, 0.0],
            [kk, kk, -kk, -kk],
        ])

    def thrust_mixer(self) -> np.ndarray:
        """Eq. 3.17: maps motor thrusts T[4] (N) to [U1, U2, U3, U4], shape (4, 4)."""
        return self.mixer() / self.thrust_gain
