"""Every telemetry message the vehicle can stream or send on request, by message id.

The builders of :mod:`fcu.mavlink.messages` (the core set) and of
:mod:`fcu.mavlink.messages_extended` (ArduPilot SITL's extended telemetry), in one table.
"""

from __future__ import annotations

from fcu.mavlink.codec import MAVLinkMessage
from fcu.mavlink.messages import BUILDERS, Builder, TelemetryContext
from fcu.mavlink.messages_extended import EXTENDED_BUILDERS
from fcu.mavlink.port import VehicleSnapshot

__all__ = ["ALL_BUILDERS", "build_stream", "can_build"]

ALL_BUILDERS: dict[int, Builder] = {**BUILDERS, **EXTENDED_BUILDERS}
"""Message id -> its builder."""


def can_build(msg_id: int) -> bool:
    """True when ``msg_id`` can be built from a snapshot (streamed or requested)."""
    return msg_id in ALL_BUILDERS


def build_stream(msg_id: int, snap: VehicleSnapshot,
                 ctx: TelemetryContext) -> list[MAVLinkMessage]:
    """The message(s) of stream ``msg_id`` now (empty when there is nothing to report).

    Raises
    ------
    KeyError
        When ``msg_id`` has no builder (see :func:`can_build`).
    """
    built = ALL_BUILDERS[msg_id](snap, ctx)
    if built is None:
        return []
    if isinstance(built, list):
        return built
    return [built]
