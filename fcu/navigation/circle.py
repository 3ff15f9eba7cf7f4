"""Circling a centre: ArduCopter's CIRCLE mode and PX4's DO_ORBIT, one implementation.

The reference runs round a circle of radius ``r`` about ``centre`` (m, NED) at the altitude
of the circle, facing the centre. Its angle starts where the vehicle is and its rate grows
at the acceleration limit to ``omega`` (rad/s; > 0 clockwise seen from above, as ArduCopter's
CIRCLE_RATE), so the speed along the circle goes from 0 to ``|omega| r`` without a step::

    theta(t) = theta0 + omega tau^2 / (2 T)        for tau = t - t0 < T = |omega| r / a
    theta(t) = theta0 + omega (tau - T / 2)        after
    p = centre + r (cos theta, sin theta, 0),  v = r theta' (-sin, cos, 0),
    a = r theta'' (-sin, cos, 0) - r theta'^2 (cos, sin, 0)

CIRCLE puts the centre ``CIRCLE_RADIUS`` ahead of the vehicle (ArduCopter), so the vehicle
starts on the circle; DO_ORBIT gives the centre, and a vehicle off the circle first flies to
its nearest point (a "move" leg), then circles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fcu.floats import wrap_pi
from fcu.navigation.reference import Reference

__all__ = ["Circle", "circle_entry"]


@dataclass(frozen=True)
class Circle:
    """A circle being flown from ``t0_s`` (s)."""

    centre_ned: np.ndarray  # m, (3,): the circle's altitude is centre_ned[2]
    radius_m: float  # m, >= 0 (0: turn on the spot about the centre)
    rate_rad_s: float  # rad/s, > 0 clockwise seen from above
    theta0_rad: float  # rad, angle of the start point about the centre (0 = north)
    t0_s: float  # s
    accel_m_s2: float  # m/s^2, > 0: the speed along the circle grows at this rate

    @property
    def ramp_s(self) -> float:
        """T, s: time to reach the full rate."""
        speed = abs(self.rate_rad_s) * self.radius_m
        return speed / self.accel_m_s2 if speed > 0.0 else 0.0

    def angle(self, time_s: float) -> tuple[float, float, float]:
        """theta (rad), theta' (rad/s), theta'' (rad/s^2) at ``time_s``."""
        tau = max(time_s - self.t0_s, 0.0)
        w, ramp = self.rate_rad_s, self.ramp_s
        if tau < ramp:
            return self.theta0_rad + 0.5 * w * tau * tau / ramp, w * tau / ramp, w / ramp
        return self.theta0_rad + w * (tau - 0.5 * ramp), w, 0.0

    def reference(self, time_s: float) -> Reference:
        """Where the vehicle should be at ``time_s`` (module docstring), facing the centre."""
        theta, dtheta, ddtheta = self.angle(time_s)
        c, s, r = math.cos(theta), math.sin(theta), self.radius_m
        pos = self.centre_ned + np.array([r * c, r * s, 0.0])
        vel = np.array([-r * s * dtheta, r * c * dtheta, 0.0])
        acc = np.array([-r * s * ddtheta - r * c * dtheta**2,
                        r * c * ddtheta - r * s * dtheta**2, 0.0])
        yaw = math.atan2(-s, -c)  # towards the centre
        return Reference(pos_ned=pos, vel_ned=vel, acc_ned=acc,
                         yaw_rad=wrap_pi(yaw),
                         yaw_rate_rad_s=dtheta)


def circle_entry(pos_ned: np.ndarray, centre_ned: np.ndarray, radius_m: float
                 ) -> tuple[np.ndarray, float]:
    """The point of the circle about ``centre_ned`` (at its altitude) nearest ``pos_ned``
    (m, NED), and its angle (rad, 0 = north of the centre)."""
    dn, de = float(pos_ned[0] - centre_ned[0]), float(pos_ned[1] - centre_ned[1])
    theta = math.atan2(de, dn) if math.hypot(dn, de) > 1e-9 else 0.0
    point = centre_ned + np.array([radius_m * math.cos(theta), radius_m * math.sin(theta), 0.0])
    return point, theta
