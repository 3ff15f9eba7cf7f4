"""From telemetry samples to aligned arrays: true position, held references, the flying mask.

The arithmetic behind :meth:`gcs.analysis.FlightAnalyzer.series` and ``report`` (the module
docstring of :mod:`gcs.analysis` says which messages feed it and which samples count).

SIM_STATE rows, as the analyzer stores them, are 11 columns: time (s), roll, pitch, yaw (rad),
lat_int, lon_int (degE7), alt (m AMSL), lat, lon (float32 degrees), vn, ve (m/s). Home is
(latitude degE7, longitude degE7, altitude mm AMSL, local x, y, z in m) from HOME_POSITION.
Reference rows are (time s, three values).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flightdata.series import hold_index

__all__ = ["Aligned", "align", "bridged", "covered_time_s", "hold", "metres_per_degree",
           "stale_after", "truth_ned", "velocity_aided"]

WGS84_A_M = 6378137.0  # m
WGS84_E2 = 6.69437999014e-3
GAP_S = 0.5  # s without SIM_STATE that ends a stretch of velocity integration
BRIDGE_S = GAP_S  # s: a stream missing for up to this long lost packets; longer, it stopped
# velocity_aided's anchor: samples moving faster than this along the axis (m/s), when at least
# this many (a 10 ms sample moves 1 mm at 0.1 m/s: ten of them cross a 1e-7 degree step)
ANCHOR_SPEED_M_S = 0.1
ANCHOR_MIN_SAMPLES = 200

Home = tuple[int, int, int, float, float, float]


def metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """Metres per degree of latitude and longitude at ``lat_deg`` (WGS84 radii of curvature)."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    w = math.sqrt(1.0 - WGS84_E2 * s2)
    rad = math.pi / 180.0
    return (WGS84_A_M * (1.0 - WGS84_E2) / (w * w * w) * rad,
            WGS84_A_M / w * math.cos(math.radians(lat_deg)) * rad)


@dataclass(frozen=True, eq=False)
class Aligned:
    """Truth and references on the SIM_STATE samples (n rows).

    Attributes
    ----------
    truth : (n, 11) the SIM_STATE rows
    pos : (n, 3) true NED position, m (:func:`truth_ned`)
    ref_pos, ref_att : (n, 3) the position (m) and attitude (rad) references on each sample:
        the one of that tick, else interpolated across lost packets (:func:`bridged`), NaN
        where the reference had stopped
    fresh_pos, fresh_att : (n,) bool, the reference of that very tick arrived
    tracked : (n,) bool, both references exist on the sample (fresh or bridged)
    airborne : (n,) bool, the vehicle is off the ground
    flying : (n,) bool, both references fresh and the vehicle airborne: the samples the
        errors are taken over
    """

    truth: np.ndarray
    pos: np.ndarray
    ref_pos: np.ndarray
    ref_att: np.ndarray
    fresh_pos: np.ndarray
    fresh_att: np.ndarray
    tracked: np.ndarray
    airborne: np.ndarray
    flying: np.ndarray

    def flight_s(self) -> float:
        """Simulated seconds airborne under a tracked reference, lost samples bridged
        (:func:`covered_time_s`)."""
        return covered_time_s(self.truth[:, 0], self.tracked & self.airborne)


def truth_ned(rows: np.ndarray, home: Home) -> np.ndarray:
    """True NED positions (m, (n, 3)) of SIM_STATE rows about the origin.

    North and east: the integral of the true velocity (``vn``, ``ve``, trapezoids between
    samples), anchored to the mean of the geodetic positions over each stretch without a
    gap. The geodetic position alone is coarse: ``lat_int``/``lon_int`` resolve 1e-7
    degree (about 1 cm), the float32 ``lat``/``lon`` 0.4 m at 35 degrees (they are used
    where finer, near the equator or the prime meridian). The velocity carries the
    millimetres, the mean of ~10^3 quantised fixes the constant. Down: ``alt`` (float32,
    AMSL: 0.06 mm at 584 m) against home's altitude.
    """
    lat_e7, lon_e7, alt_mm, hx, hy, hz = home
    north_per_deg, east_per_deg = metres_per_degree(lat_e7 * 1e-7)
    lat = _finest(rows[:, 7], rows[:, 4])
    lon = _finest(rows[:, 8], rows[:, 5])
    north = (lat - lat_e7 * 1e-7) * north_per_deg + hx
    dlon = (lon - lon_e7 * 1e-7 + 180.0) % 360.0 - 180.0
    east = dlon * east_per_deg + hy
    down = (alt_mm * 1e-3 - rows[:, 6]) + hz
    north = velocity_aided(rows[:, 0], north, rows[:, 9])
    east = velocity_aided(rows[:, 0], east, rows[:, 10])
    return np.column_stack([north, east, down])


def align(truth: np.ndarray, pos_ref: np.ndarray, att_ref: np.ndarray, home: Home,
          airborne_alt_m: float) -> Aligned:
    """Put the references on the SIM_STATE samples and find the flying ones.

    A sample flies when the position and attitude references of its own tick arrived
    (younger than their period, :func:`stale_after`) and the true altitude above home
    exceeds ``airborne_alt_m`` (raised to two float32 steps of SIM_STATE.alt at home's
    altitude when those are coarser). A reference lost in transit is bridged
    (:func:`bridged`): it is drawn and the time counts, but no error is taken there.
    """
    pos = truth_ned(truth, home)
    t = truth[:, 0]
    ref_pos, fresh_pos, have_pos = bridged(pos_ref, t, stale_after(pos_ref[:, 0]))
    ref_att, fresh_att, have_att = bridged(att_ref, t, stale_after(att_ref[:, 0]),
                                           angles=True)
    home_alt_m = home[2] * 1e-3
    threshold = max(airborne_alt_m, 2.0 * float(np.spacing(np.float32(abs(home_alt_m) + 1.0))))
    airborne = (-pos[:, 2] + home[5]) > threshold
    flying = fresh_pos & fresh_att & airborne
    return Aligned(truth=truth, pos=pos, ref_pos=ref_pos, ref_att=ref_att, fresh_pos=fresh_pos,
                   fresh_att=fresh_att, tracked=have_pos & have_att, airborne=airborne,
                   flying=flying)


def bridged(rows: np.ndarray, t_query: np.ndarray, fresh_s: float, *,
            angles: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A reference stream's value at each query time, across lost packets.

    Parameters
    ----------
    rows : (k, 4) time (s, non-decreasing) and three values
    t_query : (n,) s
    fresh_s : float
        Age up to which the latest sample is the one of the query's own tick.
    angles : bool
        The values are angles (rad): interpolated along the shorter way round.

    Returns
    -------
    values : (n, 3)
        The fresh sample; else the straight line between the samples either side when they
        are at most :data:`BRIDGE_S` apart (packets were lost, the stream went on); else NaN
        (the stream had stopped, or not started).
    fresh : (n,) bool
        The value is the fresh sample.
    known : (n,) bool
        The value is fresh or bridged.
    """
    t_query = np.asarray(t_query, dtype=float)
    n = len(t_query)
    values = np.full((n, 3), np.nan)
    if not len(rows):
        return values, np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    t_src = rows[:, 0]
    i, fresh = hold(t_src, t_query, fresh_s=fresh_s)
    values[fresh] = rows[i[fresh], 1:4]
    j = np.minimum(i + 1, len(t_src) - 1)
    span = t_src[j] - t_src[i]
    gap = (~fresh & (hold_index(t_src, t_query) >= 0) & (j > i) & (span <= BRIDGE_S + 1e-9)
           & (t_query <= t_src[j] + 1e-9))
    if np.any(gap):
        a, b = rows[i[gap], 1:4], rows[j[gap], 1:4]
        w = ((t_query[gap] - t_src[i[gap]]) / span[gap])[:, None]
        step = np.angle(np.exp(1j * (b - a))) if angles else b - a
        values[gap] = a + w * step
        if angles:
            values[gap] = np.angle(np.exp(1j * values[gap]))
    return values, fresh, fresh | gap


def covered_time_s(t_s: np.ndarray, counted: np.ndarray) -> float:
    """Seconds covered by the ``counted`` samples, across lost ones.

    Each counted sample covers the time to the next sample when that is at most
    :data:`GAP_S` away (the samples lost in between were of the same flight), else one
    median sample period. Without losses this is the number of counted samples times the
    period.

    Parameters
    ----------
    t_s : (n,) sample times, s, non-decreasing
    counted : (n,) bool
    """
    t_s = np.asarray(t_s, dtype=float)
    if not np.any(counted):
        return 0.0
    steps = np.diff(t_s)
    period = float(np.median(steps)) if len(steps) else 0.0
    to_next = np.r_[steps, period]
    span = np.where(to_next <= GAP_S + 1e-9, to_next, period)
    return float(np.sum(span[np.asarray(counted, dtype=bool)]))


def velocity_aided(t_s: np.ndarray, coarse_m: np.ndarray, vel_m_s: np.ndarray) -> np.ndarray:
    """Positions from integrated velocity, anchored to the mean coarse position per stretch
    (over the samples moving along the axis, when there are enough).

    Parameters
    ----------
    t_s : (n,) sample times, s, non-decreasing
    coarse_m : (n,) positions, m, quantised (degE7) but unbiased
    vel_m_s : (n,) their exact time derivative at the samples, m/s
    """
    out = np.array(coarse_m, dtype=float)
    n = len(t_s)
    if n < 2:
        return out
    dt = np.diff(t_s)
    breaks = np.flatnonzero(dt > GAP_S) + 1
    for lo, hi in zip(np.r_[0, breaks], np.r_[breaks, n], strict=True):
        if hi - lo < 2:
            continue
        seg_t = t_s[lo:hi]
        seg_v = vel_m_s[lo:hi]
        # x_k = x_0 + sum of (v_i + v_i+1) / 2 * dt_i
        integral = np.r_[0.0, np.cumsum(0.5 * (seg_v[1:] + seg_v[:-1]) * np.diff(seg_t))]
        offsets = coarse_m[lo:hi] - integral
        # a vehicle standing still repeats one quantisation error sample after sample (on
        # the ground before take-off, for as long as the link takes to arm it): the anchor
        # is the mean over the samples moving along the axis, which cross the grid, when
        # there are enough of them
        moving = np.abs(seg_v) > ANCHOR_SPEED_M_S
        if np.count_nonzero(moving) >= ANCHOR_MIN_SAMPLES:
            offsets = offsets[moving]
        out[lo:hi] = integral + float(np.mean(offsets))
    return out


def _finest(deg_f32: np.ndarray, deg_e7: np.ndarray) -> np.ndarray:
    """Per sample, the float32 degrees where their resolution beats 1e-7, else degE7."""
    finer = np.spacing(np.abs(deg_f32).astype(np.float32)) < 1e-7
    return np.where(finer, deg_f32, deg_e7 * 1e-7)


def stale_after(t_src: np.ndarray) -> float:
    """Age (s) beyond which a sample of a stream with these time stamps counts as stopped.

    One period less a millisecond: a stream that keeps coming has a fresh sample at least
    once per period (time stamps are whole milliseconds of the vehicle's ticks), so a sample
    a full period old means the stream, and the controller behind it, stopped.
    """
    if len(t_src) < 2:
        return 0.0005
    return max(0.0005, float(np.median(np.diff(t_src))) - 0.001)


def hold(t_src: np.ndarray, t_query: np.ndarray,
         fresh_s: float | None = 0.005) -> tuple[np.ndarray, np.ndarray]:
    """Sample-and-hold: index of the latest source sample at or before each query time.

    Returns the indices (0 where none) and whether each is valid: a source sample exists at
    or before the query and, when ``fresh_s`` is given, is no older than ``fresh_s`` seconds
    (a reference that stopped coming means the controller went idle).
    """
    idx = hold_index(t_src, t_query)
    valid = idx >= 0
    idx = np.where(valid, idx, 0)
    if fresh_s is not None and len(t_src):
        valid &= (t_query - t_src[idx]) <= fresh_s + 1e-9
    return idx, valid
