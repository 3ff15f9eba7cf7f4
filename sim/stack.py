"""The one tick loop: a simulated world and the autopilot on one simulated clock.

Both composition roots run it: the headless runner (:mod:`sim.runner`) as fast as the CPU
allows, the vehicle process (:mod:`sim.vehicle`) paced against the wall clock with its
MAVLink endpoint serviced between ticks::

    first_tick():  pwm = autopilot.step(0.0, [])                   # boot, before any plant step
    tick():        samples = world.step(pwm, steps_per_tick)       # plant at plant_rate_hz,
                                                                    # power module at 10 Hz
                   pwm     = autopilot.step(world.time_s, samples)  # autopilot at loop_rate_hz

The PWM computed at a tick is held (zero-order hold) over the next ``steps_per_tick`` plant
steps. Commands to the autopilot (arming, modes, missions, parameters) and fault injections
into the world happen between ticks, so a run depends only on the tick at which each arrived.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from fcu.autopilot import Autopilot, AutopilotConfig, AutopilotEvent
from fcu.navigation.navigator import Mode
from sim.world import World, WorldConfig, WorldEvent
from sim.world.fault_types import ActuatorFault, Fault, SensorFault
from sim.world.samples import SensorSample


def steps_per_tick(world: WorldConfig, autopilot: AutopilotConfig) -> int:
    """Plant steps per autopilot tick.

    Raises
    ------
    ValueError
        The autopilot's loop rate does not divide the plant rate.
    """
    plant_hz, loop_hz = world.plant_rate_hz, autopilot.loop_rate_hz
    steps = round(plant_hz / loop_hz)
    if steps < 1 or abs(steps * loop_hz - plant_hz) > 1e-9 * plant_hz:
        raise ValueError(f"autopilot.loop_rate_hz = {loop_hz:g}: must divide the plant rate "
                         f"{plant_hz:g} Hz")
    return steps


class SimulatedStack:
    """A world and an autopilot ticked together (module docstring).

    Parameters
    ----------
    world : WorldConfig
        Airframe, wind, sensors, plant rate.
    autopilot : AutopilotConfig
        The autopilot's configuration.
    seed : int
        Seed of every random stream of the world.
    faults : sequence of Fault
        Scheduled in simulated time before the first tick.

    Attributes
    ----------
    world : World
    autopilot : Autopilot
        May be replaced between ticks (a reconfiguration over MAVLink rebuilds it).
    pwm : ndarray, shape (4,)
        PWM commanded at the last tick, held until the next.
    ticks : int
        Ticks since the boot tick.
    samples : sequence of samples
        The samples the autopilot received at the last tick (the world's batch).
    """

    def __init__(self, world: WorldConfig, autopilot: AutopilotConfig, seed: int,
                 faults: Sequence[Fault] = ()) -> None:
        self.steps_per_tick = steps_per_tick(world, autopilot)
        self.tick_s = 1.0 / autopilot.loop_rate_hz
        self.world = World(world, seed)
        for fault in faults:
            self.world.faults.schedule(fault)
        self.autopilot = Autopilot(autopilot)
        self.pwm = np.zeros(4)
        self.ticks = 0
        self.samples: Sequence[SensorSample] = ()
        self._booted = False

    @property
    def time_s(self) -> float:
        """Simulated time, s."""
        return self.world.time_s

    def first_tick(self) -> None:
        """The boot tick at t = 0, before any plant step (once; later calls do nothing)."""
        if not self._booted:
            self._booted = True
            self.pwm = self.autopilot.step(0.0, [])

    def tick(self) -> None:
        """``steps_per_tick`` plant steps holding the PWM, then one autopilot step."""
        self.samples = samples = self.world.step(self.pwm, self.steps_per_tick)
        self.pwm = self.autopilot.step(self.world.time_s, samples)
        self.ticks += 1

    def drain_events(self) -> tuple[list[AutopilotEvent], list[WorldEvent]]:
        """The autopilot's and the world's events since the previous call, each in order."""
        return self.autopilot.drain_events(), self.world.drain_events()


_WARM_UP_FAULTS = (ActuatorFault(motor=1, kind="loe", loe=0.05, start_s=0.0),
                   SensorFault(sensor="baro", kind="bias", magnitude=0.001, start_s=0.0))


def warm_up(world: WorldConfig, autopilot: AutopilotConfig, seed: int, ticks: int = 50,
            between_ticks: Callable[[], object] | None = None) -> None:
    """Fly a throwaway stack for ``ticks`` ticks (boot, arm, take-off).

    The plant, sensors and estimators are numba code whose first call loads (or compiles)
    machine code: about 0.2 s that would otherwise fall on the first real tick, a glitch in
    a real-time run. The copy has its own world and autopilot, so the real ones are
    untouched (determinism is kept). It flies with a small actuator and a sensor fault, so
    that the fault kernels are loaded (or, on a fresh machine, compiled: seconds) here too and
    not at the first fault of the real flight. ``between_ticks`` is called after each tick
    (the vehicle process answers its ground stations meanwhile).
    """
    stack = SimulatedStack(world, autopilot, seed, faults=_WARM_UP_FAULTS)
    stack.first_tick()
    nav = stack.autopilot.navigator
    nav.set_mode(int(Mode.GUIDED))
    nav.arm()
    nav.takeoff(1.0)
    for _ in range(ticks):
        stack.tick()
        if between_ticks is not None:
            between_ticks()
    stack.world.truth()
    stack.drain_events()
