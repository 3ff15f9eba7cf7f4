"""The ground station's idea of where arming is allowed matches the vehicle's."""

from __future__ import annotations

from fcu.navigation.settings import NavigatorConfig
from gcs.station import ARMING_MODES


def test_the_ground_station_arms_in_every_mode_the_vehicle_arms_in() -> None:
    """A mode missing here makes ``ftc-gcs`` switch a vehicle that could arm where it is to
    STABILIZE first (POSHOLD once was)."""
    assert ARMING_MODES == set(NavigatorConfig().armable_modes)
