"""The simulated world: airframe, rigid body, motors, wind, sensors and the fault engine.

Nothing here knows the autopilot (tests/test_import_boundaries.py): the world takes motor
PWM and gives sensor samples, truth and events. :class:`World` (``sim/world/world.py``) is the
one way to step it; its samples come as a :class:`SampleBatch` of :class:`SensorSample`.
"""

from sim.world.samples import SampleBatch, SensorSample
from sim.world.world import PlantEvent, Truth, World, WorldConfig, WorldEvent

__all__ = ["PlantEvent", "SampleBatch", "SensorSample", "Truth", "World", "WorldConfig",
           "WorldEvent"]
