"""The snapshot an autopilot tick gives the MAVLink endpoint, its costlier fields computed
when first read: :class:`LazySnapshot`, taken by
:class:`fcu.mavlink.autopilot_port.AutopilotPort`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Generic, TypeVar

import numpy as np

from fcu.autopilot import Autopilot, AutopilotStatus
from fcu.mavlink.enums import MavState
from fcu.mavlink.port_records import (
    AttitudeTarget,
    BatteryState,
    PositionTarget,
    SensorHealth,
    SimTruth,
    VehicleSnapshot,
)
from flightdata.geometry import body_rates_from_euler_rates

if TYPE_CHECKING:
    from fcu.mavlink.autopilot_port import AutopilotPort

__all__ = ["LazySnapshot"]

_T = TypeVar("_T")


class _first_read(Generic[_T]):  # noqa: N801 (used as a decorator, like cached_property)
    """:func:`functools.cached_property` without its lock (Python 3.11 takes one at every
    first read, a dozen times per telemetry burst; a snapshot is used from one thread)."""

    def __init__(self, func: Callable[[Any], _T]) -> None:
        self._func = func
        self._name = func.__name__

    def __set_name__(self, owner: type, name: str) -> None:
        self._name = name

    def __get__(self, obj: Any, owner: type | None = None) -> _T:
        if obj is None:
            return self  # type: ignore[return-value]
        value = obj.__dict__[self._name] = self._func(obj)  # later reads: the instance dict
        return value


class LazySnapshot(VehicleSnapshot):
    """The snapshot of one autopilot tick whose costlier fields are computed when first read.

    Telemetry is due about 25 times per simulated second, and most bursts read only the
    estimate (ATTITUDE, LOCAL_POSITION_NED at 20 Hz). Home, the landed state, the
    references, PWM, battery, truth, LOE, health (the pre-arm check) and mission progress are
    computed on first read, once, from the autopilot as it stands; what HEARTBEAT reads is
    taken at once, so that the endpoint's fallback HEARTBEAT can always be built. The port
    expires the snapshot when the vehicle moves on (the next tick, a command): a field first
    read after that raises rather than mix two instants. (It is built here, not through the
    dataclass constructor, so :func:`dataclasses.replace` does not apply to it.)
    """

    def __init__(self, port: AutopilotPort, ap: Autopilot, status: AutopilotStatus,
                 time_s: float) -> None:
        nav = ap.navigator
        est = status.estimate
        detected = any(status.fault_detected)
        armed = nav.armed
        if detected:
            system_status = MavState.CRITICAL
        elif armed:
            system_status = MavState.ACTIVE
        else:
            system_status = MavState.STANDBY
        self.__dict__.update({  # frozen: the fields are set once, here
            "time_s": time_s, "armed": armed, "custom_mode": int(nav.mode),
            "pos_ned": est.pos_ned, "vel_ned": est.vel_ned, "euler_rad": est.euler_rad,
            "rate_frd": est.rate_frd, "origin": port.origin, "system_status": system_status,
            "failsafe_active": bool(nav.failsafe_sources), "extended": port.telemetry,
            "_port": port, "_ap": ap, "_status": status, "_expired": False})

    def expire(self) -> None:
        """The autopilot has moved on: fields not read yet can no longer be computed."""
        self.__dict__["_expired"] = True

    def _source(self, name: str) -> tuple[Autopilot, AutopilotStatus]:
        if self.__dict__["_expired"]:
            raise RuntimeError(f"snapshot field {name!r} first read after the vehicle moved on "
                               "(take a new snapshot)")
        return self.__dict__["_ap"], self.__dict__["_status"]

    @_first_read
    def home_pos_ned(self) -> np.ndarray | None:
        return self._source("home_pos_ned")[0].navigator.home_pos_ned

    @_first_read
    def landed_state(self) -> int:
        return int(self._source("landed_state")[0].navigator.landed_state)

    @_first_read
    def position_target(self) -> PositionTarget | None:
        _, status = self._source("position_target")
        ref = status.reference
        if ref is None:
            return None
        return PositionTarget(pos_ned=ref.pos_ned, vel_ned=ref.vel_ned, acc_ned=ref.acc_ned,
                              yaw_rad=ref.yaw_rad)

    @_first_read
    def attitude_target(self) -> AttitudeTarget | None:
        ap, status = self._source("attitude_target")
        att = status.attitude_reference
        if att is None:
            return None
        model = ap.model
        full_thrust_n = 4.0 * model.thrust_gain * model.pwm_max
        return AttitudeTarget(
            euler_rad=att.euler_rad,
            rate_frd=body_rates_from_euler_rates(att.euler_rad, att.rate),
            thrust=min(max(status.thrust_cmd_n / full_thrust_n, 0.0), 1.0))

    @_first_read
    def pwm(self) -> np.ndarray:
        return np.array(self._source("pwm")[1].pwm)

    @_first_read
    def battery(self) -> BatteryState:
        return _battery_state(self._source("battery")[0])

    @_first_read
    def truth(self) -> SimTruth | None:
        self._source("truth")
        return self.__dict__["_port"]._truth()

    @_first_read
    def loe(self) -> np.ndarray | None:
        return np.array(self._source("loe")[1].loe_estimate)

    @_first_read
    def health(self) -> SensorHealth:
        ap, status = self._source("health")
        est = status.estimate
        healthy = all(math.isfinite(v) for a in (est.pos_ned, est.vel_ned, est.euler_rad)
                      for v in a.tolist())
        return SensorHealth(gps=healthy, ahrs=healthy, motors=not any(status.fault_detected),
                            prearm=ap.navigator.prearm_check().ok)

    @_first_read
    def _progress(self) -> tuple[int, int]:
        progress = self._source("mission_seq")[0].navigator.mission_progress()
        return progress.current_seq, int(progress.state)

    @property
    def mission_seq(self) -> int:
        return self._progress[0]

    @property
    def mission_state(self) -> int:
        return self._progress[1]


def _battery_state(ap: Autopilot) -> BatteryState:
    """The battery monitor's view (:mod:`fcu.monitoring.battery`); NaN until a reading."""
    mon = ap.battery
    remaining = mon.time_remaining_s
    return BatteryState(voltage_v=mon.voltage_v, current_a=mon.current_a,
                        remaining=mon.remaining, healthy=mon.level != "critical",
                        low=mon.level != "ok", consumed_mah=mon.consumed_mah,
                        consumed_j=mon.consumed_j,
                        time_remaining_s=None if math.isnan(remaining) else remaining)
