"""Mission items: what a mission is made of, in local NED, and the thesis's mission.

One definition for the autopilot (which flies them), the simulator's scenario files (which
load them from TOML) and both ends of the mission protocol (:func:`mavlink_form`: what a
ground station uploads, what a vehicle booted with a mission reports in a download).
As in ArduPilot, seq 0 is home: ``items[k]`` has seq ``k + 1``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from flightdata.config import finite, require

MissionCommand = Literal["waypoint", "takeoff", "land", "rtl", "change_speed"]
SpeedType = Literal["ground", "climb", "descent"]

#: MAV_CMD number of each mission command.
MAV_CMD_BY_COMMAND: dict[str, int] = {
    "waypoint": 16,  # MAV_CMD_NAV_WAYPOINT
    "rtl": 20,  # MAV_CMD_NAV_RETURN_TO_LAUNCH
    "land": 21,  # MAV_CMD_NAV_LAND
    "takeoff": 22,  # MAV_CMD_NAV_TAKEOFF
    "change_speed": 178,  # MAV_CMD_DO_CHANGE_SPEED
}
#: Mission command of each supported MAV_CMD number.
COMMAND_BY_MAV_CMD: dict[int, str] = {v: k for k, v in MAV_CMD_BY_COMMAND.items()}
#: DO_CHANGE_SPEED param1 (speed type) -> SpeedType; airspeed is taken as ground speed.
SPEED_TYPE_BY_MAV_PARAM: dict[int, str] = {0: "ground", 1: "ground", 2: "climb", 3: "descent"}
#: SpeedType -> DO_CHANGE_SPEED param1 (what a mission item is uploaded with).
MAV_PARAM_BY_SPEED_TYPE: dict[str, int] = {"ground": 1, "climb": 2, "descent": 3}
MAV_FRAME_LOCAL_NED = 1
MAV_FRAME_MISSION = 2
MAV_FRAME_GLOBAL_RELATIVE_ALT_INT = 6


@dataclass(frozen=True, kw_only=True)
class MissionItem:
    """One mission item, local NED; loadable from a TOML table.

    Attributes
    ----------
    command : {"waypoint", "takeoff", "land", "rtl", "change_speed"}
        MAV_CMD_NAV_WAYPOINT, NAV_TAKEOFF, NAV_LAND, NAV_RETURN_TO_LAUNCH, DO_CHANGE_SPEED.
    pos_ned : tuple of 3 float or None
        waypoint: target, NED, m; land: touchdown point (x, y used; flown to at the current
        altitude first); None: where the vehicle is.
    alt_m : float
        takeoff: altitude above home, m (> 0).
    hold_s : float
        waypoint: time at rest at the waypoint before the next item, s.
    speed_m_s : float
        change_speed: new peak speed, m/s (> 0).
    speed_type : {"ground", "climb", "descent"}
        change_speed: which limit changes (DO_CHANGE_SPEED param1 1, 2, 3).
    yaw_rad : float or None
        waypoint: yaw on arrival, rad; None keeps the current yaw (a take-off keeps it).
    """

    command: MissionCommand = "waypoint"
    pos_ned: tuple[float, float, float] | None = None  # m, NED
    alt_m: float = 0.0  # m above home (takeoff)
    hold_s: float = 0.0  # s (waypoint)
    speed_m_s: float = 0.0  # m/s (change_speed)
    speed_type: SpeedType = "ground"
    yaw_rad: float | None = None  # rad

    def __post_init__(self) -> None:
        require(self.command in MAV_CMD_BY_COMMAND, "command", self.command,
                f"must be one of {', '.join(MAV_CMD_BY_COMMAND)}")
        if self.pos_ned is not None:
            pos = tuple(self.pos_ned)
            require(len(pos) == 3 and all(finite(v) for v in pos), "pos_ned", self.pos_ned,
                    "must be three finite numbers (m, NED) or None")
            object.__setattr__(self, "pos_ned", tuple(float(v) for v in pos))
        require(finite(self.hold_s) and self.hold_s >= 0, "hold_s", self.hold_s,
                "must be a finite time >= 0 s")
        require(self.yaw_rad is None or finite(self.yaw_rad), "yaw_rad", self.yaw_rad,
                "must be finite (rad) or None")
        require(self.speed_type in ("ground", "climb", "descent"), "speed_type",
                self.speed_type, "must be ground, climb or descent")
        if self.command == "takeoff":
            require(finite(self.alt_m) and self.alt_m > 0, "alt_m", self.alt_m,
                    "must be a finite altitude > 0 m for a takeoff")
        if self.command == "change_speed":
            require(finite(self.speed_m_s) and self.speed_m_s > 0, "speed_m_s",
                    self.speed_m_s, "must be a finite speed > 0 m/s for change_speed")

    @property
    def mav_cmd(self) -> int:
        """The MAV_CMD number of this item."""
        return MAV_CMD_BY_COMMAND[self.command]

    @property
    def is_nav(self) -> bool:
        """True for NAV commands (they move the vehicle and take time)."""
        return self.command != "change_speed"

    def describe(self) -> str:
        """Short human-readable form, e.g. ``NAV_WAYPOINT (1.00, 0.00, -0.60) hold 1.0 s``."""
        if self.command == "takeoff":
            return f"NAV_TAKEOFF {self.alt_m:.2f} m"
        if self.command == "change_speed":
            return f"DO_CHANGE_SPEED {self.speed_type} {self.speed_m_s:.3f} m/s"
        where = "here" if self.pos_ned is None else \
            "({:.2f}, {:.2f}, {:.2f})".format(*self.pos_ned)
        if self.command == "land":
            return f"NAV_LAND {where}"
        if self.command == "rtl":
            return "NAV_RETURN_TO_LAUNCH"
        return f"NAV_WAYPOINT {where} hold {self.hold_s:.1f} s"


@dataclass(frozen=True, kw_only=True)
class MavlinkForm:
    """A mission item as MISSION_ITEM_INT carries it, before scaling to integers.

    Attributes
    ----------
    command : int
        MAV_CMD.
    frame : int
        MAV_FRAME (:func:`mavlink_form` uses LOCAL_NED, GLOBAL_RELATIVE_ALT_INT with
        x = y = 0 for "here", and MISSION).
    params : tuple of 4 float
        param1..param4 in the units MAV_CMD defines; NaN where the spec allows "default"
        (a NaN yaw keeps the heading mode).
    x, y : float
        Latitude, longitude in degrees (global frames) or north, east in metres (local).
    z : float
        Altitude in metres (by frame), or down in metres (MAV_FRAME_LOCAL_NED).
    """

    command: int
    frame: int = MAV_FRAME_MISSION
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


def mavlink_form(item: MissionItem) -> MavlinkForm:
    """How ``item`` goes on the wire: local NED targets; take-off and landing "here" as
    lat = lon = 0 in a relative-altitude frame, altitude above home, as ArduPilot reads them.
    """
    nan = math.nan
    if item.command == "change_speed":
        return MavlinkForm(command=item.mav_cmd,
                           params=(float(MAV_PARAM_BY_SPEED_TYPE[item.speed_type]),
                                   float(item.speed_m_s), -1.0, 0.0))
    if item.command == "takeoff":
        return MavlinkForm(command=item.mav_cmd, frame=MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                           params=(0.0, 0.0, 0.0, nan), z=float(item.alt_m))
    if item.command == "rtl":
        return MavlinkForm(command=item.mav_cmd)
    if item.command == "land" and item.pos_ned is None:
        return MavlinkForm(command=item.mav_cmd, frame=MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                           params=(0.0, 0.0, 0.0, nan))
    assert item.pos_ned is not None, "a waypoint has a position (MissionItem checks it)"
    north, east, down = item.pos_ned
    if item.command == "land":
        return MavlinkForm(command=item.mav_cmd, frame=MAV_FRAME_LOCAL_NED,
                           params=(0.0, 0.0, 0.0, nan), x=north, y=east, z=down)
    yaw_deg = nan if item.yaw_rad is None else math.degrees(item.yaw_rad)
    return MavlinkForm(command=item.mav_cmd, frame=MAV_FRAME_LOCAL_NED,
                       params=(float(item.hold_s), 0.0, 0.0, yaw_deg), x=north, y=east, z=down)


def thesis_mission(*, alt_m: float = 0.6, side_m: float = 1.0, takeoff_s: float = 5.0,
                   settle_s: float = 2.0, leg_s: float = 10.0, corner_hold_s: float = 1.0,
                   final_hold_s: float = 2.0, land_s: float = 4.0) -> tuple[MissionItem, ...]:
    """The chapter-7 flight: take off to 0.6 m, a 1 m square at 0.6 m, land (about 60 s).

    Speeds are chosen so that each cubic takes the stated time (peak speed = 1.5 d / T),
    which makes the timeline data rather than code. With the defaults, for a vehicle armed
    and started at t = 0 s that tracks its reference:

    =====  ==========================================  =============
    seq    item                                        reference
    =====  ==========================================  =============
    1      DO_CHANGE_SPEED climb 0.18 m/s              t = 0
    2      NAV_TAKEOFF 0.6 m                           0 - 5 s
    3      NAV_WAYPOINT (0, 0, -0.6) hold 2 s          hold 5 - 7 s
    4      DO_CHANGE_SPEED ground 0.15 m/s             t = 7
    5      NAV_WAYPOINT (1, 0, -0.6) hold 1 s (north)  7 - 17, hold to 18
    6      NAV_WAYPOINT (1, 1, -0.6) hold 1 s (east)   18 - 28, hold to 29
    7      NAV_WAYPOINT (0, 1, -0.6) hold 1 s (south)  29 - 39, hold to 40
    8      NAV_WAYPOINT (0, 0, -0.6) hold 2 s (west)   40 - 50, hold to 52
    9      DO_CHANGE_SPEED descent 0.225 m/s           t = 52
    10     NAV_LAND                                    52 - 56 cubic, then creep down
    =====  ==========================================  =============

    Landing is detected about ``land_detect_time_s`` (1 s) after touchdown (~57 s), the
    motors disarm ``landed_disarm_delay_s`` (2 s) later (~59 s); the run ends at 60 s. The
    thesis's faults at 22 s (leg 2, 40 % along), 38 s (leg 3, 90 %) and 48 s (leg 4, 80 %)
    all fall while the square is flown, at 0.6 m and with the vehicle moving. Peak
    accelerations 6 d / T^2 are 0.144 m/s^2 (take-off, landing) and 0.06 m/s^2 (legs).

    Parameters
    ----------
    alt_m : float
        Hover altitude, m. side_m : float, square side, m. The remaining parameters are
        the durations (s) of take-off, the settling hold, each leg, the corner holds, the
        hold back at the start, and the landing cubic.

    Returns
    -------
    tuple of MissionItem
        Items for seq 1..10 (seq 0 is home).
    """
    for name, value in (("alt_m", alt_m), ("side_m", side_m), ("takeoff_s", takeoff_s),
                        ("leg_s", leg_s), ("land_s", land_s)):
        require(finite(value) and value > 0, name, value, "must be a finite number > 0")
    z = -float(alt_m)
    corners = [(side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]
    items: list[MissionItem] = [
        MissionItem(command="change_speed", speed_type="climb",
                    speed_m_s=1.5 * alt_m / takeoff_s),
        MissionItem(command="takeoff", alt_m=alt_m),
        MissionItem(command="waypoint", pos_ned=(0.0, 0.0, z), hold_s=settle_s),
        MissionItem(command="change_speed", speed_type="ground",
                    speed_m_s=1.5 * side_m / leg_s),
    ]
    for i, (north, east) in enumerate(corners):
        hold = final_hold_s if i == len(corners) - 1 else corner_hold_s
        items.append(MissionItem(command="waypoint", pos_ned=(north, east, z), hold_s=hold))
    items += [
        MissionItem(command="change_speed", speed_type="descent",
                    speed_m_s=1.5 * alt_m / land_s),
        MissionItem(command="land"),
    ]
    return tuple(items)
