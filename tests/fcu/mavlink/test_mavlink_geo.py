"""Local NED <-> latitude/longitude/altitude (fcu.mavlink.geo)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from fcu.mavlink.geo import geo_to_ned, home_alt_amsl_m, metres_per_degree, ned_to_geo
from fcu.mavlink.port_records import GeoPoint


def test_metres_per_degree_match_the_wgs84_figures() -> None:
    # Published WGS84 lengths of one degree: 110574 m (lat) / 111320 m (lon) at the equator,
    # 111132 m / 78847 m at 45 deg. Tolerance 2 m: a tangent-plane scale against the true
    # arc of a whole degree, plus rounding of the published figures.
    north, east = metres_per_degree(0.0)
    assert north == pytest.approx(110574.0, abs=2.0)
    assert east == pytest.approx(111320.0, abs=2.0)
    north, east = metres_per_degree(45.0)
    assert north == pytest.approx(111132.0, abs=2.0)
    assert east == pytest.approx(78847.0, abs=2.0)


def test_one_kilometre_north_east_and_up() -> None:
    origin = GeoPoint(40.0, 29.0, 100.0)
    north_per_deg, east_per_deg = metres_per_degree(40.0)
    lat, lon, alt = ned_to_geo(np.array([1000.0, -500.0, -20.0]), origin)
    assert lat == pytest.approx(40.0 + 1000.0 / north_per_deg, abs=1e-12)
    assert lon == pytest.approx(29.0 - 500.0 / east_per_deg, abs=1e-12)
    assert alt == pytest.approx(120.0)  # 20 m above the origin (down is negative)


def test_origin_maps_to_zero() -> None:
    origin = GeoPoint(-33.9, 151.2, 5.0)
    assert_allclose(geo_to_ned(-33.9, 151.2, 5.0, origin), np.zeros(3), atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(lat0=st.floats(-80.0, 80.0), lon0=st.floats(-180.0, 180.0),
       alt0=st.floats(-400.0, 5000.0),
       ned=st.tuples(*(st.floats(-10_000.0, 10_000.0),) * 3))
def test_round_trip_is_exact(lat0: float, lon0: float, alt0: float,
                             ned: tuple[float, float, float]) -> None:
    origin = GeoPoint(lat0, lon0, alt0)
    lat, lon, alt = ned_to_geo(np.array(ned), origin)
    # 1e-6 m: the maps are exact inverses; only float64 rounding of ~1e4 m values remains.
    assert_allclose(geo_to_ned(lat, lon, alt, origin), ned, atol=1e-6)


def test_crossing_the_antimeridian() -> None:
    origin = GeoPoint(10.0, 179.9999, 0.0)
    lat, lon, _ = ned_to_geo(np.array([0.0, 100.0, 0.0]), origin)
    assert -180.0 <= lon < -179.99  # wrapped, not 180.0008
    assert_allclose(geo_to_ned(lat, lon, 0.0, origin), [0.0, 100.0, 0.0], atol=1e-6)


def test_no_tangent_plane_at_the_pole() -> None:
    with pytest.raises(ValueError, match="lat_deg"):
        ned_to_geo(np.zeros(3), GeoPoint(89.95, 0.0, 0.0))


@pytest.mark.parametrize("lat, lon, alt", [(91.0, 0.0, 0.0), (0.0, 180.5, 0.0),
                                           (float("nan"), 0.0, 0.0), (0.0, 0.0, float("inf"))])
def test_geopoint_refuses_impossible_values(lat: float, lon: float, alt: float) -> None:
    with pytest.raises(ValueError):
        GeoPoint(lat, lon, alt)


def test_home_altitude_follows_home_down() -> None:
    origin = GeoPoint(40.0, 29.0, 100.0)
    assert home_alt_amsl_m(origin, None) == 100.0
    assert home_alt_amsl_m(origin, np.array([3.0, 4.0, -2.5])) == pytest.approx(102.5)
