"""FOLLOW: ArduCopter's follow mode (``AP_Follow`` and ``ModeFollow``), flown as a chase.

A lead vehicle reports where it is (the endpoint turns FOLLOW_TARGET, or another system's
GLOBAL_POSITION_INT, into local NED: :meth:`FollowTarget.report`). The follower's goal is
the lead's position, extrapolated with its velocity from the report's time, plus an offset::

    goal(t) = p_lead + v_lead (t - t_report) + offset          (m, NED)
    offset  = (FOLL_OFS_X, FOLL_OFS_Y, FOLL_OFS_Z)             FOLL_OFS_TYPE 0: north, east, down
            = R(psi_lead) (FOLL_OFS_X, FOLL_OFS_Y, FOLL_OFS_Z) FOLL_OFS_TYPE 1: forward, right,
                                                                down of the lead's heading

All three offsets 0 (the default) take the follower's offset from the lead when the lead is
first seen in the mode and keep it (as ``AP_Follow::init_offsets_if_required``).

ArduCopter commands a velocity ``v = v_lead + FOLL_POS_P (goal - p)`` (``ModeFollow::run``)
to its velocity controller, limited to WPNAV_SPEED and the climb and descent speeds. Here
the controllers track a position reference, so the same law moves the reference point
``r`` instead of being fed the vehicle's position, with the guidance's acceleration limit::

    v_cmd = v_lead + FOLL_POS_P (goal - r)           limited to the leg speeds
    dv    = clip(v_cmd - r', |dv| <= a dt)          r' += dv,  r += r' dt

Without a usable lead (none yet, no report for ``FOLLOW_TIMEOUT_S``, farther than
FOLL_DIST_MAX, or FOLL_OFS_TYPE 1 without a heading) ``v_cmd`` is 0: the reference brakes
at the acceleration limit and holds, as ArduCopter's velocity controller does.

Yaw (FOLL_YAW_BEHAVE): 0 kept, 1 towards the lead (farther than 1 m horizontally), 2 the
lead's heading (when reported), 3 the direction of flight (above ``DIR_OF_FLIGHT_M_S``);
turned at the guidance's yaw rate limit.

FOLL_SYSID 0 follows the first system heard (and forgets it when it times out); any other
value follows only that system. Reports from the vehicle's own system id never count (the
endpoint drops them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fcu.floats import wrap_pi
from fcu.navigation.guidance import SpeedLimits
from fcu.navigation.reference import Reference
from flightdata.config import finite, require

__all__ = ["FollowChase", "FollowConfig", "FollowTarget", "LeadEstimate"]

FOLLOW_TIMEOUT_S = 3.0  # s without a report before the lead is lost (AP_FOLLOW_TIMEOUT_MS)
FACE_LEAD_MIN_M = 1.0  # m, horizontal distance below which yaw 1 keeps its heading (AP)
DIR_OF_FLIGHT_M_S = 0.1  # m/s, speed above which yaw 3 turns to the flight direction
# (ArduCopter's 1 m/s is twice this vehicle's default WPNAV_SPEED)
MAX_STEP_S = 0.05  # s, the chase integrates longer gaps in steps of at most this
OFFSET_NED, OFFSET_RELATIVE = 0, 1  # FOLL_OFS_TYPE
YAW_NONE, YAW_FACE_LEAD, YAW_SAME_AS_LEAD, YAW_DIR_OF_FLIGHT = 0, 1, 2, 3  # FOLL_YAW_BEHAVE
ALT_ABSOLUTE, ALT_RELATIVE = 0, 1  # FOLL_ALT_TYPE: GLOBAL_POSITION_INT's alt or relative_alt


@dataclass(frozen=True, kw_only=True)
class FollowConfig:
    """FOLLOW mode settings (ArduCopter's parameter in brackets)."""

    enable: int = 0  # 0 off (FOLLOW refused), 1 on [FOLL_ENABLE]
    sysid: int = 0  # system id of the lead, 0 = the first heard [FOLL_SYSID]
    dist_max_m: float = 100.0  # m, a lead farther than this is not followed, 0 = any
    # distance [FOLL_DIST_MAX]
    offset_x_m: float = 0.0  # m, north (type 0) or forward of the lead (type 1) [FOLL_OFS_X]
    offset_y_m: float = 0.0  # m, east (type 0) or right of the lead (type 1) [FOLL_OFS_Y]
    offset_z_m: float = 0.0  # m, below the lead (negative: above) [FOLL_OFS_Z]
    offset_type: int = OFFSET_NED  # 0 NED, 1 relative to the lead's heading [FOLL_OFS_TYPE]
    yaw_behave: int = YAW_FACE_LEAD  # 0 none, 1 face the lead, 2 the lead's heading,
    # 3 direction of flight [FOLL_YAW_BEHAVE]
    pos_p: float = 0.1  # 1/s, speed commanded per metre from the goal [FOLL_POS_P]
    alt_type: int = ALT_RELATIVE  # 0 AMSL, 1 above home: which altitude of another
    # system's GLOBAL_POSITION_INT is used (FOLLOW_TARGET's is AMSL) [FOLL_ALT_TYPE]

    def __post_init__(self) -> None:
        for name, hi in (("enable", 1), ("sysid", 255), ("offset_type", 1),
                         ("yaw_behave", 3), ("alt_type", 1)):
            value = getattr(self, name)
            require(isinstance(value, int) and not isinstance(value, bool)
                    and 0 <= value <= hi, name, value, f"must be a whole number in 0..{hi}")
        for name in ("offset_x_m", "offset_y_m", "offset_z_m"):
            require(finite(getattr(self, name)), name, getattr(self, name),
                    "must be a finite number (m)")
        require(finite(self.dist_max_m) and self.dist_max_m >= 0, "dist_max_m",
                self.dist_max_m, "must be a finite number >= 0 (m; 0 = no limit)")
        require(finite(self.pos_p) and self.pos_p > 0, "pos_p", self.pos_p,
                "must be a finite number > 0 (1/s)")

    @property
    def offsets_m(self) -> np.ndarray:
        """(FOLL_OFS_X, FOLL_OFS_Y, FOLL_OFS_Z), m."""
        return np.array([self.offset_x_m, self.offset_y_m, self.offset_z_m])


@dataclass(frozen=True)
class LeadEstimate:
    """Where the lead is at one instant (extrapolated from its latest report)."""

    sysid: int
    pos_ned: np.ndarray  # m, NED
    vel_ned: np.ndarray  # m/s, NED (zero when not reported)
    heading_rad: float | None  # rad from north, None when not reported


def _rotate_by_heading(offset: np.ndarray, heading_rad: float) -> np.ndarray:
    """(forward, right, down) in the lead's heading frame -> NED."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1], offset[2]])


class FollowTarget:
    """The lead vehicle as its reports describe it (``AP_Follow``'s target half).

    Parameters
    ----------
    config : FollowConfig
        FOLL_* settings; :meth:`configure` replaces them (in flight too).
    """

    def __init__(self, config: FollowConfig) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        """No lead known."""
        self._sysid: int | None = None  # the lead's system id once locked on
        self._time_s = -math.inf  # s, time of the latest report
        self._pos_ned = np.zeros(3)
        self._vel_ned = np.zeros(3)
        self._heading_rad: float | None = None

    def configure(self, config: FollowConfig) -> None:
        """New FOLL_* settings; a different FOLL_SYSID drops the lead locked on."""
        if config.sysid != self.config.sysid:
            self.reset()
        self.config = config

    @property
    def sysid(self) -> int | None:
        """System id of the lead locked on, None before the first report."""
        return self._sysid

    def report(self, time_s: float, sysid: int, pos_ned: np.ndarray,
               vel_ned: np.ndarray | None, heading_rad: float | None) -> bool:
        """A position report of system ``sysid`` at ``time_s`` (s): position (m, NED),
        velocity (m/s, NED; None unknown), heading (rad; None unknown). Returns True when it
        is the lead's (FOLL_SYSID, or the first system heard while it is 0)."""
        pos = np.asarray(pos_ned, dtype=float).reshape(-1)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            return False
        if self.config.sysid:
            if sysid != self.config.sysid:
                return False
        elif self._sysid is not None and sysid != self._sysid and \
                time_s - self._time_s <= FOLLOW_TIMEOUT_S:
            return False  # locked on another system that is still reporting
        self._sysid = int(sysid)
        self._time_s = float(time_s)
        self._pos_ned = pos.copy()
        vel = None if vel_ned is None else np.asarray(vel_ned, dtype=float).reshape(-1)
        self._vel_ned = vel.copy() if vel is not None and vel.shape == (3,) and \
            np.all(np.isfinite(vel)) else np.zeros(3)
        self._heading_rad = float(heading_rad) if heading_rad is not None and \
            finite(heading_rad) else None
        return True

    def estimate(self, time_s: float) -> LeadEstimate | None:
        """The lead at ``time_s`` (s), extrapolated at its reported velocity; None when no
        report came within ``FOLLOW_TIMEOUT_S``."""
        age_s = time_s - self._time_s
        if self._sysid is None or age_s > FOLLOW_TIMEOUT_S:
            return None
        dt = max(age_s, 0.0)
        return LeadEstimate(self._sysid, self._pos_ned + self._vel_ned * dt,
                            self._vel_ned.copy(), self._heading_rad)


class FollowChase:
    """The reference of a FOLLOW leg (module docstring), integrated as time advances.

    Parameters
    ----------
    target : FollowTarget
        The lead (shared with the navigator, which feeds it reports).
    start : Reference
        Where the reference starts (the current reference when the mode is entered).
    t0_s : float
        Time of ``start``, s.
    limits : SpeedLimits
        Speeds, acceleration and yaw rate of the chase.
    est_pos_ned : numpy.ndarray
        The vehicle's position at entry (m, NED): all-zero offsets are taken from it.
    """

    def __init__(self, target: FollowTarget, start: Reference, t0_s: float,
                 limits: SpeedLimits, est_pos_ned: np.ndarray) -> None:
        self._target = target
        self._limits = limits
        self._pos = np.array(start.pos_ned, dtype=float)
        self._vel = np.array(start.vel_ned, dtype=float)
        self._acc = np.zeros(3)
        self._yaw = float(start.yaw_rad)
        self._yaw_rate = 0.0
        self._time_s = float(t0_s)
        self._entry_pos = np.asarray(est_pos_ned, dtype=float).copy()
        self._captured: np.ndarray | None = None  # the offset taken at the first lead
        self._ref = self._make_reference()

    @property
    def following(self) -> bool:
        """True while the lead is usable (the chase heads for it)."""
        return self._goal(self._time_s)[0] is not None

    def _offset_ned(self, lead: LeadEstimate) -> np.ndarray | None:
        cfg = self._target.config
        offsets = cfg.offsets_m
        relative = cfg.offset_type == OFFSET_RELATIVE
        if relative and lead.heading_rad is None:
            return None
        if not np.any(offsets):  # all zero: keep the offset found when the lead appears
            if self._captured is None:
                found = self._entry_pos - lead.pos_ned
                self._captured = _rotate_by_heading(found, -lead.heading_rad) \
                    if relative and lead.heading_rad is not None else found
            offsets = self._captured
        return _rotate_by_heading(offsets, lead.heading_rad) \
            if relative and lead.heading_rad is not None else offsets

    def _goal(self, time_s: float) -> tuple[np.ndarray | None, LeadEstimate | None]:
        """The goal (m, NED) and the lead, or (None, lead or None) when not followed."""
        lead = self._target.estimate(time_s)
        if lead is None:
            return None, None
        dist_max = self._target.config.dist_max_m
        if dist_max > 0.0 and float(np.linalg.norm(lead.pos_ned - self._pos)) > dist_max:
            return None, lead
        offset = self._offset_ned(lead)
        if offset is None:
            return None, lead
        return lead.pos_ned + offset, lead

    def _advance(self, time_s: float, dt: float) -> None:
        lim = self._limits
        goal, lead = self._goal(time_s)
        if goal is None or lead is None:
            cmd = np.zeros(3)  # no usable lead: brake and hold
        else:
            # v_cmd = v_lead + FOLL_POS_P (goal - r), within the leg speeds
            cmd = lead.vel_ned + self._target.config.pos_p * (goal - self._pos)
            speed_xy = math.hypot(cmd[0], cmd[1])
            if speed_xy > lim.horizontal_m_s:
                cmd[:2] *= lim.horizontal_m_s / speed_xy
            cmd[2] = min(max(cmd[2], -lim.up_m_s), lim.down_m_s)
        # dv = clip(v_cmd - r', |dv| <= a dt)
        dv = cmd - self._vel
        dv_max = lim.accel_m_s2 * dt
        norm = float(np.linalg.norm(dv))
        if norm > dv_max:
            dv *= dv_max / norm
        self._pos = self._pos + (self._vel + 0.5 * dv) * dt  # r += mean r' over dt
        self._vel = self._vel + dv
        self._acc = dv / dt
        self._turn(self._yaw_goal(goal, lead), dt)

    def _yaw_goal(self, goal: np.ndarray | None, lead: LeadEstimate | None) -> float:
        behave = self._target.config.yaw_behave
        if lead is None or goal is None:
            return self._yaw
        if behave == YAW_FACE_LEAD:
            d = lead.pos_ned - self._pos
            if math.hypot(d[0], d[1]) > FACE_LEAD_MIN_M:
                return math.atan2(d[1], d[0])
        elif behave == YAW_SAME_AS_LEAD and lead.heading_rad is not None:
            return lead.heading_rad
        elif behave == YAW_DIR_OF_FLIGHT and math.hypot(self._vel[0], self._vel[1]) > \
                DIR_OF_FLIGHT_M_S:
            return math.atan2(self._vel[1], self._vel[0])
        return self._yaw

    def _turn(self, yaw_goal: float, dt: float) -> None:
        """Turn towards ``yaw_goal`` (rad) at most at the yaw rate limit."""
        step = wrap_pi(yaw_goal - self._yaw)
        max_step = self._limits.yaw_rate_rad_s * dt
        step = min(max(step, -max_step), max_step)
        self._yaw = wrap_pi(self._yaw + step)
        self._yaw_rate = step / dt

    def _make_reference(self) -> Reference:
        return Reference(pos_ned=self._pos, vel_ned=self._vel, acc_ned=self._acc,
                         yaw_rad=self._yaw, yaw_rate_rad_s=self._yaw_rate)

    def reference(self, time_s: float) -> Reference:
        """The reference at ``time_s`` (s): the chase advanced to it (a time not later than
        the latest one returns the latest reference)."""
        if time_s <= self._time_s:
            return self._ref
        while time_s > self._time_s:
            dt = min(time_s - self._time_s, MAX_STEP_S)
            self._time_s += dt
            self._advance(self._time_s, dt)
        self._ref = self._make_reference()
        return self._ref
