"""The records that cross the vehicle port (:mod:`fcu.mavlink.port`): command results,
set-points, the vehicle snapshot and its parts, mission items, parameter specs and events.

Everything here is in SI units and in the NED/FRD frames of docs/design.md; MAVLink units
(degE7, mm, cdeg, PWM microseconds) exist only inside ``fcu/mavlink``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fcu.mavlink.enums import MavState
from fcu.mavlink.telemetry.extended import ExtendedTelemetry
from fcu.navigation.navigator import LandedState, MissionState  # one definition of each enum
from flightdata.records import Record

__all__ = [
    "AttitudeTarget",
    "BatteryState",
    "CommandResult",
    "GeoPoint",
    "LandedState",
    "MissionItem",
    "MissionItemReached",
    "MissionState",
    "ParamSpec",
    "PositionTarget",
    "RecordEvent",
    "SensorHealth",
    "SimTruth",
    "StatusText",
    "VehicleEvent",
    "VehicleSnapshot",
]


@dataclass(frozen=True, slots=True)
class CommandResult:
    """Outcome of a command handed to the vehicle.

    Attributes
    ----------
    accepted : bool
        True when the vehicle accepted (and started) the command.
    reason : str
        Why it was refused, in words a pilot can act on (sent as STATUSTEXT); may be empty
        when accepted.
    unsupported : bool
        True when the vehicle does not implement the request at all (MAV_RESULT_UNSUPPORTED
        rather than MAV_RESULT_DENIED). Only meaningful when ``accepted`` is False.
    """

    accepted: bool
    reason: str = ""
    unsupported: bool = False

    @classmethod
    def ok(cls) -> CommandResult:
        """An accepted command."""
        return cls(True)

    @classmethod
    def denied(cls, reason: str) -> CommandResult:
        """A command refused now, with the reason."""
        return cls(False, reason)

    @classmethod
    def not_supported(cls, reason: str) -> CommandResult:
        """A command this vehicle does not implement."""
        return cls(False, reason, unsupported=True)


@dataclass(frozen=True, slots=True)
class GeoPoint:
    """A WGS84 position.

    Attributes
    ----------
    lat_deg, lon_deg : float
        Latitude in [-90, 90] and longitude in [-180, 180], degrees.
    alt_m : float
        Altitude above mean sea level, m (up positive).
    """

    lat_deg: float
    lon_deg: float
    alt_m: float

    def __post_init__(self) -> None:
        for name in ("lat_deg", "lon_deg", "alt_m"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ValueError(f"{name} = {value!r}: must be finite")
        if abs(self.lat_deg) > 90.0:
            raise ValueError(f"lat_deg = {self.lat_deg!r}: must be in [-90, 90]")
        if abs(self.lon_deg) > 180.0:
            raise ValueError(f"lon_deg = {self.lon_deg!r}: must be in [-180, 180]")


def _vec(n: int) -> np.ndarray:
    return np.zeros(n)


@dataclass(frozen=True, kw_only=True)
class PositionTarget:
    """What the position controller is tracking (POSITION_TARGET_LOCAL_NED).

    Attributes
    ----------
    pos_ned : ndarray, shape (3,)
        Reference position, m, NED about the origin.
    vel_ned : ndarray, shape (3,)
        Reference velocity, m/s.
    acc_ned : ndarray, shape (3,)
        Reference acceleration, m/s^2.
    yaw_rad : float
        Reference heading, rad.
    """

    pos_ned: np.ndarray
    vel_ned: np.ndarray = field(default_factory=lambda: _vec(3))
    acc_ned: np.ndarray = field(default_factory=lambda: _vec(3))
    yaw_rad: float = 0.0


@dataclass(frozen=True, kw_only=True)
class AttitudeTarget:
    """What the attitude controller is tracking (ATTITUDE_TARGET).

    Attributes
    ----------
    euler_rad : ndarray, shape (3,)
        Desired roll, pitch, yaw (ZYX), rad.
    rate_frd : ndarray, shape (3,)
        Desired body rates p, q, r, rad/s.
    thrust : float
        Collective thrust normalised to [0, 1] (U1 over its maximum).
    """

    euler_rad: np.ndarray
    rate_frd: np.ndarray = field(default_factory=lambda: _vec(3))
    thrust: float = 0.0


@dataclass(frozen=True, kw_only=True)
class SimTruth:
    """Simulator truth for SIM_STATE (the composition root fills it; the autopilot never reads it).

    Attributes
    ----------
    pos_ned : ndarray, shape (3,)
        True position, m, NED about the origin.
    vel_ned : ndarray, shape (3,)
        True velocity, m/s.
    quat_wxyz : ndarray, shape (4,)
        True attitude quaternion [w, x, y, z], body FRD to NED.
    rate_frd : ndarray, shape (3,)
        True body rates, rad/s.
    accel_frd : ndarray, shape (3,)
        True specific force in the body frame, m/s^2 (what an ideal accelerometer reads).
    wind_ned : ndarray, shape (3,), or None
        True wind velocity at the vehicle (mean plus turbulence), NED, m/s (the velocity of
        the air, not the direction it comes from); None when not simulated.
    esc_rpm, esc_current_a : ndarray, shape (4,), or None
        What the ESCs of motors 1..4 measure: rotor speed, rev/min, and current, A (from the
        motor model: a lost rotor reads 0 rpm, a stuck one its stuck speed); None when not
        simulated.
    esc_voltage_v : float or None
        The ESCs' bus voltage, V.
    """

    pos_ned: np.ndarray
    vel_ned: np.ndarray
    quat_wxyz: np.ndarray
    rate_frd: np.ndarray
    accel_frd: np.ndarray
    wind_ned: np.ndarray | None = None
    esc_rpm: np.ndarray | None = None
    esc_current_a: np.ndarray | None = None
    esc_voltage_v: float | None = None


@dataclass(frozen=True, kw_only=True)
class BatteryState:
    """Battery as the autopilot measures it.

    Attributes
    ----------
    voltage_v : float
        Pack voltage, V.
    current_a : float or None
        Current drawn, A; None when not measured.
    remaining : float or None
        State of charge in [0, 1]; None when unknown.
    healthy : bool
        False below the critical voltage or on a detected battery fault.
    low : bool
        The battery monitor's low level was reached (BATT_LOW_VOLT / BATT_LOW_MAH).
    consumed_mah : float or None
        Charge used since boot, mAh; None when not measured.
    consumed_j : float or None
        Energy used since boot, J; None when not measured.
    time_remaining_s : float or None
        Time to empty at the present current, s; None when unknown.
    """

    voltage_v: float = 12.6
    current_a: float | None = None
    remaining: float | None = 1.0
    healthy: bool = True
    low: bool = False
    consumed_mah: float | None = None
    consumed_j: float | None = None
    time_remaining_s: float | None = None


@dataclass(frozen=True, kw_only=True)
class SensorHealth:
    """Health flags reported in SYS_STATUS (True = healthy).

    The Qball-X4 has no magnetometer or GPS: ``mag`` reports the heading source (mocap
    attitude) and ``gps`` the absolute position source (mocap position), because ground
    stations gate "ready to fly" on those bits.
    """

    gyro: bool = True
    accel: bool = True
    mag: bool = True
    baro: bool = True
    gps: bool = True
    ahrs: bool = True  # the attitude/position estimator has converged
    motors: bool = True  # no detected actuator fault
    prearm: bool = True  # arming checks pass (armable)


@dataclass(frozen=True, kw_only=True)
class VehicleSnapshot:
    """Everything telemetry needs, at one instant, in SI units and NED/FRD.

    Attributes
    ----------
    time_s : float
        Simulated time since boot, s (becomes time_boot_ms / time_usec).
    armed : bool
        Motors armed.
    custom_mode : int
        ArduCopter mode number (:class:`fcu.navigation.modes.Mode`).
    pos_ned, vel_ned : ndarray, shape (3,)
        Estimated position (m, about ``origin``) and velocity (m/s).
    euler_rad : ndarray, shape (3,)
        Estimated roll, pitch, yaw (ZYX), rad.
    rate_frd : ndarray, shape (3,)
        Estimated body rates p, q, r, rad/s.
    origin : GeoPoint
        Geodetic position of the NED origin (home at boot, on the ground); the only
        geodetic datum the vehicle keeps, everything else is NED about it.
    home_pos_ned : ndarray, shape (3,), or None
        Current home (RTL target), m, NED about the origin; None until set.
    system_status : int
        :class:`fcu.mavlink.enums.MavState`; the endpoint raises it to CRITICAL while its GCS
        failsafe acts.
    landed_state : int
        :class:`LandedState`.
    position_target, attitude_target : optional
        Controller references; None when that controller is not running.
    pwm : ndarray, shape (4,)
        Motor commands u of motors 1..4 (thesis numbering), 0..pwm_max.
    battery : BatteryState
    truth : SimTruth or None
        Simulator truth for SIM_STATE; None outside simulation.
    loe : ndarray, shape (4,), or None
        Estimated loss of effectiveness of motors 1..4 (0 healthy, 1 no thrust); None when no
        estimator runs.
    health : SensorHealth
    mission_seq : int
        Current mission item (seq 1.. ; 0 when none).
    mission_state : int
        :class:`MissionState`.
    failsafe_active : bool
        A vehicle failsafe (battery, detected fault, ...) is acting.
    extended : ExtendedTelemetry or None
        Computes the extended telemetry (IMU, pressure, vibration, EKF status, AHRS2,
        navigation output) when one of those messages is built
        (:mod:`fcu.mavlink.telemetry.extended`); None: those messages are not sent.
    """

    time_s: float
    armed: bool
    custom_mode: int
    pos_ned: np.ndarray
    vel_ned: np.ndarray
    euler_rad: np.ndarray
    rate_frd: np.ndarray
    origin: GeoPoint
    home_pos_ned: np.ndarray | None = None
    system_status: int = MavState.STANDBY
    landed_state: int = LandedState.ON_GROUND
    position_target: PositionTarget | None = None
    attitude_target: AttitudeTarget | None = None
    pwm: np.ndarray = field(default_factory=lambda: _vec(4))
    battery: BatteryState = field(default_factory=BatteryState)
    truth: SimTruth | None = None
    loe: np.ndarray | None = None
    health: SensorHealth = field(default_factory=SensorHealth)
    mission_seq: int = 0
    mission_state: int = MissionState.NO_MISSION
    failsafe_active: bool = False
    extended: ExtendedTelemetry | None = None


@dataclass(frozen=True, kw_only=True)
class MissionItem:
    """One uploaded mission item (seq >= 1; seq 0 is home and never handed over).

    Attributes
    ----------
    seq : int
        Position in the mission, 1..n-1.
    command : int
        MAV_CMD number (16 NAV_WAYPOINT, 17 NAV_LOITER_UNLIM, 19 NAV_LOITER_TIME,
        20 NAV_RETURN_TO_LAUNCH, 21 NAV_LAND, 22 NAV_TAKEOFF, 178 DO_CHANGE_SPEED, ...).
    autocontinue : bool
        Continue to the next item when this one completes.
    params : tuple of 4 float
        param1..param4 as on the wire, in the units MAV_CMD defines (seconds, metres, m/s;
        the one angle, param4 yaw of NAV commands, is also given in ``yaw_rad``). NaN only in
        slots where the MAVLink spec defines it as "use the default".
    north_east_m : tuple of 2 float or None
        Target north, east, m about the NED origin; None when the item has no horizontal
        target (frame MAV_FRAME_MISSION, or latitude = longitude = 0 meaning "here").
    down_m : float or None
        Target down, m about the NED origin; None when the frame carries no position.
    alt_m : float or None
        The same target as altitude above the current home, m (up positive); None when the
        frame carries no position. What NAV_TAKEOFF means by its altitude.
    yaw_rad : float or None
        param4 of a NAV command in radians; None when NaN (keep the heading mode) or not a
        NAV command.
    """

    seq: int
    command: int
    autocontinue: bool
    params: tuple[float, float, float, float]
    north_east_m: tuple[float, float] | None
    down_m: float | None
    alt_m: float | None
    yaw_rad: float | None


@dataclass(frozen=True, kw_only=True)
class ParamSpec:
    """Definition of one parameter exposed over MAVLink (C_CAST encoding; typed REAL32, or
    INT8/INT16/INT32 when ``integer``: :func:`fcu.mavlink.protocols.params.wire_type`).

    Attributes
    ----------
    name : str
        At most 16 ASCII characters, ArduPilot style (``FS_GCS_TIMEOUT``).
    value : float
        Current value.
    min_value, max_value : float
        Inclusive range.
    allowed : tuple of float or None
        When given, the only values accepted (enumerations).
    integer : bool
        Only whole numbers are accepted.
    description : str
        One line, with the unit.
    """

    name: str
    value: float
    min_value: float = -math.inf
    max_value: float = math.inf
    allowed: tuple[float, ...] | None = None
    integer: bool = False
    description: str = ""

    def __post_init__(self) -> None:
        if not 1 <= len(self.name) <= 16 or not self.name.isascii():
            raise ValueError(f"name = {self.name!r}: must be 1..16 ASCII characters")
        if not math.isfinite(self.value):
            raise ValueError(f"{self.name}: value = {self.value!r}: must be finite")


@dataclass(frozen=True, slots=True)
class StatusText:
    """A message for the pilot (STATUSTEXT); long texts are chunked by the endpoint."""

    severity: int
    text: str


@dataclass(frozen=True, slots=True)
class MissionItemReached:
    """The mission item ``seq`` was reached (MISSION_ITEM_REACHED)."""

    seq: int


@dataclass(frozen=True, slots=True)
class RecordEvent:
    """A fault, detection or outcome record (DEBUG_FLOAT_ARRAY ``FTC_REC``,
    :mod:`fcu.mavlink.telemetry.record_relay`)."""

    record: Record


VehicleEvent = StatusText | MissionItemReached | RecordEvent
