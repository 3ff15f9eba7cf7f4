"""The one way to step the simulated world: motor PWM in; sensor samples, truth and events out.

A :class:`World` owns the rigid-body plant, the Dryden wind, the sensor suite and the fault
engine, and advances them together on the plant's fixed step. The headless scenario runner
and the MAVLink vehicle process both drive it; it knows nothing about the autopilot.

Per plant step ``k`` (time ``t_k = k dt``)::

    u_eff = faults.actuator_inputs(t_k, u_cmd)          # LOE, lock, float, hard-over
    m     = faults.mass_kg(t_k)                         # structural failure
    wind  = dryden.step(altitude, airspeed)             # held over the step
    x     = plant.step(u_eff, wind, m)                  # RK4 + ground contact
    samples += sensors.sample(k + 1, t_{k+1}, x, f_b)   # those due at t_{k+1}

Randomness: one seed makes a :class:`numpy.random.SeedSequence` whose children feed the wind,
the sensors and the fault engine separately, so that (for example) turning turbulence off
does not change the sensor noise sequence.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from flightdata.config import finite, require
from sim.world.airframe import Airframe
from sim.world.dynamics import (
    _STEPS_CONTACT,
    POS_NED,
    QUAT_WXYZ,
    RATE_FRD,
    STATE_SIZE,
    THRUST_N,
    VEL_NED,
    RigidBodyPlant,
    _plant_steps,
    pack_params,
    quat_to_euler,
    specific_force_frd,
)
from sim.world.faults import FaultEngine, FaultEvent
from sim.world.sensors import _AXES, SENSOR_NAMES, SensorConfig, SensorSample, SensorSuite
from sim.world.wind import DrydenWind, WindConfig


@dataclass(frozen=True, kw_only=True)
class WorldConfig:
    """Everything that defines a simulated world except the seed."""

    plant_rate_hz: float = 500.0  # Hz, fixed RK4 step rate (>= 500)
    airframe: Airframe = field(default_factory=Airframe)
    wind: WindConfig = field(default_factory=WindConfig)
    sensors: SensorConfig = field(default_factory=SensorConfig)

    def __post_init__(self) -> None:
        require(finite(self.plant_rate_hz) and 500.0 <= self.plant_rate_hz <= 20000.0,
                "plant_rate_hz", self.plant_rate_hz, "must be within [500, 20000] Hz")


@dataclass(frozen=True)
class Truth:
    """The true state of the vehicle at one instant (for logs and SIM_STATE, never the FCU)."""

    time_s: float  # s, simulated
    pos_ned: np.ndarray  # m, (3,)
    vel_ned: np.ndarray  # m/s, (3,)
    quat_wxyz: np.ndarray  # -, (4,)
    euler_rad: np.ndarray  # rad, roll pitch yaw (3,)
    rate_frd: np.ndarray  # rad/s, (3,)
    thrust_n: np.ndarray  # N, motors 1..4
    accel_frd: np.ndarray  # m/s^2, specific force (what an ideal accelerometer reads)
    wind_ned: np.ndarray  # m/s, wind velocity over the last step
    mass_kg: float  # kg
    pwm_effective: np.ndarray  # PWM the motors saw over the last step (after faults)
    loe_true: np.ndarray  # injected loss of effectiveness per motor (NaN: lock/hard-over)
    on_ground: bool
    crashed: bool


@dataclass(frozen=True, slots=True)
class PlantEvent:
    """A change of the plant's contact state (touchdown, lift-off, crash)."""

    time_s: float
    kind: str  # "touchdown" | "liftoff" | "crash"
    description: str


WorldEvent = FaultEvent | PlantEvent


# ---- compiled stepping ------------------------------------------------------------------
# The loop of World.step costs ~8 us of Python per plant step. On the usual steps (no fault
# starts or ends, no time-varying actuator fault, the wind inside its cache band, noise at
# hand) World._steps_compiled takes several steps in three compiled calls, each in the module
# that owns the maths (the wind's recursion, the plant steps, the sensor readings), with the
# same operations in the same order; every other step goes through the Python loop. Sensor
# readings are corrupted by the fault engine and wrapped into samples afterwards, in their
# original order (corruption never feeds back into the plant within a call).


class World:
    """Plant, wind, sensors and faults stepped together.

    Parameters
    ----------
    config : WorldConfig
        Airframe, wind, sensors and plant rate.
    seed : int
        Seed of every random stream of the world (>= 0).
    """

    def __init__(self, config: WorldConfig, seed: int) -> None:
        require(isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0, "seed",
                seed, "must be an integer >= 0")
        self.config = config
        self.seed = seed
        self.dt_s = 1.0 / config.plant_rate_hz
        self._params = pack_params(config.airframe)
        self.plant = RigidBodyPlant(config.airframe, self.dt_s)
        self._build_random_parts()

    def _build_random_parts(self) -> None:
        wind_ss, sensor_ss, fault_ss = np.random.SeedSequence(self.seed).spawn(3)
        self.faults = FaultEngine(np.random.default_rng(fault_ss), self.config.airframe.pwm_max,
                                  self.config.airframe.mass)
        self.wind = DrydenWind(self.config.wind, self.dt_s, np.random.default_rng(wind_ss))
        self._wind_seed = wind_ss
        self.sensors = SensorSuite(self.config.sensors, self.config.plant_rate_hz,
                                   np.random.default_rng(sensor_ss), self.faults)
        self._accel_every = self.sensors.decimation("accel")
        self._steps = 0
        self._wind_ned = self.wind.mean_ned_m_s.copy()
        self._pwm_effective = np.zeros(4)
        self._specific_force = np.zeros(3)
        self._events: list[PlantEvent] = []
        self._was_on_ground = self.plant.on_ground
        self._was_crashed = False

    def reset(self, *, pos_ned: Sequence[float] = (0.0, 0.0, 0.0), yaw_rad: float = 0.0) -> None:
        """Start again at time 0 on (or above) ``pos_ned``: same seed, same run."""
        self.plant.reset(pos_ned=pos_ned, yaw_rad=yaw_rad)
        self._build_random_parts()

    def set_wind(self, config: WindConfig) -> None:
        """Replace the wind model from now on (its random stream continues from the seed)."""
        self.wind = DrydenWind(config, self.dt_s,
                               np.random.default_rng(self._wind_seed.spawn(1)[0]))

    # ------------------------------------------------------------------ stepping
    @property
    def time_s(self) -> float:
        """Simulated time, s."""
        return self._steps * self.dt_s

    @property
    def step_count(self) -> int:
        """Plant steps taken since reset."""
        return self._steps

    def step(self, pwm_cmd: np.ndarray, n_steps: int = 1) -> list[SensorSample]:
        """Advance ``n_steps`` plant steps holding ``pwm_cmd``; return the samples produced.

        Parameters
        ----------
        pwm_cmd : numpy.ndarray, shape (4,)
            Commanded PWM of motors 1..4, held over all the steps (zero-order hold).
        n_steps : int
            Plant steps to take.
        """
        pwm = np.asarray(pwm_cmd, dtype=np.float64)
        if pwm.shape != (4,):
            raise ValueError(f"pwm_cmd shape {pwm.shape}: want (4,), motors 1..4")
        samples: list[SensorSample] = []
        done = 0
        while done < n_steps:
            steps = self._steps_compiled(pwm, n_steps - done, samples)
            done += steps
            if done < n_steps and steps == 0:  # the next step needs the Python objects
                self._steps_python(pwm, 1, samples)
                done += 1
        return samples

    def _steps_compiled(self, pwm: np.ndarray, n_steps: int,
                        samples: list[SensorSample]) -> int:
        """As many of the next ``n_steps`` steps as the compiled path can take (comment at
        the top of the section); returns how many were taken (0: the next needs Python)."""
        faults, wind, sensors, plant = self.faults, self.wind, self.sensors, self.plant
        mode, gains, mass, next_change_s = faults._stepping_state()
        step0, dt = self._steps, self.dt_s
        if mode == 2 or not step0 * dt < next_change_s:
            return 0
        n = sensors._compiled_steps_available(step0, n_steps)
        if n == 0:
            return 0
        # the winds these steps would see without a retune (the plant steps check the band)
        winds, wind_x, n = wind._preview(n)
        if n == 0:
            return 0
        check_band, band = wind._cache_band
        u_eff = pwm if mode == 0 else pwm * gains
        x, params, flags, work = plant._stepping_state()
        states = np.empty((n, STATE_SIZE))
        forces = np.empty((n, 3))
        steps, why = _plant_steps(
            n, step0, dt, next_change_s, x, u_eff, mass, params, flags, work,
            self._was_on_ground, self._was_crashed, check_band, band, winds, self._wind_ned,
            self._accel_every, self._specific_force, states, forces)
        if steps == 0:
            return 0
        plant._count_steps(steps)
        wind._accept(steps, wind_x, n)
        self._steps += steps
        self._wind_ned = winds[steps - 1].copy()
        self._pwm_effective = u_eff
        # the readings (sensors.sample's), then the fault engine, in their original order
        readings, sensor, step = sensors._compiled_readings(step0, states, forces, steps)
        sigma = sensors._sigma_vec
        for j, (i, k) in enumerate(zip(sensor, step, strict=True)):
            name, time_s = SENSOR_NAMES[i], k * dt
            value = faults.corrupt(name, time_s, readings[j, :_AXES[i]].copy(), sigma[i])
            samples.append(SensorSample(name, time_s, value))
        if not step or step[-1] != self._steps:
            faults._set_clock((self._steps - 1) * dt)  # as mass_kg() at the last step
        if why == _STEPS_CONTACT:
            self._contact_changed()
        return steps

    def _steps_python(self, pwm: np.ndarray, n_steps: int, samples: list[SensorSample]) -> None:
        """``n_steps`` steps of the loop of :meth:`step`, one object call at a time."""
        plant, faults, wind, sensors = self.plant, self.faults, self.wind, self.sensors
        x = plant.state
        dt = self.dt_s
        params = self._params
        for _ in range(n_steps):
            t = self._steps * dt
            # (4,) float64 from the fault engine, a mass > 0 (checked when faults are
            # scheduled), a (3,) wind: the plant's per-step input checks are not needed
            u_eff = faults.actuator_inputs(t, pwm)
            mass = faults.mass_kg(t)
            wind_prev = self._wind_ned
            airspeed = math.hypot(x.item(3) - wind_prev.item(0), x.item(4) - wind_prev.item(1))
            wind_ned = wind.step(-x.item(2), airspeed)
            plant._step_checked(u_eff, wind_ned, mass)
            self._steps += 1
            k = self._steps
            if k % self._accel_every == 0:
                self._specific_force = specific_force_frd(x, wind_ned, mass, params)
            due = sensors.sample(k, k * dt, x, self._specific_force)
            if due:
                samples.extend(due)
            self._wind_ned = wind_ned
            self._pwm_effective = u_eff
            if plant.on_ground != self._was_on_ground or plant.crashed != self._was_crashed:
                self._contact_changed()

    def _contact_changed(self) -> None:
        t = self.time_s
        if self.plant.crashed and not self._was_crashed:
            speed = self.plant.touchdown_speed_m_s or 0.0
            self._events.append(PlantEvent(t, "crash", f"crash: touchdown at {speed:.2f} m/s"))
        elif self.plant.on_ground and not self._was_on_ground:
            speed = self.plant.touchdown_speed_m_s or 0.0
            self._events.append(PlantEvent(t, "touchdown", f"touchdown at {speed:.2f} m/s"))
        elif not self.plant.on_ground and self._was_on_ground:
            self._events.append(PlantEvent(t, "liftoff", "lift-off"))
        self._was_on_ground = self.plant.on_ground
        self._was_crashed = self.plant.crashed

    @property
    def wind_ned(self) -> np.ndarray:
        """Wind velocity over the last step, NED, m/s (a live array: copy to keep)."""
        return self._wind_ned

    def drain_events(self) -> list[WorldEvent]:
        """Fault and contact events since the previous call, in time order."""
        events: list[WorldEvent] = [*self.faults.drain_events(), *self._events]
        self._events = []
        events.sort(key=lambda e: e.time_s)
        return events

    # ------------------------------------------------------------------ observation
    def truth(self) -> Truth:
        """A snapshot of the true state (copies; safe to keep)."""
        x = self.plant.state
        t = self.time_s
        mass = self.faults.mass_kg(t)
        quat = np.array(x[QUAT_WXYZ])
        return Truth(
            time_s=t,
            pos_ned=np.array(x[POS_NED]),
            vel_ned=np.array(x[VEL_NED]),
            quat_wxyz=quat,
            euler_rad=np.asarray(quat_to_euler(quat)),
            rate_frd=np.array(x[RATE_FRD]),
            thrust_n=np.array(x[THRUST_N]),
            accel_frd=np.asarray(specific_force_frd(x, self._wind_ned, mass, self._params)),
            wind_ned=np.array(self._wind_ned),
            mass_kg=mass,
            pwm_effective=np.array(self._pwm_effective),
            loe_true=self.faults.true_loe(t),
            on_ground=self.plant.on_ground,
            crashed=self.plant.crashed,
        )
