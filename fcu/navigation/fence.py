"""The geofence, as ArduCopter's ``FENCE_*`` parameters describe it.

Off by default (``FENCE_ENABLE`` 0), as in ArduCopter: the vehicle then has no altitude or
distance limit of its own. Enabled, it keeps the vehicle below ``FENCE_ALT_MAX`` above home
(``FENCE_TYPE`` bit 0) and within ``FENCE_RADIUS`` of home horizontally (bit 1). A command
or mission item that would take the vehicle outside is refused with the parameter that
refuses it; a breach in flight triggers ``FENCE_ACTION``:

====  ==========================================================================
0     report only
1     RTL, or LAND when RTL cannot be flown (ArduCopter's default)
2     always LAND
3     SmartRTL or RTL or LAND (no SmartRTL here: RTL)
4     BRAKE or LAND (BRAKE)
5     SmartRTL or LAND (no SmartRTL here: LAND)
====  ==========================================================================

The breach is judged on the estimate (the autopilot never knows more). A breach triggers
once; the fence re-arms when the vehicle is back inside by ``FENCE_MARGIN``.

The fence uploaded as a plan (MAV_MISSION_TYPE_FENCE: inclusion and exclusion polygons and
circles, :class:`FenceAreas`) is enforced the same way while ``FENCE_TYPE`` bit 2 is set:
inside every inclusion area, outside every exclusion area.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from flightdata.config import finite, require

Vec3 = Sequence[float] | np.ndarray  # m, NED

__all__ = ["FENCE_ACTIONS", "FENCE_TYPE_ALT_MAX", "FENCE_TYPE_CIRCLE", "FENCE_TYPE_POLYGON",
           "FenceAreas", "FenceConfig", "Vec3", "area_problem", "breach", "inside_polygon",
           "target_problem"]

FENCE_TYPE_ALT_MAX = 1  # FENCE_TYPE bit 0: maximum altitude above home
FENCE_TYPE_CIRCLE = 2  # FENCE_TYPE bit 1: circle about home
FENCE_TYPE_POLYGON = 4  # FENCE_TYPE bit 2: polygons (uploaded as MAV_MISSION_TYPE_FENCE)
FENCE_TYPE_MAX = FENCE_TYPE_ALT_MAX | FENCE_TYPE_CIRCLE | FENCE_TYPE_POLYGON

#: The mode each FENCE_ACTION switches to ("" = report only).
FENCE_ACTIONS: dict[int, str] = {0: "", 1: "rtl", 2: "land", 3: "rtl", 4: "brake", 5: "land"}


@dataclass(frozen=True, kw_only=True)
class FenceConfig:
    """The geofence (ArduCopter parameter in brackets)."""

    enable: int = 0  # 0 off, 1 on [FENCE_ENABLE]
    types: int = FENCE_TYPE_MAX  # bitmask: 1 altitude max, 2 circle, 4 polygon [FENCE_TYPE]
    alt_max_m: float = 100.0  # m above home [FENCE_ALT_MAX]
    radius_m: float = 300.0  # m from home, horizontal [FENCE_RADIUS]
    action: int = 1  # see FENCE_ACTIONS [FENCE_ACTION]
    margin_m: float = 2.0  # m, distance back inside that re-arms the fence [FENCE_MARGIN]

    def __post_init__(self) -> None:
        require(self.enable in (0, 1) and not isinstance(self.enable, bool), "enable",
                self.enable, "must be 0 or 1")
        require(isinstance(self.types, int) and 0 <= self.types <= FENCE_TYPE_MAX, "types",
                self.types, f"must be a bitmask in 0..{FENCE_TYPE_MAX}")
        for name in ("alt_max_m", "radius_m"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a finite number > 0")
        require(finite(self.margin_m) and self.margin_m >= 0, "margin_m", self.margin_m,
                "must be a finite number >= 0")
        require(self.action in FENCE_ACTIONS, "action", self.action,
                f"must be one of {sorted(FENCE_ACTIONS)}")

    @property
    def altitude_on(self) -> bool:
        """The altitude fence is enforced."""
        return bool(self.enable and self.types & FENCE_TYPE_ALT_MAX)

    @property
    def circle_on(self) -> bool:
        """The circular fence is enforced."""
        return bool(self.enable and self.types & FENCE_TYPE_CIRCLE)


@dataclass(frozen=True)
class FenceAreas:
    """The uploaded fence (MAV_MISSION_TYPE_FENCE) in local NED: polygons as (N, 2) arrays
    of north, east (m) and circles as (north, east, radius) (m). As ArduPilot: the vehicle
    must be inside every inclusion area and outside every exclusion area."""

    inclusion_polygons: tuple[np.ndarray, ...] = ()
    exclusion_polygons: tuple[np.ndarray, ...] = ()
    inclusion_circles: tuple[tuple[float, float, float], ...] = ()
    exclusion_circles: tuple[tuple[float, float, float], ...] = ()

    @property
    def empty(self) -> bool:
        """No area at all."""
        return not (self.inclusion_polygons or self.exclusion_polygons
                    or self.inclusion_circles or self.exclusion_circles)


def inside_polygon(north: float, east: float, polygon: np.ndarray) -> bool:
    """Point in polygon (even-odd rule: a ray towards +east crosses the edges)."""
    inside = False
    n = len(polygon)
    for i in range(n):
        (n1, e1), (n2, e2) = polygon[i], polygon[(i + 1) % n]
        if (n1 > north) != (n2 > north):
            e_cross = e1 + (north - n1) * (e2 - e1) / (n2 - n1)
            if east < e_cross:
                inside = not inside
    return inside


def area_problem(pos_ned: Vec3, areas: FenceAreas) -> str | None:
    """Which uploaded fence area ``pos_ned`` (m, NED) violates, or None."""
    north, east = float(pos_ned[0]), float(pos_ned[1])
    for k, polygon in enumerate(areas.inclusion_polygons):
        if not inside_polygon(north, east, polygon):
            return f"outside inclusion polygon {k + 1}"
    for k, polygon in enumerate(areas.exclusion_polygons):
        if inside_polygon(north, east, polygon):
            return f"inside exclusion polygon {k + 1}"
    for k, (cn, ce, r) in enumerate(areas.inclusion_circles):
        if math.hypot(north - cn, east - ce) > r:
            return f"outside inclusion circle {k + 1}"
    for k, (cn, ce, r) in enumerate(areas.exclusion_circles):
        if math.hypot(north - cn, east - ce) < r:
            return f"inside exclusion circle {k + 1}"
    return None


def target_problem(pos_ned: Vec3, home_ned: Vec3,
                   fence: FenceConfig) -> str | None:
    """Why a target at ``pos_ned`` (m, NED) lies outside the enabled fence about
    ``home_ned``, naming the parameter; None when it is inside (or the fence is off)."""
    alt_m = float(home_ned[2]) - float(pos_ned[2])
    if fence.altitude_on and alt_m > fence.alt_max_m:
        return f"altitude {alt_m:.2f} m above FENCE_ALT_MAX ({fence.alt_max_m:g} m)"
    if fence.circle_on:
        dist_m = math.hypot(float(pos_ned[0]) - float(home_ned[0]),
                            float(pos_ned[1]) - float(home_ned[1]))
        if dist_m > fence.radius_m:
            return (f"{dist_m:.1f} m from home, beyond FENCE_RADIUS "
                    f"({fence.radius_m:g} m)")
    return None


def breach(pos_ned: Vec3, home_ned: Vec3, fence: FenceConfig,
           margin_m: float = 0.0, areas: FenceAreas | None = None) -> str | None:
    """Which fence the vehicle at ``pos_ned`` breaches (outside by more than ``-margin_m``:
    a positive margin judges "not yet back inside by the margin"), or None."""
    alt_m = float(home_ned[2]) - float(pos_ned[2])
    if fence.altitude_on and alt_m > fence.alt_max_m - margin_m:
        return f"altitude {alt_m:.1f} m above FENCE_ALT_MAX {fence.alt_max_m:g} m"
    if fence.circle_on:
        dist_m = math.hypot(float(pos_ned[0]) - float(home_ned[0]),
                            float(pos_ned[1]) - float(home_ned[1]))
        if dist_m > fence.radius_m - margin_m:
            return f"{dist_m:.1f} m from home, beyond FENCE_RADIUS {fence.radius_m:g} m"
    if areas is not None and fence.enable and fence.types & FENCE_TYPE_POLYGON:
        return area_problem(pos_ned, areas)  # (the margin applies to the parameters' fence)
    return None
