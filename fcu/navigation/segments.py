"""The pieces a guidance trajectory is made of: cubic, hold and ramp segments.

Each segment covers ``[t0_s, t0_s + duration_s)`` and evaluates to a
:class:`~fcu.navigation.reference.Reference` at any time, clamped to its end points outside.

Cubic segment (rest to rest, :class:`CubicSegment`)
-------------------------------------------------
Between two points ``p0`` and ``p1`` over a leg time ``T`` starting at ``t0``, with
``s = (t - t0) / T`` in [0, 1]::

    p(t) = p0 + (p1 - p0) (3 s^2 - 2 s^3)
    v(t) = (p1 - p0) (6 s - 6 s^2) / T          zero at s = 0 and s = 1
    a(t) = (p1 - p0) (6 - 12 s) / T^2

Yaw follows the same shape function along the shortest way round:
``psi(t) = wrap(psi0 + wrap(psi1 - psi0) (3 s^2 - 2 s^3))``. The leg times that honour the
speed limits are :func:`fcu.navigation.guidance.leg_duration_s`'s.

:class:`HoldSegment` is a constant reference (possibly endless), :class:`RampSegment` a
constant velocity ``p(t) = p0 + v (t - t0)`` (a landing's final creep).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fcu.floats import wrap_pi
from fcu.navigation.reference import Reference, read_only_vec3, reference_from_nine
from flightdata.config import finite, require

__all__ = ["CubicSegment", "HoldSegment", "RampSegment", "Segment"]


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
        object.__setattr__(self, "start_pos_ned",
                           read_only_vec3(self.start_pos_ned, "start_pos_ned"))
        object.__setattr__(self, "end_pos_ned", read_only_vec3(self.end_pos_ned, "end_pos_ned"))
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
        return reference_from_nine(p0x + dx * h, p0y + dy * h, p0z + dz * h,
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
        object.__setattr__(self, "pos_ned", read_only_vec3(self.pos_ned, "pos_ned"))
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
        object.__setattr__(self, "start_pos_ned",
                           read_only_vec3(self.start_pos_ned, "start_pos_ned"))
        object.__setattr__(self, "vel_ned", read_only_vec3(self.vel_ned, "vel_ned"))
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
        return reference_from_nine(p0x + vx * dt_s, p0y + vy * dt_s, p0z + vz * dt_s,
                                    vx, vy, vz, 0.0, 0.0, 0.0, self.yaw_rad, 0.0)


Segment = CubicSegment | HoldSegment | RampSegment
