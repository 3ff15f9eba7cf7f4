"""GUIDED's velocity and attitude set-points, and position set-points from the ground.

A ground station flying "offboard" (MAVSDK's Offboard plugin, ArduCopter's guided velocity
and attitude control, PX4's OFFBOARD) streams set-points at 10-50 Hz:

- **velocity** (SET_POSITION_TARGET_* with only the velocity used): flown by a pilot leg's
  ``"loiter"`` law (:mod:`fcu.navigation.pilot_leg`): the target position moves at the
  set-point's horizontal velocity (reached at LOIT_ACC_MAX), the altitude at its vertical one
  (reached at PILOT_ACCEL_Z); a heading turns the yaw reference to it, a yaw rate turns it at
  that rate. A body-frame velocity (MAV_FRAME_BODY_NED) is kept in the heading frame, so a
  forward velocity with a yaw rate flies a circle, as MAVSDK's ``offboard_velocity_body.py``
  expects.
- **attitude** (SET_ATTITUDE_TARGET): flown by the ``"alt_hold"`` law: the lean angles as
  given (at most ANGLE_MAX), the heading, and the thrust read as ArduCopter reads it without
  GUID_OPTIONS bit 3: a climb rate, ``(thrust - 0.5) 2`` times WPNAV_SPEED_UP above one half,
  times WPNAV_SPEED_DN below.

A velocity or attitude set-point older than ``GUID_TIMEOUT`` (``guided_timeout_s``, 3 s, as
ArduCopter) is replaced by a hold (zero velocity, level, no climb) until the next one comes.
Armed on the ground in GUIDED, a set-point that climbs takes off (as PX4's OFFBOARD does; a
position target above the ground too, through a take-off leg to its altitude), so the
offboard examples written for PX4 fly here; one that does not climb is kept for later.
"""

from __future__ import annotations

import math

import numpy as np

from fcu.navigation.events import CommandResult
from fcu.navigation.modes import Mode
from fcu.navigation.pilot_leg import HOLD, Demand, PilotLaw
from fcu.navigation.pilot_modes import PilotModes

__all__ = ["GuidedSetpoints"]


class GuidedSetpoints(PilotModes):
    """Velocity and attitude set-points in GUIDED (module docstring); a layer of the
    navigator."""

    _mode: Mode  # the navigator's flight mode
    _armed: bool  # the navigator's arming state

    def _reset_flight(self) -> None:
        super()._reset_flight()
        # the latest set-point: its law, demand and arrival time (s, simulated)
        self._setpoint: tuple[PilotLaw, Demand, float] | None = None

    def set_velocity(self, vel_ned: np.ndarray, yaw_rad: float | None = None,
                     yaw_rate_rad_s: float | None = None, heading_frame: bool = False
                     ) -> CommandResult:
        """Fly at ``vel_ned`` (m/s, NED; with ``heading_frame``: forward, right, down of the
        heading) in GUIDED, turning to ``yaw_rad`` (rad) or at ``yaw_rate_rad_s`` (rad/s, >
        0 clockwise) if given."""
        vel = np.asarray(vel_ned, dtype=float).reshape(-1)
        if vel.shape != (3,) or not np.all(np.isfinite(vel)):
            return self._refuse("velocity", f"{vel_ned!r} is not three finite numbers")
        if yaw_rad is not None and not math.isfinite(yaw_rad):
            return self._refuse("velocity", f"yaw {yaw_rad!r} is not finite")
        if yaw_rate_rad_s is not None and not math.isfinite(yaw_rate_rad_s):
            return self._refuse("velocity", f"yaw rate {yaw_rate_rad_s!r} is not finite")
        demand = Demand(vel_ne_m_s=(float(vel[0]), float(vel[1])), climb_m_s=-float(vel[2]),
                        heading_frame=heading_frame, yaw_rad=yaw_rad,
                        yaw_rate_rad_s=0.0 if yaw_rate_rad_s is None else yaw_rate_rad_s)
        return self._set_point("velocity", "loiter", demand)

    def set_attitude(self, roll_rad: float, pitch_rad: float, yaw_rad: float | None,
                     thrust: float) -> CommandResult:
        """Lean to (``roll_rad``, ``pitch_rad``) (rad, at most ANGLE_MAX each), face
        ``yaw_rad`` (rad; None: no turn) in GUIDED, climbing as ``thrust`` (0..1) asks
        (module docstring: 0.5 holds the altitude)."""
        values = (roll_rad, pitch_rad, thrust) + (() if yaw_rad is None else (yaw_rad,))
        if not all(math.isfinite(v) for v in values):
            return self._refuse("attitude", f"{values!r} are not all finite")
        if not 0.0 <= thrust <= 1.0:
            return self._refuse("attitude", f"thrust {thrust!r} outside [0, 1]")
        cfg = self.config
        climb = 2.0 * (thrust - 0.5) * (cfg.speed_up_m_s if thrust > 0.5
                                         else cfg.speed_down_m_s)
        limit = math.radians(cfg.pilot.angle_max_deg)
        lean = (min(max(roll_rad, -limit), limit), min(max(pitch_rad, -limit), limit))
        demand = Demand(lean_rad=lean, climb_m_s=climb, yaw_rad=yaw_rad)
        return self._set_point("attitude", "alt_hold", demand)

    def _set_point(self, what: str, law: PilotLaw, demand: Demand) -> CommandResult:
        if self._mode != Mode.GUIDED:
            return self._refuse(what, f"needs GUIDED (mode is {self._mode.name})")
        if not self._armed:
            return self._refuse(what, "not armed")
        t = self._now()
        self._setpoint = (law, demand, t)
        leg = self._leg
        if not self._flying:
            if demand.climb_m_s > 0.0:
                self._pilot_lift_off(t, law, demand, f"take-off by {what} set-point")
            return self._ok()
        if leg is None or leg.pilot is None or leg.pilot.law != law:
            self._leg = self._pilot_leg(t, law=law)
            self._event("mode", f"GUIDED: flown by {what} set-points")
        return self._ok()

    def _goto_from_ground(self, t: float, target: np.ndarray, yaw_rad: float | None
                          ) -> CommandResult:
        """A position target armed on the ground in GUIDED (``target``, m, NED): take off
        along a leg to it, reported as a take-off until it arrives."""
        if -target[2] <= self.config.land_detect_alt_m:
            return self._refuse("go-to", "not flying: the target is on the ground")
        self._start_takeoff(t, float(-target[2]), None)
        self._leg = self._move_leg("takeoff", t, target, yaw_rad)
        return self._ok()

    def _run_flight(self, t: float, max_transitions: int) -> None:
        leg, setpoint = self._leg, self._setpoint
        pilot = leg.pilot if leg is not None else None
        if self._mode != Mode.GUIDED or pilot is None or setpoint is None or leg is None:
            super()._run_flight(t, max_transitions)
            return
        _, demand, since_s = setpoint
        if t - since_s > self.config.guided_timeout_s:
            demand = HOLD  # a stale set-point: stop and hold, level
        self._fly_pilot(t, leg, pilot, demand)
