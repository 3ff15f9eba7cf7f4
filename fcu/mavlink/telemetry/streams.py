"""Telemetry scheduling: which message is due when.

Time base
---------
Streams are scheduled in **simulated** time, the same clock as their ``time_boot_ms`` /
``time_usec`` fields: ATTITUDE at 20 Hz means one message per 50 ms of simulated time. At a
speed-up of k the wall-clock rates are k times higher (and at a slow-down lower); a recorded
log looks the same at any speed-up. Ground stations cope with that, except for one message:
HEARTBEAT, whose absence for 3 wall-clock seconds makes MAVSDK drop the vehicle. HEARTBEAT is
therefore due when its simulated period has elapsed **or** ``heartbeat_wall_period_s`` of
wall-clock time has passed since the last one, whichever comes first. When the simulation is
paused or slower than real time the heartbeat still goes out once per wall second, provided
the composition root keeps calling ``tick`` (it must, at least a few times per wall second).

Rates change through REQUEST_DATA_STREAM (ArduPilot stream groups below; rate 0 or
start_stop 0 stops the group) and SET_MESSAGE_INTERVAL (per message; -1 stops, 0 restores the
default). HEARTBEAT cannot be stopped. A stream is sent at most once per tick, so a rate above
``max_rate_hz`` (the autopilot's loop rate) is clamped to it, as ArduPilot caps message rates
at its main loop rate; :meth:`StreamScheduler.rate_hz` reports the rate in force.

ArduPilot stream groups (ArduCopter's GCS_Mavlink.cpp STREAM_*_msgs, restricted to what we
send, plus our own messages where they fit)
-----------------------------------------------------------------------------------------
==================  ===================================================================
RAW_SENSORS 1       RAW_IMU, SCALED_IMU (the one IMU scaled: ArduCopter's slot for a
                    second IMU, SCALED_IMU2), SCALED_PRESSURE
EXTENDED_STATUS 2   SYS_STATUS, GPS_RAW_INT, MISSION_CURRENT, NAV_CONTROLLER_OUTPUT,
                    EXTENDED_SYS_STATE, POSITION_TARGET_LOCAL_NED
RC_CHANNELS 3       SERVO_OUTPUT_RAW, RC_CHANNELS
POSITION 6          GLOBAL_POSITION_INT, LOCAL_POSITION_NED
EXTRA1 10           ATTITUDE, ATTITUDE_QUATERNION, ATTITUDE_TARGET, SIM_STATE, AHRS2
EXTRA2 11           VFR_HUD
EXTRA3 12           SYSTEM_TIME, WIND, BATTERY_STATUS, EKF_STATUS_REPORT, VIBRATION,
                    NAMED_VALUE_FLOAT (LOE1..LOE4), ESC_TELEMETRY_1_TO_4
ALL 0               every group
==================  ===================================================================
HOME_POSITION belongs to no group (SET_MESSAGE_INTERVAL and REQUEST_MESSAGE only), nor do
PX4's HIGHRES_IMU, ODOMETRY and ACTUATOR_OUTPUT_STATUS (:mod:`fcu.mavlink.telemetry.messages_px4`),
which start at rate 0: they are sent when asked for.
The extended messages (RAW_IMU ... VIBRATION, :mod:`fcu.mavlink.telemetry.messages_extended`) are
computed when they are due, so their cost follows these rates.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from fcu.mavlink.transport.codec import mavlink2

__all__ = ["DEFAULT_RATES_HZ", "STREAM_GROUPS", "StreamScheduler"]

_M = mavlink2

DEFAULT_RATES_HZ: Mapping[int, float] = {
    _M.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    _M.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    _M.MAVLINK_MSG_ID_GPS_RAW_INT: 2.0,
    _M.MAVLINK_MSG_ID_ATTITUDE: 20.0,
    _M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: 10.0,
    _M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 20.0,
    _M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0,
    _M.MAVLINK_MSG_ID_VFR_HUD: 4.0,
    _M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: 10.0,
    _M.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    _M.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
    _M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    _M.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
    _M.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
    _M.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: 10.0,
    _M.MAVLINK_MSG_ID_ATTITUDE_TARGET: 10.0,
    _M.MAVLINK_MSG_ID_SIM_STATE: 10.0,
    _M.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT: 2.0,
    _M.MAVLINK_MSG_ID_RAW_IMU: 2.0,
    _M.MAVLINK_MSG_ID_SCALED_IMU: 2.0,
    _M.MAVLINK_MSG_ID_SCALED_PRESSURE: 2.0,
    _M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT: 2.0,
    _M.MAVLINK_MSG_ID_RC_CHANNELS: 2.0,
    _M.MAVLINK_MSG_ID_AHRS2: 4.0,
    _M.MAVLINK_MSG_ID_WIND: 1.0,
    _M.MAVLINK_MSG_ID_EKF_STATUS_REPORT: 1.0,
    _M.MAVLINK_MSG_ID_VIBRATION: 1.0,
    # PX4's telemetry and ArduPilot's ESC report: streamed when asked for
    _M.MAVLINK_MSG_ID_HIGHRES_IMU: 0.0,
    _M.MAVLINK_MSG_ID_ODOMETRY: 0.0,
    _M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS: 0.0,
    _M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4: 0.0,
}
"""Default stream rates, Hz of simulated time, by message id (0: only when asked for)."""

STREAM_GROUPS: Mapping[int, tuple[int, ...]] = {
    _M.MAV_DATA_STREAM_RAW_SENSORS: (
        _M.MAVLINK_MSG_ID_RAW_IMU, _M.MAVLINK_MSG_ID_SCALED_IMU,
        _M.MAVLINK_MSG_ID_SCALED_PRESSURE),
    _M.MAV_DATA_STREAM_EXTENDED_STATUS: (
        _M.MAVLINK_MSG_ID_SYS_STATUS, _M.MAVLINK_MSG_ID_GPS_RAW_INT,
        _M.MAVLINK_MSG_ID_MISSION_CURRENT, _M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT,
        _M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, _M.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED),
    _M.MAV_DATA_STREAM_RC_CHANNELS: (
        _M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, _M.MAVLINK_MSG_ID_RC_CHANNELS),
    _M.MAV_DATA_STREAM_POSITION: (
        _M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, _M.MAVLINK_MSG_ID_LOCAL_POSITION_NED),
    _M.MAV_DATA_STREAM_EXTRA1: (
        _M.MAVLINK_MSG_ID_ATTITUDE, _M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION,
        _M.MAVLINK_MSG_ID_ATTITUDE_TARGET, _M.MAVLINK_MSG_ID_SIM_STATE,
        _M.MAVLINK_MSG_ID_AHRS2),
    _M.MAV_DATA_STREAM_EXTRA2: (_M.MAVLINK_MSG_ID_VFR_HUD,),
    _M.MAV_DATA_STREAM_EXTRA3: (
        _M.MAVLINK_MSG_ID_SYSTEM_TIME, _M.MAVLINK_MSG_ID_WIND,
        _M.MAVLINK_MSG_ID_BATTERY_STATUS, _M.MAVLINK_MSG_ID_EKF_STATUS_REPORT,
        _M.MAVLINK_MSG_ID_VIBRATION, _M.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT,
        _M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4),
}
"""REQUEST_DATA_STREAM stream id -> message ids (MAV_DATA_STREAM_ALL = 0 means all)."""

_HEARTBEAT = _M.MAVLINK_MSG_ID_HEARTBEAT
MAX_RATE_HZ = 100.0  # Hz, default cap: the autopilot's default loop rate (one per tick)


class StreamScheduler:
    """Per-message periodic schedule in simulated time, with a wall-clock heartbeat floor.

    Parameters
    ----------
    default_rates_hz : mapping of int to float
        Message id -> rate, Hz of simulated time; these are the streams that exist.
    heartbeat_wall_period_s : float
        Longest wall-clock gap between two HEARTBEATs, s.
    max_rate_hz : float
        Fastest rate a stream can be set to, Hz of simulated time (the autopilot's loop
        rate: one message per tick); faster requests are clamped to it.
    """

    def __init__(self, default_rates_hz: Mapping[int, float] = DEFAULT_RATES_HZ,
                 heartbeat_wall_period_s: float = 1.0,
                 max_rate_hz: float = MAX_RATE_HZ) -> None:
        if _HEARTBEAT not in default_rates_hz or not default_rates_hz[_HEARTBEAT] > 0:
            raise ValueError("default_rates_hz must give HEARTBEAT a rate > 0")
        if not heartbeat_wall_period_s > 0:
            raise ValueError(f"heartbeat_wall_period_s = {heartbeat_wall_period_s!r}: must be > 0")
        if not (math.isfinite(max_rate_hz) and max_rate_hz > 0):
            raise ValueError(f"max_rate_hz = {max_rate_hz!r}: must be a finite rate > 0 Hz")
        self._max_rate_hz = float(max_rate_hz)
        self._defaults = dict(default_rates_hz)
        self._heartbeat_wall_period_s = heartbeat_wall_period_s
        self._rates_hz: dict[int, float] = {}
        self._next_s: dict[int, float] = {}
        self._last_time_s = -math.inf
        self._last_heartbeat_wall_s = -math.inf
        self._earliest_s = -math.inf  # no stream is due before this simulated time
        self.reset()

    def reset(self) -> None:
        """Back to the default rates, everything due at the next tick."""
        self._rates_hz = dict(self._defaults)
        self._next_s = {msg_id: -math.inf for msg_id in self._defaults}
        self._last_heartbeat_wall_s = -math.inf
        self._earliest_s = -math.inf

    @property
    def message_ids(self) -> tuple[int, ...]:
        """The messages that can be streamed."""
        return tuple(self._defaults)

    def has(self, msg_id: int) -> bool:
        """True when ``msg_id`` can be streamed."""
        return msg_id in self._defaults

    def default_rate_hz(self, msg_id: int) -> float:
        """Default rate of ``msg_id``, Hz."""
        return self._defaults[msg_id]

    def rate_hz(self, msg_id: int) -> float:
        """Current rate of ``msg_id``, Hz (0 = stopped)."""
        return self._rates_hz[msg_id]

    def set_rate(self, msg_id: int, rate_hz: float | None) -> None:
        """Stream ``msg_id`` at ``rate_hz`` (0 stops it, None restores the default), at most
        ``max_rate_hz``.

        Raises
        ------
        KeyError
            When ``msg_id`` is not a stream.
        ValueError
            When the rate is negative or not finite, or would stop HEARTBEAT.
        """
        default = self._defaults[msg_id]
        rate = default if rate_hz is None else float(rate_hz)
        if not (math.isfinite(rate) and rate >= 0.0):
            raise ValueError(f"rate_hz = {rate_hz!r}: must be finite and >= 0")
        if msg_id == _HEARTBEAT and rate == 0.0:
            raise ValueError("HEARTBEAT cannot be stopped")
        self._rates_hz[msg_id] = min(rate, self._max_rate_hz)
        self._next_s[msg_id] = -math.inf  # start (again) at the next tick
        self._earliest_s = -math.inf

    def set_group_rate(self, stream_id: int, rate_hz: float) -> bool:
        """REQUEST_DATA_STREAM: set every message of ArduPilot group ``stream_id``.

        Returns
        -------
        bool
            False when ``stream_id`` is not a known group (nothing changes).
        """
        if stream_id == _M.MAV_DATA_STREAM_ALL:
            members = [m for group in STREAM_GROUPS.values() for m in group]
        elif stream_id in STREAM_GROUPS:
            members = list(STREAM_GROUPS[stream_id])
        else:
            return False
        for msg_id in members:
            if msg_id in self._defaults:
                self.set_rate(msg_id, rate_hz)
        return True

    def request_heartbeat(self) -> None:
        """Make HEARTBEAT due at the next tick (e.g. to confirm a mode change at once)."""
        self._next_s[_HEARTBEAT] = -math.inf
        self._earliest_s = -math.inf

    def due(self, time_s: float, wall_time_s: float) -> list[int]:
        """Message ids to send now, HEARTBEAT first; advances their schedules.

        Parameters
        ----------
        time_s : float
            Simulated time, s. A step backwards (reboot, reset) restarts every schedule.
        wall_time_s : float
            Monotonic wall-clock time, s (for the heartbeat floor only).
        """
        if time_s < self._last_time_s:
            self._next_s = {msg_id: -math.inf for msg_id in self._defaults}
            self._earliest_s = -math.inf
        self._last_time_s = time_s
        if (time_s < self._earliest_s and wall_time_s - self._last_heartbeat_wall_s
                < self._heartbeat_wall_period_s):
            return []  # the common tick: nothing due (the loop below would find nothing)
        out: list[int] = []
        next_by_id = self._next_s
        heartbeat_wall_due = (wall_time_s - self._last_heartbeat_wall_s
                              >= self._heartbeat_wall_period_s)
        earliest = math.inf
        for msg_id, rate in self._rates_hz.items():
            wall_due = heartbeat_wall_due and msg_id == _HEARTBEAT
            if rate <= 0.0 and not wall_due:
                continue
            next_s = next_by_id[msg_id]
            if time_s >= next_s or wall_due:
                period = 1.0 / rate
                # Keep the phase; after a gap (a stall, a fresh start) restart from now.
                next_s = next_s + period if time_s < next_s + period else time_s + period
                if msg_id == _HEARTBEAT:
                    self._last_heartbeat_wall_s = wall_time_s
                    if wall_due and time_s < next_by_id[msg_id]:
                        next_s = time_s + period
                next_by_id[msg_id] = next_s
                out.append(msg_id)
            if rate > 0.0 and next_s < earliest:
                earliest = next_s
        self._earliest_s = earliest
        if len(out) > 1 and _HEARTBEAT in out and out[0] != _HEARTBEAT:
            out.remove(_HEARTBEAT)  # HEARTBEAT first, the others in their order
            out.insert(0, _HEARTBEAT)
        return out
