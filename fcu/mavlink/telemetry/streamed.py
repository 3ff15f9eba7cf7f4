"""Every telemetry message the vehicle can stream or send on request, by message id.

The builders of :mod:`fcu.mavlink.telemetry.messages` (the core set), of
:mod:`fcu.mavlink.telemetry.messages_extended` (ArduPilot SITL's extended telemetry) and of
:mod:`fcu.mavlink.telemetry.messages_px4` (PX4's, on request), in one table.
A builder gives its messages' constructor arguments, filled by name (records of
:func:`fcu.mavlink.transport.codec.fields_of` the entry's class): :func:`stream_fields` hands
them to the packer as they are (the endpoint's telemetry path, no message object made), and
:func:`build_stream` makes the messages (replies to REQUEST_MESSAGE, tests).
"""

from __future__ import annotations

from fcu.mavlink.port_records import VehicleSnapshot
from fcu.mavlink.telemetry.messages import BUILDERS, BuilderTable, Fields, TelemetryContext
from fcu.mavlink.telemetry.messages_extended import EXTENDED_BUILDERS
from fcu.mavlink.telemetry.messages_px4 import PX4_BUILDERS
from fcu.mavlink.transport.codec import MAVLinkMessage

__all__ = ["ALL_BUILDERS", "build_stream", "can_build", "stream_fields"]

ALL_BUILDERS: BuilderTable = {**BUILDERS, **EXTENDED_BUILDERS, **PX4_BUILDERS}


def can_build(msg_id: int) -> bool:
    """True when ``msg_id`` can be built from a snapshot (streamed or requested)."""
    return msg_id in ALL_BUILDERS


def stream_fields(msg_id: int, snap: VehicleSnapshot,
                  ctx: TelemetryContext) -> tuple[type[MAVLinkMessage], list[Fields]]:
    """The message class of stream ``msg_id`` and the constructor arguments of each of its
    messages now (an empty list when there is nothing to report).

    Raises
    ------
    KeyError
        When ``msg_id`` has no builder (see :func:`can_build`).
    """
    cls, builder = ALL_BUILDERS[msg_id]
    built = builder(snap, ctx)
    if built is None:
        return cls, []
    if isinstance(built, list):
        return cls, built
    return cls, [built]


def build_stream(msg_id: int, snap: VehicleSnapshot,
                 ctx: TelemetryContext) -> list[MAVLinkMessage]:
    """The message(s) of stream ``msg_id`` now (empty when there is nothing to report).

    Raises
    ------
    KeyError
        When ``msg_id`` has no builder (see :func:`can_build`).
    """
    cls, built = stream_fields(msg_id, snap, ctx)
    return [cls(*fields) for fields in built]
