"""The world's compiled step: plant, wind, sensors and faults advanced together in numba.

:func:`world_steps` does, step after step, what :meth:`sim.world.World` does in Python (the
reference, ``World._step_python``), calling each part's compiled function on the part's own
state record, with the same operations in the same order::

    u_eff = apply_actuator_faults(faults, t_k, u_cmd)      # fault_kernels: LOE, lock, ...
    m     = faults.mass_kg                                 # structural faults
    wind  = dryden_step(wind)                              # wind: held over the step
    x     = plant_step(plant, u_eff, wind, m)              # dynamics: RK4 + ground contact
    f     = specific_force(x, wind, m)   every accel_every steps
    for each sensor due at k + 1:                          # sensors, then fault_kernels
        sample = corrupt_reading(faults, sensor_reading(sensors, x, f), t_{k+1})

It takes a step only when the whole step can be done here; otherwise it stops *before* the
step and says why (:data:`STOP_PYTHON`, :data:`STOP_DRAW`), and the world takes over:

* a fault starts or ends at or before the step's readings (``t_{k+1} >= next_change_s``):
  only the Python engine starts and ends faults, so the world takes that step in Python;
* turbulence is on and the altitude or airspeed left the wind's cache band
  (:func:`sim.world.wind.dryden_ready`): a rediscretisation, which needs scipy's matrix
  exponential, so a Python step;
* a block of pre-drawn random numbers is used up (wind normals, sensor noise, a fault's
  draws): the world draws more from the same generator (:data:`STOP_DRAW`) and calls again.

After a step that changed the ground contact it stops (:data:`STOP_CONTACT`) so that the world
records the event at that step's time.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from jitsupport.cache import drop_stale_kernels
from sim.world.dynamics import plant_step, specific_force_into
from sim.world.fault_kernels import (
    actuator_draws_ready,
    apply_actuator_faults,
    corrupt_reading,
    sensor_draws_ready,
)
from sim.world.fault_types import SENSOR_AXES, SENSOR_NAMES
from sim.world.sensors import noise_ready, sensor_due, sensor_reading
from sim.world.wind import WIND_READY, WIND_RETUNE, dryden_ready, dryden_step

drop_stale_kernels(__file__)  # the world step compiles in dynamics, sensors, wind, faults

STOP_DONE = 0  # all the steps asked for were taken
STOP_CONTACT = 1  # the last step taken changed the ground contact (touchdown, lift-off, crash)
STOP_PYTHON = 2  # the next step must be taken in Python (a fault change, a wind retune)
STOP_DRAW = 3  # the next step needs random numbers not drawn yet

WORLD_STATE = np.dtype([
    ("steps", np.int64),  # -, plant steps since reset; the world's time is steps * dt_s
    ("dt_s", np.float64),  # s, plant step
    ("accel_every", np.int64),  # -, plant steps between accelerometer samples
    ("wind_ned", np.float64, (3,)),  # m/s, wind over the last step
    ("pwm_effective", np.float64, (4,)),  # PWM the motors saw over the last step (after faults)
    ("specific_force", np.float64, (3,)),  # m/s^2 FRD, at the last accelerometer step
    ("was_on_ground", np.bool_),  # ground contact as last reported in an event
    ("was_crashed", np.bool_),  # crash as last reported in an event
], align=True)
"""What the world itself keeps between steps (one record, ``World.kernel_state``)."""

_AXES = np.array([SENSOR_AXES[name] for name in SENSOR_NAMES], dtype=np.int64)
_N_SENSORS = len(SENSOR_NAMES)


@njit(cache=True, error_model="numpy")
def _why_not(world: np.ndarray, plant: np.ndarray, wind: np.ndarray, sensors: np.ndarray,
             faults: np.ndarray, table: np.ndarray) -> int:
    """STOP_DONE when the next step can be taken here, else why not (module docstring)."""
    w, x = world[0], plant[0].x
    k = w.steps
    if not (k + 1) * w.dt_s < faults[0].next_change_s:
        return STOP_PYTHON  # a fault starts or ends before the step's readings
    # the altitude and the horizontal airspeed over the previous wind, as World._step_python
    airspeed = math.hypot(x[3] - w.wind_ned[0], x[4] - w.wind_ned[1])
    wind_ready = dryden_ready(wind, -x[2], airspeed)
    if wind_ready != WIND_READY:
        return STOP_PYTHON if wind_ready == WIND_RETUNE else STOP_DRAW
    if not actuator_draws_ready(faults, table, k * w.dt_s):
        return STOP_DRAW
    for i in range(_N_SENSORS):
        if sensor_due(sensors, i, k + 1) and not (
                noise_ready(sensors, i) and sensor_draws_ready(faults, table, i, _AXES[i])):
            return STOP_DRAW
    return STOP_DONE


@njit(cache=True, error_model="numpy")
def world_steps(n_steps: int, pwm_cmd: np.ndarray, world: np.ndarray, plant: np.ndarray,
                wind: np.ndarray, sensors: np.ndarray, faults: np.ndarray, table: np.ndarray,
                pool: np.ndarray, samples: np.ndarray, n_samples: int) -> tuple[int, int, int]:
    """Up to ``n_steps`` world steps holding ``pwm_cmd`` (module docstring).

    Parameters
    ----------
    n_steps : int
        Steps to take.
    pwm_cmd : numpy.ndarray
        Commanded PWM of motors 1..4, shape (4,), held (zero-order hold).
    world, plant, wind, sensors, faults : numpy.ndarray
        The state records of the world (:data:`WORLD_STATE`), the plant
        (``RigidBodyPlant.kernel_state``), the wind (``DrydenWind.kernel_state``), the sensors
        (``SensorSuite.kernel_state``) and the fault engine (``FaultEngine.arrays.state``),
        advanced in place.
    table, pool : numpy.ndarray
        The fault engine's ``arrays.table`` and ``arrays.pool``.
    samples : numpy.ndarray
        :data:`sim.world.samples.SAMPLE_RECORD` array receiving the readings from index
        ``n_samples`` on; room for one per sensor and step.
    n_samples : int
        Readings already in ``samples``.

    Returns
    -------
    tuple of int
        ``(steps_taken, n_samples, why)``: why is one of the ``STOP_*`` codes.
    """
    w, s, f = world[0], plant[0], faults[0]
    x, params = s.x[:], s.params[:]
    dt = w.dt_s
    m = n_samples
    for j in range(n_steps):
        why = _why_not(world, plant, wind, sensors, faults, table)
        if why != STOP_DONE:
            return j, m, why
        k = w.steps
        t = k * dt
        # actuator faults at t_k, then the structural mass (the engine's clock reads t_k)
        # (the record's arrays passed as plain views, ``[:]``: the kernels they go to are
        # compiled once, for the plain arrays the Python path passes too)
        apply_actuator_faults(faults, table, pool, t, pwm_cmd, w.pwm_effective[:])
        mass = f.mass_kg
        f.clock_s = t
        # the wind held over the step (inside its band, checked above), then the plant
        dryden_step(wind, w.wind_ned)
        plant_step(plant, w.pwm_effective[:], w.wind_ned[:], mass)
        k += 1
        w.steps = k
        if k % w.accel_every == 0:
            specific_force_into(x, w.wind_ned[:], mass, params, w.specific_force[:])
        # the readings due at t_{k+1}: truth + noise, then the sensor faults
        t_next = k * dt
        for i in range(_N_SENSORS):
            if not sensor_due(sensors, i, k):
                continue
            rec = samples[m]
            value = rec.value
            value[0] = value[1] = value[2] = 0.0
            reading = value[:_AXES[i]]
            sensor_reading(sensors, i, x, w.specific_force, reading)
            corrupt_reading(faults, table, pool, i, t_next, reading, sensors[0].sigma[i])
            rec.sensor = i
            rec.time_s = t_next
            f.clock_s = t_next
            m += 1
        if s.on_ground != w.was_on_ground or s.crashed != w.was_crashed:
            return j + 1, m, STOP_CONTACT
    return n_steps, m, STOP_DONE
