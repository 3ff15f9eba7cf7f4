"""The autopilot's configuration as ArduPilot-style parameters (the table lives with the code
whose configuration it exposes, as ArduPilot keeps a library's parameters with the library).

:data:`AUTOPILOT_PARAMS` maps each parameter to a field of :class:`fcu.autopilot.AutopilotConfig`:
``ATT_CTRL``, ``EST_TYPE``, ``DOB_TYPE``, ``HGT_SOURCE`` select the configuration choices of
:mod:`flightdata.vocabulary` (value = index of the choice); the position gains
``POS_XY_*``/``POS_Z_*``, the PD gains ``ATT_PD_*``, the LQR weights ``LQR_*``, the DOB cut-off,
the fault detector's threshold, persistence and significance (``FD_*``), the crash check's
action (``FS_CRASH_CHECK``, as ArduCopter's), and the navigator's settings under their
ArduCopter names and units (``WPNAV_SPEED`` cm/s, ``RTL_ALT`` cm, ``DISARM_DELAY`` s,
the battery monitor's capacity, thresholds and failsafe actions (``BATT_*``,
:mod:`fcu.monitoring.battery`), the geofence (``FENCE_*``, :mod:`fcu.navigation.fence`: off
by default, as ArduCopter's), ``AUTO_OPTIONS`` bits 0 and 1 as ArduCopter's: arming in
AUTO, take-off in AUTO without MISSION_START; default 0 as ArduCopter's, since
MISSION_START, which MAVSDK and QGC send to start a mission, takes off without either bit).
:class:`fcu.mavlink.autopilot_port.AutopilotPort` applies them: a change rebuilds the
autopilot with the new configuration, so it is accepted only disarmed on the ground, except
the parameters with ``live_speed`` (``WPNAV_SPEED``, ``WPNAV_SPEED_UP``, ``WPNAV_SPEED_DN``),
which also act at once in flight like DO_CHANGE_SPEED, ``FTC_MODE``, which switches the
fault-tolerant control at once, in flight or not, and the ``FENCE_*`` parameters, which act at
once in flight or not (as ArduCopter's: a fence enabled with the vehicle outside it is
breached at once). The pilot modes' stick settings (``ANGLE_MAX``, ``PILOT_*``, ``LOIT_*``,
``THR_DZ``, ``MOT_THST_HOVER``, :class:`fcu.navigation.sticks.PilotConfig`) are ordinary
parameters (disarmed on the ground).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, TypeVar

from fcu.autopilot import AutopilotConfig
from fcu.navigation.settings import NavigatorConfig
from flightdata import vocabulary

__all__ = ["AUTOPILOT_PARAMS", "ApParam", "find_param"]

Getter = Callable[[AutopilotConfig], float]
Setter = Callable[[AutopilotConfig, float], AutopilotConfig]


@dataclass(frozen=True)
class ApParam:
    """One autopilot parameter: its definition and how it reads/writes the configuration."""

    name: str
    description: str
    get: Getter
    set: Setter
    min_value: float = -math.inf
    max_value: float = math.inf
    allowed: tuple[float, ...] | None = None
    integer: bool = False
    live_speed: str | None = None  # DO_CHANGE_SPEED type applied at once in flight
    live_ftc: bool = False  # the FTC mode: switched at once, in flight too (no rebuild)
    live_fence: bool = False  # the geofence: applied at once, in flight too (no rebuild)
    live_follow: bool = False  # FOLLOW's settings: applied at once, in flight too
    read_only: bool = False


C = TypeVar("C")


def _with(obj: C, name: str, value: Any) -> C:
    """The frozen dataclass ``obj`` with field ``name`` replaced (its checks run again)."""
    changes: dict[str, Any] = {name: value}
    return replace(obj, **changes)  # type: ignore[type-var]


def _enum_param(attr: str, description: str) -> ApParam:
    """A configuration choice (:data:`flightdata.vocabulary.CONFIG_CHOICES`) as the parameter
    :data:`flightdata.vocabulary.CONFIG_PARAMS` names, valued by the choice's index."""
    choices = vocabulary.CONFIG_CHOICES[attr]
    return ApParam(
        vocabulary.CONFIG_PARAMS[attr], description,
        get=lambda c: float(choices.index(getattr(c, attr))),
        set=lambda c, v: _with(c, attr, choices[int(v)]),
        min_value=0, max_value=len(choices) - 1,
        allowed=tuple(float(i) for i in range(len(choices))), integer=True)


def _axes(values: tuple[float, float, float], value: float, axes: tuple[int, ...]
          ) -> tuple[float, float, float]:
    out = list(values)
    for i in axes:
        out[i] = float(value)
    return (out[0], out[1], out[2])


def _gain_param(name: str, group: str, attr: str, axes: tuple[int, ...], unit: str,
                description: str, lo: float, hi: float) -> ApParam:
    return ApParam(
        name, f"{description}, {unit}",
        get=lambda c: float(getattr(getattr(c, group), attr)[axes[0]]),
        set=lambda c, v: _with(c, group, _with(
            getattr(c, group), attr, _axes(getattr(getattr(c, group), attr), v, axes))),
        min_value=lo, max_value=hi)


def _nav_param(name: str, attr: str, scale: float, unit: str, description: str,
               lo: float, hi: float, live_speed: str | None = None) -> ApParam:
    """A NavigatorConfig field shown in ArduCopter units (``value = field * scale``)."""
    return ApParam(
        name, f"{description}, {unit}",
        get=lambda c: float(getattr(c.navigator, attr)) * scale,
        set=lambda c, v: replace(c, navigator=_with(c.navigator, attr, v / scale)),
        min_value=lo, max_value=hi, live_speed=live_speed)


def _section_param(section: str, name: str, attr: str, unit: str, description: str,
                   lo: float, hi: float, integer: bool) -> ApParam:
    """A field of a settings section of the navigator (``fence``, ``follow``), applied at
    once in flight too."""
    cast: Callable[[float], Any] = int if integer else float
    return ApParam(
        name, f"{description}, {unit}",
        get=lambda c: float(getattr(getattr(c.navigator, section), attr)),
        set=lambda c, v: replace(c, navigator=_with(
            c.navigator, section, _with(getattr(c.navigator, section), attr, cast(v)))),
        min_value=lo, max_value=hi, integer=integer,
        allowed=tuple(float(v) for v in range(int(lo), int(hi) + 1)) if integer else None,
        live_fence=section == "fence", live_follow=section == "follow")


def _fence_param(name: str, attr: str, unit: str, description: str, lo: float, hi: float,
                 integer: bool = False) -> ApParam:
    """A field of the navigator's geofence (:class:`fcu.navigation.fence.FenceConfig`)."""
    return _section_param("fence", name, attr, unit, description, lo, hi, integer)


def _follow_param(name: str, attr: str, unit: str, description: str, lo: float, hi: float,
                  integer: bool = False) -> ApParam:
    """A field of FOLLOW's settings (:class:`fcu.navigation.follow.FollowConfig`)."""
    return _section_param("follow", name, attr, unit, description, lo, hi, integer)


def _pilot_param(name: str, attr: str, scale: float, unit: str, description: str, lo: float,
                 hi: float) -> ApParam:
    """A field of the pilot modes' settings (:class:`fcu.navigation.sticks.PilotConfig`) in
    ArduCopter units (``value = field * scale``)."""
    return ApParam(
        name, f"{description}, {unit}",
        get=lambda c: float(getattr(c.navigator.pilot, attr)) * scale,
        set=lambda c, v: replace(c, navigator=_with(
            c.navigator, "pilot", _with(c.navigator.pilot, attr, v / scale))),
        min_value=lo, max_value=hi)


def _top_param(name: str, attr: str, unit: str, description: str, lo: float,
               hi: float) -> ApParam:
    return ApParam(name, f"{description}, {unit}", get=lambda c: float(getattr(c, attr)),
                    set=lambda c, v: _with(c, attr, float(v)), min_value=lo,
                    max_value=hi)


def _group_param(name: str, group: str, attr: str, unit: str, description: str, lo: float,
                 hi: float, integer: bool = False) -> ApParam:
    """A field of one of the configuration's groups (``detector``, ``crash``...)."""
    cast: Callable[[float], Any] = int if integer else float
    return ApParam(name, f"{description}, {unit}",
                   get=lambda c: float(getattr(getattr(c, group), attr)),
                   set=lambda c, v: _with(c, group, _with(getattr(c, group), attr, cast(v))),
                   min_value=lo, max_value=hi, integer=integer,
                   allowed=tuple(float(v) for v in range(int(lo), int(hi) + 1))
                   if integer else None)


# The gains and weights: name, configuration group, field, axes (0 north/roll, 1 east/pitch,
# 2 down/yaw), unit, description, range. The position and PD gains range from 0 to a few
# times their defaults (a gain of 1e9 slams the motors between saturations); the LQR weights
# only matter relative to each other, so any positive value is a design.
_GAINS: tuple[tuple[str, str, str, tuple[int, ...], str, str, float, float], ...] = (
    ("POS_XY_KP", "position", "kp", (0, 1), "1/s^2", "Horizontal position P gain", 0.0, 40.0),
    ("POS_XY_KD", "position", "kd", (0, 1), "1/s", "Horizontal position D gain", 0.0, 30.0),
    ("POS_XY_KI", "position", "ki", (0, 1), "1/s^3", "Horizontal position I gain", 0.0, 15.0),
    ("POS_Z_KP", "position", "kp", (2,), "1/s^2", "Vertical position P gain", 0.0, 40.0),
    ("POS_Z_KD", "position", "kd", (2,), "1/s", "Vertical position D gain", 0.0, 30.0),
    ("POS_Z_KI", "position", "ki", (2,), "1/s^3", "Vertical position I gain", 0.0, 15.0),
    ("ATT_PD_RP_KP", "pd", "kp", (0, 1), "1/s^2", "PD roll/pitch angle gain", 0.0, 500.0),
    ("ATT_PD_RP_KD", "pd", "kd", (0, 1), "1/s", "PD roll/pitch rate gain", 0.0, 80.0),
    ("ATT_PD_Y_KP", "pd", "kp", (2,), "1/s^2", "PD yaw angle gain", 0.0, 100.0),
    ("ATT_PD_Y_KD", "pd", "kd", (2,), "1/s", "PD yaw rate gain", 0.0, 40.0),
    ("LQR_QINT_RP", "lqr", "q_integral", (0, 1), "1/(rad*s)^2",
      "LQR roll/pitch integral weight", 1e-9, 1e9),
    ("LQR_QANG_RP", "lqr", "q_angle", (0, 1), "1/rad^2", "LQR roll/pitch angle weight", 1e-9, 1e9),
    ("LQR_QRATE_RP", "lqr", "q_rate", (0, 1), "1/(rad/s)^2",
      "LQR roll/pitch rate weight", 1e-9, 1e9),
    ("LQR_R_RP", "lqr", "r_torque", (0, 1), "1/(N*m)^2",
      "LQR roll/pitch torque weight", 1e-9, 1e9),
    ("LQR_QINT_Y", "lqr", "q_integral", (2,), "1/(rad*s)^2", "LQR yaw integral weight", 1e-9, 1e9),
    ("LQR_QANG_Y", "lqr", "q_angle", (2,), "1/rad^2", "LQR yaw angle weight", 1e-9, 1e9),
    ("LQR_QRATE_Y", "lqr", "q_rate", (2,), "1/(rad/s)^2", "LQR yaw rate weight", 1e-9, 1e9),
    ("LQR_R_Y", "lqr", "r_torque", (2,), "1/(N*m)^2", "LQR yaw torque weight", 1e-9, 1e9),
)


AUTOPILOT_PARAMS: tuple[ApParam, ...] = (
    _enum_param("attitude",
                "Attitude controller: 0 PD (eq. 5.6), 1 LQG (LQR + integral, eq. 5.10)"),
    _enum_param("estimator",
                "Estimate fed to the controllers: 0 EKF, 1 TSKF"),
    _enum_param("dob",
                "Disturbance observer: 0 none, 1 VbDOB, 2 AbDOB (eq. 6.27-6.30)"),
    _enum_param("height_source",
                "Height source: 0 motion capture, 1 barometer"),
    replace(_enum_param("ftc", "Fault-tolerant control: 0 passive (thesis), 1 active "
                        "(allocation uses the estimated motor effectiveness); "
                        "switches in flight"), live_ftc=True),
    ApParam("ARMING_CHECK", "Pre-arm checks: 1 all, always (read-only; COMPONENT_ARM_DISARM "
             "p2 = 21196 forces)", get=lambda c: 1.0, set=lambda c, v: c, min_value=0,
             max_value=1, integer=True, read_only=True),
    ApParam("SCHED_LOOP_RATE", "Autopilot loop rate, Hz (read-only)",
             get=lambda c: float(c.loop_rate_hz), set=lambda c, v: c, min_value=0,
             max_value=1e6, read_only=True),
    _top_param("DOB_CUTOFF", "dob_cutoff_rad_s", "rad/s", "DOB Q-filter cut-off", 0.01, 1e3),
    _top_param("ATT_REF_BW", "attitude_ref_bandwidth_rad_s", "rad/s",
               "Attitude reference filter bandwidth", 0.01, 1e3),
    *(_gain_param(*gain) for gain in _GAINS),
    _group_param("FD_THRESH", "detector", "threshold", "fraction",
                 "Fault detector: LOE above which a motor is suspected", 0.01, 0.99),
    _group_param("FD_PERSIST", "detector", "persistence_s", "s",
                 "Fault detector: time above the threshold before a fault is declared",
                 0.0, 60.0),
    _group_param("FD_SIGNIF", "detector", "significance", "chi-square",
                 "Fault detector: GLR statistic a motor fault must exceed (25: 5 sigma)",
                 1.0, 1e4),
    _group_param("FS_CRASH_CHECK", "crash", "action", "0 report, 1 disarm",
                 "Crash check: what a detected crash does", 0, 1, integer=True),
    _nav_param("WPNAV_SPEED", "speed_horizontal_m_s", 100.0, "cm/s",
               "Horizontal leg speed", 1.0, 500.0, live_speed="ground"),
    _nav_param("WPNAV_SPEED_UP", "speed_up_m_s", 100.0, "cm/s", "Climb speed", 1.0, 500.0,
               live_speed="climb"),
    _nav_param("WPNAV_SPEED_DN", "speed_down_m_s", 100.0, "cm/s", "Descent speed", 1.0,
               500.0, live_speed="descent"),
    _nav_param("WPNAV_ACCEL", "accel_m_s2", 100.0, "cm/s/s", "Peak leg acceleration", 1.0,
               1000.0),
    _nav_param("WPNAV_RADIUS", "wp_radius_m", 100.0, "cm", "Waypoint reached radius", 1.0,
               1000.0),
    _nav_param("RTL_ALT", "rtl_alt_m", 100.0, "cm", "RTL return altitude above home", 10.0,
               1000.0),
    _nav_param("RTL_LOIT_TIME", "rtl_hold_s", 1000.0, "ms", "RTL hold above home", 0.0,
               60000.0),
    _nav_param("LAND_SPEED", "land_creep_speed_m_s", 100.0, "cm/s",
               "Final landing descent speed", 1.0, 200.0),
    _nav_param("DISARM_DELAY", "idle_disarm_delay_s", 1.0, "s",
               "Auto-disarm delay when armed on the ground without a take-off (0 never; "
               f"auto-disarm after a landing: {NavigatorConfig().landed_disarm_delay_s:g} s, "
               "not this parameter)",
               0.0, 127.0),
    _group_param("BATT_CAPACITY", "battery", "capacity_mah", "mAh",
                 "Battery capacity (remaining charge, BATT_LOW_MAH)", 1.0, 1e6),
    _group_param("BATT_LOW_VOLT", "battery", "low_volt_v", "V",
                 "Battery low below this for BATT_LOW_TIMER (0 off)", 0.0, 100.0),
    _group_param("BATT_LOW_MAH", "battery", "low_mah", "mAh",
                 "Battery low when less charge remains (0 off)", 0.0, 1e6),
    _group_param("BATT_CRT_VOLT", "battery", "critical_volt_v", "V",
                 "Battery critical below this for BATT_LOW_TIMER (0 off)", 0.0, 100.0),
    _group_param("BATT_CRT_MAH", "battery", "critical_mah", "mAh",
                 "Battery critical when less charge remains (0 off)", 0.0, 1e6),
    _group_param("BATT_FS_LOW_ACT", "battery", "low_action", "0 warn, 1 LAND, 2 RTL",
                 "Battery low failsafe action", 0, 2, integer=True),
    _group_param("BATT_FS_CRT_ACT", "battery", "critical_action", "0 warn, 1 LAND, 2 RTL",
                 "Battery critical failsafe action", 0, 2, integer=True),
    _group_param("BATT_LOW_TIMER", "battery", "low_timer_s", "s",
                 "Voltage below a threshold this long before the failsafe", 0.0, 120.0),
    _fence_param("FENCE_ENABLE", "enable", "0 off, 1 on",
                 "Geofence enforced (off by default, as ArduCopter)", 0, 1, integer=True),
    _fence_param("FENCE_TYPE", "types", "bitmask",
                 "Fences enforced: 1 maximum altitude, 2 circle about home, 4 polygons",
                 0, 7, integer=True),
    _fence_param("FENCE_ALT_MAX", "alt_max_m", "m", "Fence: maximum altitude above home",
                 1.0, 1000.0),
    _fence_param("FENCE_RADIUS", "radius_m", "m", "Fence: circle radius about home",
                 1.0, 10000.0),
    _fence_param("FENCE_ACTION", "action", "0 report, 1 RTL or LAND, 2 LAND, 3 SmartRTL or "
                 "RTL (RTL), 4 BRAKE, 5 SmartRTL or LAND (LAND)",
                 "Fence breach action", 0, 5, integer=True),
    _fence_param("FENCE_MARGIN", "margin_m", "m",
                 "Fence margin: RTL stays this far below FENCE_ALT_MAX; back inside by it "
                 "re-arms the breach", 0.0, 100.0),
    _nav_param("CIRCLE_RADIUS", "circle_radius_m", 100.0, "cm", "CIRCLE mode radius", 0.0,
               1e6),
    _nav_param("CIRCLE_RATE", "circle_rate_deg_s", 1.0, "deg/s",
               "CIRCLE mode turn rate, > 0 clockwise seen from above", -90.0, 90.0),
    _nav_param("GUID_TIMEOUT", "guided_timeout_s", 1.0, "s", "GUIDED velocity and attitude "
               "set-points older than this are replaced by a hold", 0.1, 5.0),
    _follow_param("FOLL_ENABLE", "enable", "0 off, 1 on", "FOLLOW mode allowed", 0, 1,
                  integer=True),
    _follow_param("FOLL_SYSID", "sysid", "system id", "FOLLOW: the lead's system id (0: the "
                  "first heard)", 0, 255, integer=True),
    _follow_param("FOLL_DIST_MAX", "dist_max_m", "m",
                  "FOLLOW: a lead farther than this is not followed (0: any distance)",
                  0.0, 1000.0),
    _follow_param("FOLL_OFS_TYPE", "offset_type", "0 NED, 1 relative to the lead's heading",
                  "FOLLOW: offset frame", 0, 1, integer=True),
    _follow_param("FOLL_OFS_X", "offset_x_m", "m", "FOLLOW: offset north or forward of the "
                  "lead (all three 0: the offset when the lead is first seen)", -500.0, 500.0),
    _follow_param("FOLL_OFS_Y", "offset_y_m", "m", "FOLLOW: offset east or right of the lead",
                  -500.0, 500.0),
    _follow_param("FOLL_OFS_Z", "offset_z_m", "m", "FOLLOW: offset below the lead (negative: "
                  "above)", -500.0, 500.0),
    _follow_param("FOLL_YAW_BEHAVE", "yaw_behave", "0 none, 1 face the lead, 2 the lead's "
                  "heading, 3 direction of flight", "FOLLOW: yaw", 0, 3, integer=True),
    _follow_param("FOLL_POS_P", "pos_p", "1/s", "FOLLOW: speed per metre from the goal",
                  0.01, 10.0),
    _follow_param("FOLL_ALT_TYPE", "alt_type", "0 AMSL, 1 above home",
                  "FOLLOW: altitude of the lead's GLOBAL_POSITION_INT used", 0, 1, integer=True),
    _pilot_param("ANGLE_MAX", "angle_max_deg", 100.0, "cdeg",
                 "Lean angle at full roll/pitch stick (STABILIZE, ALT_HOLD)", 100.0, 8000.0),
    _pilot_param("PILOT_Y_RATE", "yaw_rate_deg_s", 1.0, "deg/s",
                 "Yaw rate at full yaw stick", 1.0, 500.0),
    _pilot_param("PILOT_SPEED_UP", "speed_up_m_s", 100.0, "cm/s",
                 "Climb rate at full throttle (ALT_HOLD, LOITER, POSHOLD)", 10.0, 500.0),
    _pilot_param("PILOT_SPEED_DN", "speed_down_m_s", 100.0, "cm/s",
                 "Descent rate at zero throttle (0: PILOT_SPEED_UP)", 0.0, 500.0),
    _pilot_param("PILOT_ACCEL_Z", "accel_z_m_s2", 100.0, "cm/s/s",
                 "Vertical acceleration following the throttle stick", 10.0, 500.0),
    _pilot_param("LOIT_SPEED", "loiter_speed_m_s", 100.0, "cm/s",
                 "Horizontal speed at full stick (LOITER, POSHOLD)", 10.0, 2000.0),
    _pilot_param("LOIT_ACC_MAX", "loiter_accel_m_s2", 100.0, "cm/s/s",
                 "Horizontal acceleration following the sticks (LOITER, POSHOLD)",
                 10.0, 1000.0),
    _pilot_param("THR_DZ", "throttle_deadzone", 1000.0, "of 1000",
                 "Throttle dead zone either side of mid-stick (no climb)", 0.0, 300.0),
    _pilot_param("MOT_THST_HOVER", "hover_throttle", 1.0, "fraction",
                 "Throttle curve output at mid-stick (STABILIZE)", 0.1, 0.8),
    ApParam("AUTO_OPTIONS", "AUTO mode options, bitmask: bit 0 (1) arming in AUTO allowed, "
            "bit 1 (2) AUTO armed on the ground takes off without MISSION_START",
            get=lambda c: float(c.navigator.auto_options),
            set=lambda c, v: replace(c, navigator=_with(c.navigator, "auto_options", int(v))),
            min_value=0, max_value=3, allowed=(0.0, 1.0, 2.0, 3.0), integer=True),
)


def find_param(name: str) -> ApParam | None:
    """The autopilot parameter called ``name``, if there is one."""
    return _BY_NAME.get(name)


_BY_NAME = {p.name: p for p in AUTOPILOT_PARAMS}
