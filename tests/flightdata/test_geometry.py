"""Angles and quaternions of :mod:`flightdata.geometry`: against closed forms, rotation
matrices built independently, and the simulator's compiled copy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from flightdata.geometry import (
    body_rates_from_euler_rates,
    euler_from_quat,
    euler_from_wxyz,
    eulers_from_quats,
    quat_from_euler,
    quats_from_euler,
    wrap_pi_array,
)
from sim.world.rotations import quat_to_euler


def rotation_of(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (body FRD to NED) of a unit quaternion [w, x, y, z]."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def rotation_zyx(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll) (thesis eq. 3.9), from elementary rotations."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch),
                              math.sin(pitch), math.cos(yaw), math.sin(yaw))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


@settings(max_examples=200, deadline=None)
@given(roll=st.floats(-3.1, 3.1), pitch=st.floats(-1.5, 1.5), yaw=st.floats(-3.1, 3.1))
def test_quaternion_and_euler_are_inverse(roll: float, pitch: float, yaw: float) -> None:
    q = quat_from_euler(np.array([roll, pitch, yaw]))
    assert np.linalg.norm(q) == pytest.approx(1.0)
    # 1e-7 rad: asin near pitch = +-1.5 loses a few digits of float64.
    assert_allclose(euler_from_quat(q), [roll, pitch, yaw], atol=1e-7)
    # the quaternion is the ZYX rotation (1e-12: a few float64 roundings)
    assert_allclose(rotation_of(q), rotation_zyx(roll, pitch, yaw), atol=1e-12)


def test_quaternion_convention_yaw_nose_right() -> None:
    # ZYX, body FRD to NED: a yaw of +90 deg turns the nose from north to east.
    q = quat_from_euler(np.array([0.0, 0.0, math.pi / 2]))
    assert_allclose(rotation_of(q) @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-12)


def test_quaternions_of_euler_rows_invert_euler_from_quat() -> None:
    angles = np.array([[0.1, -0.2, 0.3], [-0.5, 0.4, -3.0], [0.0, 0.0, math.pi - 1e-6]])
    q = quats_from_euler(angles)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    for row, a in zip(q, angles, strict=True):
        assert euler_from_quat(row) == pytest.approx(tuple(a), abs=1e-12)
        # the vectorised form is the scalar one (1e-15: numpy's and libm's sin, cos)
        assert_allclose(row, quat_from_euler(a), rtol=0, atol=1e-15)


def test_euler_from_quat_is_the_simulators_to_the_last_bit() -> None:
    rng = np.random.default_rng(7)
    quats = rng.normal(size=(2000, 4))
    quats /= np.linalg.norm(quats, axis=1)[:, None]
    # and the two poles, where only yaw -/+ roll is defined
    poles = np.array([quat_from_euler([0.0, s * math.pi / 2, 0.7]) for s in (1.0, -1.0)])
    for q in np.vstack([quats, poles]):
        np.testing.assert_array_equal(euler_from_quat(q), quat_to_euler(q))


def test_eulers_of_quaternion_rows_are_the_scalar_ones() -> None:
    rng = np.random.default_rng(11)
    quats = rng.normal(size=(2000, 4))
    quats /= np.linalg.norm(quats, axis=1)[:, None]
    # both poles (gimbal lock: roll 0), and yaw near +-pi there
    poles = np.array([quat_from_euler([0.0, s * math.pi / 2, y])
                      for s in (1.0, -1.0) for y in (0.7, math.pi - 1e-9, -math.pi + 1e-9)])
    quats = np.vstack([quats, poles])
    rows = eulers_from_quats(quats)
    assert rows.shape == (quats.shape[0], 3)
    scalar = np.array([euler_from_wxyz(*q) for q in quats.tolist()])
    # 1e-15: numpy's and libm's asin and atan2 may differ in the last place
    assert_allclose(rows, scalar, rtol=0, atol=1e-15)
    assert np.all(rows[-6:, 0] == 0.0)


def test_euler_at_gimbal_lock_puts_the_rotation_in_yaw() -> None:
    for pitch in (math.pi / 2, -math.pi / 2):
        q = quat_from_euler([0.3, pitch, 1.0])
        roll, p, yaw = euler_from_quat(q)
        assert roll == 0.0 and p == pytest.approx(pitch, abs=1e-7)
        # same rotation (1e-7: pitch off the pole by the clipped asin's rounding)
        assert_allclose(rotation_zyx(roll, p, yaw), rotation_of(q), atol=1e-7)


def test_body_rates_are_the_rotation_rate_of_the_euler_angles() -> None:
    euler = np.array([0.3, -0.4, 2.0])
    rates = np.array([0.5, -0.2, 0.8])
    # omega_body = R' dR/dt as a skew matrix, dR/dt by central differences (dt = 1e-6 s:
    # truncation ~1e-12, rounding ~1e-10 rad/s)
    dt = 1e-6
    r_dot = (rotation_zyx(*(euler + rates * dt)) - rotation_zyx(*(euler - rates * dt))) / (2 * dt)
    skew = rotation_zyx(*euler).T @ r_dot
    assert_allclose(body_rates_from_euler_rates(euler, rates),
                    [skew[2, 1], skew[0, 2], skew[1, 0]], atol=1e-8)
    # level: body rates are the Euler rates
    assert_allclose(body_rates_from_euler_rates(np.zeros(3), rates), rates, atol=0)


def test_wrap_is_half_open_and_keeps_the_angle() -> None:
    angles = np.array([-math.pi, math.pi, 3 * math.pi, -7.0, 0.5, 179.0])
    wrapped = wrap_pi_array(angles)
    assert np.all((wrapped >= -math.pi) & (wrapped < math.pi))
    assert wrapped[1] == -math.pi  # +pi maps to -pi: [-pi, pi)
    assert_allclose(np.cos(wrapped), np.cos(angles), atol=1e-12)  # the same angle
    assert_allclose(np.sin(wrapped), np.sin(angles), atol=1e-12)
    # the +-180 deg seam: 179 deg against -179 deg is a 2 deg error, not 358
    seam = wrap_pi_array(math.radians(179.0) - math.radians(-179.0))
    assert math.degrees(float(seam)) == pytest.approx(-2.0)
