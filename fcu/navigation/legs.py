"""Legs: what the vehicle is doing in flight, a trajectory and how it completes.

The navigator's state machine (:mod:`fcu.navigation.navigator`) flies one :class:`Leg` at a
time; the functions below plan each kind from where the vehicle is (the current reference in
flight, else the estimate) with the guidance of :mod:`fcu.navigation.guidance`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from fcu.navigation.circle import Circle
from fcu.navigation.follow import FollowChase
from fcu.navigation.guidance import (
    SpeedLimits,
    Trajectory,
    Waypoint,
    hold_trajectory,
    landing_trajectory,
    takeoff_trajectory,
)
from fcu.navigation.pilot_leg import PilotLeg
from fcu.navigation.reference import Reference

LegKind = Literal["takeoff", "move", "hold", "manual", "approach", "rtl_return", "land",
                  "circle", "circle_approach", "follow", "pilot"]


@dataclass
class Leg:
    """What the vehicle is doing in flight: a trajectory and how it completes."""

    kind: LegKind
    trajectory: Trajectory | None  # None for "manual", "circle", "pilot"
    target_pos_ned: np.ndarray | None = None
    arrival_s: float = math.inf  # s, reference arrives at the target
    hold_s: float = 0.0  # s, rest at the target before the leg is done
    item_index: int | None = None  # mission item this leg flies (AUTO)
    manual_z_ned: float = 0.0  # m, held altitude of a "manual" leg
    manual_yaw_rad: float = 0.0  # rad, held yaw of a "manual" leg
    checked: bool = False  # the reached test ran at least once after arrival
    reached_s: float | None = None  # s, step time the target was reached
    ready_s: float | None = None  # s, time counted as arrival when scheduling what follows
    done: bool = False
    circle: Circle | None = None  # the circle of a "circle" leg (no trajectory)
    follow: FollowChase | None = None  # the chase of a "follow" leg (no trajectory)
    pilot: PilotLeg | None = None  # the sticks' targets of a "pilot" leg (no trajectory)

    def reference(self, time_s: float, est_pos_ned: np.ndarray, est_vel_ned: np.ndarray
                  ) -> Reference:
        """What the controllers track at ``time_s`` (s); a "manual" leg follows the
        estimate (m, m/s, NED) horizontally and holds its altitude and yaw."""
        if self.kind == "manual":
            pos = np.array([est_pos_ned[0], est_pos_ned[1], self.manual_z_ned])
            vel = np.array([est_vel_ned[0], est_vel_ned[1], 0.0])
            return Reference(pos_ned=pos, vel_ned=vel, acc_ned=np.zeros(3),
                             yaw_rad=self.manual_yaw_rad)
        if self.circle is not None:
            return self.circle.reference(time_s)
        if self.follow is not None:
            return self.follow.reference(time_s)
        if self.pilot is not None:  # (advanced once per tick by the navigator)
            return self.pilot.reference
        assert self.trajectory is not None
        return self.trajectory.evaluate(time_s)


def stopping_point(pos_ned: np.ndarray, vel_ned: np.ndarray, limits: SpeedLimits
                   ) -> np.ndarray:
    """Position plus the distance to stop at the acceleration limit, ``v|v| / (2 a)`` (m)."""
    return pos_ned + vel_ned * np.abs(vel_ned) / (2.0 * limits.accel_m_s2)


def move_leg(kind: LegKind, t0: float, start: np.ndarray, start_yaw_rad: float,
             target: np.ndarray, yaw_rad: float | None, limits: SpeedLimits,
             hold_s: float = 0.0, item_index: int | None = None) -> Leg:
    """A cubic from ``start`` (m, NED; yaw rad) to ``target`` starting at ``t0`` (s);
    ``yaw_rad`` None keeps the start yaw."""
    traj = Trajectory.from_waypoints(
        t0, start, [Waypoint(pos_ned=tuple(target), yaw_rad=yaw_rad)], limits, start_yaw_rad)
    return Leg(kind, traj, np.array(target, dtype=float), traj.arrival_times_s[-1],
               hold_s, item_index)


def hold_leg(t0: float, pos_ned: np.ndarray, yaw_rad: float) -> Leg:
    """Hold ``pos_ned`` (m, NED) and ``yaw_rad`` (rad) from ``t0`` (s) on."""
    return Leg("hold", hold_trajectory(t0, pos_ned, yaw_rad))


def manual_leg(z_ned: float, yaw_rad: float) -> Leg:
    """Hold altitude ``z_ned`` (m) and ``yaw_rad`` (rad), the horizontal position free."""
    return Leg("manual", None, manual_z_ned=z_ned, manual_yaw_rad=yaw_rad)


def takeoff_leg(t0: float, start: np.ndarray, yaw_rad: float, alt_m: float,
                limits: SpeedLimits, item_index: int | None) -> Leg:
    """Climb vertically from the ground at ``start`` (m, NED) to ``alt_m`` (m above home)."""
    traj = takeoff_trajectory(t0, start, alt_m, limits, yaw_rad)
    return Leg("takeoff", traj, np.array([start[0], start[1], -alt_m]),
               traj.arrival_times_s[-1], 0.0, item_index)


def landing_leg(t0: float, start: np.ndarray, yaw_rad: float, limits: SpeedLimits,
                creep_speed_m_s: float, item_index: int | None) -> Leg:
    """Descend from ``start`` (m, NED) to the ground, then creep down at
    ``creep_speed_m_s`` (m/s) until landing is detected."""
    traj = landing_trajectory(t0, start, limits, creep_speed_m_s, yaw_rad)
    return Leg("land", traj, None, traj.arrival_times_s[-1], 0.0, item_index)


def rtl_leg(t0: float, start: np.ndarray, yaw_rad: float, home_pos_ned: np.ndarray,
            rtl_alt_m: float, hold_s: float, limits: SpeedLimits,
            item_index: int | None) -> Leg:
    """Climb to ``rtl_alt_m`` (m) if lower, fly above home (m, NED), hold ``hold_s`` (s)."""
    z_return = min(float(start[2]), -rtl_alt_m)
    wps = []
    if z_return < float(start[2]) - 1e-9:
        wps.append(Waypoint(pos_ned=(float(start[0]), float(start[1]), z_return)))
    wps.append(Waypoint(pos_ned=(float(home_pos_ned[0]), float(home_pos_ned[1]), z_return)))
    traj = Trajectory.from_waypoints(t0, start, wps, limits, yaw_rad)
    return Leg("rtl_return", traj, np.array(wps[-1].pos_ned), traj.arrival_times_s[-1],
               hold_s, item_index)
