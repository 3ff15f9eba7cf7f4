"""Landing detection: whether the vehicle looks on the ground, and for how long.

The vehicle looks on the ground when its estimated altitude is below ``land_detect_alt_m``,
its vertical speed below ``land_detect_speed_m_s``, and the caller's ``on_ground_hint`` is
not False. A True hint (the autopilot asks for much less than hover thrust and the vehicle
does not move: ArduCopter's throttle-at-minimum test) accepts an estimated altitude and
vertical speed up to three times the limits: a height source a few centimetres off or a few
centimetres noisy (a drifting barometer) must not keep a vehicle that sits on the ground from
knowing it. While landing, that must hold continuously for ``land_detect_time_s`` before the
landing is detected (:class:`LandingDetector`). The same test gates arming
(:mod:`fcu.navigation.arming`).
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

from fcu.navigation.settings import TIME_TOL_S, NavigatorConfig


class LandedState(IntEnum):
    """MAV_LANDED_STATE values (EXTENDED_SYS_STATE.landed_state)."""

    UNDEFINED = 0
    ON_GROUND = 1
    IN_AIR = 2
    TAKEOFF = 3
    LANDING = 4


def looks_on_ground(pos_ned: np.ndarray, vel_ned: np.ndarray, on_ground_hint: bool | None,
                    config: NavigatorConfig) -> bool:
    """Low (altitude ``-z`` below ``land_detect_alt_m``, m), still (``|v_z|`` below
    ``land_detect_speed_m_s``, m/s; both three times that with a True ``on_ground_hint``) and
    not contradicted by ``on_ground_hint``."""
    scale = 3.0 if on_ground_hint is True else 1.0
    return bool(-pos_ned[2] < scale * config.land_detect_alt_m
                and abs(vel_ned[2]) < scale * config.land_detect_speed_m_s
                and on_ground_hint is not False)


class LandingDetector:
    """Declares a landing once the vehicle has looked on the ground for ``detect_time_s``.

    Parameters
    ----------
    detect_time_s : float
        How long the on-ground test must hold without a break, s.
    """

    def __init__(self, detect_time_s: float) -> None:
        self.detect_time_s = float(detect_time_s)
        self._since_s: float | None = None

    def reset(self) -> None:
        """Forget how long the vehicle has looked on the ground."""
        self._since_s = None

    def step(self, time_s: float, on_ground: bool) -> bool:
        """True when the vehicle has looked on the ground since ``detect_time_s`` ago (s)."""
        if not on_ground:
            self._since_s = None
            return False
        if self._since_s is None:
            self._since_s = time_s
        return time_s - self._since_s >= self.detect_time_s - TIME_TOL_S
