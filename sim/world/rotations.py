"""Attitude conversions shared by the plant and the sensors (docs/design.md conventions).

Quaternions are [w, x, y, z] and rotate body FRD vectors into NED; Euler angles are ZYX with
R = Rz(yaw) Ry(pitch) Rx(roll) (thesis eq. 3.9, corrected in the reading notes). All are
numba functions, callable from Python and from the compiled kernels.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@njit(cache=True, error_model="numpy")
def rotation_entries(
    qw: float, qx: float, qy: float, qz: float
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """Entries r00..r22 of R(q), body FRD -> NED; q need not be exactly unit (it is scaled)."""
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    r00 = 1.0 - s * (qy * qy + qz * qz)
    r01 = s * (qx * qy - qw * qz)
    r02 = s * (qx * qz + qw * qy)
    r10 = s * (qx * qy + qw * qz)
    r11 = 1.0 - s * (qx * qx + qz * qz)
    r12 = s * (qy * qz - qw * qx)
    r20 = s * (qx * qz - qw * qy)
    r21 = s * (qy * qz + qw * qx)
    r22 = 1.0 - s * (qx * qx + qy * qy)
    return r00, r01, r02, r10, r11, r12, r20, r21, r22


@njit(cache=True, error_model="numpy")
def quat_to_rotation(q: FloatArray) -> FloatArray:
    """Rotation matrix of a quaternion, R = Rz(yaw) Ry(pitch) Rx(roll) (corrected eq. 3.9).

    Parameters
    ----------
    q : numpy.ndarray
        Quaternion [w, x, y, z], float64, shape (4,); a non-unit q is normalised.

    Returns
    -------
    numpy.ndarray
        Shape (3, 3), maps body FRD vectors to NED (v = R v_b, eq. 3.7).
    """
    r = rotation_entries(q[0], q[1], q[2], q[3])
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = r[3 * i + j]
    return out


@njit(cache=True, error_model="numpy")
def euler_to_quat(roll_rad: float, pitch_rad: float, yaw_rad: float) -> FloatArray:
    """Unit quaternion [w, x, y, z] of ZYX Euler angles, q = q_z(yaw) q_y(pitch) q_x(roll).

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : float
        phi (right side down positive), theta (nose up positive), psi (nose right positive),
        rad.

    Returns
    -------
    numpy.ndarray
        Shape (4,), with the same rotation as R = Rz(psi) Ry(theta) Rx(phi) (eq. 3.9).
    """
    cr, sr = math.cos(0.5 * roll_rad), math.sin(0.5 * roll_rad)
    cp, sp = math.cos(0.5 * pitch_rad), math.sin(0.5 * pitch_rad)
    cy, sy = math.cos(0.5 * yaw_rad), math.sin(0.5 * yaw_rad)
    q = np.empty(4)
    q[0] = cr * cp * cy + sr * sp * sy
    q[1] = sr * cp * cy - cr * sp * sy
    q[2] = cr * sp * cy + sr * cp * sy
    q[3] = cr * cp * sy - sr * sp * cy
    return q


@njit(cache=True, error_model="numpy")
def yaw_of(qw: float, qx: float, qy: float, qz: float) -> float:
    """ZYX yaw psi of a quaternion, rad in (-pi, pi]."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


@njit(cache=True, error_model="numpy")
def quat_to_euler(q: FloatArray) -> FloatArray:
    """ZYX Euler angles (roll, pitch, yaw) of a unit quaternion [w, x, y, z].

    Parameters
    ----------
    q : numpy.ndarray
        Unit quaternion, float64, shape (4,).

    Returns
    -------
    numpy.ndarray
        [phi, theta, psi] in rad, shape (3,): roll and yaw in (-pi, pi], pitch in
        [-pi/2, pi/2], such that R(q) = Rz(psi) Ry(theta) Rx(phi) (eq. 3.9). At gimbal lock
        (|theta| = pi/2, where only psi -/+ phi is defined) phi is returned as 0.
    """
    qw, qx, qy, qz = q[0], q[1], q[2], q[3]
    out = np.empty(3)
    # sin(theta) = -R[2, 0]; clipped against round-off beyond +-1 at the poles
    s = 2.0 * (qw * qy - qz * qx)
    out[1] = math.asin(min(1.0, max(-1.0, s)))
    if abs(s) > 1.0 - 1e-15:
        # gimbal lock (|theta| = 90 deg): both atan2 below read 0/0. Only psi -/+ phi is
        # defined; with phi = 0, q = (c cos(psi/2), .., .., c sin(psi/2)) for either pole.
        out[0] = 0.0
        yaw = 2.0 * math.atan2(qz, qw)
        out[2] = yaw - 2.0 * math.pi if yaw > math.pi else (
            yaw + 2.0 * math.pi if yaw <= -math.pi else yaw)
        return out
    out[0] = math.atan2(2.0 * (qw * qx + qy * qz), 1.0 - 2.0 * (qx * qx + qy * qy))
    out[2] = yaw_of(qw, qx, qy, qz)
    return out


__all__ = ["euler_to_quat", "quat_to_euler", "quat_to_rotation", "rotation_entries", "yaw_of"]
