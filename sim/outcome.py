"""How a flight really ended, judged from simulator truth: landed, crashed, flyaway, airborne.

The autopilot's view of a flight can be wrong (a crash it did not notice, an estimate that
followed garbage), so the outcome is judged here, from the world's true state, by the
composition roots (the headless runner and the vehicle process). The autopilot never sees
it.

A flight starts at the first lift-off after the judge is created (or after the previous
flight's outcome) and ends with the first of:

==========  ================================================================================
crashed     a touchdown faster than ``impact_speed_m_s`` (1.5 m/s) or with the airframe tilted
            more than ``impact_tilt_deg`` (30 deg) just before contact; or ground contact held
            for ``tilted_contact_s`` while tilted more than ``impact_tilt_deg`` (a vehicle
            scraping along the ground on its side). Time: the touchdown.
flyaway     the true position farther than ``flyaway_distance_m`` (5 m) horizontally outside
            the mission area (the box around home, every mission target and every target the
            vehicle was sent to), or higher than ``flyaway_distance_m`` above the area's
            highest point. Time: when the limit was crossed.
landed      back on the ground, every touchdown gentle, and disarmed (the vehicle process) or
            at the end of the run (the headless runner). Time: the last touchdown.
airborne    still flying when the run ended. Time: the end of the run.
==========  ================================================================================

Why these limits: a normal landing of this autopilot touches down at 0.05-0.2 m/s level; a
touchdown at 1.5 m/s is a drop from about 11 cm, which a 1.4 kg quadrotor's landing gear
absorbs at the limit; beyond 30 deg of tilt the rotor tips reach the ground of a 0.2 m-arm
frame with 0.1 m props before the skids (0.1 m / 0.2 m = sin 30 deg). The mission of the
thesis is a 1 m square: 5 m outside any target is nowhere a tracking error can take the
vehicle, only a loss of control or of the position fix.

A crash or a fly-away is final for the flight: the physics keeps running (a crashed vehicle
may hop), but the outcome does not change.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from flightdata.config import finite, require
from flightdata.mission import MissionItem
from flightdata.records import OutcomeRecord

Vector = Sequence[float] | np.ndarray


@dataclass(frozen=True, kw_only=True)
class OutcomeLimits:
    """Where a touchdown becomes a crash and a drift a fly-away (module docstring)."""

    impact_speed_m_s: float = 1.5  # m/s, touchdown speed above which it is a crash
    impact_tilt_deg: float = 30.0  # deg, tilt at touchdown (or in contact) above which: crash
    tilted_contact_s: float = 0.2  # s of ground contact at that tilt that is a crash too
    flyaway_distance_m: float = 5.0  # m outside the mission area: a fly-away

    def __post_init__(self) -> None:
        for name in ("impact_speed_m_s", "impact_tilt_deg", "flyaway_distance_m"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a finite number > 0")
        require(finite(self.tilted_contact_s) and self.tilted_contact_s >= 0,
                "tilted_contact_s", self.tilted_contact_s, "must be >= 0 s")


_HALF_SQRT2 = math.sqrt(0.5)


class MissionArea:
    """Axis-aligned box (NED, m) around home and every target the vehicle was sent to."""

    def __init__(self, points: Iterable[Vector] = ((0.0, 0.0, 0.0),)) -> None:
        self._lo = np.full(3, math.inf)
        self._hi = np.full(3, -math.inf)
        self._lo_l, self._hi_l = self._lo.tolist(), self._hi.tolist()  # read every tick
        for p in points:
            self.extend(p)

    def extend(self, point_ned: Vector) -> None:
        """Grow the box to hold ``point_ned`` (m, NED)."""
        p = np.asarray(point_ned, dtype=float).reshape(3)
        if np.all(np.isfinite(p)):
            self._lo = np.minimum(self._lo, p)
            self._hi = np.maximum(self._hi, p)
            self._lo_l, self._hi_l = self._lo.tolist(), self._hi.tolist()

    def corners(self) -> list[tuple[float, float, float]]:
        """The box's two extreme corners (none while empty), m, NED."""
        if not np.all(np.isfinite(self._lo)):
            return []
        lo, hi = self._lo.tolist(), self._hi.tolist()
        return [(lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])]

    def inside(self, x: float, y: float, z: float, margin_m: float = 0.0) -> bool:
        """``(x, y, z)`` (m, NED) is in the box or below it (:meth:`outside_m` is (0, 0));
        with a ``margin_m`` (m), in the box grown by ``margin_m / sqrt(2)`` horizontally and
        by ``margin_m`` upwards, where both of :meth:`outside_m`'s distances are at most
        ``margin_m`` (a quick test: near a corner a point that close may still answer
        False)."""
        lo, hi = self._lo_l, self._hi_l
        h = margin_m * _HALF_SQRT2
        return (lo[0] - h <= x <= hi[0] + h and lo[1] - h <= y <= hi[1] + h
                and z >= lo[2] - margin_m)

    def outside_m(self, pos_ned: Vector) -> tuple[float, float]:
        """(horizontal distance outside the box, height above its top), m (0 inside)."""
        x, y, z = pos_ned
        return self.outside_xyz(float(x), float(y), float(z))

    def outside_xyz(self, x: float, y: float, z: float) -> tuple[float, float]:
        """:meth:`outside_m` of the point ``(x, y, z)`` given as three floats (m, NED)."""
        lo, hi = self._lo_l, self._hi_l
        dx = max(lo[0] - x, 0.0, x - hi[0])
        dy = max(lo[1] - y, 0.0, y - hi[1])
        above = max(lo[2] - z, 0.0)  # NED: higher = more negative z
        return math.hypot(dx, dy), above


def mission_area(mission: Sequence[MissionItem], home_ned: Vector = (0.0, 0.0, 0.0)
                 ) -> MissionArea:
    """The box around home and every mission target (a take-off's altitude above home)."""
    area = MissionArea([tuple(home_ned)])
    for item in mission:
        if item.pos_ned is not None:
            area.extend(item.pos_ned)
        if item.command == "takeoff":
            area.extend((home_ned[0], home_ned[1], home_ned[2] - item.alt_m))
    return area


def tilt_deg(quat_wxyz: Vector) -> float:
    """Angle between the body z axis and the vertical, deg, of the attitude ``quat_wxyz``
    (unit quaternion [w, x, y, z]): acos(R[2, 2]), R[2, 2] = cos(roll) cos(pitch)
    = 1 - 2 (x^2 + y^2)."""
    x, y = float(quat_wxyz[1]), float(quat_wxyz[2])
    c = 1.0 - 2.0 * (x * x + y * y)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


class OutcomeJudge:
    """Watches the true state tick by tick and decides each flight's outcome.

    Parameters
    ----------
    area : MissionArea
        Where the vehicle is meant to be (grow it with :meth:`MissionArea.extend` when new
        targets are given).
    limits : OutcomeLimits

    Notes
    -----
    Call :meth:`observe` after every tick with the truth and the touchdowns the plant reported
    during the tick (several contacts can happen between two ticks: a crash, a bounce and a
    soft touchdown), then :meth:`finish` at the end of a headless run. :attr:`outcome` holds
    the current flight's decided outcome (None while undecided); :meth:`drain` returns each
    outcome once, as it is decided.
    """

    def __init__(self, area: MissionArea, limits: OutcomeLimits | None = None) -> None:
        self.area = area
        self.limits = limits if limits is not None else OutcomeLimits()
        self.outcome: OutcomeRecord | None = None
        self._new: list[OutcomeRecord] = []
        self._flying = False
        self._flew = False
        self._was_on_ground = True
        self._last_air_quat: Vector = (1.0, 0.0, 0.0, 0.0)  # the attitude last seen in the air
        self._contact_speeds: list[float] = []
        self._max_contact_tilt_deg = 0.0
        self._tilted_since_s: float | None = None
        self._last_touchdown_s: float | None = None
        self._max_outside_m = 0.0

    def observe(self, time_s: float, pos_ned: Vector, quat_wxyz: Vector,
                on_ground: bool, touchdowns: Sequence[tuple[float, float]], armed: bool) -> None:
        """One tick of truth: time (s), position (m, NED), attitude (unit quaternion
        [w, x, y, z], body FRD to NED), ground contact,
        the touchdowns of the tick as (time s, speed m/s), and whether the autopilot is
        armed.

        A tick in the air inside the mission area is a few comparisons: the tilt is worked
        out only where it is judged (a touchdown, ground contact), the distance outside the
        area only outside it.
        """
        if self._flying and touchdowns:
            for t_contact, speed in touchdowns:
                if self._flying:
                    self._touchdown(t_contact, speed)
        if not on_ground:
            self._last_air_quat = quat_wxyz
            if not self._flying and self.outcome is None:
                self._start_flight()
            if self._flying:
                x, y, z = pos_ned
                # no farther outside than the farthest so far: nothing to do (0 m inside)
                if not self.area.inside(x, y, z, self._max_outside_m):
                    self._check_distance(time_s, float(x), float(y), float(z))
        elif self._flying:
            if self._flying:
                self._check_tilted_contact(time_s, tilt_deg(quat_wxyz))
            if self._flying and not armed:
                self._decide("landed", time_s if self._last_touchdown_s is None
                             else self._last_touchdown_s, "touchdown")
        self._was_on_ground = on_ground

    def finish(self, time_s: float) -> OutcomeRecord:
        """The outcome at the end of a run (decides ``landed`` or ``airborne`` if pending)."""
        if self.outcome is None:
            if self._flying and not self._was_on_ground:
                self._decide("airborne", time_s, "end_of_run")
            elif self._flying:
                touchdown = self._last_touchdown_s
                self._decide("landed", time_s if touchdown is None else touchdown, "touchdown")
            else:
                self._decide("landed", time_s, "no_flight")
        assert self.outcome is not None
        return self.outcome

    @property
    def decided(self) -> bool:
        """An outcome waits to be drained."""
        return bool(self._new)

    def drain(self) -> list[OutcomeRecord]:
        """Outcomes decided since the previous call."""
        new, self._new = self._new, []
        return new

    # ------------------------------------------------------------------ the checks
    def _start_flight(self) -> None:
        self._flying = True
        self._flew = True
        self._contact_speeds = []
        self._max_contact_tilt_deg = 0.0
        self._tilted_since_s = None
        self._last_touchdown_s = None
        self._max_outside_m = 0.0

    def _touchdown(self, time_s: float, speed_m_s: float) -> None:
        speed = float(speed_m_s)
        tilt = tilt_deg(self._last_air_quat)  # just before contact
        self._contact_speeds.append(speed)
        self._max_contact_tilt_deg = max(self._max_contact_tilt_deg, tilt)
        self._last_touchdown_s = time_s
        lim = self.limits
        if speed > lim.impact_speed_m_s:
            self._decide("crashed", time_s, "impact_speed")
        elif tilt > lim.impact_tilt_deg:
            self._decide("crashed", time_s, "impact_tilt")

    def _check_tilted_contact(self, time_s: float, tilt: float) -> None:
        if tilt <= self.limits.impact_tilt_deg:
            self._tilted_since_s = None
            return
        self._max_contact_tilt_deg = max(self._max_contact_tilt_deg, tilt)
        if self._tilted_since_s is None:
            self._tilted_since_s = time_s
        if time_s - self._tilted_since_s >= self.limits.tilted_contact_s - 1e-9:
            self._decide("crashed", self._tilted_since_s, "tilted_on_ground")

    def _check_distance(self, time_s: float, x: float, y: float, z: float) -> None:
        horizontal, above = self.area.outside_xyz(x, y, z)
        self._max_outside_m = max(self._max_outside_m, horizontal, above)
        if max(horizontal, above) > self.limits.flyaway_distance_m:
            self._decide("flyaway", time_s, "distance")

    def _decide(self, kind: str, time_s: float, cause: str) -> None:
        speeds = self._contact_speeds
        record = OutcomeRecord(
            kind=kind, time_s=float(time_s), cause=cause,
            impact_speed_m_s=max(speeds) if speeds else math.nan,
            tilt_deg=self._max_contact_tilt_deg if speeds else math.nan,
            distance_m=self._max_outside_m)
        self.outcome = record
        self._new.append(record)
        self._flying = False

    def rearm(self) -> None:
        """Forget a decided outcome so that the next lift-off starts a new flight (the
        vehicle process calls this when the vehicle is armed again)."""
        if self.outcome is not None:
            self.outcome = None
            self._flying = False
