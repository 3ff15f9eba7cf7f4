"""The navigator's settings (TOML ``[autopilot.navigator]``)."""

from __future__ import annotations

from dataclasses import dataclass, field

from fcu.navigation.fence import FenceConfig
from fcu.navigation.follow import FollowConfig
from fcu.navigation.guidance import SpeedLimits
from fcu.navigation.modes import SUPPORTED_MODE_NUMBERS, Mode
from fcu.navigation.sticks import PilotConfig
from flightdata.config import finite, require

TIME_TOL_S = 1e-6  # s, slack when comparing step times with planned times (float sums)
AUTO_ALLOW_ARMING = 1  # AUTO_OPTIONS bit 0: arming in AUTO is allowed
AUTO_TAKEOFF_WITHOUT_START = 2  # AUTO_OPTIONS bit 1: AUTO on the ground takes off by itself
AUTO_OPTIONS_MAX = AUTO_ALLOW_ARMING | AUTO_TAKEOFF_WITHOUT_START

@dataclass(frozen=True, kw_only=True)
class NavigatorConfig:
    """Navigator settings (ArduPilot parameter in brackets where one exists)."""

    initial_mode: int = 0  # ArduCopter mode number at boot (supported, see Mode)
    speed_horizontal_m_s: float = 0.5  # m/s, peak horizontal leg speed [WPNAV_SPEED]
    speed_up_m_s: float = 0.3  # m/s, peak climb speed [WPNAV_SPEED_UP]
    speed_down_m_s: float = 0.2  # m/s, peak descent speed, also landing [WPNAV_SPEED_DN]
    accel_m_s2: float = 0.5  # m/s^2, peak leg acceleration 6 d / T^2 [WPNAV_ACCEL]
    yaw_rate_rad_s: float = 0.5  # rad/s, peak yaw rate along a leg
    min_leg_s: float = 0.5  # s, shortest leg that moves
    max_speed_m_s: float = 5.0  # m/s, largest speed DO_CHANGE_SPEED accepts
    wp_radius_m: float = 0.1  # m, distance at which a target counts as reached [WPNAV_RADIUS]
    rtl_alt_m: float = 1.0  # m, RTL return altitude [RTL_ALT]
    rtl_hold_s: float = 1.0  # s, hold above home before landing [RTL_LOIT_TIME]
    land_creep_speed_m_s: float = 0.1  # m/s, descent after the cubic reached the ground
    land_detect_alt_m: float = 0.1  # m, below this altitude the vehicle may be landed
    land_detect_speed_m_s: float = 0.05  # m/s, |vertical speed| below this when landed
    land_detect_time_s: float = 1.0  # s, both conditions held this long = landed
    landed_disarm_delay_s: float = 2.0  # s, auto-disarm after landing
    idle_disarm_delay_s: float = 10.0  # s, auto-disarm armed without take-off; 0 = never
    home_pos_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m, NED
    armable_modes: tuple[int, ...] = (0, 2, 4, 5, 16)  # STABILIZE, ALT_HOLD, GUIDED, LOITER,
    # POSHOLD
    position_timeout_s: float = 3.0  # s holding attitude and height without a position fix
    # before landing [FS_POS_TIMEOUT]
    auto_options: int = 0  # bitmask [AUTO_OPTIONS]: bit 0 arming in AUTO allowed, bit 1 AUTO
    # armed on the ground takes off without MISSION_START (ArduCopter's "without raising the
    # throttle": there is no throttle stick here, MISSION_START is the only other trigger)
    circle_radius_m: float = 10.0  # m, CIRCLE mode's radius [CIRCLE_RADIUS, cm]
    circle_rate_deg_s: float = 20.0  # deg/s, CIRCLE's turn rate, > 0 clockwise seen from
    # above, < 0 counter-clockwise [CIRCLE_RATE]
    guided_timeout_s: float = 3.0  # s, a GUIDED velocity or attitude set-point older than
    # this is replaced by a hold [GUID_TIMEOUT]
    fence: FenceConfig = field(default_factory=FenceConfig)  # the geofence [FENCE_*]; off by
    # default as in ArduCopter, so no altitude or distance limit applies unless enabled
    follow: FollowConfig = field(default_factory=FollowConfig)  # FOLLOW mode [FOLL_*]
    pilot: PilotConfig = field(default_factory=PilotConfig)  # what the sticks fly in
    # STABILIZE, ALT_HOLD, LOITER, POSHOLD [ANGLE_MAX, PILOT_*, LOIT_*, THR_DZ]

    def __post_init__(self) -> None:
        supported = SUPPORTED_MODE_NUMBERS
        require(isinstance(self.initial_mode, int) and self.initial_mode in supported,
                "initial_mode", self.initial_mode, f"must be one of {sorted(supported)}")
        positive = ("speed_horizontal_m_s", "speed_up_m_s", "speed_down_m_s", "accel_m_s2",
                    "yaw_rate_rad_s", "max_speed_m_s", "wp_radius_m",
                    "rtl_alt_m", "land_creep_speed_m_s", "land_detect_alt_m",
                    "land_detect_speed_m_s")
        for name in positive:
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a finite number > 0")
        for name in ("min_leg_s", "rtl_hold_s", "land_detect_time_s", "landed_disarm_delay_s",
                     "idle_disarm_delay_s", "position_timeout_s"):
            value = getattr(self, name)
            require(finite(value) and value >= 0, name, value,
                    "must be a finite number >= 0")
        require(len(self.home_pos_ned) == 3 and all(finite(v) for v in self.home_pos_ned),
                "home_pos_ned", self.home_pos_ned, "must be three finite numbers (m, NED)")
        require(all(m in supported for m in self.armable_modes), "armable_modes",
                self.armable_modes, f"must be mode numbers among {sorted(supported)}")
        require(isinstance(self.auto_options, int) and not isinstance(self.auto_options, bool)
                and 0 <= self.auto_options <= AUTO_OPTIONS_MAX, "auto_options",
                self.auto_options, f"must be a bitmask in 0..{AUTO_OPTIONS_MAX}")
        require(finite(self.circle_radius_m) and self.circle_radius_m >= 0,
                "circle_radius_m", self.circle_radius_m, "must be a finite number >= 0")
        require(finite(self.guided_timeout_s) and self.guided_timeout_s > 0.0,
                "guided_timeout_s", self.guided_timeout_s, "must be a finite number > 0 s")
        require(finite(self.circle_rate_deg_s) and abs(self.circle_rate_deg_s) <= 90.0,
                "circle_rate_deg_s", self.circle_rate_deg_s, "must be within [-90, 90] deg/s")
        require(isinstance(self.fence, FenceConfig), "fence", self.fence,
                "must be a FenceConfig")
        require(isinstance(self.follow, FollowConfig), "follow", self.follow,
                "must be a FollowConfig")
        require(isinstance(self.pilot, PilotConfig), "pilot", self.pilot,
                "must be a PilotConfig")

    def allows_arming_in(self, mode: int) -> bool:
        """Arming is allowed in ``mode`` (``armable_modes``; AUTO with AUTO_OPTIONS bit 0)."""
        if int(mode) in self.armable_modes:
            return True
        return int(mode) == int(Mode.AUTO) and bool(self.auto_options & AUTO_ALLOW_ARMING)

    def speed_limits(self) -> SpeedLimits:
        """The guidance limits these settings describe."""
        return SpeedLimits(horizontal_m_s=self.speed_horizontal_m_s, up_m_s=self.speed_up_m_s,
                           down_m_s=self.speed_down_m_s, accel_m_s2=self.accel_m_s2,
                           yaw_rate_rad_s=self.yaw_rate_rad_s, min_duration_s=self.min_leg_s)

