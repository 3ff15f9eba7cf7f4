"""The MAVLink services the vehicle answers, each checking what arrives and telling the port.

- :mod:`~fcu.mavlink.protocols.commands`: COMMAND_LONG/INT dispatch and SET_MODE.
- :mod:`~fcu.mavlink.protocols.command_request`: a command's request, answer and limits.
- :mod:`~fcu.mavlink.protocols.message_commands`: message requests and stream intervals.
- :mod:`~fcu.mavlink.protocols.calibration_command`: PREFLIGHT_CALIBRATION (simulated).
- :mod:`~fcu.mavlink.protocols.setpoint_commands`: GUIDED set-points.
- :mod:`~fcu.mavlink.protocols.mission`: the mission protocol (ArduPilot flavour).
- :mod:`~fcu.mavlink.protocols.mission_items`: its items, their checks and conversions.
- :mod:`~fcu.mavlink.protocols.params`: the parameter table and protocol.
- :mod:`~fcu.mavlink.protocols.ftp`: MAVLink FTP answered at once (no file server).
- :mod:`~fcu.mavlink.protocols.manual_input`: sticks over MAVLink, and the RC failsafe.
- :mod:`~fcu.mavlink.protocols.follow_target`: a lead's position reports for FOLLOW.
- :mod:`~fcu.mavlink.protocols.failsafe`: the GCS heartbeat-loss failsafe.
"""
