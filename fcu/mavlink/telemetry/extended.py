"""What the extended telemetry reports, and the port that computes it on demand.

The messages ArduPilot SITL streams beside the basic set (RAW_IMU, SCALED_IMU,
SCALED_PRESSURE, VIBRATION, EKF_STATUS_REPORT, AHRS2, NAV_CONTROLLER_OUTPUT) need quantities
that cost more than a snapshot field: filters over every accelerometer sample, the
estimator's covariance, the navigator's leg. A :class:`~fcu.mavlink.port_records.VehicleSnapshot`
therefore carries an :class:`ExtendedTelemetry` (``snapshot.extended``) whose methods compute
each quantity when its message is built, i.e. at that message's stream rate, never every
tick. Everything here is SI and NED/FRD; MAVLink units exist only in
:mod:`fcu.mavlink.telemetry.messages_extended`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = ["EkfReport", "ExtendedTelemetry", "ImuReading", "NavControllerReport",
           "PressureReading", "SecondaryAttitude", "VibrationLevels"]


@dataclass(frozen=True, kw_only=True)
class ImuReading:
    """The latest IMU sample the autopilot received (RAW_IMU, SCALED_IMU).

    Attributes
    ----------
    time_s : float
        Simulated time of the sample, s.
    accel_frd : ndarray, shape (3,)
        Specific force, body FRD, m/s^2.
    gyro_frd : ndarray, shape (3,)
        Body rates p, q, r, rad/s.
    temperature_c : float
        Sensor temperature, degrees Celsius.
    """

    time_s: float
    accel_frd: np.ndarray
    gyro_frd: np.ndarray
    temperature_c: float


@dataclass(frozen=True, kw_only=True)
class PressureReading:
    """The latest barometer sample as the sensor reports it (SCALED_PRESSURE).

    Attributes
    ----------
    time_s : float
        Simulated time of the sample, s.
    pressure_pa : float
        Static pressure, Pa.
    temperature_c : float
        Air temperature at the sensor, degrees Celsius.
    """

    time_s: float
    pressure_pa: float
    temperature_c: float


@dataclass(frozen=True, kw_only=True)
class VibrationLevels:
    """Accelerometer vibration and clipping, ArduPilot's definition (VIBRATION).

    Attributes
    ----------
    time_s : float
        Simulated time of the last sample included, s.
    vibration_m_s2 : ndarray, shape (3,)
        Per body axis, sqrt of the 2 Hz low-pass of the squared difference between each
        sample and its 5 Hz low-pass, m/s^2.
    clipping : tuple of 3 int
        Samples at the accelerometer's full scale since boot, per IMU (one IMU: the other
        two stay 0).
    """

    time_s: float
    vibration_m_s2: np.ndarray
    clipping: tuple[int, int, int]


@dataclass(frozen=True, kw_only=True)
class EkfReport:
    """The flying estimator's health (EKF_STATUS_REPORT).

    Attributes
    ----------
    flags : int
        EKF_STATUS_FLAGS bitmask.
    velocity_variance : float
        Sum of the velocity variances (N, E, D), (m/s)^2.
    pos_horiz_variance : float
        Sum of the north and east position variances, m^2.
    pos_vert_variance : float
        Down position variance, m^2.
    compass_variance : float
        Yaw variance (the heading source: motion capture), rad^2.
    terrain_alt_variance : float
        Height-above-terrain variance, m^2 (0: no terrain estimate).
    """

    flags: int
    velocity_variance: float
    pos_horiz_variance: float
    pos_vert_variance: float
    compass_variance: float
    terrain_alt_variance: float = 0.0


@dataclass(frozen=True, kw_only=True)
class SecondaryAttitude:
    """The estimator that is not flying the vehicle (AHRS2).

    Attributes
    ----------
    euler_rad : ndarray, shape (3,)
        Roll, pitch, yaw (ZYX), rad.
    pos_ned : ndarray, shape (3,)
        Position about the NED origin, m.
    """

    euler_rad: np.ndarray
    pos_ned: np.ndarray


@dataclass(frozen=True, kw_only=True)
class NavControllerReport:
    """What the navigator and its controllers are steering to (NAV_CONTROLLER_OUTPUT).

    Attributes
    ----------
    roll_rad, pitch_rad : float
        Desired roll and pitch (the attitude reference), rad.
    bearing_rad : float
        Desired heading (the reference yaw), rad.
    target_bearing_rad : float
        Bearing from the vehicle to the current leg's target, rad (NaN: none).
    wp_dist_m : float
        Horizontal distance to the current leg's target, m (NaN: none).
    alt_error_m : float
        Reference altitude minus estimated altitude, m.
    xtrack_error_m : float
        Horizontal distance from the straight line from the leg's start to its target, m.
    """

    roll_rad: float
    pitch_rad: float
    bearing_rad: float
    target_bearing_rad: float
    wp_dist_m: float
    alt_error_m: float
    xtrack_error_m: float


class ExtendedTelemetry(Protocol):
    """Computes the extended telemetry when a message is built (module docstring); every
    method answers None when it has nothing to report (no sample yet, not flying...)."""

    def imu(self) -> ImuReading | None:
        """The latest IMU sample."""
        ...

    def pressure(self) -> PressureReading | None:
        """The latest barometer sample."""
        ...

    def vibration(self) -> VibrationLevels | None:
        """Vibration levels and clipping counts up to the latest accelerometer sample."""
        ...

    def ekf(self) -> EkfReport | None:
        """The flying estimator's variances and flags."""
        ...

    def secondary(self) -> SecondaryAttitude | None:
        """The estimator that is not flying (None when only one runs)."""
        ...

    def nav_controller(self) -> NavControllerReport | None:
        """The navigator's targets (None when not flying)."""
        ...
