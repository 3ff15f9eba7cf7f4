"""Thesis-style figures of merit computed from a flight log (chapter 7).

Errors are reference minus true state; RMS and maximum absolute value over the run. Control
effort is the time average of the sum of the four PWM commands (Table 7.2 note: 4 x hover PWM
= m g / K = 0.0796 for the Qball-X4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

POSITION_AXES = ("x", "y", "z")  # m
ATTITUDE_AXES = ("roll", "pitch", "yaw")  # deg


@dataclass(frozen=True)
class ErrorFigure:
    """RMS and maximum absolute value of one error channel."""

    rms: float
    max: float


def error_figure(error: np.ndarray) -> ErrorFigure:
    """RMS and max |e| of a sampled error signal (uniform sampling assumed)."""
    e = np.asarray(error, dtype=float)
    return ErrorFigure(rms=float(np.sqrt(np.mean(e * e))), max=float(np.max(np.abs(e))))


def wrap_angle_rad(angle: np.ndarray) -> np.ndarray:
    """Wrap angles to [-pi, pi) so yaw errors across the +-180 deg seam stay small."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def tracking_errors(ref_pos_ned: np.ndarray, pos_ned: np.ndarray, ref_euler_rad: np.ndarray,
                    euler_rad: np.ndarray) -> dict[str, ErrorFigure]:
    """Per-axis error figures: x, y, z in metres, roll, pitch, yaw in degrees.

    Parameters
    ----------
    ref_pos_ned, pos_ned : (n, 3) arrays, m
    ref_euler_rad, euler_rad : (n, 3) arrays, rad
    """
    out: dict[str, ErrorFigure] = {}
    pos_err = np.asarray(ref_pos_ned) - np.asarray(pos_ned)
    att_err = np.degrees(wrap_angle_rad(np.asarray(ref_euler_rad) - np.asarray(euler_rad)))
    for i, axis in enumerate(POSITION_AXES):
        out[axis] = error_figure(pos_err[:, i])
    for i, axis in enumerate(ATTITUDE_AXES):
        out[axis] = error_figure(att_err[:, i])
    return out


def control_effort(pwm: np.ndarray) -> float:
    """Time mean of the sum of the four PWM commands, shape (n, 4) uniformly sampled."""
    return float(np.mean(np.sum(np.asarray(pwm, dtype=float), axis=1)))
