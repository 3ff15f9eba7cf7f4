"""The MAVLink and ArduCopter numbers the endpoint and its port speak in.

ArduCopter flight modes (HEARTBEAT.custom_mode), MAV_STATE, MAV_SEVERITY and the
MAV_CMD_INJECT_FAILURE unit and type numbers, as :class:`enum.IntEnum` so that they compare
equal to the wire values. What the vehicle maps the failure numbers to is in the docstring of
:mod:`fcu.mavlink.port`.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = ["FailureType", "FailureUnit", "MavState", "Severity"]


class MavState(IntEnum):
    """MAV_STATE values for HEARTBEAT.system_status."""

    UNINIT = 0
    BOOT = 1
    CALIBRATING = 2
    STANDBY = 3
    ACTIVE = 4
    CRITICAL = 5
    EMERGENCY = 6
    POWEROFF = 7


class Severity(IntEnum):
    """MAV_SEVERITY values for STATUSTEXT."""

    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7


class FailureUnit(IntEnum):
    """FAILURE_UNIT values (MAV_CMD_INJECT_FAILURE param1)."""

    SENSOR_GYRO = 0
    SENSOR_ACCEL = 1
    SENSOR_MAG = 2
    SENSOR_BARO = 3
    SENSOR_GPS = 4
    SENSOR_OPTICAL_FLOW = 5
    SENSOR_VIO = 6
    SENSOR_DISTANCE_SENSOR = 7
    SENSOR_AIRSPEED = 8
    SYSTEM_BATTERY = 100
    SYSTEM_MOTOR = 101
    SYSTEM_SERVO = 102
    SYSTEM_AVOIDANCE = 103
    SYSTEM_RC_SIGNAL = 104
    SYSTEM_MAVLINK_SIGNAL = 105


class FailureType(IntEnum):
    """FAILURE_TYPE values (MAV_CMD_INJECT_FAILURE param2).

    DRIFT (8) is newer than the common.xml bundled with pymavlink 2.4.50; it is accepted.
    """

    OK = 0
    OFF = 1
    STUCK = 2
    GARBAGE = 3
    WRONG = 4
    SLOW = 5
    DELAYED = 6
    INTERMITTENT = 7
    DRIFT = 8
