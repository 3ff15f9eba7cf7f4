"""Local NED <-> WGS84 latitude/longitude/altitude about a reference point (flat earth).

The vehicle flies within a few hundred metres of its origin, so a tangent plane is exact to
well below a millimetre there: north and east scale with the WGS84 meridian and
prime-vertical radii of curvature at the reference latitude, down is minus altitude.
The mapping and its inverse are exact inverses of each other (up to floating point).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from fcu.mavlink.port_records import GeoPoint

__all__ = ["WGS84_A_M", "WGS84_E2", "geo_to_ned", "home_alt_amsl_m", "metres_per_degree",
           "ned_to_geo"]

WGS84_A_M = 6378137.0  # m, WGS84 semi-major axis
WGS84_E2 = 6.69437999014e-3  # WGS84 first eccentricity squared
_MAX_REF_LAT_DEG = 89.9  # deg, beyond this east-west degrees shrink to nothing


@functools.lru_cache(maxsize=16)  # a vehicle converts about its one origin all the time
def metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """Metres per degree of latitude and of longitude at ``lat_deg``.

    Parameters
    ----------
    lat_deg : float
        Reference latitude, degrees.

    Returns
    -------
    north_m_per_deg, east_m_per_deg : float
        Meridian radius times pi/180, and prime-vertical radius times cos(lat) times pi/180.
    """
    s2 = math.sin(math.radians(lat_deg)) ** 2
    w = math.sqrt(1.0 - WGS84_E2 * s2)
    # R_M = a (1 - e^2) / (1 - e^2 sin^2 lat)^(3/2),  R_N = a / (1 - e^2 sin^2 lat)^(1/2)
    r_meridian_m = WGS84_A_M * (1.0 - WGS84_E2) / (w * w * w)
    r_normal_m = WGS84_A_M / w
    rad = math.pi / 180.0
    return r_meridian_m * rad, r_normal_m * math.cos(math.radians(lat_deg)) * rad


def _check_ref(ref: GeoPoint) -> tuple[float, float]:
    if abs(ref.lat_deg) > _MAX_REF_LAT_DEG:
        raise ValueError(f"reference lat_deg = {ref.lat_deg!r}: must be within "
                         f"+-{_MAX_REF_LAT_DEG} for a local tangent plane")
    return metres_per_degree(ref.lat_deg)


def _wrap_deg(angle_deg: float) -> float:
    """Wrap to [-180, 180)."""
    return (angle_deg + 180.0) % 360.0 - 180.0


def geo_to_ned(lat_deg: float, lon_deg: float, alt_m: float, ref: GeoPoint) -> np.ndarray:
    """Position about ``ref`` in NED, m.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Latitude and longitude, degrees.
    alt_m : float
        Altitude above mean sea level, m.
    ref : GeoPoint
        The NED origin.

    Returns
    -------
    ndarray, shape (3,)
        north, east, down in metres.
    """
    north_per_deg, east_per_deg = _check_ref(ref)
    north_m = (lat_deg - ref.lat_deg) * north_per_deg
    east_m = _wrap_deg(lon_deg - ref.lon_deg) * east_per_deg
    down_m = ref.alt_m - alt_m
    return np.array([north_m, east_m, down_m])


def ned_to_geo(pos_ned: np.ndarray, ref: GeoPoint) -> tuple[float, float, float]:
    """Latitude, longitude (degrees) and altitude AMSL (m) of ``pos_ned`` about ``ref``.

    Parameters
    ----------
    pos_ned : array_like, shape (3,)
        north, east, down in metres.
    ref : GeoPoint
        The NED origin.
    """
    north_per_deg, east_per_deg = _check_ref(ref)
    lat_deg = ref.lat_deg + float(pos_ned[0]) / north_per_deg
    lon_deg = _wrap_deg(ref.lon_deg + float(pos_ned[1]) / east_per_deg)
    alt_m = ref.alt_m - float(pos_ned[2])
    return lat_deg, lon_deg, alt_m


def home_alt_amsl_m(origin: GeoPoint, home_pos_ned: np.ndarray | None) -> float:
    """Altitude AMSL (m) of home at ``home_pos_ned`` about ``origin`` (the origin when None).

    Relative altitudes (MAV_FRAME_GLOBAL_RELATIVE_ALT, GLOBAL_POSITION_INT.relative_alt) are
    measured from it.
    """
    return origin.alt_m - (float(home_pos_ned[2]) if home_pos_ned is not None else 0.0)
