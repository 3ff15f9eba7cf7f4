"""The autopilot's MAVLink endpoint (ArduCopter dialect, MAVLink 2).

Modules, one job each:

- :mod:`~fcu.mavlink.port`: what the endpoint needs from the vehicle (``VehiclePort``,
  ``FailureInjector``, ``ParamProvider``) in SI units and NED;
  :mod:`~fcu.mavlink.port_records`: the records crossing it (``VehicleSnapshot``,
  ``CommandResult``, set-points, mission items, parameter specs, events).
- :mod:`~fcu.mavlink.enums`: the MAVLink numbers it speaks in (``MavState``, ``Severity``,
  ``FailureUnit``, ``FailureType``); flight modes are the navigator's
  (:class:`fcu.navigation.modes.Mode`, ArduCopter's numbers).
- :mod:`~fcu.mavlink.codec`: the dialect choice, packing and per-datagram parsing.
- :mod:`~fcu.mavlink.geo`: local NED <-> latitude/longitude/altitude.
- :mod:`~fcu.mavlink.messages`: telemetry and reply messages from a snapshot (unit edge).
- :mod:`~fcu.mavlink.streams`: telemetry scheduling (simulated time, wall-clock heartbeat).
- :mod:`~fcu.mavlink.params`: parameter table and protocol.
- :mod:`~fcu.mavlink.mission`: mission protocol (ArduPilot flavour);
  :mod:`~fcu.mavlink.mission_items`: its items, their checks and conversions.
- :mod:`~fcu.mavlink.commands`: COMMAND_LONG/INT, SET_MODE, GUIDED set-points.
- :mod:`~fcu.mavlink.failsafe`: GCS heartbeat-loss failsafe.
- :mod:`~fcu.mavlink.manual_input`: MANUAL_CONTROL and RC_CHANNELS_OVERRIDE as sticks, and
  the RC failsafe.
- :mod:`~fcu.mavlink.ftp`: MAVLink FTP answered at once (no file server).
- :mod:`~fcu.mavlink.signing`: MAVLink 2 signing (SETUP_SIGNING, signed output, checks of
  what arrives, the SIGN_REJ count).
- :mod:`~fcu.mavlink.link`, :mod:`~fcu.mavlink.udp`: transport.
- :mod:`~fcu.mavlink.endpoint`: ``MavlinkEndpoint``, what a composition root drives, with
  its :mod:`~fcu.mavlink.endpoint_config`.

Each name is imported from the module that defines it; the package re-exports nothing.
"""
