"""The guided commands of the navigator: take-off, go-to, reposition, orbit, speed, home.

:class:`GuidedCommands` checks each command's target (finite, above home, inside the fence)
and state (GUIDED, armed, flying) and starts its leg: NAV_TAKEOFF, a position set-point
(SET_POSITION_TARGET_LOCAL_NED), DO_REPOSITION, DO_ORBIT (CIRCLE), DO_CHANGE_SPEED and
DO_SET_HOME.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from fcu.floats import wrap_pi
from fcu.navigation.events import CommandResult
from fcu.navigation.fence import target_problem
from fcu.navigation.mode_changes import ModeChanges
from fcu.navigation.modes import Mode
from flightdata.config import finite

__all__ = ["GuidedCommands"]


class GuidedCommands(ModeChanges):
    """Take-off, go-to, reposition, orbit, speed and home (module docstring); a layer of
    the navigator."""

    def takeoff(self, alt_m: float) -> CommandResult:
        """NAV_TAKEOFF in GUIDED: climb vertically to ``alt_m`` (m above home), then hold."""
        cfg = self.config
        if not finite(alt_m) or not cfg.land_detect_alt_m < alt_m:
            return self._refuse("take-off", f"altitude {alt_m!r} m not above "
                                f"{cfg.land_detect_alt_m} m")
        home = self._home_pos_ned
        problem = target_problem((home[0], home[1], home[2] - alt_m), home, cfg.fence)
        if problem is not None:
            return self._refuse("take-off", problem)
        if self._mode != Mode.GUIDED:
            return self._refuse("take-off", f"needs GUIDED (mode is {self._mode.name})")
        if not self._armed:
            return self._refuse("take-off", "not armed")
        if self._flying:
            return self._refuse("take-off", "already flying")
        self._start_takeoff(self._now(), float(alt_m), None)
        return self._ok()

    def _check_target(self, what: str, pos_ned: Sequence[float] | np.ndarray
                      ) -> np.ndarray | CommandResult:
        target = np.asarray(pos_ned, dtype=float).reshape(-1)
        if target.shape != (3,) or not np.all(np.isfinite(target)):
            return self._refuse(what, f"target {pos_ned!r} is not three finite numbers")
        if -target[2] < 0.0:
            return self._refuse(what, f"target altitude {-target[2]:.2f} m outside the air "
                                "(below home)")
        problem = target_problem(target, self._home_pos_ned, self.config.fence)
        if problem is not None:
            return self._refuse(what, f"target {problem}")
        return target

    def go_to(self, pos_ned: Sequence[float] | np.ndarray, yaw_rad: float | None = None
              ) -> CommandResult:
        """Fly to ``pos_ned`` (m, NED) along a cubic (SET_POSITION_TARGET_LOCAL_NED).

        Needs GUIDED and armed; on the ground it takes off along the leg
        (:mod:`fcu.navigation.guided_setpoints`). ``yaw_rad`` (rad) None keeps the current
        yaw. A new
        target replans from the current reference point, at rest (the velocity reference
        steps to zero); repeating the current target (a GCS streaming its setpoint) changes
        nothing.
        """
        target = self._check_target("go-to", pos_ned)
        if isinstance(target, CommandResult):
            return target
        if yaw_rad is not None and not finite(yaw_rad):
            return self._refuse("go-to", f"yaw {yaw_rad!r} is not finite")
        if self._mode != Mode.GUIDED:
            return self._refuse("go-to", f"needs GUIDED (mode is {self._mode.name})")
        if not self._armed:
            return self._refuse("go-to", "not armed")
        t = self._now()
        if not self._flying:  # a position set-point from the ground takes off (as PX4's)
            return self._goto_from_ground(t, target, yaw_rad)
        leg = self._leg
        if leg is not None and leg.kind in ("move", "takeoff") and leg.item_index is None and \
                leg.target_pos_ned is not None and leg.trajectory is not None and \
                float(np.max(np.abs(leg.target_pos_ned - target))) < 1e-6 and (
                    yaw_rad is None or abs(wrap_pi(
                        yaw_rad - leg.trajectory.evaluate(math.inf).yaw_rad)) < 1e-6):
            return self._ok("already going there")
        self._leg = self._move_leg("move", t, target, yaw_rad)
        self._event("mission", "going to ({:.2f}, {:.2f}, {:.2f})".format(*target))
        return self._ok()

    def reposition(self, pos_ned: Sequence[float] | np.ndarray, yaw_rad: float | None = None
                   ) -> CommandResult:
        """DO_REPOSITION: switch to GUIDED if needed, then :meth:`go_to`."""
        target = self._check_target("reposition", pos_ned)
        if isinstance(target, CommandResult):
            return target
        if not (self._armed and self._flying):
            return self._refuse("reposition", "not flying")
        if self._mode != Mode.GUIDED:
            result = self.set_mode(Mode.GUIDED)
            if not result.accepted:
                return result
        return self.go_to(target, yaw_rad)

    def orbit(self, centre_ned: Sequence[float] | np.ndarray | None, radius_m: float | None,
              speed_m_s: float | None) -> CommandResult:
        """DO_ORBIT: circle ``centre_ned`` (m, NED; None = the current position, at the
        current altitude) at ``radius_m`` (None: CIRCLE_RADIUS) and ``speed_m_s`` along the
        circle (> 0 clockwise seen from above; None: CIRCLE_RATE), in CIRCLE mode."""
        cfg = self.config
        if not (self._armed and self._flying):
            return self._refuse("orbit", "not flying")
        radius = cfg.circle_radius_m if radius_m is None else float(radius_m)
        if not finite(radius) or radius < 0.0:
            return self._refuse("orbit", f"radius {radius_m!r} m is not >= 0")
        if speed_m_s is None:
            rate = math.radians(cfg.circle_rate_deg_s)
        elif not finite(speed_m_s) or abs(speed_m_s) > cfg.max_speed_m_s:
            return self._refuse("orbit", f"speed {speed_m_s!r} m/s outside "
                                f"[-{cfg.max_speed_m_s}, {cfg.max_speed_m_s}] m/s")
        else:
            rate = float(speed_m_s) / radius if radius > 0.0 else 0.0
        start, _ = self._plan_start(self._now())
        checked = self._check_target(
            "orbit", start.copy() if centre_ned is None else np.asarray(centre_ned, dtype=float))
        if isinstance(checked, CommandResult):
            return checked
        centre = checked
        for point in ((centre[0] + radius, centre[1], centre[2]),
                      (centre[0], centre[1] + radius, centre[2]),
                      (centre[0] - radius, centre[1], centre[2]),
                      (centre[0], centre[1] - radius, centre[2])):
            problem = target_problem(point, self._home_pos_ned, cfg.fence)
            if problem is not None:
                return self._refuse("orbit", f"circle {problem}")
        if self._mode != Mode.CIRCLE:
            self._mode, old = Mode.CIRCLE, self._mode
            self._event("mode", f"mode {old.name} -> CIRCLE (orbit)")
            if old == Mode.AUTO:
                self._mission.active = False
        self._orbit(self._now(), centre, radius, rate)
        return self._ok()

    def change_speed(self, speed_m_s: float, speed_type: str = "ground") -> CommandResult:
        """DO_CHANGE_SPEED: set the ground, climb or descent speed of later legs (m/s)."""
        if speed_type not in ("ground", "climb", "descent"):
            return self._refuse("speed change", f"speed type {speed_type!r} is not ground, "
                                "climb or descent")
        if not finite(speed_m_s) or not 0.0 < speed_m_s <= self.config.max_speed_m_s:
            return self._refuse("speed change", f"speed {speed_m_s!r} m/s outside "
                                f"(0, {self.config.max_speed_m_s}] m/s")
        self._apply_speed(float(speed_m_s), speed_type)
        return self._ok()

    def set_home(self, pos_ned: Sequence[float] | np.ndarray) -> CommandResult:
        """DO_SET_HOME in local NED (m); RTL returns above it."""
        home = np.asarray(pos_ned, dtype=float).reshape(-1)
        if home.shape != (3,) or not np.all(np.isfinite(home)):
            return self._refuse("set home", f"position {pos_ned!r} is not three finite numbers")
        self._home_pos_ned = home.copy()
        self._event("home", "home set to ({:.2f}, {:.2f}, {:.2f})".format(*home))
        return self._ok()
