"""The autopilot's MAVLink endpoint (ArduCopter dialect, MAVLink 2).

Modules, one job each:

- :mod:`~fcu.mavlink.port`: what the endpoint needs from the vehicle (``VehiclePort``,
  ``VehicleSnapshot``, ``FailureInjector``, ``ParamProvider``) in SI units and NED.
- :mod:`~fcu.mavlink.enums`: the MAVLink numbers it speaks in (``MavState``, ``Severity``,
  ``FailureUnit``, ``FailureType``); flight modes are the navigator's
  (:class:`fcu.navigation.modes.Mode`, ArduCopter's numbers).
- :mod:`~fcu.mavlink.codec`: the dialect choice, packing and per-datagram parsing.
- :mod:`~fcu.mavlink.geo`: local NED <-> latitude/longitude/altitude.
- :mod:`~fcu.mavlink.messages`: telemetry and reply messages from a snapshot (unit edge).
- :mod:`~fcu.mavlink.streams`: telemetry scheduling (simulated time, wall-clock heartbeat).
- :mod:`~fcu.mavlink.params`: parameter table and protocol.
- :mod:`~fcu.mavlink.mission`: mission protocol (ArduPilot flavour).
- :mod:`~fcu.mavlink.commands`: COMMAND_LONG/INT, SET_MODE, GUIDED set-points.
- :mod:`~fcu.mavlink.failsafe`: GCS heartbeat-loss failsafe.
- :mod:`~fcu.mavlink.signing`: MAVLink 2 signing (SETUP_SIGNING, signed output, checks of
  what arrives, the SIGN_REJ count).
- :mod:`~fcu.mavlink.link`, :mod:`~fcu.mavlink.udp`: transport.
- :mod:`~fcu.mavlink.endpoint`: ``MavlinkEndpoint``, what a composition root drives.
"""

from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.endpoint_config import EndpointConfig, EndpointStats
from fcu.mavlink.enums import FailureType, FailureUnit, MavState, Severity
from fcu.mavlink.port import (
    AttitudeTarget,
    BatteryState,
    CommandResult,
    FailureInjector,
    GeoPoint,
    LandedState,
    MissionItem,
    MissionItemReached,
    MissionState,
    ParamProvider,
    ParamSpec,
    PositionTarget,
    SensorHealth,
    SimTruth,
    StatusText,
    VehicleEvent,
    VehiclePort,
    VehicleSnapshot,
)
from fcu.mavlink.udp import UdpLink

__all__ = [
    "AttitudeTarget",
    "BatteryState",
    "CommandResult",
    "EndpointConfig",
    "EndpointStats",
    "FailureInjector",
    "FailureType",
    "FailureUnit",
    "GeoPoint",
    "LandedState",
    "MavState",
    "MavlinkEndpoint",
    "MissionItem",
    "MissionItemReached",
    "MissionState",
    "ParamProvider",
    "ParamSpec",
    "PositionTarget",
    "SensorHealth",
    "Severity",
    "SimTruth",
    "StatusText",
    "UdpLink",
    "VehicleEvent",
    "VehiclePort",
    "VehicleSnapshot",
]
