"""Simulated sensors: truth plus seeded Gaussian noise, then the fault engine.

Each sensor fires on plant steps ``step_index`` with ``step_index % (plant_rate / rate) == 0``
and reports the truth at that step plus white Gaussian noise, passed through
:meth:`sim.world.faults.FaultEngine.corrupt`. Value layouts (docs/design.md, fcu/hal.py):

=============  ============================================  ==============
sensor         value                                         source
=============  ============================================  ==============
``gyro``       body rates p, q, r (FRD), rad/s (3)            state[10:13]
``accel``      specific force (FRD), m/s^2 (3)                given per step
``mocap_pos``  position (NED, home origin), m (3)             state[0:3]
``mocap_att``  roll, pitch, yaw (ZYX Euler), rad (3)          state[6:10]
``baro``       altitude above home (up positive), m (1)       -state[2]
=============  ============================================  ==============

Noise levels (1 sigma, per axis) model indoor flight of a Qball-X4-class vehicle whose
position and attitude come from a motion-capture system; each default is justified at its
field in :class:`SensorConfig`. Noise is pre-drawn in blocks from one generator per sensor
(seeded from the injected generator at construction), so each sensor's noise sequence depends
only on the seed, and :meth:`SensorSuite.reset` replays it from the start.

Two implementations, one state: :meth:`SensorSuite.sample` makes the readings in Python (the
reference) and :func:`sensor_reading` in numba for the world's compiled stepping, with the same
operations in the same order; both take noise rows from :attr:`SensorSuite.kernel_state`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import reduce

import numpy as np
from numba import njit
from numba.extending import register_jitable

from flightdata.config import finite, require
from sim.world.fault_types import SENSOR_AXES, SENSOR_NAMES
from sim.world.faults import FaultEngine
from sim.world.samples import SensorSample

_AXES = tuple(SENSOR_AXES[name] for name in SENSOR_NAMES)  # value length of each sensor
_SIGMA_FIELDS = ("gyro_sigma_rad_s", "accel_sigma_m_s2", "mocap_pos_sigma_m",
                 "mocap_att_sigma_rad", "baro_sigma_m")
_GYRO, _ACCEL, _POS, _ATT, _BARO = range(5)
NOISE_BLOCK = 512  # noise rows pre-drawn per sensor at a time
_MAX_CYCLE = 100_000  # longest due-table (steps); longer cycles test each sensor per step
_NO_SAMPLES: tuple[SensorSample, ...] = ()

SENSOR_STATE = np.dtype([
    ("decimation", np.int64, (5,)),  # -, plant steps between two samples of each sensor
    ("sigma", np.float64, (5,)),  # sensor unit, noise sigma after noise_scale
    ("rows", np.int64, (5,)),  # -, noise rows drawn per sensor (0 before the first draw)
    ("next_row", np.int64, (5,)),  # -, next unused noise row per sensor
    ("noise", np.float64, (5, NOISE_BLOCK, 3)),  # sensor unit, pre-drawn noise, sigma included
], align=True)
"""Decimations, sigmas and pre-drawn noise of the sensor suite (one record)."""


@dataclass(frozen=True, kw_only=True)
class SensorConfig:
    """Rates and noise levels of the simulated sensors (TOML-loadable with ``from_mapping``).

    Every rate must divide the plant rate; that is checked by :class:`SensorSuite`, which
    knows the plant rate.

    Raises
    ------
    ConfigError
        A rate is not > 0, a sigma or ``noise_scale`` is negative or not finite.
    """

    # A MEMS IMU (MPU-6000/ICM-20602 class) read at 250 Hz, a common inner-loop rate.
    gyro_rate_hz: float = 250.0  # Hz
    # Datasheet rate noise density ~0.005 deg/s/sqrt(Hz) over ~125 Hz of bandwidth gives
    # 0.001 rad/s; propeller vibration in flight typically triples it: 0.003 rad/s.
    gyro_sigma_rad_s: float = 0.003  # rad/s, 1 sigma per axis
    accel_rate_hz: float = 250.0  # Hz, same IMU as the gyro
    # Noise density 150-400 ug/sqrt(Hz) over ~100 Hz gives 0.015-0.04 m/s^2; 0.03 sits inside.
    accel_sigma_m_s2: float = 0.03  # m/s^2, 1 sigma per axis
    # Motion capture (OptiTrack/Vicon, as in the Qball-X4 lab) streams at 100 Hz typically.
    mocap_pos_rate_hz: float = 100.0  # Hz
    # Vendors quote sub-millimetre marker jitter in a calibrated volume: 0.5 mm.
    mocap_pos_sigma_m: float = 0.0005  # m, 1 sigma per axis
    mocap_att_rate_hz: float = 100.0  # Hz, same stream as the position
    # 0.5 mm of marker jitter over a ~0.25 m marker baseline: 0.0005 / 0.25 = 0.002 rad.
    mocap_att_sigma_rad: float = 0.002  # rad, 1 sigma per angle
    # A barometer (DPS310/BMP388 class) at 50 Hz in its high-precision oversampling mode.
    baro_rate_hz: float = 50.0  # Hz
    # DPS310 datasheet: pressure precision +-0.002 hPa, i.e. +-0.02 m, indoors (no gusts).
    baro_sigma_m: float = 0.02  # m, 1 sigma
    # Multiplies every sigma; 0 switches noise off (a test setting, never the default).
    noise_scale: float = 1.0  # -

    def __post_init__(self) -> None:
        for name, sigma_field in zip(SENSOR_NAMES, _SIGMA_FIELDS, strict=True):
            key = f"{name}_rate_hz"
            rate = getattr(self, key)
            require(finite(rate) and rate > 0.0, key, rate, "must be a rate > 0 Hz")
            sigma = getattr(self, sigma_field)
            require(finite(sigma) and sigma >= 0.0, sigma_field, sigma,
                    "must be a finite standard deviation >= 0")
        require(finite(self.noise_scale) and self.noise_scale >= 0.0, "noise_scale",
                self.noise_scale, "must be a finite factor >= 0 (0 = noise off)")

    def rate_hz(self, sensor: str) -> float:
        """Sample rate of ``sensor``, Hz."""
        return float(getattr(self, f"{sensor}_rate_hz"))

    def sigma(self, sensor: str) -> float:
        """Nominal noise sigma of ``sensor`` (its unit), before ``noise_scale``."""
        return float(getattr(self, _SIGMA_FIELDS[SENSOR_NAMES.index(sensor)]))


def quat_to_euler_zyx(q_wxyz: np.ndarray) -> tuple[float, float, float]:
    """ZYX Euler angles of a quaternion (docs/design.md: R = Rz(yaw) Ry(pitch) Rx(roll)).

    Parameters
    ----------
    q_wxyz : numpy.ndarray, shape (4,)
        Attitude quaternion [w, x, y, z], body FRD to NED; normalised here.

    Returns
    -------
    tuple of float
        (roll, pitch, yaw), rad; roll and yaw in [-pi, pi], pitch in [-pi/2, pi/2].
    """
    w, x, y, z = np.asarray(q_wxyz, dtype=float).tolist()
    return _euler_zyx(w, x, y, z)


def _euler_zyx(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """:func:`quat_to_euler_zyx` on four floats (the sampling hot path)."""
    n2 = w * w + x * x + y * y + z * z
    if n2 != 1.0:
        inv = 1.0 / math.sqrt(n2)
        w, x, y, z = w * inv, x * inv, y * inv, z * inv
    # R[2,1] = 2(yz + wx), R[2,2] = 1 - 2(x^2 + y^2): roll = atan2(R21, R22)
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    # R[2,0] = 2(xz - wy) = -sin(pitch)
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - x * z))))
    # R[1,0] = 2(xy + wz), R[0,0] = 1 - 2(y^2 + z^2): yaw = atan2(R10, R00)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


@register_jitable
def _fold_past_pi(angle: float) -> float:
    """Bring an angle pushed just past +-pi by noise back into [-pi, pi] (exact otherwise,
    unlike ``(a + pi) % (2 pi) - pi``, which rounds; the Python and compiled sensors)."""
    if angle > math.pi:
        return angle - 2.0 * math.pi
    if angle < -math.pi:
        return angle + 2.0 * math.pi
    return angle


class SensorSuite:
    """All sensors of the vehicle, sampled on the plant's step grid.

    Parameters
    ----------
    config : SensorConfig
        Rates and noise levels.
    plant_rate_hz : float
        Plant step rate, Hz; every sensor rate must divide it.
    rng : numpy.random.Generator
        Seeds one noise generator per sensor at construction (five integer draws).
    faults : sim.world.faults.FaultEngine
        Applies the active sensor faults to each noisy reading.

    Attributes
    ----------
    kernel_state : numpy.ndarray
        One :data:`SENSOR_STATE` record: decimations, sigmas and the pre-drawn noise with the
        next row of each sensor. :meth:`sample` (Python) and :func:`sensor_reading` (numba,
        the world's compiled stepping) take noise rows from it in the same order.

    Raises
    ------
    ConfigError
        ``plant_rate_hz`` is not > 0, or a sensor rate does not divide it.
    """

    def __init__(self, config: SensorConfig, plant_rate_hz: float, rng: np.random.Generator,
                 faults: FaultEngine) -> None:
        require(finite(plant_rate_hz) and plant_rate_hz > 0.0, "plant_rate_hz", plant_rate_hz,
                "must be a rate > 0 Hz")
        self._config = config
        self._plant_rate_hz = float(plant_rate_hz)
        self._faults = faults
        decimations = []
        for name in SENSOR_NAMES:
            rate = config.rate_hz(name)
            ratio = plant_rate_hz / rate
            steps = round(ratio)
            require(steps >= 1 and abs(ratio - steps) <= 1e-9 * ratio, f"{name}_rate_hz", rate,
                    f"must divide the plant rate {plant_rate_hz:g} Hz into a whole number of "
                    f"steps (e.g. {', '.join(_divisor_rates(plant_rate_hz))} Hz)")
            decimations.append(steps)
        self._decimation = tuple(decimations)
        cycle = reduce(math.lcm, decimations)
        if cycle <= _MAX_CYCLE:
            self._cycle = cycle
            self._due: tuple[tuple[int, ...], ...] = tuple(
                tuple(i for i, d in enumerate(decimations) if k % d == 0) for k in range(cycle))
        else:  # pathological rates: no table, test every sensor each step
            self._cycle = 1
            self._due = ((-1,),)
        scale = config.noise_scale
        self._sigma = tuple(config.sigma(name) * scale for name in SENSOR_NAMES)
        self._seeds = tuple(int(s) for s in rng.integers(0, 2**63 - 1, size=len(SENSOR_NAMES)))
        self.kernel_state = np.zeros(1, dtype=SENSOR_STATE)
        self._s = self.kernel_state[0]  # a view: writes go to the array
        self._s["decimation"] = decimations
        self._s["sigma"] = self._sigma
        self._noise = self.kernel_state["noise"][0]  # (5, NOISE_BLOCK, 3) view
        self._rows = self.kernel_state["rows"][0]  # (5,) view
        self._next_row = self.kernel_state["next_row"][0]  # (5,) view
        self.reset()

    @property
    def config(self) -> SensorConfig:
        """The configuration the suite was built with."""
        return self._config

    def decimation(self, sensor: str) -> int:
        """Plant steps between two samples of ``sensor``."""
        return self._decimation[SENSOR_NAMES.index(sensor)]

    def reset(self) -> None:
        """Rewind every noise generator to its state at construction."""
        self._rngs = [np.random.default_rng(s) for s in self._seeds]
        self._rows[:] = 0
        self._next_row[:] = 0

    def draw_noise(self, i: int) -> None:
        """Pre-draw the next block of noise rows of sensor ``i`` (zeros when sigma is 0) and
        start at its first row; the only draw site of the sensor noise."""
        n = _AXES[i]
        if self._sigma[i] > 0.0:
            self._noise[i, :, :n] = self._rngs[i].standard_normal((NOISE_BLOCK, n)) * self._sigma[i]
        else:
            self._noise[i] = 0.0  # adding +0.0 leaves the truth exact
        self._rows[i] = NOISE_BLOCK
        self._next_row[i] = 0

    def refill(self) -> None:
        """Draw the next block of every sensor whose rows are used up (the world's compiled
        stepping asks for this before a step that needs a row it does not have)."""
        for i in range(len(SENSOR_NAMES)):
            if self._next_row[i] >= self._rows[i]:
                self.draw_noise(i)

    def sample(self, step_index: int, time_s: float, state: np.ndarray,
               specific_force_frd: np.ndarray) -> Sequence[SensorSample]:
        """Samples due at plant step ``step_index``.

        Parameters
        ----------
        step_index : int
            Plant step counter (>= 0); a sensor fires when it is a multiple of its decimation.
        time_s : float
            Simulated time of the step, s; becomes each sample's ``time_s``.
        state : numpy.ndarray, shape (17,)
            True plant state (docs/design.md): pos_ned, vel_ned, quat wxyz, rate_frd, thrust_n.
        specific_force_frd : numpy.ndarray, shape (3,)
            True specific force (non-gravitational acceleration) in FRD, m/s^2.

        Returns
        -------
        Sequence of SensorSample
            A tuple in :data:`SENSOR_NAMES` order; a shared empty tuple when nothing is due.
        """
        due = self._due[step_index % self._cycle]
        if not due:
            return _NO_SAMPLES
        if due[0] < 0:
            due = tuple(i for i, d in enumerate(self._decimation) if step_index % d == 0)
            if not due:
                return _NO_SAMPLES
        xs = state.tolist()
        samples = []
        for i in due:
            if self._next_row[i] >= self._rows[i]:
                self.draw_noise(i)
            pos = int(self._next_row[i])
            r = self._noise[i, pos].tolist()
            self._next_row[i] = pos + 1
            if i == _GYRO:
                reading = np.array((xs[10] + r[0], xs[11] + r[1], xs[12] + r[2]))
            elif i == _ACCEL:
                f0, f1, f2 = specific_force_frd.tolist()
                reading = np.array((f0 + r[0], f1 + r[1], f2 + r[2]))
            elif i == _POS:
                reading = np.array((xs[0] + r[0], xs[1] + r[1], xs[2] + r[2]))
            elif i == _ATT:
                roll, pitch, yaw = _euler_zyx(xs[6], xs[7], xs[8], xs[9])
                reading = np.array((_fold_past_pi(roll + r[0]), pitch + r[1],
                                    _fold_past_pi(yaw + r[2])))
            else:
                reading = np.array((-xs[2] + r[0],))  # altitude = -z_ned
            name = SENSOR_NAMES[i]
            value = self._faults.corrupt(name, time_s, reading, self._sigma[i])
            samples.append(SensorSample(name, time_s, value))
        return tuple(samples)


_euler_zyx_compiled = njit(cache=True)(_euler_zyx)


@njit(cache=True)
def sensor_due(sensors: np.ndarray, i: int, step_index: int) -> bool:
    """True when sensor ``i`` fires at plant step ``step_index`` (a multiple of its
    decimation), as :meth:`SensorSuite.sample` decides."""
    return step_index % sensors[0].decimation[i] == 0


@njit(cache=True)
def noise_ready(sensors: np.ndarray, i: int) -> bool:
    """True when sensor ``i`` has a pre-drawn noise row left (else call
    :meth:`SensorSuite.refill`)."""
    s = sensors[0]
    return s.next_row[i] < s.rows[i]


@njit(cache=True)
def sensor_reading(sensors: np.ndarray, i: int, x: np.ndarray, specific_force: np.ndarray,
                   out: np.ndarray) -> None:
    """The noisy reading of sensor ``i`` (before faults) into ``out``, as
    :meth:`SensorSuite.sample` makes it: truth (module docstring table) plus the sensor's
    next noise row, which it consumes (:func:`noise_ready` must hold).

    Parameters
    ----------
    sensors : numpy.ndarray
        One :data:`SENSOR_STATE` record (``SensorSuite.kernel_state``).
    i : int
        Sensor index into :data:`SENSOR_NAMES`.
    x : numpy.ndarray
        True plant state, shape (17,).
    specific_force : numpy.ndarray
        True specific force in FRD, m/s^2, shape (3,).
    out : numpy.ndarray
        Receives the reading's elements (3, or 1 for the barometer), sensor unit.
    """
    s = sensors[0]
    r = s.noise[i, s.next_row[i]]
    s.next_row[i] += 1
    if i == _GYRO:  # body rates p, q, r + noise
        out[0], out[1], out[2] = x[10] + r[0], x[11] + r[1], x[12] + r[2]
    elif i == _ACCEL:  # specific force + noise
        f = specific_force
        out[0], out[1], out[2] = f[0] + r[0], f[1] + r[1], f[2] + r[2]
    elif i == _POS:  # NED position + noise
        out[0], out[1], out[2] = x[0] + r[0], x[1] + r[1], x[2] + r[2]
    elif i == _ATT:  # ZYX Euler angles + noise, roll and yaw wrapped into [-pi, pi]
        roll, pitch, yaw = _euler_zyx_compiled(x[6], x[7], x[8], x[9])
        out[0] = _fold_past_pi(roll + r[0])
        out[1] = pitch + r[1]
        out[2] = _fold_past_pi(yaw + r[2])
    else:
        out[0] = -x[2] + r[0]  # altitude = -z_ned


def _divisor_rates(plant_rate_hz: float) -> list[str]:
    """A few rates that divide the plant rate, for error messages."""
    return [f"{plant_rate_hz / d:g}" for d in (1, 2, 4, 5, 10)]


__all__ = ["NOISE_BLOCK", "SENSOR_STATE", "SensorConfig", "SensorSuite", "noise_ready",
           "quat_to_euler_zyx", "sensor_due", "sensor_reading"]
