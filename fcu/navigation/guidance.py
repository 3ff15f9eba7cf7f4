"""Guidance: smooth position/yaw references along cubic segments between waypoints.

A :class:`Trajectory` strings segments (:mod:`fcu.navigation.segments`) together and
evaluates the :class:`~fcu.navigation.reference.Reference` the controllers track; this module
chooses the leg times (:func:`leg_duration_s`) and builds the trajectories of waypoints, a
hold, a take-off and a landing.

The thesis (chapter 7) flies its square along cubic trajectory segments and feeds the
reference acceleration forward into the position loop (eq. 5.3), so guidance must provide
position, velocity and acceleration analytically.

Cubic segment (rest to rest)
----------------------------
Between two points ``p0`` and ``p1`` over a leg time ``T`` starting at ``t0``, with
``s = (t - t0) / T`` in [0, 1] and ``d = |p1 - p0|``::

    p(t) = p0 + (p1 - p0) (3 s^2 - 2 s^3)
    v(t) = (p1 - p0) (6 s - 6 s^2) / T          zero at s = 0 and s = 1
    a(t) = (p1 - p0) (6 - 12 s) / T^2

The speed peaks at s = 1/2: ``|v|max = 1.5 d / T``; the acceleration magnitude peaks at the
ends: ``|a|max = 6 d / T^2``. A leg time therefore honours a speed limit ``v_max`` when
``T >= 1.5 d / v_max`` and an acceleration limit ``a_max`` when ``T >= sqrt(6 d / a_max)``.
:func:`leg_duration_s` takes the largest of these (horizontal, climb and descent speeds
apply to the horizontal and vertical parts of the leg separately, because both parts share
the same shape function), of ``1.5 |dpsi| / yaw_rate_max`` for the yaw change, and of a
minimum leg time.

Yaw is interpolated with the same shape function along the shortest way round:
``psi(t) = wrap(psi0 + wrap(psi1 - psi0) (3 s^2 - 2 s^3))``.

Frames and time: positions are NED (m, home origin on the ground, altitude = -z); times are
simulated seconds passed in by the caller.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fcu.floats import wrap_pi
from fcu.navigation.reference import Reference, read_only_vec3
from fcu.navigation.segments import CubicSegment, HoldSegment, RampSegment, Segment
from flightdata.config import finite, require

_JOIN_TOL_S = 1e-9  # s, tolerance when checking that segments follow one another


@dataclass(frozen=True, kw_only=True)
class SpeedLimits:
    """Limits that set the leg time of a cubic segment (see the module docstring)."""

    horizontal_m_s: float = 0.5  # m/s, peak horizontal speed
    up_m_s: float = 0.3  # m/s, peak climb speed
    down_m_s: float = 0.2  # m/s, peak descent speed
    accel_m_s2: float = 0.5  # m/s^2, peak acceleration magnitude (6 d / T^2)
    yaw_rate_rad_s: float = 0.5  # rad/s, peak yaw rate
    min_duration_s: float = 0.5  # s, shortest leg that moves at all

    def __post_init__(self) -> None:
        for name in ("horizontal_m_s", "up_m_s", "down_m_s", "accel_m_s2", "yaw_rate_rad_s"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a finite number > 0")
        require(finite(self.min_duration_s) and self.min_duration_s >= 0, "min_duration_s",
                self.min_duration_s, "must be a finite number >= 0")


def leg_duration_s(start_pos_ned: np.ndarray | Sequence[float],
                   end_pos_ned: np.ndarray | Sequence[float], limits: SpeedLimits,
                   yaw_change_rad: float = 0.0) -> float:
    """Leg time of a rest-to-rest cubic from ``start_pos_ned`` to ``end_pos_ned``.

    Parameters
    ----------
    start_pos_ned, end_pos_ned : array_like, shape (3,)
        End points, NED, m.
    limits : SpeedLimits
        Peak speeds (horizontal, climb, descent), acceleration and yaw rate.
    yaw_change_rad : float
        Yaw change along the leg, rad (only its magnitude matters).

    Returns
    -------
    float
        ``T = max(1.5 d_h / v_h, 1.5 d_up / v_up, 1.5 d_down / v_down, sqrt(6 d / a_max),
        1.5 |dpsi| / r_max, T_min)``, s; exactly 0 when the leg neither moves nor turns.
    """
    delta = (read_only_vec3(end_pos_ned, "end_pos_ned")
             - read_only_vec3(start_pos_ned, "start_pos_ned"))
    dist_m = float(np.linalg.norm(delta))
    dist_h_m = float(np.hypot(delta[0], delta[1]))
    climb_m = max(0.0, -float(delta[2]))  # z decreasing = climbing
    descent_m = max(0.0, float(delta[2]))
    dyaw = abs(float(yaw_change_rad))
    if dist_m == 0.0 and dyaw == 0.0:
        return 0.0
    return max(
        1.5 * dist_h_m / limits.horizontal_m_s,
        1.5 * climb_m / limits.up_m_s,
        1.5 * descent_m / limits.down_m_s,
        math.sqrt(6.0 * dist_m / limits.accel_m_s2),
        1.5 * dyaw / limits.yaw_rate_rad_s,
        limits.min_duration_s,
    )



@dataclass(frozen=True, kw_only=True)
class Waypoint:
    """One waypoint of a trajectory.

    Attributes
    ----------
    pos_ned : tuple of float
        Target position, NED, m.
    hold_s : float
        Time spent at rest at the waypoint after arriving, s.
    yaw_rad : float or None
        Yaw on arrival, rad; None keeps the yaw of the previous point.
    """

    pos_ned: tuple[float, float, float]
    hold_s: float = 0.0
    yaw_rad: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "pos_ned", tuple(float(v) for v in
                                                  read_only_vec3(self.pos_ned, "pos_ned")))
        require(finite(self.hold_s) and self.hold_s >= 0, "hold_s", self.hold_s,
                "must be a finite number >= 0")
        require(self.yaw_rad is None or finite(self.yaw_rad), "yaw_rad", self.yaw_rad,
                "must be finite or None")


class Trajectory:
    """Contiguous sequence of segments: evaluate a :class:`Reference` at any time.

    Before the first segment the trajectory holds its start point; after the last one (when
    it ends) it holds its end point at rest.

    Parameters
    ----------
    segments : sequence of Segment
        Non-empty; each starts when the previous ends; only the last may last forever.
    arrival_times_s : sequence of float
        Times (s) at which the trajectory arrives at its waypoints, when built from
        waypoints (:meth:`from_waypoints`); informational, empty by default.
    """

    def __init__(self, segments: Sequence[Segment], arrival_times_s: Sequence[float] = ()
                 ) -> None:
        if not segments:
            raise ValueError("segments = []: a trajectory needs at least one segment")
        for i, (a, b) in enumerate(zip(segments[:-1], segments[1:], strict=True)):
            if not math.isfinite(a.end_time_s):
                raise ValueError(f"segments[{i}] never ends: only the last may last forever")
            if abs(b.t0_s - a.end_time_s) > _JOIN_TOL_S:
                raise ValueError(f"segments[{i + 1}].t0_s = {b.t0_s!r}: must equal the end "
                                 f"of segments[{i}] ({a.end_time_s!r})")
        self._segments: tuple[Segment, ...] = tuple(segments)
        self._starts_s = [float(seg.t0_s) for seg in self._segments]  # for bisect
        self._start_s = float(self._segments[0].t0_s)
        self._end_s = float(self._segments[-1].end_time_s)
        self._before_ref: Reference | None = None  # the rest references outside, once built
        self._after_ref: Reference | None = None
        # the segment last evaluated: (from, until (s), segment), see evaluate()
        self._current: tuple[float, float, Segment] | None = None
        self.arrival_times_s: tuple[float, ...] = tuple(float(t) for t in arrival_times_s)

    @property
    def segments(self) -> tuple[Segment, ...]:
        """The segments, in time order."""
        return self._segments

    @property
    def start_time_s(self) -> float:
        """Start of the first segment, s."""
        return self._start_s

    @property
    def end_time_s(self) -> float:
        """End of the last segment, s (inf when it lasts forever)."""
        return self._end_s

    def segment_index(self, time_s: float) -> int:
        """Index of the segment active at ``time_s`` (s); clamped to the first/last segment.

        At a join the later segment is active (``searchsorted`` on the start times), so a
        zero-length segment followed by another is never active.
        """
        idx = bisect.bisect_right(self._starts_s, time_s) - 1
        return min(max(idx, 0), len(self._segments) - 1)

    def evaluate(self, time_s: float) -> Reference:
        """Reference at ``time_s`` (s)."""
        if time_s < self._start_s:
            if self._before_ref is None:  # the same reference every time: build it once
                self._before_ref = self._segments[0].evaluate(self._start_s).at_rest()
            return self._before_ref
        if time_s >= self._end_s:
            if self._after_ref is None:
                self._after_ref = self._segments[-1].evaluate(self._end_s).at_rest()
            return self._after_ref
        # start <= time_s < end: the segment of the previous call while it lasts (a tick
        # after another), else segment_index() without its clamps, which cannot apply
        current = self._current
        if current is None or not current[0] <= time_s < current[1]:
            current = self._find_current(time_s)
        return current[2].evaluate(time_s)

    def _find_current(self, time_s: float) -> tuple[float, float, Segment]:
        """The segment active at ``time_s`` (s, start <= time_s < end) with the times it is
        active from and until, kept for the calls that follow."""
        i = bisect.bisect_right(self._starts_s, time_s) - 1
        # from its start until the next segment's (the later one is active at a join)
        current = self._current = (self._starts_s[i], self._starts_s[i + 1] if
                                   i + 1 < len(self._starts_s) else self._end_s,
                                   self._segments[i])
        return current

    def moving_span(self, time_s: float) -> tuple[Callable[[float], Reference], float] | None:
        """What gives :meth:`evaluate` from ``time_s`` (s) on, while the reference moves: the
        active segment's ``inside`` (a cubic's or a ramp's) and the time until which it
        does (s, exclusive); None when the reference is one constant object instead (a hold,
        or outside the segments)."""
        if not self._start_s <= time_s < self._end_s:
            return None
        _, until_s, segment = self._find_current(time_s)
        if isinstance(segment, HoldSegment) or not segment.t0_s <= time_s < \
                segment.end_time_s or segment.duration_s == 0.0:
            return None
        return segment.inside, min(until_s, segment.end_time_s)

    @classmethod
    def from_waypoints(cls, t0_s: float, start_pos_ned: np.ndarray | Sequence[float],
                       waypoints: Sequence[Waypoint], limits: SpeedLimits,
                       start_yaw_rad: float = 0.0) -> Trajectory:
        """Cubic legs (and holds) through ``waypoints`` starting at rest at ``t0_s``.

        Parameters
        ----------
        t0_s : float
            Start time, s.
        start_pos_ned : array_like, shape (3,)
            Where the first leg starts, NED, m.
        waypoints : sequence of Waypoint
            Targets in order, each with its hold time and optional yaw.
        limits : SpeedLimits
            Sets each leg's time (:func:`leg_duration_s`).
        start_yaw_rad : float
            Yaw at the start, rad.

        Returns
        -------
        Trajectory
            With ``arrival_times_s[i]`` the time the reference reaches ``waypoints[i]``.
            Legs that neither move nor turn take no time.
        """
        pos = read_only_vec3(start_pos_ned, "start_pos_ned")
        yaw = float(start_yaw_rad)
        t = float(t0_s)
        segments: list[Segment] = []
        arrivals: list[float] = []
        for wp in waypoints:
            target = np.array(wp.pos_ned)
            target_yaw = yaw if wp.yaw_rad is None else float(wp.yaw_rad)
            dyaw = wrap_pi(target_yaw - yaw)
            duration = leg_duration_s(pos, target, limits, dyaw)
            if duration > 0.0:
                segments.append(CubicSegment(t, duration, pos, target, yaw, yaw + dyaw))
                t += duration
            arrivals.append(t)
            pos, yaw = read_only_vec3(target, "pos_ned"), wrap_pi(yaw + dyaw)
            if wp.hold_s > 0.0:
                segments.append(HoldSegment(t, wp.hold_s, pos, yaw))
                t += wp.hold_s
        if not segments:
            segments.append(HoldSegment(t, 0.0, pos, yaw))
        return cls(segments, arrivals)


def hold_trajectory(t0_s: float, pos_ned: np.ndarray | Sequence[float],
                    yaw_rad: float = 0.0) -> Trajectory:
    """Endless constant reference at ``pos_ned`` (m) and ``yaw_rad`` from ``t0_s`` (s)."""
    return Trajectory([HoldSegment(float(t0_s), math.inf, np.asarray(pos_ned, dtype=float),
                                   float(yaw_rad))])


def takeoff_trajectory(t0_s: float, start_pos_ned: np.ndarray | Sequence[float], alt_m: float,
                       limits: SpeedLimits, yaw_rad: float = 0.0) -> Trajectory:
    """Vertical cubic from ``start_pos_ned`` (m) up to altitude ``alt_m`` (m above home).

    The leg time follows the climb speed and acceleration limits; afterwards the trajectory
    holds the target. ``arrival_times_s[0]`` is the time the reference reaches altitude.
    """
    require(finite(alt_m), "alt_m", alt_m, "must be a finite altitude in m")
    start = read_only_vec3(start_pos_ned, "start_pos_ned")
    target = (float(start[0]), float(start[1]), -float(alt_m))
    return Trajectory.from_waypoints(t0_s, start, [Waypoint(pos_ned=target)], limits, yaw_rad)


def landing_trajectory(t0_s: float, start_pos_ned: np.ndarray | Sequence[float],
                       limits: SpeedLimits, creep_speed_m_s: float, yaw_rad: float = 0.0,
                       ground_z_ned: float = 0.0) -> Trajectory:
    """Descend to the ground along a cubic, then keep descending slowly without end.

    Parameters
    ----------
    t0_s : float
        Start time, s.
    start_pos_ned : array_like, shape (3,)
        Where the descent starts, NED, m.
    limits : SpeedLimits
        The cubic's peak descent speed is ``limits.down_m_s``.
    creep_speed_m_s : float
        Speed of the endless final descent, m/s (> 0). It starts at the ground height, so
        the vehicle is already at rest on the ground when the reference keeps pushing down;
        the caller decides when the vehicle has landed and stops using the trajectory.
    yaw_rad : float
        Yaw held during the descent, rad.
    ground_z_ned : float
        Ground height as NED z, m (0: flat ground at home).

    Returns
    -------
    Trajectory
        Endless (``end_time_s`` is inf); ``arrival_times_s[0]`` is when the cubic reaches
        the ground.
    """
    require(finite(creep_speed_m_s) and creep_speed_m_s > 0, "creep_speed_m_s",
            creep_speed_m_s, "must be a finite speed > 0 in m/s")
    start = read_only_vec3(start_pos_ned, "start_pos_ned")
    touchdown = np.array([start[0], start[1], max(float(ground_z_ned), float(start[2]))])
    duration = leg_duration_s(start, touchdown, limits)
    segments: list[Segment] = []
    t = float(t0_s)
    if duration > 0.0:
        segments.append(CubicSegment(t, duration, start, touchdown, yaw_rad, yaw_rad))
        t += duration
    segments.append(RampSegment(t, math.inf, touchdown, np.array([0.0, 0.0, creep_speed_m_s]),
                                yaw_rad))
    return Trajectory(segments, (t,))
