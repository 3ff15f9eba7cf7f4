"""Accelerometer vibration and clipping, as ArduPilot's ``AP_InertialSensor`` measures them.

For every accelerometer sample ``a`` (m/s^2, body FRD) taken ``dt`` after the previous one
(``AP_InertialSensor::calc_vibration_and_clipping``)::

    floor  <- floor + alpha(dt, 5 Hz) (a - floor)          # the 5 Hz low-pass: the motion
    square <- square + alpha(dt, 2 Hz) ((a - floor)^2 - square)   # per axis
    vibration = sqrt(square)                                # m/s^2, per axis
    alpha(dt, fc) = dt / (dt + 1 / (2 pi fc))               # ArduPilot's LowPassFilter

so the vibration is the RMS, over about half a second, of what the 5 Hz low-pass leaves out.
A sample counts as clipped when any axis exceeds the full scale less 0.5 g (ArduPilot's clip
limit); the count runs from boot. ArduCopter's pilots read vibration below 30 m/s^2 as fine
and above 60 m/s^2 as a problem; a healthy frame shows a few tenths.

:class:`VibrationMonitor` takes the samples in batches (whenever the VIBRATION message is
built), filtering them one by one in a compiled loop: the same numbers as sample-by-sample
updates at the cost of one call per batch.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["ACCEL_FULL_SCALE_M_S2", "CLIP_MARGIN_M_S2", "VIBE_FILTER_HZ", "VIBE_FLOOR_HZ",
           "VibrationMonitor"]

VIBE_FLOOR_HZ = 5.0  # Hz, AP_INERTIAL_SENSOR_ACCEL_VIBE_FLOOR_FILT_HZ
VIBE_FILTER_HZ = 2.0  # Hz, AP_INERTIAL_SENSOR_ACCEL_VIBE_FILT_HZ
ACCEL_FULL_SCALE_M_S2 = 16.0 * 9.80665  # m/s^2, +-16 g: a MEMS accelerometer's widest range
CLIP_MARGIN_M_S2 = 0.5 * 9.80665  # m/s^2, ArduPilot clips 0.5 g below the full scale


@njit(cache=True, error_model="numpy")
def _vibration_kernel(times_s: np.ndarray, accel: np.ndarray, state: np.ndarray,
                      clip_limit: float) -> int:
    """Filter the samples ``accel`` (n, 3) taken at ``times_s`` (n,) into ``state``
    (floor 0:3, squared 3:6, last time 6, started 7); returns the clipped samples."""
    clipped = 0
    tau_floor = 1.0 / (2.0 * math.pi * VIBE_FLOOR_HZ)
    tau_vibe = 1.0 / (2.0 * math.pi * VIBE_FILTER_HZ)
    for k in range(times_s.shape[0]):
        t = times_s[k]
        if state[7] == 0.0:  # the first sample starts the floor filter at its value
            for i in range(3):
                state[i] = accel[k, i]
            state[6] = t
            state[7] = 1.0
        dt = t - state[6]
        state[6] = t
        a_floor = dt / (dt + tau_floor) if dt > 0.0 else 0.0
        a_vibe = dt / (dt + tau_vibe) if dt > 0.0 else 0.0
        clip = False
        for i in range(3):
            a = accel[k, i]
            if abs(a) > clip_limit:
                clip = True
            state[i] += a_floor * (a - state[i])
            diff = a - state[i]
            state[3 + i] += a_vibe * (diff * diff - state[3 + i])
        if clip:
            clipped += 1
    return clipped


class VibrationMonitor:
    """ArduPilot's vibration levels and clip count of one accelerometer (module docstring).

    Parameters
    ----------
    full_scale_m_s2 : float
        The accelerometer's range, m/s^2 (+-); samples beyond it less 0.5 g are clipped.
    """

    def __init__(self, full_scale_m_s2: float = ACCEL_FULL_SCALE_M_S2) -> None:
        if not (math.isfinite(full_scale_m_s2) and full_scale_m_s2 > CLIP_MARGIN_M_S2):
            raise ValueError(f"full_scale_m_s2 = {full_scale_m_s2!r}: must be a finite range "
                             f"> {CLIP_MARGIN_M_S2:.2f} m/s^2")
        self.clip_limit_m_s2 = full_scale_m_s2 - CLIP_MARGIN_M_S2
        self.reset()

    def reset(self) -> None:
        """No sample seen, no clipping."""
        self._state = np.zeros(8)
        self.clipped = 0

    def update(self, times_s: np.ndarray, accel_frd: np.ndarray) -> None:
        """Take samples ``accel_frd`` (n, 3), m/s^2, taken at ``times_s`` (n,), s, in order.

        Non-finite samples are skipped (a sensor that returns NaN is not vibrating).
        """
        t = np.ascontiguousarray(times_s, dtype=float).reshape(-1)
        a = np.ascontiguousarray(accel_frd, dtype=float).reshape(-1, 3)
        if t.shape[0] != a.shape[0]:
            raise ValueError(f"{t.shape[0]} times for {a.shape[0]} samples")
        keep = np.isfinite(t) & np.all(np.isfinite(a), axis=1)
        if not np.all(keep):
            t, a = t[keep], a[keep]
        if t.shape[0]:
            self.clipped += int(_vibration_kernel(t, a, self._state, self.clip_limit_m_s2))

    @property
    def started(self) -> bool:
        """At least one sample has been taken."""
        return bool(self._state[7])

    @property
    def time_s(self) -> float:
        """Time of the latest sample, s (NaN before the first)."""
        return float(self._state[6]) if self.started else math.nan

    @property
    def levels_m_s2(self) -> np.ndarray:
        """Vibration per body axis, m/s^2, shape (3,)."""
        return np.sqrt(np.maximum(self._state[3:6], 0.0))
