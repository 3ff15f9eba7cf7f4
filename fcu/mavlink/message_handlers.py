"""The endpoint's receiving side: each message addressed to the vehicle to its handler.

:class:`MessageHandlers` routes HEARTBEAT (the GCS-loss failsafe), TIMESYNC, commands and
SET_MODE (one COMMAND_ACK each), stream requests, parameters, the mission protocol,
set-points, sticks, signing set-up, FTP and a lead's position to the part of the endpoint
that handles them; a message for another system or component is counted and dropped.
"""

from __future__ import annotations

import logging

from fcu.mavlink.endpoint_config import EndpointStats
from fcu.mavlink.enums import Severity
from fcu.mavlink.link_outbox import LinkOutbox
from fcu.mavlink.port import VehiclePort
from fcu.mavlink.protocols.command_request import CommandOutcome, CommandRequest
from fcu.mavlink.protocols.commands import CommandDispatcher
from fcu.mavlink.protocols.failsafe import GcsFailsafe, GcsFailsafeConfig
from fcu.mavlink.protocols.follow_target import lead_report
from fcu.mavlink.protocols.ftp import ftp_reply
from fcu.mavlink.protocols.manual_input import ManualInput
from fcu.mavlink.protocols.mission import MissionProtocol
from fcu.mavlink.protocols.mission_items import set_current_refusal
from fcu.mavlink.protocols.params import ParamService
from fcu.mavlink.telemetry import messages as build
from fcu.mavlink.telemetry import streamed
from fcu.mavlink.telemetry.streams import StreamScheduler
from fcu.mavlink.transport.codec import Codec, MAVLinkMessage, mavlink2
from fcu.mavlink.transport.link import Address, Link
from fcu.mavlink.transport.signing import MessageSigning

__all__ = ["MessageHandlers"]

_M = mavlink2
_log = logging.getLogger("fcu.mavlink.endpoint")  # the endpoint's log, as before
_SETPOINT_STATUS_INTERVAL_S = 1.0  # s wall; set-point refusals arrive at stream rates


class MessageHandlers:
    """The receiving side (module docstring); a part of
    :class:`fcu.mavlink.endpoint.MavlinkEndpoint`, whose protocol parts it hands messages
    to."""

    stats: EndpointStats
    manual: ManualInput
    signing: MessageSigning
    _port: VehiclePort
    _link: Link
    _codec: Codec
    _outbox: LinkOutbox
    _params: ParamService
    _streams: StreamScheduler
    _mission: MissionProtocol
    _commands: CommandDispatcher
    _failsafe: GcsFailsafe
    _time_s: float  # s, simulated time of the latest tick
    _wall_s: float  # s, wall-clock time of the latest receive
    _last_tc1_ns: int  # ns, the latest TIMESYNC answer (never decreasing)
    _last_setpoint_status: tuple[float, str]  # wall s and text of the latest refusal said

    def _failsafe_config(self) -> GcsFailsafeConfig:
        """The endpoint's (:meth:`fcu.mavlink.endpoint.MavlinkEndpoint._failsafe_config`)."""
        raise NotImplementedError

    def _clear_gcs_failsafe(self, why: str) -> None:
        """The endpoint's."""
        raise NotImplementedError

    def _context(self) -> build.TelemetryContext:
        """The endpoint's telemetry context."""
        raise NotImplementedError

    def _reboot(self) -> None:
        """The endpoint's reboot."""
        raise NotImplementedError

    def _for_us(self, msg: MAVLinkMessage) -> bool:
        target_system = getattr(msg, "target_system", 0)
        target_component = getattr(msg, "target_component", 0)
        ok = (target_system in (0, self._codec.sysid)
              and target_component in (0, self._codec.compid))
        if not ok:
            self.stats.not_for_us += 1
        return ok

    def _handle_message(self, msg: MAVLinkMessage, addr: Address) -> None:
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if src == (self._codec.sysid, self._codec.compid):
            return  # our own packet looped back
        self._link.add_peer(addr)
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            if self._failsafe.on_heartbeat(src[0], int(msg.type), self._wall_s,
                                           self._failsafe_config()):
                self._clear_gcs_failsafe("heartbeat back")
            return
        if kind == "TIMESYNC":
            self._timesync(msg, addr)
            return
        handler = self._HANDLERS.get(kind)
        if handler is None or not self._for_us(msg):
            return  # PING, COMMAND_ACK, ...: ignored
        handler(self, msg, src, addr)

    def _command(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        self.stats.commands += 1
        command = int(msg.command)
        try:
            outcome = self._commands.dispatch(CommandRequest.from_message(msg))
        except Exception:
            self.stats.handler_errors += 1
            _log.exception("command %d", command)
            outcome = CommandOutcome(_M.MAV_RESULT_FAILED, f"command {command} failed")
        self._finish_command(command, outcome, src, addr)

    def _finish_command(self, command: int, outcome: CommandOutcome, src: tuple[int, int],
                        addr: Address) -> None:
        """Exactly one COMMAND_ACK, then the reason and follow-up messages."""
        self._outbox.send_fields(_M.MAVLink_command_ack_message,
                                 build.command_ack(command, outcome.result, *src), addr)
        if outcome.reason:
            self._outbox.status(Severity.WARNING, outcome.reason)
        for follow in outcome.follow_up:
            self._outbox.send(follow, addr)
        if outcome.heartbeat_soon:
            self._streams.request_heartbeat()
        if outcome.reboot:
            self._reboot()

    def _lead_report(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        """Another system's position, for FOLLOW (never our own system's)."""
        report = lead_report(msg) if src[0] != self._codec.sysid else None
        if report is not None:
            self._port.follow_target(report)

    def _set_mode_message(self, msg: MAVLinkMessage, src: tuple[int, int],
                          addr: Address) -> None:
        """Legacy SET_MODE: acknowledged as ArduPilot does (COMMAND_ACK, command = 11)."""
        if not int(msg.base_mode) & _M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            outcome = CommandOutcome(_M.MAV_RESULT_DENIED,
                                     "Set mode: only custom (ArduCopter) modes are supported")
        else:
            outcome = self._commands.set_mode(int(msg.custom_mode))
        self._finish_command(_M.MAVLINK_MSG_ID_SET_MODE, outcome, src, addr)

    def _timesync(self, msg: MAVLinkMessage, addr: Address) -> None:
        if int(msg.tc1) != 0:
            return  # an answer to someone else's request
        now_ns = max(int(self._time_s * 1e9), self._last_tc1_ns)
        self._last_tc1_ns = now_ns
        self._outbox.send(_M.MAVLink_timesync_message(now_ns, int(msg.ts1)), addr)

    def _request_data_stream(self, msg: MAVLinkMessage, src: tuple[int, int],
                             addr: Address) -> None:
        rate = float(msg.req_message_rate) if int(msg.start_stop) else 0.0
        self._streams.set_group_rate(int(msg.req_stream_id), rate)

    def _param_list(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        self._params.handle_request_list(addr)

    def _param_read(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        self._params.handle_request_read(msg, addr)

    def _param_set(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        self._params.handle_set(msg)

    def _mission_count(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        self._mission.handle_count(msg, src, addr, self._wall_s)

    def _mission_item(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        self._mission.handle_item(msg, src, addr, self._wall_s)

    def _mission_request_list(self, msg: MAVLinkMessage, src: tuple[int, int],
                              addr: Address) -> None:
        self._mission.handle_request_list(msg, src, addr)

    def _mission_request(self, msg: MAVLinkMessage, src: tuple[int, int],
                         addr: Address) -> None:
        self._mission.handle_request(msg, src, addr)

    def _mission_clear(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        self._mission.handle_clear_all(msg, src, addr)

    def _mission_set_current(self, msg: MAVLinkMessage, src: tuple[int, int],
                             addr: Address) -> None:
        """MISSION_SET_CURRENT (no ACK exists): answered with MISSION_CURRENT."""
        seq = int(msg.seq)
        total = self._mission.total
        if not 0 <= seq <= total or total == 0:
            self._outbox.status(Severity.WARNING, set_current_refusal(seq, total))
        else:
            result = self._port.mission_set_current(max(seq, 1))
            if not result.accepted:
                self._outbox.status(Severity.WARNING, f"Set mission current: {result.reason}")
        cls, built = streamed.stream_fields(_M.MAVLINK_MSG_ID_MISSION_CURRENT,
                                            self._port.snapshot(), self._context())
        for fields in built:
            self._outbox.send_fields(cls, fields, addr)

    def _sticks(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        if msg.get_type() == "RC_CHANNELS_OVERRIDE":
            self.manual.rc_override(msg, self._wall_s)
        elif int(msg.target) in (0, self._codec.sysid):  # MANUAL_CONTROL
            self.manual.manual_control(msg, self._wall_s)

    def _setup_signing(self, msg: MAVLinkMessage, src: tuple[int, int],
                       addr: Address) -> None:
        self.signing.handle_setup(msg)

    def _ftp(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        """MAVLink FTP: no file server here, said at once
        (:func:`fcu.mavlink.protocols.ftp.ftp_reply`)."""
        reply = ftp_reply(msg, src)
        if reply is not None:
            self._outbox.send(reply, addr)

    def _setpoint(self, msg: MAVLinkMessage, src: tuple[int, int], addr: Address) -> None:
        kind = msg.get_type()
        if kind == "SET_POSITION_TARGET_LOCAL_NED":
            result = self._commands.position_target_local(msg)
        elif kind == "SET_POSITION_TARGET_GLOBAL_INT":
            result = self._commands.position_target_global(msg)
        else:
            result = self._commands.attitude_target(msg)
        if result.accepted:
            return
        # Set-points stream at 10-50 Hz: say the same refusal at most once per wall second.
        text = result.reason or "Set-point refused"
        last_s, last_text = self._last_setpoint_status
        if text != last_text or self._wall_s - last_s >= _SETPOINT_STATUS_INTERVAL_S:
            self._last_setpoint_status = (self._wall_s, text)
            self._outbox.status(Severity.WARNING, text)

    _HANDLERS = {
        "COMMAND_LONG": _command,
        "COMMAND_INT": _command,
        "SET_MODE": _set_mode_message,
        "REQUEST_DATA_STREAM": _request_data_stream,
        "PARAM_REQUEST_LIST": _param_list,
        "PARAM_REQUEST_READ": _param_read,
        "PARAM_SET": _param_set,
        "MISSION_COUNT": _mission_count,
        "MISSION_ITEM_INT": _mission_item,
        "MISSION_ITEM": _mission_item,
        "MISSION_REQUEST_LIST": _mission_request_list,
        "MISSION_REQUEST_INT": _mission_request,
        "MISSION_REQUEST": _mission_request,
        "MISSION_CLEAR_ALL": _mission_clear,
        "MISSION_SET_CURRENT": _mission_set_current,
        "SET_POSITION_TARGET_LOCAL_NED": _setpoint,
        "SET_POSITION_TARGET_GLOBAL_INT": _setpoint,
        "SET_ATTITUDE_TARGET": _setpoint,
        "FILE_TRANSFER_PROTOCOL": _ftp,
        "SETUP_SIGNING": _setup_signing,
        "FOLLOW_TARGET": _lead_report,
        "GLOBAL_POSITION_INT": _lead_report,
        "MANUAL_CONTROL": _sticks,
        "RC_CHANNELS_OVERRIDE": _sticks,
    }
