"""Angles and quaternions, in plain Python and numpy: one definition for every room.

Conventions (STYLE.md): quaternions are [w, x, y, z], the rotation of body FRD into NED;
Euler angles are ZYX roll, pitch, yaw (phi, theta, psi) in rad, so that
R(q) = Rz(psi) Ry(theta) Rx(phi) (thesis eq. 3.9).

The simulator's compiled kernels (``sim/world/dynamics.py``, ``sim/world/sensors.py``) and the
autopilot's estimators keep their own numba-compiled copies: a compiled kernel cannot call
these. :func:`euler_from_quat` gives the same numbers as ``sim.world.dynamics.quat_to_euler``
(the same formulas in the same order, gimbal lock included).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

__all__ = [
    "body_rates_from_euler_rates",
    "euler_from_quat",
    "euler_from_wxyz",
    "eulers_from_quats",
    "quat_from_euler",
    "quats_from_euler",
    "wrap_pi_array",
]


def wrap_pi_array(angle_rad: npt.ArrayLike) -> np.ndarray:
    """Every element of ``angle_rad`` wrapped to [-pi, pi), rad (any shape).

    So that an error across the +-180 deg seam (yaw 179 deg against -179 deg) stays small.
    """
    return (np.asarray(angle_rad) + np.pi) % (2.0 * np.pi) - np.pi


def euler_from_quat(quat_wxyz: Sequence[float] | np.ndarray) -> np.ndarray:
    """ZYX roll, pitch, yaw (rad, shape (3,)) of a unit quaternion [w, x, y, z].

    Roll and yaw are in (-pi, pi], pitch in [-pi/2, pi/2]. At gimbal lock (|pitch| = pi/2,
    where only yaw -/+ roll is defined) roll is returned as 0. (:func:`euler_from_wxyz` on
    the four components.)
    """
    w, x, y, z = (quat_wxyz.tolist() if isinstance(quat_wxyz, np.ndarray)
                  else [float(v) for v in quat_wxyz])
    return np.array(euler_from_wxyz(w, x, y, z))


def euler_from_wxyz(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """:func:`euler_from_quat` of the quaternion ``w + x i + y j + z k`` given as four floats:
    (roll, pitch, yaw), rad, as floats (a per-tick log's row, without an array)."""
    # sin(theta) = -R[2, 0]; clipped against round-off beyond +-1 at the poles
    s = 2.0 * (w * y - z * x)
    pitch = math.asin(min(1.0, max(-1.0, s)))
    if abs(s) > 1.0 - 1e-15:
        # gimbal lock: both atan2 below would read 0/0; with roll = 0,
        # q = (c cos(psi/2), .., .., c sin(psi/2)) at either pole
        yaw = 2.0 * math.atan2(z, w)
        yaw = yaw - 2.0 * math.pi if yaw > math.pi else (
            yaw + 2.0 * math.pi if yaw <= -math.pi else yaw)
        return 0.0, pitch, yaw
    # roll = atan2(R[2, 1], R[2, 2]), yaw = atan2(R[1, 0], R[0, 0])
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def eulers_from_quats(quats_wxyz: npt.ArrayLike) -> np.ndarray:
    """:func:`euler_from_wxyz` of each row of an (n, 4) array of quaternions [w, x, y, z]:
    roll, pitch, yaw, rad, shape (n, 3) (the same formulas, gimbal lock included; equal to
    within a unit or two in the last place, numpy's and math's libraries differing)."""
    q = np.asarray(quats_wxyz, dtype=float).reshape(-1, 4)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    # sin(theta) = -R[2, 0]; clipped against round-off beyond +-1 at the poles
    s = 2.0 * (w * y - z * x)
    pitch = np.arcsin(np.clip(s, -1.0, 1.0))
    # roll = atan2(R[2, 1], R[2, 2]), yaw = atan2(R[1, 0], R[0, 0])
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    lock = np.abs(s) > 1.0 - 1e-15
    if lock.any():  # gimbal lock: roll 0, yaw from q = (c cos(psi/2), .., .., c sin(psi/2))
        yaw_lock = 2.0 * np.arctan2(z[lock], w[lock])
        yaw_lock = np.where(yaw_lock > np.pi, yaw_lock - 2.0 * np.pi,
                            np.where(yaw_lock <= -np.pi, yaw_lock + 2.0 * np.pi, yaw_lock))
        roll[lock] = 0.0
        yaw[lock] = yaw_lock
    return np.column_stack((roll, pitch, yaw))


def quat_from_euler(euler_rad: Sequence[float] | np.ndarray) -> np.ndarray:
    """Quaternion [w, x, y, z] (shape (4,)) of ZYX roll, pitch, yaw (rad)."""
    hr, hp, hy = 0.5 * float(euler_rad[0]), 0.5 * float(euler_rad[1]), 0.5 * float(euler_rad[2])
    cr, sr = math.cos(hr), math.sin(hr)
    cp, sp = math.cos(hp), math.sin(hp)
    cy, sy = math.cos(hy), math.sin(hy)
    # q = q_z(yaw) * q_y(pitch) * q_x(roll)
    return np.array([
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ])


def quats_from_euler(euler_rad: npt.ArrayLike) -> np.ndarray:
    """:func:`quat_from_euler` of each row of an (n, 3) array of roll, pitch, yaw: (n, 4)."""
    e = np.asarray(euler_rad, dtype=float).reshape(-1, 3)
    cr, sr = np.cos(e[:, 0] / 2), np.sin(e[:, 0] / 2)
    cp, sp = np.cos(e[:, 1] / 2), np.sin(e[:, 1] / 2)
    cy, sy = np.cos(e[:, 2] / 2), np.sin(e[:, 2] / 2)
    # q = q_z(yaw) q_y(pitch) q_x(roll)
    return np.column_stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def body_rates_from_euler_rates(euler_rad: Sequence[float] | np.ndarray,
                                euler_rate: Sequence[float] | np.ndarray) -> np.ndarray:
    """Body rates p, q, r (rad/s, FRD, shape (3,)) of ZYX Euler angles and their derivatives.

    Parameters
    ----------
    euler_rad : (3,) roll, pitch, yaw, rad (yaw does not enter)
    euler_rate : (3,) their time derivatives, rad/s
    """
    phi, theta = float(euler_rad[0]), float(euler_rad[1])
    dphi, dtheta, dpsi = (float(v) for v in euler_rate)
    sp, cp = math.sin(phi), math.cos(phi)
    st, ct = math.sin(theta), math.cos(theta)
    # p = phi' - psi' sin(theta); q = theta' cos(phi) + psi' sin(phi) cos(theta);
    # r = -theta' sin(phi) + psi' cos(phi) cos(theta)
    return np.array([dphi - dpsi * st, dtheta * cp + dpsi * sp * ct,
                     -dtheta * sp + dpsi * cp * ct])
