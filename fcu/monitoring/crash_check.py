"""Crash and thrust-loss checks, after ArduCopter's (``crash_check.cpp``), on the estimate.

An autopilot that does not notice it has crashed keeps its motors running on the ground,
hops, and flies again with a dead motor. Three crash checks run while armed and flying (the
navigator's view: not on the ground); the first to fire disarms the motors
(``FS_CRASH_CHECK`` = 1; 0 only reports):

- **attitude** (ArduCopter's check): lean angle above ``angle_deg`` (30 deg) *and* attitude
  error (reference against estimate, the larger of roll and pitch) above ``angle_deg``,
  continuously for ``angle_time_s`` (2 s). A vehicle tumbling or lying on its side.
- **impact**: the estimate reaches the ground (altitude below ``ground_alt_m``) after
  descending faster than ``impact_speed_m_s`` (1.5 m/s) within the last ``impact_window_s``
  (0.3 s), in any leg (a landing descends at a few tenths of a m/s). A fall.
- **ground contact in flight**: the estimate sits on the ground (altitude below
  ``ground_alt_m``, speed below 0.1 m/s) for ``contact_time_s`` (1 s) while the navigator
  flies a leg that is not a take-off or a landing. A vehicle that came down without a hard
  impact (a slow loss of thrust) and cannot get up.

ArduCopter's *thrust-loss* check warns only: collective command above ``thrust_loss_throttle``
(90 % of full thrust) with the attitude error below 15 deg while descending faster than
``thrust_loss_descent_m_s``, for ``thrust_loss_time_s`` (1 s): the motors give all they have
and the vehicle still sinks. Reported once per flight (``thrust_loss``, magnitude: the
collective command, 0..1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from flightdata.config import finite, require
from flightdata.records import DetectionRecord


@dataclass(frozen=True, kw_only=True)
class CrashCheckConfig:
    """Settings of the crash and thrust-loss checks (module docstring)."""

    action: int = 1  # FS_CRASH_CHECK: 0 report only, 1 disarm
    angle_deg: float = 30.0  # deg, lean and attitude error of the attitude check
    angle_time_s: float = 2.0  # s the attitude check must hold
    impact_speed_m_s: float = 1.5  # m/s, descent speed before reaching the ground: a fall
    impact_window_s: float = 0.3  # s, how recent that speed must be
    contact_time_s: float = 1.0  # s on the ground in a flying leg
    ground_alt_m: float = 0.05  # m, altitude below which the estimate is on the ground
    thrust_loss_throttle: float = 0.9  # collective command, fraction of full thrust
    thrust_loss_descent_m_s: float = 0.5  # m/s, descent speed of the thrust-loss check
    thrust_loss_time_s: float = 1.0  # s the thrust-loss check must hold

    def __post_init__(self) -> None:
        require(self.action in (0, 1), "action", self.action, "must be 0 or 1")
        for name in ("angle_deg", "angle_time_s", "impact_speed_m_s", "impact_window_s",
                     "contact_time_s", "ground_alt_m", "thrust_loss_throttle",
                     "thrust_loss_descent_m_s", "thrust_loss_time_s"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a number > 0")


class CrashCheck:
    """The checks of the module docstring, fed once per tick."""

    def __init__(self, config: CrashCheckConfig) -> None:
        self.config = config
        self._angle_rad = math.radians(config.angle_deg)
        self._thrust_loss_error_rad = math.radians(15.0)
        self.reset()

    def reset(self) -> None:
        """A new flight: timers and the once-per-flight warning restart."""
        self._angle_since: float | None = None
        self._contact_since: float | None = None
        self._fast_descent_s = -math.inf
        self._thrust_since: float | None = None
        self._thrust_warned = False
        self.crashed = False

    def step(self, time_s: float, *, flying: bool, leg: str, alt_m: float,
             vel_down_m_s: float, speed_m_s: float, lean_rad: float,
             attitude_error_rad: float, collective: float) -> list[DetectionRecord]:
        """One tick.

        Parameters
        ----------
        time_s : float
            Tick time, s.
        flying : bool
            Armed and not on the ground (the navigator's view).
        leg : str
            What the navigator flies: "takeoff", "land" or anything else.
        alt_m, vel_down_m_s, speed_m_s : float
            Estimated altitude (m), vertical speed (m/s, + down) and speed (m/s).
        lean_rad, attitude_error_rad : float
            Estimated lean (angle of the body z axis from the vertical) and the attitude
            error against the reference (the larger of roll and pitch), rad.
        collective : float
            Commanded collective thrust as a fraction of full thrust.
        """
        cfg = self.config
        if not flying:
            self.reset()
            return []
        if vel_down_m_s > cfg.impact_speed_m_s:
            self._fast_descent_s = time_s
        out: list[DetectionRecord] = []
        if not self._thrust_warned:
            self._thrust_loss(out, time_s, vel_down_m_s, attitude_error_rad, collective)
        if self.crashed:
            return out
        angle = self._angle_rad
        if lean_rad > angle and attitude_error_rad > angle:
            if self._angle_since is None:
                self._angle_since = time_s
            if time_s - self._angle_since >= cfg.angle_time_s - 1e-9:
                return out + self._crash(time_s, attitude_error_rad)
        else:
            self._angle_since = None
        on_ground = alt_m < cfg.ground_alt_m
        if on_ground and time_s - self._fast_descent_s <= cfg.impact_window_s + 1e-9:
            return out + self._crash(time_s, attitude_error_rad)
        if on_ground and speed_m_s < 0.1 and leg not in ("takeoff", "land"):
            if self._contact_since is None:
                self._contact_since = time_s
            if time_s - self._contact_since >= cfg.contact_time_s - 1e-9:
                return out + self._crash(time_s, attitude_error_rad)
        else:
            self._contact_since = None
        return out

    def _crash(self, time_s: float, attitude_error_rad: float) -> list[DetectionRecord]:
        self.crashed = True
        return [DetectionRecord(time_s=time_s, action="detected", kind="crash",
                                magnitude=attitude_error_rad)]

    def _thrust_loss(self, out: list[DetectionRecord], time_s: float, vel_down_m_s: float,
                     attitude_error_rad: float, collective: float) -> None:
        """The thrust-loss warning, once per flight (appended to ``out``)."""
        cfg = self.config
        if collective > cfg.thrust_loss_throttle and vel_down_m_s > \
                cfg.thrust_loss_descent_m_s and attitude_error_rad < self._thrust_loss_error_rad:
            if self._thrust_since is None:
                self._thrust_since = time_s
            if time_s - self._thrust_since >= cfg.thrust_loss_time_s - 1e-9:
                self._thrust_warned = True
                out.append(DetectionRecord(time_s=time_s, action="detected", kind="thrust_loss",
                                           magnitude=collective))
        else:
            self._thrust_since = None
