"""The one way to step the simulated world: motor PWM in; sensor samples, truth and events out.

A :class:`World` owns the rigid-body plant, the Dryden wind, the sensor suite and the fault
engine, and advances them together on the plant's fixed step. The headless scenario runner
and the MAVLink vehicle process both drive it; it knows nothing about the autopilot.

Per plant step ``k`` (time ``t_k = k dt``)::

    u_eff = faults.actuator_inputs(t_k, u_cmd)          # LOE, lock, float, hard-over
    m     = faults.mass_kg(t_k)                         # structural failure
    wind  = dryden.step(altitude, airspeed)             # held over the step
    x     = plant.step(u_eff, wind, m)                  # RK4 + ground contact
    f_b   = specific_force(x, wind, m)                  # every accel_every steps
    samples += sensors.sample(k + 1, t_{k+1}, x, f_b)   # those due at t_{k+1}, then faults

and once per :meth:`World.step` call the battery discharges at the motors' thrust and its
power module's readings due follow the sensors' in the batch (:mod:`sim.world.battery`,
compiled in both ways of stepping).

Two ways to take a step, one state
----------------------------------
That loop, written with the parts' Python methods, is the reference (``World._step_python``;
the fault engine's methods apply the compiled fault rules of :mod:`sim.world.fault_kernels`,
the one implementation of each).
:func:`sim.world.stepping.world_steps` runs the same loop compiled, on the parts' state
records (``kernel_state`` of the plant, the wind, the sensors and the fault engine, plus the
world's own :data:`sim.world.stepping.WORLD_STATE`): the same operations in the same order,
so the same numbers. It stops before a step it cannot take (a fault starting or ending, a
wind rediscretisation) and the world takes that one in Python, or before one that needs
random numbers not drawn yet, which the world draws from the same generators before calling
it again. ``World(config, seed, stepping="python")`` takes every step in Python;
``tests/sim/world/test_world_stepping.py`` checks that both give the same samples, truth and
events bit for bit.

Randomness: one seed makes a :class:`numpy.random.SeedSequence` whose children feed the wind,
the sensors and the fault engine separately, so that (for example) turning turbulence off
does not change the sensor noise sequence.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from flightdata.config import finite, require
from jitsupport.cache import preload_blas_bindings
from jitsupport.calls import KernelCall
from sim.world.airframe import Airframe
from sim.world.battery import Battery, BatteryConfig
from sim.world.dynamics import (
    POS_NED,
    QUAT_WXYZ,
    RATE_FRD,
    THRUST_N,
    VEL_NED,
    RigidBodyPlant,
    specific_force_frd,
)
from sim.world.fault_types import SENSOR_NAMES, FaultEvent
from sim.world.faults import FaultEngine
from sim.world.rotations import quat_to_euler
from sim.world.samples import SAMPLE_RECORD, SampleBatch
from sim.world.sensors import SensorConfig, SensorSuite
from sim.world.stepping import STOP_CONTACT, STOP_DONE, STOP_DRAW, WORLD_STATE, world_steps
from sim.world.wind import DrydenWind, WindConfig


@dataclass(frozen=True, kw_only=True)
class WorldConfig:
    """Everything that defines a simulated world except the seed."""

    plant_rate_hz: float = 500.0  # Hz, fixed RK4 step rate (>= 500)
    airframe: Airframe = field(default_factory=Airframe)
    wind: WindConfig = field(default_factory=WindConfig)
    sensors: SensorConfig = field(default_factory=SensorConfig)
    battery: BatteryConfig = field(default_factory=BatteryConfig)

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
    speed_m_s: float = 0.0  # m/s, speed at the contact instant (touchdown and crash)


WorldEvent = FaultEvent | PlantEvent


def _event_time_s(event: WorldEvent) -> float:
    """The sort key of :meth:`World.drain_events`, s."""
    return event.time_s


_FLOAT64 = np.dtype(np.float64)
_N_SENSORS = len(SENSOR_NAMES)  # at most one reading per sensor and step
_SENSOR_INDEX = {name: i for i, name in enumerate(SENSOR_NAMES)}
_world_steps = KernelCall(world_steps)  # (its arguments: the parts' records, pwm checked)
_SAMPLE_BUFFER = 4096  # readings per sample buffer (about 800 calls of 5 steps)


class World:
    """Plant, wind, sensors and faults stepped together.

    Parameters
    ----------
    config : WorldConfig
        Airframe, wind, sensors and plant rate.
    seed : int
        Seed of every random stream of the world (>= 0).
    stepping : {"compiled", "python"}
        ``"compiled"`` (default) takes steps in :func:`sim.world.stepping.world_steps`
        wherever it can; ``"python"`` takes every step with the parts' Python methods (the
        reference; several times slower). Both give the same numbers.

    Attributes
    ----------
    plant : RigidBodyPlant
    wind : DrydenWind
        Replaced by :meth:`set_wind`.
    sensors : SensorSuite
    battery : Battery
        The flight battery, stepped once per :meth:`step` call; its power-module samples
        end the call's batch.
    faults : FaultEngine
        Schedule, apply and clear faults here (between steps).
    kernel_state : numpy.ndarray
        The world's own :data:`sim.world.stepping.WORLD_STATE` record (step count, the wind
        and effective PWM of the last step, the specific force, the contact last reported).
    """

    def __init__(self, config: WorldConfig, seed: int, *,
                 stepping: Literal["compiled", "python"] = "compiled") -> None:
        require(isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0, "seed",
                seed, "must be an integer >= 0")
        require(stepping in ("compiled", "python"), "stepping", stepping,
                "must be 'compiled' or 'python'")
        preload_blas_bindings()  # before the first kernel loads: no scipy.linalg for numba
        self.config = config
        self.seed = seed
        self.stepping = stepping
        self.dt_s = 1.0 / config.plant_rate_hz
        self.plant = RigidBodyPlant(config.airframe, self.dt_s)
        self._thrust_n = self.plant.state[THRUST_N]  # (4,) live view (the battery's load)
        self._params = self.plant.kernel_state["params"][0]
        self.kernel_state = np.zeros(1, dtype=WORLD_STATE)
        self._w = self.kernel_state[0]  # a view: writes go to the array
        self._wind_ned = self.kernel_state["wind_ned"][0]  # (3,) views
        self._pwm_effective = self.kernel_state["pwm_effective"][0]
        self._specific_force = self.kernel_state["specific_force"][0]
        self._steps = self.kernel_state["steps"]  # (1,) views
        self._was_on_ground = self.kernel_state["was_on_ground"]
        self._was_crashed = self.kernel_state["was_crashed"]
        self._samples_used = 0  # readings in the sample buffer
        self._new_sample_buffer(0)
        self._build_random_parts()

    def _build_random_parts(self) -> None:
        # a fourth child for the battery: the first three are those of spawn(3), as before
        wind_ss, sensor_ss, fault_ss, battery_ss = np.random.SeedSequence(self.seed).spawn(4)
        self.battery = Battery(self.config.battery, np.random.default_rng(battery_ss))
        self.faults = FaultEngine(np.random.default_rng(fault_ss), self.config.airframe.pwm_max,
                                  self.config.airframe.mass)
        self.wind = DrydenWind(self.config.wind, self.dt_s, np.random.default_rng(wind_ss))
        self._wind_seed = wind_ss
        self.sensors = SensorSuite(self.config.sensors, self.config.plant_rate_hz,
                                   np.random.default_rng(sensor_ss), self.faults)
        self.kernel_state[0] = np.zeros((), dtype=WORLD_STATE)
        self._w["dt_s"] = self.dt_s
        self._accel_every = self.sensors.decimation("accel")
        self._w["accel_every"] = self._accel_every
        self._wind_ned[:] = self.wind.mean_ned_m_s
        self._w["was_on_ground"] = self.plant.on_ground
        self._events: list[PlantEvent] = []
        # power-module readings a call of n steps can hold: n * this, plus 2
        self._battery_per_step = self.dt_s * self.config.battery.monitor_rate_hz

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
        return self._steps.item(0) * self.dt_s  # (step_count * dt_s, read thrice a tick)

    @property
    def step_count(self) -> int:
        """Plant steps taken since reset."""
        return int(self._steps[0])

    def step(self, pwm_cmd: np.ndarray, n_steps: int = 1) -> SampleBatch:
        """Advance ``n_steps`` plant steps holding ``pwm_cmd``; return the samples produced.

        Parameters
        ----------
        pwm_cmd : numpy.ndarray, shape (4,)
            Commanded PWM of motors 1..4, held over all the steps (zero-order hold).
        n_steps : int
            Plant steps to take.

        Returns
        -------
        SampleBatch
            The readings, in the order taken, then the power module's: a sequence of
            ``SensorSample`` whose values are read-only views of the batch's arrays
            (:mod:`sim.world.samples`).
        """
        pwm = pwm_cmd
        if not (pwm.__class__ is np.ndarray and pwm.dtype == _FLOAT64 and pwm.shape == (4,)
                and pwm.flags.c_contiguous):  # (the compiled steps' argument type)
            pwm = np.ascontiguousarray(pwm_cmd, dtype=np.float64)  # (itself when it is one)
            if pwm.shape != (4,):
                raise ValueError(f"pwm_cmd shape {pwm.shape}: want (4,), motors 1..4")
        first = m = self._samples_used
        room = _N_SENSORS * n_steps + int(n_steps * self._battery_per_step) + 2
        if first + room > self._samples.shape[0]:
            self._new_sample_buffer(room)
            first = m = 0
        if self.stepping == "python":
            for _ in range(n_steps):
                m = self._step_python(pwm, m)
        else:
            m = self._steps_compiled(pwm, n_steps, m)
        m = self.battery.step_into(self.time_s, n_steps * self.dt_s, self._thrust_n,
                                   self._samples, m)
        self._samples_used = m
        return SampleBatch.wrap(self._samples_read_only[first:m])

    def _steps_compiled(self, pwm: np.ndarray, n_steps: int, m: int) -> int:
        """``n_steps`` steps, in :func:`sim.world.stepping.world_steps` wherever it can take
        them (module docstring); readings go to the sample buffer from index ``m``; returns
        the new count."""
        done = 0
        drew = False  # numbers were just drawn for the step the kernel stopped before
        while done < n_steps:
            faults = self.faults.arrays
            steps, m, why = _world_steps.call(
                n_steps - done, pwm, self.kernel_state, self.plant.kernel_state,
                self.wind.kernel_state, self.sensors.kernel_state, faults.state, faults.table,
                faults.pool, self._samples, m)
            done += steps
            if why == STOP_CONTACT:  # the last step touched down, lifted off or crashed
                self._contact_changed()
            elif why == STOP_DRAW and not (drew and steps == 0):
                self.wind.refill()  # each draws only what is used up or asked for
                self.sensors.refill()
                self.faults.refill_draws()
                drew = True
                continue
            elif why != STOP_DONE:  # STOP_PYTHON (or draws that did not help): in Python
                m = self._step_python(pwm, m)
                done += 1
            drew = False
        return m

    def _new_sample_buffer(self, room: int) -> None:
        """Start a new buffer of readings (at least ``room``); batches already returned keep
        theirs (views)."""
        self._samples = np.empty(max(_SAMPLE_BUFFER, room), dtype=SAMPLE_RECORD)
        self._samples_read_only = self._samples.view()
        self._samples_read_only.flags.writeable = False
        self._sample_columns = (self._samples["sensor"], self._samples["time_s"],
                                self._samples["value"])
        self._samples_used = 0

    def _step_python(self, pwm: np.ndarray, m: int) -> int:
        """One step of the loop in the module docstring with the parts' Python methods (the
        reference); its readings go to the sample buffer from index ``m``; returns the new
        count."""
        plant, faults, wind, sensors = self.plant, self.faults, self.wind, self.sensors
        x = plant.state
        dt = self.dt_s
        k = int(self._steps[0])
        t = k * dt
        # (4,) float64 from the fault engine, a mass > 0 (checked when faults are
        # scheduled), a (3,) wind: the plant's per-step input checks are not needed
        u_eff = faults.actuator_inputs(t, pwm)
        mass = faults.mass_kg(t)
        wind_prev = self._wind_ned
        airspeed = math.hypot(x.item(3) - wind_prev.item(0), x.item(4) - wind_prev.item(1))
        wind_ned = wind.step(-x.item(2), airspeed)
        plant.step_unchecked(u_eff, wind_ned, mass)
        k += 1
        self._steps[0] = k
        if k % self._accel_every == 0:
            self._specific_force[:] = specific_force_frd(x, wind_ned, mass, self._params)
        sensor_index, time_s, values = self._sample_columns
        for sample in sensors.sample(k, k * dt, x, self._specific_force):
            sensor_index[m] = _SENSOR_INDEX[sample.sensor]
            time_s[m] = sample.time_s
            n = sample.value.shape[0]
            values[m, :n] = sample.value
            values[m, n:] = 0.0
            m += 1
        self._wind_ned[:] = wind_ned
        self._pwm_effective[:] = u_eff
        if plant.on_ground != self._was_on_ground[0] or plant.crashed != self._was_crashed[0]:
            self._contact_changed()
        return m

    def _contact_changed(self) -> None:
        t = self.time_s
        was_on_ground, was_crashed = bool(self._w["was_on_ground"]), bool(self._w["was_crashed"])
        if self.plant.crashed and not was_crashed:
            speed = self.plant.touchdown_speed_m_s or 0.0
            self._events.append(PlantEvent(t, "crash", f"crash: touchdown at {speed:.2f} m/s",
                                           speed))
        elif self.plant.on_ground and not was_on_ground:
            speed = self.plant.touchdown_speed_m_s or 0.0
            self._events.append(PlantEvent(t, "touchdown", f"touchdown at {speed:.2f} m/s",
                                           speed))
        elif not self.plant.on_ground and was_on_ground:
            self._events.append(PlantEvent(t, "liftoff", "lift-off"))
        self._w["was_on_ground"] = self.plant.on_ground
        self._w["was_crashed"] = self.plant.crashed

    @property
    def wind_ned(self) -> np.ndarray:
        """Wind velocity over the last step, NED, m/s (a live array: copy to keep)."""
        return self._wind_ned

    def drain_events(self) -> list[WorldEvent]:
        """Fault and contact events since the previous call, in time order."""
        events: list[WorldEvent] = self.faults.drain_events()  # type: ignore[assignment]
        if self._events:  # (most ticks have none: then the fault events as they are)
            events = [*events, *self._events]
            self._events = []
        if len(events) > 1:
            events.sort(key=_event_time_s)
        return events

    # ------------------------------------------------------------------ observation
    def truth(self) -> Truth:
        """A snapshot of the true state (copies; safe to keep)."""
        x = self.plant.state
        t = self.time_s
        mass = self.faults.mass_kg(t)
        pos, vel, quat, rate, accel, wind = self._motion(mass)
        return Truth(
            time_s=t,
            pos_ned=pos,
            vel_ned=vel,
            quat_wxyz=quat,
            euler_rad=np.asarray(quat_to_euler(quat)),
            rate_frd=rate,
            thrust_n=np.array(x[THRUST_N]),
            accel_frd=accel,
            wind_ned=wind,
            mass_kg=mass,
            pwm_effective=np.array(self._pwm_effective),
            loe_true=self.faults.true_loe(t),
            on_ground=self.plant.on_ground,
            crashed=self.plant.crashed,
        )

    def motor_thrust_n(self) -> np.ndarray:
        """Thrust of motors 1..4 now, N (a copy; what the ESCs' report derives from)."""
        return np.array(self._thrust_n)

    def motion_truth(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                    np.ndarray]:
        """Position, velocity, quaternion, body rates, specific force and wind of
        :meth:`truth` (the same copies, the same numbers), without the rest: what a
        SIM_STATE and a WIND message read, at a third of the cost.

        Returns
        -------
        pos_ned, vel_ned, quat_wxyz, rate_frd, accel_frd, wind_ned : numpy.ndarray
            Shapes (3,), (3,), (4,), (3,), (3,), (3,); units as in :class:`Truth`.
        """
        return self._motion(self.faults.mass_kg(self.time_s))

    def _motion(self, mass_kg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                np.ndarray, np.ndarray]:
        x = self.plant.state
        return (x[POS_NED].copy(), x[VEL_NED].copy(), x[QUAT_WXYZ].copy(), x[RATE_FRD].copy(),
                np.asarray(specific_force_frd(x, self._wind_ned, mass_kg, self._params)),
                self._wind_ned.copy())
