"""A lead vehicle's position reports for FOLLOW, read off the wire (``AP_Follow::handle_msg``).

Two messages are taken, from any system but the vehicle's own:

=====================  ==================================================================
FOLLOW_TARGET          needs ``est_capabilities`` bit 0 (position) and a position other
                       than 0, 0; ``alt`` is AMSL (m); velocity (``vel``, m/s NED) when
                       bit 1 is set; heading from ``attitude_q`` when bit 3 is set
GLOBAL_POSITION_INT    lat/lon (degE7), ``alt`` AMSL and ``relative_alt`` (mm), velocity
                       (cm/s NED), heading ``hdg`` (cdeg; 65535 unknown)
=====================  ==================================================================

FOLL_ALT_TYPE 1 (above home, ArduCopter's default) reads GLOBAL_POSITION_INT's
``relative_alt`` as above this vehicle's home; 0 reads ``alt`` as AMSL. FOLLOW_TARGET's
altitude is AMSL either way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fcu.mavlink.geo import geo_to_ned
from fcu.mavlink.port_records import GeoPoint
from fcu.mavlink.transport.codec import MAVLinkMessage
from flightdata.geometry import euler_from_quat

__all__ = ["LeadReport", "lead_report"]

CAP_POS, CAP_VEL, CAP_ATT_RATES = 1, 2, 8  # FOLLOW_TARGET.est_capabilities bits 0, 1, 3
UNKNOWN_HDG = 65535  # GLOBAL_POSITION_INT.hdg when unknown


@dataclass(frozen=True)
class LeadReport:
    """One position report of a possible lead, in the units of the wire turned SI."""

    sysid: int
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float  # m above mean sea level
    alt_above_home_m: float | None  # m, GLOBAL_POSITION_INT's relative_alt (None: absent)
    vel_ned_m_s: tuple[float, float, float] | None  # None: not reported
    heading_rad: float | None  # rad from north, None: not reported

    def pos_ned(self, origin: GeoPoint, home_pos_ned: np.ndarray, alt_type: int) -> np.ndarray:
        """Position about ``origin`` (m, NED); ``alt_type`` is FOLL_ALT_TYPE."""
        pos = geo_to_ned(self.lat_deg, self.lon_deg, self.alt_amsl_m, origin)
        if alt_type == 1 and self.alt_above_home_m is not None:
            pos[2] = float(home_pos_ned[2]) - self.alt_above_home_m
        return pos


def lead_report(msg: MAVLinkMessage) -> LeadReport | None:
    """The report ``msg`` carries (FOLLOW_TARGET or GLOBAL_POSITION_INT), None when it
    carries no usable position (module docstring)."""
    sysid = int(msg.get_srcSystem())
    lat_deg, lon_deg = int(msg.lat) * 1e-7, int(msg.lon) * 1e-7
    if (int(msg.lat) == 0 and int(msg.lon) == 0) or not -90.0 <= lat_deg <= 90.0:
        return None
    if msg.get_type() == "FOLLOW_TARGET":
        caps = int(msg.est_capabilities)
        if not caps & CAP_POS or not math.isfinite(msg.alt):
            return None
        vel = tuple(float(v) for v in msg.vel)
        heading = None
        if caps & CAP_ATT_RATES and all(math.isfinite(q) for q in msg.attitude_q):
            heading = float(euler_from_quat(list(msg.attitude_q))[2])
        return LeadReport(sysid, lat_deg, lon_deg, float(msg.alt), None,
                          (vel[0], vel[1], vel[2]) if caps & CAP_VEL and
                          all(math.isfinite(v) for v in vel) else None, heading)
    hdg = int(msg.hdg)
    return LeadReport(sysid, lat_deg, lon_deg, int(msg.alt) / 1000.0,
                      int(msg.relative_alt) / 1000.0,
                      (int(msg.vx) / 100.0, int(msg.vy) / 100.0, int(msg.vz) / 100.0),
                      None if hdg == UNKNOWN_HDG else math.radians(hdg / 100.0))
