"""Pilot sticks: one normalised input record and ArduCopter's laws for what the sticks ask.

A stick input (:class:`Sticks`) reaches the navigator from MANUAL_CONTROL or
RC_CHANNELS_OVERRIDE (:mod:`fcu.mavlink.protocols.manual_input` converts them, as ArduCopter
converts both into RC channel values). Its axes follow ArduCopter's channel conventions
(``channel_roll->norm_input()`` ...)::

    roll      -1 full left .. +1 full right         (right: right wing down, go right)
    pitch     -1 full forward .. +1 full back        (forward: nose down, go forward)
    throttle   0 low .. 1 high, 0.5 mid-stick
    yaw       -1 full anticlockwise .. +1 full clockwise (seen from above)

The laws below are ArduCopter's ``get_pilot_desired_*`` functions in SI units:

- roll, pitch and yaw pass a dead band of ``stick_deadzone`` about centre (RCn_DZ, 20 us of
  500) and are rescaled to reach 1 at full stick;
- lean angles (STABILIZE, ALT_HOLD): ``roll * angle_max``, ``pitch * angle_max`` with the
  (roll, pitch) vector limited to length 1 (a circular stick limit, as ArduCopter's);
- climb rate (ALT_HOLD, LOITER, POSHOLD): zero within ``throttle_deadzone`` of mid-stick
  (THR_DZ), then linear to ``speed_up_m_s`` at full throttle and ``speed_down_m_s`` at zero;
- collective (STABILIZE): ArduCopter's throttle curve, through ``hover_throttle`` at
  mid-stick, expressed as a multiple of the hover thrust (1 at mid-stick: the vehicle's own
  hover thrust, what ArduCopter's MOT_HOVER_LEARN converges to);
- yaw rate: ``yaw * yaw_rate_deg_s``;
- horizontal velocity (LOITER, POSHOLD): ``(-pitch, roll) * loiter_speed_m_s`` in the
  heading frame (forward, right), circularly limited.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from flightdata.config import finite, require

__all__ = ["CENTRED", "PilotConfig", "Sticks", "climb_rate_m_s", "collective_of_hover",
           "lean_angles_rad", "stick_velocity_ned", "yaw_rate_rad_s"]


@dataclass(frozen=True, slots=True)
class Sticks:
    """One stick input, normalised (module docstring for the signs).

    Attributes
    ----------
    roll, pitch, yaw : float
        In [-1, 1].
    throttle : float
        In [0, 1]; 0.5 is mid-stick.
    time_s : float
        When it arrived, s, on the clock of whoever received it (the MAVLink endpoint's wall
        clock); the RC failsafe judges its age, the flight laws do not read it.
    """

    roll: float
    pitch: float
    throttle: float
    yaw: float
    time_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("roll", "pitch", "yaw"):
            value = getattr(self, name)
            require(finite(value) and -1.0 <= value <= 1.0, name, value,
                    "must be a stick position in [-1, 1]")
        require(finite(self.throttle) and 0.0 <= self.throttle <= 1.0, "throttle",
                self.throttle, "must be a throttle position in [0, 1]")
        require(finite(self.time_s), "time_s", self.time_s, "must be a finite time in s")

    @property
    def centred(self) -> bool:
        """Roll, pitch and yaw at centre and the throttle at mid-stick."""
        return self.roll == self.pitch == self.yaw == 0.0 and self.throttle == 0.5


CENTRED = Sticks(0.0, 0.0, 0.5, 0.0)
"""Every stick at centre, throttle at mid-stick: what a pilot mode flies without input."""


@dataclass(frozen=True, kw_only=True)
class PilotConfig:
    """What the sticks ask for in the pilot modes (ArduCopter parameter in brackets).

    The speeds and accelerations are scaled to this small indoor vehicle (the thesis's
    Qball-X4 flies its square at 0.5 m/s), as the navigator's WPNAV_* defaults are;
    ArduCopter's own defaults are given beside them.
    """

    angle_max_deg: float = 30.0  # deg, lean at full roll/pitch stick [ANGLE_MAX cdeg, 3000]
    yaw_rate_deg_s: float = 45.0  # deg/s at full yaw stick [PILOT_Y_RATE, 202.5]
    speed_up_m_s: float = 0.5  # m/s, climb at full throttle [PILOT_SPEED_UP cm/s, 250]
    speed_down_m_s: float = 0.3  # m/s, descent at zero throttle; 0 = speed_up_m_s
    # [PILOT_SPEED_DN cm/s, 0]
    accel_z_m_s2: float = 1.0  # m/s^2, how fast the climb rate follows the stick
    # [PILOT_ACCEL_Z cm/s/s, 250]
    loiter_speed_m_s: float = 1.0  # m/s at full stick in LOITER, POSHOLD [LOIT_SPEED, 1250]
    loiter_accel_m_s2: float = 1.0  # m/s^2, how fast the velocity follows the stick
    # [LOIT_ACC_MAX cm/s/s, 500]
    throttle_deadzone: float = 0.1  # of the throttle range, either side of mid-stick with
    # no climb [THR_DZ, 100 of 1000]
    hover_throttle: float = 0.35  # throttle curve's output at mid-stick [MOT_THST_HOVER]
    stick_deadzone: float = 0.04  # of half the roll/pitch/yaw range [RC1_DZ, 20 us of 500]

    def __post_init__(self) -> None:
        require(finite(self.angle_max_deg) and 1.0 <= self.angle_max_deg <= 80.0,
                "angle_max_deg", self.angle_max_deg, "must be within [1, 80] deg")
        for name in ("yaw_rate_deg_s", "speed_up_m_s", "accel_z_m_s2", "loiter_speed_m_s",
                     "loiter_accel_m_s2"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a finite number > 0")
        require(finite(self.speed_down_m_s) and self.speed_down_m_s >= 0, "speed_down_m_s",
                self.speed_down_m_s, "must be a finite number >= 0 (0: speed_up_m_s)")
        require(finite(self.throttle_deadzone) and 0.0 <= self.throttle_deadzone < 0.5,
                "throttle_deadzone", self.throttle_deadzone, "must be within [0, 0.5)")
        require(finite(self.hover_throttle) and 0.1 <= self.hover_throttle <= 0.8,
                "hover_throttle", self.hover_throttle, "must be within [0.1, 0.8]")
        require(finite(self.stick_deadzone) and 0.0 <= self.stick_deadzone < 0.5,
                "stick_deadzone", self.stick_deadzone, "must be within [0, 0.5)")

    @property
    def descent_m_s(self) -> float:
        """Descent rate at zero throttle, m/s (PILOT_SPEED_DN 0 means PILOT_SPEED_UP)."""
        return self.speed_down_m_s if self.speed_down_m_s > 0.0 else self.speed_up_m_s


def dead_band(value: float, width: float) -> float:
    """``value`` in [-1, 1] with ``width`` about 0 removed, rescaled to reach +-1."""
    magnitude = abs(value) - width
    if magnitude <= 0.0:
        return 0.0
    return math.copysign(min(magnitude / (1.0 - width), 1.0), value)


def _circular(x: float, y: float) -> tuple[float, float]:
    """(x, y) scaled down to length 1 when longer (a round stick gate)."""
    length = math.hypot(x, y)
    return (x / length, y / length) if length > 1.0 else (x, y)


def lean_angles_rad(sticks: Sticks, config: PilotConfig) -> tuple[float, float]:
    """Roll and pitch angles the sticks ask for, rad (FRD: roll > 0 right wing down, pitch
    > 0 nose up), at most ``angle_max_deg`` together."""
    roll, pitch = _circular(dead_band(sticks.roll, config.stick_deadzone),
                            dead_band(sticks.pitch, config.stick_deadzone))
    angle_max = math.radians(config.angle_max_deg)
    return roll * angle_max, pitch * angle_max


def climb_rate_m_s(throttle: float, config: PilotConfig) -> float:
    """Climb rate the throttle stick asks for, m/s (up > 0): zero within the dead zone about
    mid-stick, full climb at 1, full descent at 0."""
    top = 0.5 + config.throttle_deadzone
    bottom = 0.5 - config.throttle_deadzone
    if throttle > top:
        return config.speed_up_m_s * min((throttle - top) / (1.0 - top), 1.0)
    if throttle < bottom:
        return -config.descent_m_s * min((bottom - throttle) / bottom, 1.0)
    return 0.0


def collective_of_hover(throttle: float, config: PilotConfig) -> float:
    """STABILIZE's collective, as a multiple of the hover thrust (1 at mid-stick).

    ArduCopter's ``get_pilot_desired_throttle``: the stick, halved either side of mid, goes
    through ``out = in (1 - e) + e in^3`` with the expo ``e`` chosen so that mid-stick gives
    ``hover_throttle``; the output over its mid-stick value is the multiple returned.
    """
    expo = min(max(-(config.hover_throttle - 0.5) / 0.375, -0.5), 1.0)
    t = min(max(throttle, 0.0), 1.0)

    def curve(x: float) -> float:
        return x * (1.0 - expo) + expo * x * x * x

    return curve(t) / curve(0.5)


def yaw_rate_rad_s(sticks: Sticks, config: PilotConfig) -> float:
    """Yaw rate the yaw stick asks for, rad/s (> 0 clockwise seen from above)."""
    return dead_band(sticks.yaw, config.stick_deadzone) * math.radians(config.yaw_rate_deg_s)


def stick_velocity_ned(sticks: Sticks, yaw_rad: float, config: PilotConfig
                       ) -> tuple[float, float]:
    """Horizontal velocity (north, east, m/s) the roll and pitch sticks ask for in LOITER
    and POSHOLD: forward ``-pitch``, right ``roll``, in the frame of heading ``yaw_rad``."""
    right, back = _circular(dead_band(sticks.roll, config.stick_deadzone),
                            dead_band(sticks.pitch, config.stick_deadzone))
    forward = -back
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    speed = config.loiter_speed_m_s
    return (speed * (c * forward - s * right), speed * (s * forward + c * right))
