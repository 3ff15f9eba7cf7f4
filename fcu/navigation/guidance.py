"""Guidance: smooth position/yaw references along cubic segments between waypoints.

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
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from flightdata.config import finite, require

_JOIN_TOL_S = 1e-9  # s, tolerance when checking that segments follow one another


def _vec3(value: np.ndarray | Sequence[float], name: str) -> np.ndarray:
    """A read-only float64 copy of a 3-vector; raises ValueError naming ``name``."""
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} = {value!r}: must be three finite numbers")
    arr.setflags(write=False)
    return arr


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi), rad."""
    return float((angle_rad + math.pi) % (2.0 * math.pi) - math.pi)


_ZERO3 = np.zeros(3)
_ZERO3.setflags(write=False)
_pack9 = struct.Struct("9d").pack  # nine float64, native order (np.frombuffer's default)
_from_bytes = np.frombuffer  # over bytes: a read-only float64 array, no copy


@dataclass(frozen=True, eq=False)
class Reference:
    """What the position and yaw controllers track at one instant.

    Attributes
    ----------
    pos_ned : numpy.ndarray, shape (3,)
        Reference position, NED, m.
    vel_ned : numpy.ndarray, shape (3,)
        Reference velocity, NED, m/s.
    acc_ned : numpy.ndarray, shape (3,)
        Reference acceleration (feed-forward of eq. 5.3), NED, m/s^2.
    yaw_rad : float
        Reference yaw, rad, in [-pi, pi).
    yaw_rate_rad_s : float
        Reference yaw rate, rad/s.

    The arrays are read-only copies, so a reference can be shared safely.
    """

    pos_ned: np.ndarray
    vel_ned: np.ndarray
    acc_ned: np.ndarray
    yaw_rad: float = 0.0
    yaw_rate_rad_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("pos_ned", "vel_ned", "acc_ned"):
            object.__setattr__(self, name, _vec3(getattr(self, name), name))
        require(finite(self.yaw_rad), "yaw_rad", self.yaw_rad, "must be finite")
        require(finite(self.yaw_rate_rad_s), "yaw_rate_rad_s", self.yaw_rate_rad_s,
                "must be finite")
        object.__setattr__(self, "yaw_rad", wrap_pi(float(self.yaw_rad)))
        object.__setattr__(self, "yaw_rate_rad_s", float(self.yaw_rate_rad_s))

    @classmethod
    def hold(cls, pos_ned: np.ndarray | Sequence[float], yaw_rad: float = 0.0) -> Reference:
        """A constant reference: position ``pos_ned`` (m), yaw ``yaw_rad``, at rest."""
        return cls(pos_ned=np.asarray(pos_ned, dtype=float), vel_ned=_ZERO3, acc_ned=_ZERO3,
                   yaw_rad=yaw_rad, yaw_rate_rad_s=0.0)

    def at_rest(self) -> Reference:
        """The same position and yaw with zero velocity, acceleration and yaw rate."""
        return Reference._hold_checked(self.pos_ned, self.yaw_rad)

    # Guidance builds a reference every control tick from values it has already validated
    # (segment end points are read-only checked copies). The two constructors below skip the
    # public constructor's copies and array checks, which cost more than the rest of a
    # guidance tick, and give the same result: the arrays are read-only and nobody else
    # holds a writable view of them, the yaw is wrapped the same way, and anything
    # non-finite still goes through the public constructor and its error.
    @classmethod
    def _from_floats(cls, pos: list[float], vel: list[float], acc: list[float],
                     yaw_rad: float, yaw_rate_rad_s: float) -> Reference:
        """A reference from freshly computed floats (three per vector)."""
        if not (all(map(math.isfinite, pos + vel + acc)) and math.isfinite(yaw_rad)
                and math.isfinite(yaw_rate_rad_s)):
            return cls(pos_ned=np.array(pos), vel_ned=np.array(vel), acc_ned=np.array(acc),
                       yaw_rad=yaw_rad, yaw_rate_rad_s=yaw_rate_rad_s)  # raises
        rows = np.array((pos, vel, acc))  # one allocation; the vectors are its rows
        rows.setflags(write=False)
        return cls._assemble(rows[0], rows[1], rows[2], yaw_rad, yaw_rate_rad_s)

    @classmethod
    def _hold_checked(cls, pos_ned: np.ndarray, yaw_rad: float) -> Reference:
        """:meth:`hold` at a position that is already a checked read-only 3-vector (shared)."""
        if not finite(yaw_rad):
            return cls.hold(pos_ned, yaw_rad)  # raises
        return cls._assemble(pos_ned, _ZERO3, _ZERO3, yaw_rad, 0.0)

    @classmethod
    def _assemble(cls, pos_ned: np.ndarray, vel_ned: np.ndarray, acc_ned: np.ndarray,
                  yaw_rad: float, yaw_rate_rad_s: float) -> Reference:
        ref = object.__new__(cls)
        # the fields straight into the instance's dict: what the frozen dataclass's own
        # __init__ does through object.__setattr__, at half the cost
        fields = ref.__dict__
        fields["pos_ned"] = pos_ned
        fields["vel_ned"] = vel_ned
        fields["acc_ned"] = acc_ned
        fields["yaw_rad"] = wrap_pi(float(yaw_rad))
        fields["yaw_rate_rad_s"] = float(yaw_rate_rad_s)
        return ref


_new_object = object.__new__
_PI = math.pi
_TWO_PI = 2.0 * math.pi


def _reference_from_nine(px: float, py: float, pz: float, vx: float, vy: float, vz: float,
                         ax: float, ay: float, az: float, yaw_rad: float,
                         yaw_rate_rad_s: float) -> Reference:
    """:meth:`Reference._from_floats` for the nine floats of a guidance tick, given one by
    one (a cubic's or a ramp's); once a tick."""
    if not math.isfinite(px + py + pz + vx + vy + vz + ax + ay + az + yaw_rad
                         + yaw_rate_rad_s):  # (a sum of finite floats may overflow)
        return Reference._from_floats([px, py, pz], [vx, vy, vz], [ax, ay, az], yaw_rad,
                                      yaw_rate_rad_s)
    # one read-only buffer (bytes) for the three vectors: half the cost of an array
    # built from nested tuples and then locked
    rows = _from_bytes(_pack9(px, py, pz, vx, vy, vz, ax, ay, az))
    ref = _new_object(Reference)  # Reference._assemble(), inline
    fields = ref.__dict__
    fields["pos_ned"] = rows[0:3]
    fields["vel_ned"] = rows[3:6]
    fields["acc_ned"] = rows[6:9]
    fields["yaw_rad"] = float((yaw_rad + _PI) % _TWO_PI - _PI)  # wrap_pi(), inline
    fields["yaw_rate_rad_s"] = float(yaw_rate_rad_s)
    return ref


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
    delta = _vec3(end_pos_ned, "end_pos_ned") - _vec3(start_pos_ned, "start_pos_ned")
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


def _check_times(t0_s: float, duration_s: float, allow_inf: bool) -> None:
    require(finite(t0_s), "t0_s", t0_s, "must be a finite time in s")
    ok = duration_s >= 0 and (finite(duration_s) or (allow_inf and duration_s == math.inf))
    require(ok, "duration_s", duration_s,
            "must be >= 0" + (" (inf allowed)" if allow_inf else " and finite"))


@dataclass(frozen=True, eq=False)
class CubicSegment:
    """Rest-to-rest cubic from ``start_pos_ned`` to ``end_pos_ned`` (module docstring).

    Attributes
    ----------
    t0_s : float
        Start time, s.
    duration_s : float
        Leg time T, s (finite, >= 0; a zero-length leg jumps to the end).
    start_pos_ned, end_pos_ned : numpy.ndarray, shape (3,)
        End points, NED, m.
    start_yaw_rad, end_yaw_rad : float
        Yaw at the ends, rad; interpolated along the shortest way round.
    """

    t0_s: float
    duration_s: float
    start_pos_ned: np.ndarray
    end_pos_ned: np.ndarray
    start_yaw_rad: float = 0.0
    end_yaw_rad: float = 0.0
    # evaluate() at a time inside the segment (t0_s <= t < end_time_s, s), without the
    # checks: the cubic with the segment's constants bound once (set by __post_init__)
    inside: Callable[[float], Reference] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        _check_times(self.t0_s, self.duration_s, allow_inf=False)
        object.__setattr__(self, "start_pos_ned", _vec3(self.start_pos_ned, "start_pos_ned"))
        object.__setattr__(self, "end_pos_ned", _vec3(self.end_pos_ned, "end_pos_ned"))
        dyaw = wrap_pi(self.end_yaw_rad - self.start_yaw_rad)
        object.__setattr__(self, "_dyaw", dyaw)
        object.__setattr__(self, "_end_s", self.t0_s + self.duration_s)
        p0x, p0y, p0z = self.start_pos_ned.tolist()
        dx, dy, dz = (self.end_pos_ned - self.start_pos_ned).tolist()
        object.__setattr__(self, "inside", _cubic_inside(
            float(self.t0_s), float(self.duration_s), self.duration_s**2, p0x, p0y, p0z,
            dx, dy, dz, float(self.start_yaw_rad), dyaw))
        object.__setattr__(self, "_end_ref", None)  # the hold at the end, once built

    @property
    def end_time_s(self) -> float:
        """Time the segment arrives at ``end_pos_ned``, s."""
        return self.t0_s + self.duration_s

    @property
    def peak_speed_m_s(self) -> float:
        """Largest speed along the segment, ``1.5 d / T``, m/s."""
        if self.duration_s == 0.0:
            return 0.0
        return 1.5 * float(np.linalg.norm(self.end_pos_ned - self.start_pos_ned)) / \
            self.duration_s

    def evaluate(self, time_s: float) -> Reference:
        """Reference at ``time_s`` (s); clamped to the end points outside the segment."""
        if self.duration_s == 0.0 or time_s >= self._end_s:  # type: ignore[attr-defined]
            end_ref: Reference | None = self._end_ref  # type: ignore[attr-defined]
            if end_ref is None:  # the same reference every time: build it once
                end_yaw_rad = self.start_yaw_rad + self._dyaw  # type: ignore[attr-defined]
                end_ref = Reference._hold_checked(self.end_pos_ned, end_yaw_rad)
                object.__setattr__(self, "_end_ref", end_ref)
            return end_ref
        if time_s < self.t0_s:
            return Reference._hold_checked(self.start_pos_ned, self.start_yaw_rad)
        return self.inside(time_s)


def _cubic_inside(t0: float, T: float, T_sq: float, p0x: float, p0y: float, p0z: float,
                  dx: float, dy: float, dz: float, yaw0: float, dyaw: float
                  ) -> Callable[[float], Reference]:
    """The cubic from ``p0`` to ``p0 + d`` (m, NED) starting at ``t0`` (s) over ``T`` (s,
    > 0; ``T_sq`` = T^2), yaw from ``yaw0`` turning by ``dyaw`` (rad), as a function of a
    time inside it (s): :attr:`CubicSegment.inside`. Its constants are plain floats bound
    once (it runs every control tick)."""

    def inside(time_s: float) -> Reference:
        s = (time_s - t0) / T
        s_sq = s**2
        h = 3.0 * s_sq - 2.0 * s**3  # shape function
        dh = (6.0 * s - 6.0 * s_sq) / T  # dh/dt
        ddh = (6.0 - 12.0 * s) / T_sq  # d2h/dt2
        # p = p0 + (p1 - p0) h,  v = (p1 - p0) dh/dt,  a = (p1 - p0) d2h/dt2  (plain floats)
        return _reference_from_nine(p0x + dx * h, p0y + dy * h, p0z + dz * h,
                                    dx * dh, dy * dh, dz * dh, dx * ddh, dy * ddh, dz * ddh,
                                    yaw0 + dyaw * h, dyaw * dh)

    return inside


@dataclass(frozen=True, eq=False)
class HoldSegment:
    """Constant reference at ``pos_ned`` (m) and ``yaw_rad`` for ``duration_s`` (may be inf)."""

    t0_s: float
    duration_s: float
    pos_ned: np.ndarray
    yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        _check_times(self.t0_s, self.duration_s, allow_inf=True)
        object.__setattr__(self, "pos_ned", _vec3(self.pos_ned, "pos_ned"))
        object.__setattr__(self, "_ref", None)  # the constant reference, once built

    @property
    def end_time_s(self) -> float:
        """End of the hold, s (inf for an endless hold)."""
        return self.t0_s + self.duration_s

    def evaluate(self, time_s: float) -> Reference:
        """The constant reference (any ``time_s``)."""
        ref: Reference | None = self._ref  # type: ignore[attr-defined]
        if ref is None:
            ref = Reference._hold_checked(self.pos_ned, self.yaw_rad)
            object.__setattr__(self, "_ref", ref)
        return ref


@dataclass(frozen=True, eq=False)
class RampSegment:
    """Constant velocity ``vel_ned`` (m/s) from ``start_pos_ned`` (m): a landing's final creep.

    Before ``t0_s`` it holds the start point; after a finite end it holds the end point.
    """

    t0_s: float
    duration_s: float
    start_pos_ned: np.ndarray
    vel_ned: np.ndarray
    yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        _check_times(self.t0_s, self.duration_s, allow_inf=True)
        object.__setattr__(self, "start_pos_ned", _vec3(self.start_pos_ned, "start_pos_ned"))
        object.__setattr__(self, "vel_ned", _vec3(self.vel_ned, "vel_ned"))
        # per-tick constants of evaluate(), as plain floats
        object.__setattr__(self, "_start_f", tuple(self.start_pos_ned.tolist()))
        object.__setattr__(self, "_vel_f", tuple(self.vel_ned.tolist()))

    @property
    def end_time_s(self) -> float:
        """End of the ramp, s (inf for an endless ramp)."""
        return self.t0_s + self.duration_s

    def evaluate(self, time_s: float) -> Reference:
        """Reference at ``time_s``, s."""
        if time_s < self.t0_s:
            return Reference._hold_checked(self.start_pos_ned, self.yaw_rad)
        if time_s >= self.end_time_s:
            return Reference.hold(self.start_pos_ned + self.vel_ned * self.duration_s,
                                  self.yaw_rad)
        return self.inside(time_s)

    def inside(self, time_s: float) -> Reference:
        """:meth:`evaluate` at a time inside the ramp (``t0_s <= t < end_time_s``, s), without
        the checks."""
        # p = p0 + v (t - t0)  (plain floats)
        dt_s = time_s - self.t0_s
        p0x, p0y, p0z = self._start_f  # type: ignore[attr-defined]
        vx, vy, vz = self._vel_f  # type: ignore[attr-defined]
        return _reference_from_nine(p0x + vx * dt_s, p0y + vy * dt_s, p0z + vz * dt_s,
                                    vx, vy, vz, 0.0, 0.0, 0.0, self.yaw_rad, 0.0)


Segment = CubicSegment | HoldSegment | RampSegment


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
                                                  _vec3(self.pos_ned, "pos_ned")))
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
        pos = _vec3(start_pos_ned, "start_pos_ned")
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
            pos, yaw = _vec3(target, "pos_ned"), wrap_pi(yaw + dyaw)
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
    start = _vec3(start_pos_ned, "start_pos_ned")
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
    start = _vec3(start_pos_ned, "start_pos_ned")
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
