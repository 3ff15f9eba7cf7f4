"""The attitude tests' plant: three decoupled axes behind a first-order motor, discretised."""

from __future__ import annotations

import control
import numpy as np

from fcu.model import VehicleModel


def discrete_axes(model: VehicleModel, dt_s: float, motor_rad_s: float
                  ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per axis, (A, B) of I th'' = tau_motor + d, tau_motor' = w (tau_cmd - tau_motor).

    State [angle (rad), rate (rad/s), motor torque (N*m)], inputs [tau_cmd, d] (N*m); the exact
    zero-order-hold discretisation at ``dt_s``.
    """
    a_s, b_s = [], []
    for inertia in model.inertia:
        a_c = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0 / inertia], [0.0, 0.0, -motor_rad_s]])
        b_c = np.array([[0.0, 0.0], [0.0, 1.0 / inertia], [motor_rad_s, 0.0]])
        d = control.c2d(control.ss(a_c, b_c, np.eye(3), np.zeros((3, 2))), dt_s)
        a_s.append(np.asarray(d.A))
        b_s.append(np.asarray(d.B))
    return a_s, b_s
