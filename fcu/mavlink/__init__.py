"""The autopilot's MAVLink endpoint (ArduCopter dialect, MAVLink 2).

Grouped by job:

- :mod:`~fcu.mavlink.transport`: bytes on the wire and the link (dialect and packing, the
  UDP link, signing, the boot HEARTBEAT).
- :mod:`~fcu.mavlink.protocols`: the MAVLink services the vehicle answers (commands,
  mission, parameters, FTP, sticks, a lead's position, the GCS failsafe).
- :mod:`~fcu.mavlink.telemetry`: what the vehicle streams (messages built from a snapshot,
  their scheduling, the records relayed, the autopilot's snapshot and extended telemetry).

Here, what ties them together:

- :mod:`~fcu.mavlink.port`: what the endpoint needs from the vehicle (``VehiclePort``,
  ``FailureInjector``, ``ParamProvider``) in SI units and NED;
  :mod:`~fcu.mavlink.port_records`: the records crossing it (``VehicleSnapshot``,
  ``CommandResult``, set-points, mission items, parameter specs, events).
- :mod:`~fcu.mavlink.enums`: the MAVLink numbers it speaks in (``MavState``, ``Severity``,
  ``FailureUnit``, ``FailureType``); flight modes are the navigator's
  (:class:`fcu.navigation.modes.Mode`, ArduCopter's numbers).
- :mod:`~fcu.mavlink.geo`: local NED <-> latitude/longitude/altitude (for telemetry,
  commands and mission items alike).
- :mod:`~fcu.mavlink.endpoint`: ``MavlinkEndpoint``, what a composition root drives, with
  its :mod:`~fcu.mavlink.endpoint_config`, its receiving side
  (:mod:`~fcu.mavlink.message_handlers`: each message to its handler) and its outbox
  (:mod:`~fcu.mavlink.link_outbox`: packing, sending, STATUSTEXT chunks).
- :mod:`~fcu.mavlink.autopilot_port`: the port implemented over an autopilot, with its
  parameter table :mod:`~fcu.mavlink.autopilot_params`.

Each name is imported from the module that defines it; no package re-exports anything.
"""
