"""The extended telemetry of an autopilot
(:class:`fcu.mavlink.telemetry.extended.ExtendedTelemetry`).

:class:`AutopilotTelemetry` is handed each tick's sensor samples (:meth:`~AutopilotTelemetry.
observe`, the samples the autopilot received that tick) and keeps them unprocessed until a
message needs them: then the pending samples are folded in at once (the latest IMU and
barometer readings, ArduPilot's vibration filters over every accelerometer sample), so the
cost follows the stream rates, not the tick rate. A backlog of :data:`MAX_PENDING_TICKS` is
folded in even when no such message is streamed.

What each message reports
-------------------------
- RAW_IMU / SCALED_IMU: the latest gyro and accelerometer samples; temperature: the standard
  atmosphere's at the vehicle's altitude (there is no thermal model).
- SCALED_PRESSURE: the barometer reports an altitude above home; its pressure is the standard
  atmosphere's at that altitude above the home's AMSL altitude
  (:mod:`flightdata.atmosphere`), its temperature the atmosphere's there.
- VIBRATION: :class:`fcu.monitoring.vibration.VibrationMonitor` over every accelerometer
  sample.
- EKF_STATUS_REPORT: the variances are sums of the flying estimator's covariance diagonal
  (velocity N+E+D in (m/s)^2, position N+E in m^2, down in m^2, yaw in rad^2; ArduPilot
  sends innovation test ratios in these fields instead). The flags say which solutions are
  good: attitude, horizontal and vertical velocity, horizontal position (relative and
  absolute, and their predictions) and vertical position each when finite and one sigma
  below :data:`ATTITUDE_SIGMA_RAD`, :data:`VELOCITY_SIGMA_M_S` or
  :data:`POSITION_SIGMA_M`, the horizontal position also only with a position fix;
  CONST_POS_MODE without a fix; GPS_GLITCHING when the position source's latest sample was
  rejected as an outlier; UNINITIALIZED before the first tick.
- AHRS2: the estimator that does not fly the vehicle (the TSKF beside the EKF); none when
  the TSKF flies, as it is then the only one.
- NAV_CONTROLLER_OUTPUT: the attitude reference's roll and pitch, the reference yaw, the
  current leg's target (bearing and horizontal distance from the estimate), the reference
  altitude minus the estimated one, and the distance from the leg's straight line.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any, Protocol

import numpy as np

from fcu.autopilot import Autopilot
from fcu.estimation.state import EULER, POS, VEL, YAW_INDEX, StateEstimate
from fcu.hal import SensorSampleLike
from fcu.mavlink.port_records import GeoPoint
from fcu.mavlink.telemetry.extended import (
    EkfReport,
    ImuReading,
    NavControllerReport,
    PressureReading,
    SecondaryAttitude,
    VibrationLevels,
)
from fcu.mavlink.transport.codec import mavlink2
from fcu.monitoring.vibration import VibrationMonitor
from flightdata.atmosphere import isa_pressure_pa, isa_temperature_c

__all__ = ["ATTITUDE_SIGMA_RAD", "MAX_PENDING_TICKS", "POSITION_SIGMA_M", "VELOCITY_SIGMA_M_S",
           "AutopilotTelemetry"]

_M = mavlink2
MAX_PENDING_TICKS = 200  # ticks of samples kept unprocessed at most (2 s at 100 Hz)
ATTITUDE_SIGMA_RAD = 0.1  # rad, roll/pitch one sigma below which the attitude is good
VELOCITY_SIGMA_M_S = 0.5  # m/s, velocity one sigma below which it is good
POSITION_SIGMA_M = 0.5  # m, position one sigma below which it is good
_HORIZONTAL_FLAGS = (_M.EKF_POS_HORIZ_REL | _M.EKF_POS_HORIZ_ABS | _M.EKF_PRED_POS_HORIZ_REL
                     | _M.EKF_PRED_POS_HORIZ_ABS)


class AutopilotHost(Protocol):
    """What holds the autopilot between ticks (e.g. :class:`sim.stack.SimulatedStack`)."""

    autopilot: Autopilot  # replaced when a parameter change rebuilds the autopilot
    pwm: np.ndarray  # PWM held until the next tick, (4,)

    @property
    def time_s(self) -> float:
        """Simulated time of the last tick, s."""
        ...


class AutopilotTelemetry:
    """:class:`fcu.mavlink.telemetry.extended.ExtendedTelemetry` over the autopilot a host holds.

    Parameters
    ----------
    host : AutopilotHost
        Holds the autopilot (which a parameter change may replace).
    origin : GeoPoint
        The NED origin (home at boot): the barometer's reference altitude.
    """

    def __init__(self, host: AutopilotHost, origin: GeoPoint) -> None:
        self.host = host
        self.origin = origin
        self.vibration_monitor = VibrationMonitor()
        self._pending: list[Iterable[SensorSampleLike]] = []
        self._gyro: tuple[float, np.ndarray] | None = None
        self._accel: tuple[float, np.ndarray] | None = None
        self._baro: tuple[float, float] | None = None

    # ------------------------------------------------------------------ samples
    def observe(self, samples: Iterable[SensorSampleLike]) -> None:
        """The samples the autopilot received this tick (a collection that can be iterated
        again later, as the world's sample batch can)."""
        self._pending.append(samples)
        if len(self._pending) > MAX_PENDING_TICKS:
            self._fold()

    def _fold(self) -> None:
        """Take in every pending sample, in order (module docstring)."""
        run: list[Any] = []  # consecutive batches of arrays (the world's)
        for batch in self._pending:
            if getattr(batch, "sensor_names", None) is not None:
                run.append(batch)
                continue
            self._fold_arrays(run)
            run = []
            self._fold_samples(batch)
        self._fold_arrays(run)
        self._pending.clear()

    def _fold_samples(self, batch: Iterable[SensorSampleLike]) -> None:
        """Any iterable of samples, one object at a time."""
        times: list[float] = []
        accels: list[np.ndarray] = []
        for sample in batch:
            name = sample.sensor
            if name == "accel":
                times.append(float(sample.time_s))
                accels.append(np.asarray(sample.value, dtype=float))
            elif name == "gyro":
                self._gyro = (float(sample.time_s), np.array(sample.value, dtype=float))
            elif name == "baro":
                self._baro = (float(sample.time_s), float(np.asarray(sample.value)[0]))
        if accels:
            self._accel = (times[-1], np.array(accels[-1]))
            self.vibration_monitor.update(np.array(times), np.array(accels))

    def _fold_arrays(self, batches: list[Any]) -> None:
        """Batches with ``sensor_names``, ``sensor_index`` (into them), ``time_s`` and
        ``values`` (n, 3) arrays, as :class:`sim.world.samples.SampleBatch` offers them,
        taken in at once, with no object per sample."""
        if not batches:
            return
        index = np.concatenate([b.sensor_index for b in batches])
        time_s = np.concatenate([b.time_s for b in batches])
        values = np.concatenate([b.values for b in batches])
        names: Sequence[str] = batches[0].sensor_names
        for name in ("accel", "gyro", "baro"):
            if name not in names:
                continue
            rows = np.flatnonzero(index == names.index(name))
            if rows.size == 0:
                continue
            last = int(rows[-1])
            if name == "accel":
                self._accel = (float(time_s[last]), np.array(values[last, :3]))
                self.vibration_monitor.update(time_s[rows], values[rows, :3])
            elif name == "gyro":
                self._gyro = (float(time_s[last]), np.array(values[last, :3]))
            else:
                self._baro = (float(time_s[last]), float(values[last, 0]))

    def _alt_amsl_m(self) -> float:
        status = self.host.autopilot.status
        alt_m = 0.0 if status is None else status.estimate.alt_m
        return self.origin.alt_m + (alt_m if math.isfinite(alt_m) else 0.0)

    # ------------------------------------------------------------------ ExtendedTelemetry
    def imu(self) -> ImuReading | None:
        """The latest gyro and accelerometer samples."""
        self._fold()
        if self._gyro is None or self._accel is None:
            return None
        return ImuReading(time_s=max(self._gyro[0], self._accel[0]),
                          accel_frd=self._accel[1], gyro_frd=self._gyro[1],
                          temperature_c=isa_temperature_c(self._alt_amsl_m()))

    def pressure(self) -> PressureReading | None:
        """The latest barometer sample as pressure and temperature."""
        self._fold()
        if self._baro is None or not math.isfinite(self._baro[1]):
            return None
        alt_amsl_m = self.origin.alt_m + self._baro[1]
        return PressureReading(time_s=self._baro[0], pressure_pa=isa_pressure_pa(alt_amsl_m),
                               temperature_c=isa_temperature_c(alt_amsl_m))

    def vibration(self) -> VibrationLevels | None:
        """ArduPilot's vibration levels and clip count so far."""
        self._fold()
        monitor = self.vibration_monitor
        if not monitor.started:
            return None
        return VibrationLevels(time_s=monitor.time_s, vibration_m_s2=monitor.levels_m_s2,
                               clipping=(monitor.clipped, 0, 0))

    def ekf(self) -> EkfReport | None:
        """The flying estimator's variances and solution flags."""
        ap = self.host.autopilot
        if ap.status is None:
            return EkfReport(flags=_M.EKF_UNINITIALIZED, velocity_variance=math.nan,
                             pos_horiz_variance=math.nan, pos_vert_variance=math.nan,
                             compass_variance=math.nan)
        est = ap.estimator.estimate
        var = np.asarray(est.covariance_diag, dtype=float)
        health = ap.sensor_health
        flags = _solution_flags(est, var, health.position_fix)
        check = ap.estimator.screening.get("mocap_pos")
        if check is not None and check.status == "rejected":
            flags |= _M.EKF_GPS_GLITCHING
        return EkfReport(flags=flags, velocity_variance=float(np.sum(var[VEL])),
                         pos_horiz_variance=float(var[0] + var[1]),
                         pos_vert_variance=float(var[2]),
                         compass_variance=float(var[YAW_INDEX]))

    def secondary(self) -> SecondaryAttitude | None:
        """The TSKF's estimate while the EKF flies (None when the TSKF is the only one)."""
        ap = self.host.autopilot
        if ap.status is None or ap.estimator is ap.tskf:
            return None
        est = ap.tskf.estimate
        return SecondaryAttitude(euler_rad=np.array(est.euler_rad),
                                 pos_ned=np.array(est.pos_ned))

    def nav_controller(self) -> NavControllerReport | None:
        """Where the navigator steers (zeros on the ground, as ArduCopter's)."""
        ap = self.host.autopilot
        status = ap.status
        if status is None:
            return None
        est = status.estimate
        pos = np.asarray(est.pos_ned, dtype=float)
        att = status.attitude_reference
        ref = status.reference
        if att is None or ref is None:
            return NavControllerReport(roll_rad=0.0, pitch_rad=0.0,
                                       bearing_rad=float(est.euler_rad[2]),
                                       target_bearing_rad=math.nan, wp_dist_m=math.nan,
                                       alt_error_m=0.0, xtrack_error_m=0.0)
        bearing = dist = xtrack = math.nan
        ends = ap.navigator.leg_endpoints
        if ends is not None:
            start, target = ends
            dn, de = float(target[0] - pos[0]), float(target[1] - pos[1])
            dist = math.hypot(dn, de)
            bearing = math.atan2(de, dn) if dist > 0.0 else math.nan
            xtrack = _cross_track_m(start, target, pos)
        return NavControllerReport(
            roll_rad=float(att.euler_rad[0]), pitch_rad=float(att.euler_rad[1]),
            bearing_rad=float(ref.yaw_rad), target_bearing_rad=bearing, wp_dist_m=dist,
            alt_error_m=float(pos[2] - ref.pos_ned[2]), xtrack_error_m=xtrack)


def _solution_flags(est: StateEstimate, var: np.ndarray, position_fix: bool) -> int:
    """EKF_STATUS_FLAGS from an estimate and its covariance diagonal (module docstring)."""
    sigma = np.sqrt(np.maximum(var, 0.0))
    state = np.concatenate((est.pos_ned, est.vel_ned, est.euler_rad))
    if not (np.all(np.isfinite(state)) and np.all(np.isfinite(sigma))):
        return 0
    flags = 0
    if max(sigma[EULER][0], sigma[EULER][1]) < ATTITUDE_SIGMA_RAD:
        flags |= _M.EKF_ATTITUDE
    if max(sigma[VEL][0], sigma[VEL][1]) < VELOCITY_SIGMA_M_S:
        flags |= _M.EKF_VELOCITY_HORIZ
    if sigma[VEL][2] < VELOCITY_SIGMA_M_S:
        flags |= _M.EKF_VELOCITY_VERT
    if position_fix and max(sigma[POS][0], sigma[POS][1]) < POSITION_SIGMA_M:
        flags |= _HORIZONTAL_FLAGS
    if sigma[POS][2] < POSITION_SIGMA_M:
        flags |= _M.EKF_POS_VERT_ABS
    if not position_fix:
        flags |= _M.EKF_CONST_POS_MODE
    return int(flags)


def _cross_track_m(start: np.ndarray, target: np.ndarray, pos: np.ndarray) -> float:
    """Horizontal distance (m) of ``pos`` from the line through ``start`` and ``target``
    (from ``start`` itself when the leg does not move horizontally)."""
    ln, le = float(target[0] - start[0]), float(target[1] - start[1])
    pn, pe = float(pos[0] - start[0]), float(pos[1] - start[1])
    length = math.hypot(ln, le)
    if length < 1e-6:
        return math.hypot(pn, pe)
    return abs(ln * pe - le * pn) / length
