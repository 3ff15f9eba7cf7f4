"""Bytes on the wire and the link: what the endpoint sends and receives, and how.

- :mod:`~fcu.mavlink.transport.codec`: the dialect choice, packing, per-datagram parsing.
- :mod:`~fcu.mavlink.transport.link`: the ``Link`` and ``Outbox`` interfaces the parts share.
- :mod:`~fcu.mavlink.transport.udp`: the non-blocking UDP link and its peer table.
- :mod:`~fcu.mavlink.transport.signing`: MAVLink 2 signing, set up, applied and checked.
- :mod:`~fcu.mavlink.transport.boot_beacon`: the ``MAV_STATE_BOOT`` HEARTBEAT while booting.
"""
