"""Where vehicle number N listens and sends by default, as SITL's ``-I N`` arranges it.

Light on purpose (no numpy): ``ftc-vehicle`` binds its socket from these before it loads the
autopilot (:mod:`fcu.mavlink.transport.boot_beacon`).
"""

from __future__ import annotations

from fcu.mavlink.transport.link import Address
from fcu.mavlink.transport.udp import DEFAULT_PEERS

__all__ = ["DEFAULT_BIND", "MAX_INSTANCE", "instance_addresses"]

DEFAULT_BIND: Address = ("127.0.0.1", 14555)
"""Where the vehicle listens by default (``udpout:127.0.0.1:14555`` reaches it)."""
MAX_INSTANCE = 9  # highest --instance: beyond it the API port 14540 + N meets 14550 + 10 M


def instance_addresses(instance: int) -> tuple[Address, tuple[Address, ...]]:
    """Default listening address and telemetry destinations of vehicle ``instance``.

    As ArduPilot SITL's ``-I N`` moves its ports by 10 N, instance N listens on
    127.0.0.1:14555 + 10 N and sends to the ground-station port 14550 + 10 N; the API port
    (MAVSDK) is 14540 + N, PX4 SITL's convention for instance N (14540 + 10 N would be the
    ground-station port of instance N - 1). For N in 0..:data:`MAX_INSTANCE` no port of one
    instance is a port of another.

    Raises
    ------
    ValueError
        ``instance`` outside 0..MAX_INSTANCE.
    """
    if not 0 <= instance <= MAX_INSTANCE:
        raise ValueError(f"instance = {instance!r}: must be in 0..{MAX_INSTANCE}")
    (gcs_host, gcs_port), (api_host, api_port) = DEFAULT_PEERS
    bind = (DEFAULT_BIND[0], DEFAULT_BIND[1] + 10 * instance)
    return bind, ((gcs_host, gcs_port + 10 * instance), (api_host, api_port + instance))
