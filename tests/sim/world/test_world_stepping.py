"""The world's compiled steps against its Python reference steps, bit for bit.

``World(config, seed)`` takes its steps in :func:`sim.world.stepping.world_steps` wherever it
can; ``World(config, seed, stepping="python")`` takes every step with the parts' Python
methods. Seeded flights drive both with the same commands (a simple controller on the true
state) and must give the same samples, truth and events to the last bit: through ground
contact, lift-off, touchdown and crash; turbulence on and off and wind changes; actuator
faults of every kind and LOE profile; sensor faults of every kind on one axis and on all;
a structural mass loss; faults starting, ending, injected and cleared between and inside
calls of uneven length.

The fault engine applies its rules with the compiled kernels of :mod:`sim.world.fault_kernels`
in both ways of stepping, so the Python world here applies the independent Python reference
of the rules instead (``fault_rules_reference.py``): a wrong kernel shows as a difference.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
import pytest
from fault_rules_reference import use_reference_rules

from jitsupport.calls import KernelCall
from sim.world import Truth, World, WorldConfig
from sim.world import world as world_module
from sim.world.fault_types import ActuatorFault, SensorFault, StructuralFault
from sim.world.faults import FaultEngine
from sim.world.samples import SampleBatch, SensorSample
from sim.world.sensors import SensorConfig
from sim.world.stepping import STOP_CONTACT, STOP_DONE, STOP_DRAW, STOP_PYTHON
from sim.world.wind import WindConfig

LIGHT = WindConfig(mean_speed_m_s=0.3, mean_from_deg=270.0, turbulence="light", w20_m_s=1.5)
CALL_STEPS = (5, 5, 1, 7, 5, 13, 2, 5)  # plant steps per World.step call, cycled
G = 9.81  # m/s^2


# ---- a controller on the true state (the same commands reach both worlds) ------------------
def hover_controller(truth: Truth, target_ned: tuple[float, float, float],
                     world: World) -> np.ndarray:
    """PWM that flies the vehicle towards ``target_ned`` (PD on position and attitude, the
    inverse of the mixer of eq. 3.17). Crude but steady enough to lift off, hover, translate
    and land."""
    af = world.config.airframe
    pos, vel = truth.pos_ned, truth.vel_ned
    roll, pitch, yaw = truth.euler_rad.tolist()
    a = [4.0 * (target_ned[i] - pos[i]) - 3.0 * vel[i] for i in range(3)]  # m/s^2, NED
    a[0], a[1] = max(-3.0, min(3.0, a[0])), max(-3.0, min(3.0, a[1]))
    thrust = truth.mass_kg * (G - a[2]) / max(0.5, math.cos(roll) * math.cos(pitch))
    c, s = math.cos(yaw), math.sin(yaw)
    pitch_cmd = -(c * a[0] + s * a[1]) / G  # nose down to go forward
    roll_cmd = (-s * a[0] + c * a[1]) / G  # right side down to go right
    ixx, iyy, izz = af.inertia
    p, q, r = truth.rate_frd.tolist()
    tau = (ixx * (20.0 * (roll_cmd - roll) - 6.0 * p),
           iyy * (20.0 * (pitch_cmd - pitch) - 6.0 * q),
           izz * (4.0 * (0.0 - yaw) - 2.0 * r))
    arm, kpsi = af.arm_length, af.yaw_gain
    t1 = thrust / 4 + tau[1] / (2 * arm) + tau[2] / (4 * kpsi)
    t2 = thrust / 4 - tau[1] / (2 * arm) + tau[2] / (4 * kpsi)
    t3 = thrust / 4 + tau[0] / (2 * arm) - tau[2] / (4 * kpsi)
    t4 = thrust / 4 - tau[0] / (2 * arm) - tau[2] / (4 * kpsi)
    return np.array([t1, t2, t3, t4]) / af.thrust_gain


# ---- seeded flights ----------------------------------------------------------------------
Action = Callable[[World], None]


@dataclass
class Flight:
    """A scripted flight: world, faults, between-call actions and the target over time."""

    config: WorldConfig
    seed: int
    duration_s: float
    target: Callable[[float], tuple[float, float, float] | None]  # None: motors off
    faults: list[Any] = field(default_factory=list)
    actions: dict[float, Action] = field(default_factory=dict)  # s -> action, first call after


def _thesis_like_flight() -> Flight:
    def target(t: float) -> tuple[float, float, float] | None:
        if t < 0.6 or 7.0 <= t < 7.4 or t >= 9.4:
            return None  # idle on the ground; motors cut for a fall from 5 m at 9.4 s
        if t < 3.5:
            return (0.0, 0.0, -1.0)  # lift off, hover at 1 m
        if t < 5.0:
            return (1.5, -1.0, -1.0)  # translate: the airspeed and the wind's band change
        if t < 7.0:
            return (1.5, -1.0, min(0.3, -1.0 + 0.6 * (t - 5.0)))  # descend and touch down
        return (1.5, -1.0, -5.0)  # climb above the wind's 10 ft altitude floor

    def clear_last_step_loe(world: World) -> None:
        for s in world.faults.scheduled():
            if isinstance(s.fault, ActuatorFault) and s.fault.motor == 4 \
                    and s.fault.profile == "step":
                world.faults.clear(s.fault_id)

    af = ActuatorFault
    sf = SensorFault
    faults = [
        # actuator faults: every kind and LOE profile; starts off the step grid; overlaps
        af(motor=1, kind="loe", loe=0.2, start_s=1.2011, end_s=2.5),
        af(motor=2, kind="loe", loe=0.3, profile="sinusoid", period_s=1.0, start_s=1.3,
           end_s=3.0),
        af(motor=3, kind="loe", loe=0.25, profile="pulse", period_s=0.4, pulse_width_s=0.1,
           start_s=1.4, end_s=2.9),
        af(motor=4, kind="loe", loe=0.3, profile="random", low=0.05, hold_s=0.02,
           start_s=1.5, end_s=4.5),  # 150 gammas: more than one block of draws
        af(motor=1, kind="loe", loe=0.15, start_s=2.0, end_s=3.1),  # multiplies with both
        af(motor=1, kind="total_loss", start_s=3.0, end_s=3.03),
        af(motor=2, kind="lock", start_s=3.1, end_s=3.25),
        af(motor=2, kind="hardover", start_s=3.15, end_s=3.2),  # wins over the lock, then not
        af(motor=3, kind="float", start_s=3.3, end_s=3.33),
        af(motor=4, kind="loe", loe=0.1, start_s=6.0),  # until cleared at 6.7 s
        # sensor faults: every kind, one axis and all
        sf(sensor="mocap_att", kind="freeze", start_s=0.0, end_s=0.3),  # from the first reading
        sf(sensor="baro", kind="loss_of_accuracy", axis=0, magnitude=100.0, start_s=0.2),
        sf(sensor="gyro", kind="bias", axis=1, magnitude=0.01, start_s=0.5, end_s=5.0),
        sf(sensor="accel", kind="drift", magnitude=0.02, rate=0.01, start_s=1.0, end_s=6.0),
        sf(sensor="mocap_pos", kind="loss_of_accuracy", magnitude=200.0, start_s=1.0,
           end_s=9.0),
        sf(sensor="accel", kind="bias", axis=2, magnitude=-0.5, start_s=2.0, end_s=2.1),
        sf(sensor="gyro", kind="calibration", axis=2, start_s=2.2, end_s=2.8),
        sf(sensor="gyro", kind="freeze", start_s=2.5, end_s=2.6),  # holds calibration garbage
        sf(sensor="mocap_att", kind="calibration", low=-0.1, high=0.1, start_s=4.0,
           end_s=4.2),
        sf(sensor="baro", kind="freeze", start_s=7.0, end_s=7.5),
        StructuralFault(mass_loss_kg=0.3, start_s=3.5),
    ]
    actions: dict[float, Action] = {
        2.0: lambda w: w.faults.apply_now(
            SensorFault(sensor="baro", kind="bias", magnitude=0.05, end_s=1.0), w.time_s),
        2.7: lambda w: w.faults.apply_now(
            ActuatorFault(motor=3, kind="loe", loe=0.1, end_s=0.0105), w.time_s),
        4.0: lambda w: w.set_wind(WindConfig(mean_speed_m_s=1.0, mean_from_deg=90.0,
                                             turbulence="none")),
        5.0: lambda w: w.set_wind(WindConfig(mean_speed_m_s=0.5, turbulence="moderate")),
        6.3: clear_last_step_loe,
        9.0: lambda w: w.faults.clear_matching("sensors"),
    }
    return Flight(WorldConfig(wind=LIGHT), seed=7, duration_s=11.0, target=target,
                  faults=faults, actions=actions)


def _odd_rates_flight() -> Flight:
    """Sensor rates whose due pattern repeats only every 323323 steps (no due table in
    Python), noise off, no turbulence; a short hop with faults."""
    rate = 20000.0
    sensors = SensorConfig(gyro_rate_hz=rate / 7, accel_rate_hz=rate / 11,
                           mocap_pos_rate_hz=rate / 13, mocap_att_rate_hz=rate / 17,
                           baro_rate_hz=rate / 19, noise_scale=0.0)
    config = WorldConfig(plant_rate_hz=rate, sensors=sensors,
                         wind=WindConfig(turbulence="none", mean_speed_m_s=0.5))
    faults = [ActuatorFault(motor=2, kind="loe", loe=0.2, start_s=0.3, end_s=0.6),
              SensorFault(sensor="baro", kind="drift", rate=0.5, start_s=0.2),
              SensorFault(sensor="gyro", kind="loss_of_accuracy", magnitude=50.0,
                          start_s=0.1)]  # sigma 0: adds 0 * z, still draws
    return Flight(config, seed=3, duration_s=0.8, faults=faults,
                  target=lambda t: None if t < 0.1 else (0.0, 0.0, -0.5))


FLIGHTS = {"thesis_like": _thesis_like_flight, "odd_rates": _odd_rates_flight}


def _bits(values: Iterable[float]) -> list[int]:
    """The IEEE 754 bit patterns of ``values`` (so that -0.0 != 0.0 and NaN == NaN)."""
    return np.asarray(list(values), dtype=np.float64).view(np.uint64).tolist()


def _truth_bits(truth: Truth) -> list[int]:
    parts = [np.atleast_1d(np.asarray(getattr(truth, f.name), dtype=np.float64))
             for f in fields(truth)]
    return _bits(np.concatenate(parts))


def fly(flight: Flight, make_world: Callable[[WorldConfig, int], World]) -> list[Any]:
    """Fly ``flight``; returns what the world gave, call by call, as exact bit patterns."""
    world = make_world(flight.config, flight.seed)
    for fault in flight.faults:
        world.faults.schedule(fault)
    actions = sorted(flight.actions.items())
    out: list[Any] = []
    n_calls = 0
    while world.time_s < flight.duration_s:
        t = world.time_s
        while actions and actions[0][0] <= t:
            actions.pop(0)[1](world)
        target = flight.target(t)
        pwm = np.zeros(4) if target is None else hover_controller(world.truth(), target, world)
        n = CALL_STEPS[n_calls % len(CALL_STEPS)]
        n_calls += 1
        samples = world.step(pwm, n)
        out.append([(s.sensor, *_bits([s.time_s, *np.asarray(s.value).tolist()]))
                    for s in samples])
        out.append(_truth_bits(world.truth()))
        out.append([(e.time_s, type(e).__name__, e.description) for e in world.drain_events()])
    out.append(world.faults.clock_s)
    return out


def _compiled(config: WorldConfig, seed: int) -> World:
    return World(config, seed)


def _python(config: WorldConfig, seed: int) -> World:
    """The Python steps, the faults applied by the Python reference rules."""
    world = World(config, seed, stepping="python")
    use_reference_rules(world.faults)  # (the sensors call the same engine object)
    return world


def _python_kernels(config: WorldConfig, seed: int) -> World:
    """The Python steps, the faults applied by the engine itself (its kernels from Python)."""
    return World(config, seed, stepping="python")


@pytest.fixture
def count_stops(monkeypatch: pytest.MonkeyPatch) -> Counter[int]:
    """Count the compiled kernel's stop reasons, and its steps under key -1 (so that a
    flight that never reached the compiled path, where the comparison is empty, fails)."""
    real = world_module.world_steps
    stops: Counter[int] = Counter()

    def counting(*args: Any) -> tuple[int, int, int]:
        steps, m, why = real(*args)
        stops[why] += 1
        stops[-1] += steps  # compiled steps
        return steps, m, why

    monkeypatch.setattr(world_module, "_world_steps", KernelCall(counting))
    return stops


@pytest.mark.parametrize("name", list(FLIGHTS))
def test_compiled_steps_equal_python_steps_bit_for_bit(name: str,
                                                       count_stops: Counter[int]) -> None:
    flight = FLIGHTS[name]()
    compiled = fly(flight, _compiled)
    compiled_steps = count_stops[-1]
    python = fly(flight, _python)
    assert len(compiled) == len(python)
    for i, (a, b) in enumerate(zip(compiled, python, strict=True)):
        assert a == b, f"{name}: first difference in record {i} (call {i // 3})"
    # most steps were compiled: the comparison above compared something
    total = round(flight.duration_s * flight.config.plant_rate_hz)
    assert compiled_steps > 0.7 * total


def test_python_steps_with_the_engines_kernels_equal_the_compiled_steps() -> None:
    """``World(stepping="python")`` as the product has it: the engine calls its kernels from
    Python (their draws, held values and last readings kept across the two paths)."""
    flight = _thesis_like_flight()
    assert fly(flight, _python_kernels) == fly(flight, _compiled)


def test_the_thesis_like_flight_reaches_every_branch(count_stops: Counter[int]) -> None:
    events = [e for call in fly(_thesis_like_flight(), _compiled)[2:-1:3] for e in call]
    plant = Counter(e[2].split(" at ")[0] for e in events if e[1] == "PlantEvent")
    assert plant == {"lift-off": 2, "touchdown": 1, "crash: touchdown": 1}
    descriptions = " | ".join(e[2] for e in events)
    for text in ("loses 0.3 kg", "freeze", "calibration error", "loss of accuracy", "bias",
                 "drift", "lock", "hardover", "float", "total loss", "(random",
                 "(sinusoid)", "(pulse)", "(step)"):
        assert text in descriptions, text
    assert all(count_stops[why] > 0 for why in (STOP_DONE, STOP_CONTACT, STOP_PYTHON,
                                                STOP_DRAW))


# ---- the fault rules, compiled against Python, one call at a time ------------------------
def _engine_pair() -> tuple[FaultEngine, FaultEngine]:
    a, b = (FaultEngine(np.random.default_rng(11), 0.05, 1.42) for _ in range(2))
    for eng in (a, b):
        eng.schedule(ActuatorFault(motor=1, kind="loe", loe=0.4, profile="random",
                                   hold_s=0.01, low=0.1))
        eng.schedule(ActuatorFault(motor=2, kind="lock", start_s=0.05))
        eng.schedule(ActuatorFault(motor=2, kind="loe", loe=0.3, profile="sinusoid",
                                   period_s=0.3))
        eng.schedule(ActuatorFault(motor=3, kind="loe", loe=0.2, profile="pulse", period_s=0.1,
                                   pulse_width_s=0.03))
        eng.schedule(ActuatorFault(motor=3, kind="loe", loe=0.1, start_s=0.2))
        eng.schedule(ActuatorFault(motor=3, kind="hardover", start_s=0.4, end_s=0.5))
        eng.schedule(ActuatorFault(motor=4, kind="float", start_s=0.1, end_s=0.3))
        eng.schedule(ActuatorFault(motor=4, kind="total_loss", start_s=0.2))
        eng.schedule(SensorFault(sensor="gyro", kind="loss_of_accuracy", magnitude=150.0))
        eng.schedule(SensorFault(sensor="gyro", kind="calibration", axis=1, start_s=0.1))
        eng.schedule(SensorFault(sensor="gyro", kind="freeze", start_s=0.3, end_s=0.35))
        eng.schedule(SensorFault(sensor="baro", kind="drift", magnitude=0.1, rate=0.2))
        eng.schedule(SensorFault(sensor="baro", kind="bias", magnitude=0.05, start_s=0.6))
        eng.schedule(SensorFault(sensor="baro", kind="freeze", start_s=0.7))
    return a, b


def test_fault_kernels_equal_the_python_reference_rules() -> None:
    """The Python reference rules on one engine, the engine's own (its compiled kernels) on a
    twin, call by call: every actuator and sensor fault kind and LOE profile, overrides over
    effectiveness faults, draws running out and refilled."""
    ref, eng = _engine_pair()
    use_reference_rules(ref)
    rng = np.random.default_rng(0)
    sigma = 0.003
    for k in range(400):
        t = k / 500.0
        u = rng.uniform(0.0, 0.05, 4)
        assert _bits(eng.actuator_inputs(t, u)) == _bits(ref.actuator_inputs(t, u)), t
        assert _bits(eng.true_loe_values(t)) == _bits(ref.true_loe_values(t)), t
        reading = rng.normal(0.0, sigma, 3)
        assert _bits(eng.corrupt("gyro", t, reading, sigma)) == \
            _bits(ref.corrupt("gyro", t, reading, sigma)), t
        alt = rng.normal(1.0, 0.02, 1)
        assert _bits(eng.corrupt("baro", t, alt, 0.02)) == _bits(ref.corrupt("baro", t, alt, 0.02))
    np.testing.assert_array_equal(eng.arrays.pool, ref.arrays.pool)  # the same draws


# ---- the sample batch ---------------------------------------------------------------------
def test_sample_batch_is_a_sequence_of_samples_with_array_views() -> None:
    world = World(WorldConfig(), seed=1)
    batch = world.step(np.zeros(4), 10)
    assert isinstance(batch, SampleBatch)
    samples = list(batch)
    # 250, 250, 100, 100, 50 Hz, and the power module's first reading (10 Hz, t = 0)
    assert len(samples) == len(batch) == 5 + 5 + 2 + 2 + 1 + 1
    ga, mocap = ["gyro", "accel"], ["mocap_pos", "mocap_att"]
    # by step (2, 4, 5, 6, 8, 10), then in SENSOR_NAMES order; the power module last
    assert [s.sensor for s in samples] == ga * 2 + mocap + ga * 3 + mocap + ["baro", "battery"]
    assert all(isinstance(s, SensorSample) for s in samples)
    assert batch[-2].sensor == "baro" and batch[-2].value.shape == (1,)
    assert batch[-1].value.shape == (2,) and batch[-1].time_s == world.time_s
    assert batch[0].value.dtype == np.float64 and batch[0].value.ndim == 1
    np.testing.assert_array_equal(batch.time_s, [s.time_s for s in samples])
    np.testing.assert_array_equal(batch.values[0], samples[0].value)
    with pytest.raises(ValueError):
        samples[0].value[0] = 1.0  # read-only: the batch's memory
    again = SampleBatch.from_samples(samples)
    assert _bits(again.records["value"].ravel()) == _bits(batch.records["value"].ravel())
    assert [(s.sensor, s.time_s) for s in batch[2:4]] == [(s.sensor, s.time_s)
                                                          for s in samples[2:4]]
