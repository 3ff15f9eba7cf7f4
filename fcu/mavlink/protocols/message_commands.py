"""Message requests and stream intervals: REQUEST_MESSAGE, GET_HOME_POSITION,
REQUEST_AUTOPILOT_CAPABILITIES, SET_MESSAGE_INTERVAL and GET_MESSAGE_INTERVAL.

Any message the vehicle can produce can be streamed and requested; a message it cannot
produce gets UNSUPPORTED (not DENIED, which is for bad parameters). An interval shorter than
one autopilot tick is accepted and clamped to one message per tick, as ArduPilot caps
streams at its loop rate: GET_MESSAGE_INTERVAL reports the rate in force.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from fcu.mavlink.protocols.command_request import (
    INT32_MAX,
    CommandOutcome,
    CommandRequest,
    accepted,
    denied,
    unsupported,
    whole_number,
)
from fcu.mavlink.telemetry.streams import StreamScheduler
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2

__all__ = ["MessageCommands"]

_M = mavlink2
_MAX_INTERVAL_MSG_ID = 0xFFFF  # MESSAGE_INTERVAL.message_id is a uint16


class MessageCommands:
    """Message requests and intervals (module docstring); a part of
    :class:`fcu.mavlink.protocols.commands.CommandDispatcher`, whose streams and message builder it
    uses."""

    _streams: StreamScheduler
    _build_message: Callable[[int], list[MAVLinkMessage] | None]

    def _send_message(self, msg_id: int) -> CommandOutcome:
        messages = self._build_message(msg_id)
        if messages is None:
            return unsupported(f"Message {msg_id} not supported")
        if not messages:
            return CommandOutcome(_M.MAV_RESULT_TEMPORARILY_REJECTED,
                                  f"Message {msg_id} not available yet")
        return accepted(follow_up=messages)

    def _request_message(self, r: CommandRequest) -> CommandOutcome:
        msg_id = whole_number(r.params[0], 0, 0xFFFFFF)
        if msg_id is None:
            return denied(f"Request message: param1 = {r.params[0]} is not a message id")
        return self._send_message(msg_id)

    def _capabilities(self, r: CommandRequest) -> CommandOutcome:
        flag = whole_number(r.params[0], 0, 1)
        if flag is None:
            return denied(f"Request capabilities: param1 = {r.params[0]} must be 0 or 1")
        if flag == 0:
            return accepted()
        return self._send_message(_M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)

    def _set_message_interval(self, r: CommandRequest) -> CommandOutcome:
        msg_id = whole_number(r.params[0], 0, 0xFFFFFF)
        interval_us = r.params[1]
        if msg_id is None:
            return denied(f"Set interval: param1 = {r.params[0]} is not a message id")
        if not self._streams.has(msg_id):  # a message id, but one we cannot produce
            return unsupported(f"Set interval: message {msg_id} cannot be streamed")
        if not math.isfinite(interval_us) or (interval_us < 0 and interval_us != -1.0):
            return denied(f"Set interval: interval {interval_us} us invalid")
        if interval_us == -1.0:
            rate: float | None = 0.0
        elif interval_us == 0.0:
            rate = None
        else:
            rate = 1e6 / interval_us
        try:
            self._streams.set_rate(msg_id, rate)
        except ValueError as err:
            return denied(f"Set interval: {err}")
        return accepted()

    def _get_message_interval(self, r: CommandRequest) -> CommandOutcome:
        msg_id = whole_number(r.params[0], 0, 0xFFFFFF)
        if msg_id is None:
            return denied(f"Get interval: param1 = {r.params[0]} is not a message id")
        if msg_id > _MAX_INTERVAL_MSG_ID:
            return denied(f"Get interval: message id {msg_id} above {_MAX_INTERVAL_MSG_ID} "
                           "(MESSAGE_INTERVAL cannot carry it)")
        if not self._streams.has(msg_id):
            interval_us = 0  # MESSAGE_INTERVAL: 0 = not available
        else:
            rate = self._streams.rate_hz(msg_id)
            interval_us = -1 if rate <= 0 else min(round(1e6 / rate), INT32_MAX)
        return accepted(follow_up=[_M.MAVLink_message_interval_message(msg_id, interval_us)])
