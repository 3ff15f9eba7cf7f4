"""What the vehicle streams: messages built from a snapshot, and when each is due.

- :mod:`~fcu.mavlink.telemetry.messages`: the core messages and replies (the unit edge).
- :mod:`~fcu.mavlink.telemetry.messages_extended`: ArduPilot SITL's extended telemetry.
- :mod:`~fcu.mavlink.telemetry.messages_px4`: PX4's telemetry, on request.
- :mod:`~fcu.mavlink.telemetry.streamed`: every message the vehicle can stream, by id.
- :mod:`~fcu.mavlink.telemetry.streams`: scheduling (simulated time, wall-clock heartbeat).
- :mod:`~fcu.mavlink.telemetry.extended`: what the extended telemetry reports, on demand.
- :mod:`~fcu.mavlink.telemetry.record_relay`: faults, detections, outcomes as ``FTC_REC``.
- :mod:`~fcu.mavlink.telemetry.autopilot_snapshot`: a tick's snapshot, lazy costly fields.
- :mod:`~fcu.mavlink.telemetry.autopilot_telemetry`: an autopilot's extended telemetry.
"""
