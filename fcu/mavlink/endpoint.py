"""The autopilot's MAVLink endpoint: one object a composition root drives.

Driving API
-----------
::

    link = UdpLink(bind_port=14555)               # or any Link
    endpoint = MavlinkEndpoint(port, link, config=EndpointConfig(sysid=1),
                               injector=fault_engine_port, extra_params=[sim_params])
    while running:                                 # the autopilot loop, e.g. 100 Hz simulated
        ...step the autopilot...
        endpoint.tick(time_s=sim_time_s, wall_time_s=time.monotonic())

``tick`` reads the waiting datagrams and answers them (for at most ``receive_budget_s`` of
wall time per call: under a flood the rest wait, in order, for the next tick, so the
simulation and its telemetry keep their pace), hands vehicle events (STATUSTEXT,
MISSION_ITEM_REACHED) on, runs the GCS-loss failsafe and mission time-outs, and sends the
telemetry that is due. Call it from the thread that owns the vehicle (the port is not
called from anywhere else), after each autopilot step, and **keep calling it at least ~10
times per wall-clock second even while the simulation is paused or slower than real time**
(pass the unchanged simulated time): the wall-clock HEARTBEAT floor, command answers and the
failsafe depend on it. ``time_s`` should equal ``port.snapshot().time_s``.

``handle_bytes`` / ``poll`` exist for links that deliver data elsewhere (tests, a serial
reader); ``tick`` calls ``poll`` itself.

Robustness: nothing received can raise out of ``handle_bytes``/``poll``/``tick``. Malformed
packets, unknown message ids and handler errors are counted in :attr:`MavlinkEndpoint.stats`
(SYS_STATUS.errors_comm reports the malformed count).

Signing: MAVLink 2 signing (SETUP_SIGNING, ``EndpointConfig.signing_key``) is
:mod:`fcu.mavlink.transport.signing`; with a key, packets that fail its check are dropped before any
handling.

Clocks: telemetry rates and message time fields use simulated time
(:mod:`fcu.mavlink.telemetry.streams`); HEARTBEAT has a wall-clock floor; the GCS and RC
failsafes and mission time-outs use the wall clock. MANUAL_CONTROL and RC_CHANNELS_OVERRIDE
fly the pilot modes (:mod:`fcu.mavlink.protocols.manual_input`).
TIMESYNC answers with the simulated time in ns (never decreasing).
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from collections.abc import Callable, Sequence

from fcu.mavlink.endpoint_config import EndpointConfig, EndpointStats
from fcu.mavlink.enums import MavState, Severity
from fcu.mavlink.link_outbox import LinkOutbox
from fcu.mavlink.message_handlers import MessageHandlers
from fcu.mavlink.port import FailureInjector, ParamProvider, VehiclePort
from fcu.mavlink.port_records import (
    CommandResult,
    MissionItemReached,
    ParamSpec,
    RecordEvent,
    StatusText,
    VehicleSnapshot,
)
from fcu.mavlink.protocols.commands import CommandDispatcher
from fcu.mavlink.protocols.failsafe import FailsafeAction, GcsFailsafe, GcsFailsafeConfig
from fcu.mavlink.protocols.manual_input import ManualInput
from fcu.mavlink.protocols.mission import MissionProtocol
from fcu.mavlink.protocols.params import ParamEntry, ParamService, ParamTable, entries_from
from fcu.mavlink.telemetry import messages as build
from fcu.mavlink.telemetry import streamed
from fcu.mavlink.telemetry.record_relay import RecordRelay
from fcu.mavlink.telemetry.streams import StreamScheduler
from fcu.mavlink.transport.codec import Codec, MAVLinkMessage, mavlink2
from fcu.mavlink.transport.link import Address, Link
from fcu.mavlink.transport.signing import MessageSigning
from fcu.navigation.modes import Mode

__all__ = ["MavlinkEndpoint"]

_M = mavlink2
_log = logging.getLogger(__name__)


class MavlinkEndpoint(MessageHandlers):
    """MAVLink endpoint of the autopilot (see the module docstring for how to drive it).

    Received messages go to their handlers in
    :class:`~fcu.mavlink.message_handlers.MessageHandlers`; everything sent goes through one
    :class:`~fcu.mavlink.link_outbox.LinkOutbox`.

    Parameters
    ----------
    port : VehiclePort
        The vehicle.
    link : Link
        Datagram transport (e.g. :class:`fcu.mavlink.transport.udp.UdpLink`).
    config : EndpointConfig
    injector : FailureInjector or None
        Fault-injection port for MAV_CMD_INJECT_FAILURE (None: UNSUPPORTED).
    extra_params : sequence of ParamProvider
        More parameters (e.g. the simulator's ``SIM_*``); names must be unique overall.
    clock : callable
        Wall clock for the receive budget, s (``time.perf_counter``; injectable for tests).
    codec : Codec or None
        The packer to carry on with (the boot beacon's,
        :mod:`fcu.mavlink.transport.boot_beacon`: its sequence numbers go on); None: a new one
        for ``config``'s ids.
    """

    def __init__(self, port: VehiclePort, link: Link, *,
                 config: EndpointConfig | None = None,
                 injector: FailureInjector | None = None,
                 extra_params: Sequence[ParamProvider] = (),
                 clock: Callable[[], float] = time.perf_counter,
                 codec: Codec | None = None) -> None:
        self._config = config = config if config is not None else EndpointConfig()
        self._port = port
        self._link = link
        self.stats = EndpointStats()
        self._codec = Codec(config.sysid, config.compid) if codec is None else codec
        self._outbox = LinkOutbox(self._codec, link, self.stats)
        self.signing = MessageSigning(self._codec.signing, self._outbox, key=config.signing_key)
        self._records = RecordRelay()
        entries = self._own_params() + ManualInput.param_entries()
        entries += entries_from(port)
        for provider in extra_params:
            entries += entries_from(provider)
        self._params = ParamService(ParamTable(entries), self._outbox, lambda: self._wall_s)
        self._streams = StreamScheduler(config.stream_rates_hz, config.heartbeat_wall_period_s,
                                        config.max_stream_rate_hz)
        self._mission = MissionProtocol(self._outbox, port.snapshot, port.mission_set,
                                        config.mission, port.fence_set)
        self._commands = CommandDispatcher(port, injector, self._streams, self._build_message,
                                           lambda: self._mission.total, config.limits,
                                           set_param=self._set_param)
        self._failsafe = GcsFailsafe(config.sysid)
        self.manual = ManualInput(port, self._outbox.status, self._params.table.get)
        self._failsafe_values: tuple[float, float, float] | None = None  # the config's source
        self._failsafe_settings = GcsFailsafeConfig()
        self._context_key: tuple[int, int, bool] | None = None  # _context's source values
        self._telemetry_context = build.TelemetryContext()
        self._time_s = 0.0
        self._wall_s = 0.0
        self._last_tc1_ns = 0
        self._last_setpoint_status: tuple[float, str] = (-math.inf, "")
        self._last_snapshot: VehicleSnapshot | None = None
        self._clock = clock
        self._backlog: deque[tuple[bytes, Address]] = deque()  # received, not yet handled
        # what tick does after receiving, in order; each is called (time_s, wall_time_s)
        self._steps: tuple[Callable[[float, float], None], ...] = (
            self.signing.tick, self._forward_events, self._run_failsafe, self.manual.tick,
            self._mission_tick, self._send_due)

    # ------------------------------------------------------------------ parameters
    def _own_params(self) -> list[ParamEntry]:
        c = self._config
        return [
            ParamEntry(ParamSpec(
                name="SYSID_THISMAV", value=c.sysid, min_value=1, max_value=255, integer=True,
                description="MAVLink system id of this vehicle (applies after reboot)"),
                self._on_sysid_change),
            ParamEntry(ParamSpec(
                name="SYSID_MYGCS", value=c.gcs_sysid, min_value=1, max_value=255,
                integer=True, description="System id of the GCS whose heartbeat counts")),
            ParamEntry(ParamSpec(
                name="FS_GCS_ENABLE", value=c.gcs_failsafe_action, min_value=0, max_value=5,
                allowed=tuple(float(a) for a in FailsafeAction), integer=True,
                description="GCS-loss failsafe: 0 off, 1 RTL, 2 RTL/continue AUTO, 5 LAND")),
            ParamEntry(ParamSpec(
                name="FS_GCS_TIMEOUT", value=c.gcs_failsafe_timeout_s, min_value=2.0,
                max_value=120.0, description="GCS heartbeat loss before failsafe, s (wall)")),
        ]

    def _on_sysid_change(self, value: float) -> CommandResult:
        self._outbox.status(Severity.NOTICE,
                            f"SYSID_THISMAV {int(value)} takes effect after reboot")
        return CommandResult.ok()

    @property
    def params(self) -> ParamTable:
        """The parameter table (read-only use: values, names)."""
        return self._params.table

    @property
    def streams(self) -> StreamScheduler:
        """The telemetry schedule."""
        return self._streams

    @property
    def mission(self) -> MissionProtocol:
        """The mission protocol state."""
        return self._mission

    @property
    def gcs_failsafe_active(self) -> bool:
        """The GCS-loss failsafe has fired and no GCS heartbeat has come back."""
        return self._failsafe.active

    @property
    def sysid(self) -> int:
        """The system id in use."""
        return self._codec.sysid

    def _failsafe_config(self) -> GcsFailsafeConfig:
        """The FS_GCS_* / SYSID_MYGCS settings in force (read every tick a GCS is known: the
        settings object is made again only when one of the three values has changed)."""
        get = self._params.table.get
        values = (get("FS_GCS_ENABLE"), get("FS_GCS_TIMEOUT"), get("SYSID_MYGCS"))
        if values != self._failsafe_values:
            self._failsafe_values = values
            self._failsafe_settings = GcsFailsafeConfig(
                action=FailsafeAction(int(values[0])), timeout_s=values[1],
                gcs_sysid=int(values[2]))
        return self._failsafe_settings

    # ------------------------------------------------------------------ driving
    def tick(self, time_s: float, wall_time_s: float) -> None:
        """Receive, react and send what is due (see the module docstring).

        Parameters
        ----------
        time_s : float
            Simulated time since boot, s.
        wall_time_s : float
            Monotonic wall-clock time, s (``time.monotonic()``).
        """
        self._time_s = time_s
        self.poll(wall_time_s)
        for step in self._steps:  # each on its own: one failing does not stop the others
            try:
                step(time_s, wall_time_s)
            except Exception:
                self.stats.handler_errors += 1
                _log.exception("endpoint step failed")

    def poll(self, wall_time_s: float) -> int:
        """Handle the datagrams waiting on the link for at most ``receive_budget_s``; the
        rest wait, in order, for the next call. Returns how many were handled."""
        self._wall_s = wall_time_s
        if not self._backlog:
            try:
                self._backlog.extend(self._link.receive())
            except Exception:
                self.stats.handler_errors += 1
                _log.exception("link receive failed")
                return 0
            if not self._backlog:
                return 0  # the common tick: nothing arrived
        start = self._clock()
        handled = 0
        while self._backlog:
            data, addr = self._backlog.popleft()
            self.handle_bytes(data, addr, wall_time_s)
            handled += 1
            if self._clock() - start >= self._config.receive_budget_s:
                break
        return handled

    def handle_bytes(self, data: bytes, addr: Address, wall_time_s: float | None = None) -> None:
        """Parse one datagram from ``addr`` and answer every message in it; never raises."""
        if wall_time_s is not None:
            self._wall_s = wall_time_s
        self.stats.datagrams += 1
        parsed = self._codec.parse_datagram(bytes(data))
        self.stats.malformed += parsed.malformed
        self.stats.unknown_ids += parsed.unknown
        for msg in parsed.messages:
            self.stats.messages += 1
            try:
                if self.signing.accept(msg):  # always True without a key
                    self._handle_message(msg, addr)
            except Exception:
                self.stats.handler_errors += 1
                _log.exception("error handling %s", msg.get_type())

    # ------------------------------------------------------------------ periodic work
    def _context(self) -> build.TelemetryContext:
        """What the builders read besides the snapshot (made again only when one of the
        values that can change has changed: it is read at every telemetry burst)."""
        key = (self._mission.total, self.stats.malformed, self._failsafe.active)
        if key != self._context_key:
            self._context_key = key
            self._telemetry_context = build.TelemetryContext(
                pwm_max=self._config.pwm_max, mission_total=key[0], errors_comm=key[1],
                gcs_failsafe_active=key[2], boot_unix_time_s=self._config.boot_unix_time_s)
        return self._telemetry_context

    def _send_due(self, time_s: float, wall_time_s: float) -> None:
        due = self._streams.due(time_s, wall_time_s)
        if not due:
            return
        try:
            snap = self._port.snapshot()
            self._last_snapshot = snap
        except Exception:
            self.stats.build_errors += 1
            _log.exception("snapshot failed")
            # Keep the link alive: a HEARTBEAT from the last good state, marked CRITICAL.
            last = self._last_snapshot
            if last is None or _M.MAVLINK_MSG_ID_HEARTBEAT not in due:
                return
            snap = VehicleSnapshot(  # what HEARTBEAT reads (a port may compute the rest late)
                time_s=last.time_s, armed=last.armed, custom_mode=last.custom_mode,
                pos_ned=last.pos_ned, vel_ned=last.vel_ned, euler_rad=last.euler_rad,
                rate_frd=last.rate_frd, origin=last.origin, system_status=MavState.CRITICAL,
                failsafe_active=last.failsafe_active)
            due = [_M.MAVLINK_MSG_ID_HEARTBEAT]
        ctx = self._context()
        send = self._outbox.send_fields
        for msg_id in due:
            try:
                cls, built = streamed.stream_fields(msg_id, snap, ctx)
            except Exception:
                self.stats.build_errors += 1
                _log.exception("cannot build message %d", msg_id)
                continue
            for fields in built:
                send(cls, fields)

    def _mission_tick(self, time_s: float, wall_time_s: float) -> None:
        self._mission.tick(wall_time_s)

    def _forward_events(self, time_s: float, wall_time_s: float) -> None:
        for event in self._port.drain_events():
            if isinstance(event, StatusText):
                self._outbox.status(event.severity, event.text)
            elif isinstance(event, MissionItemReached):
                self._outbox.send(_M.MAVLink_mission_item_reached_message(
                    build.clamp_int(event.seq, 0, 0xFFFF, 0)))
            elif isinstance(event, RecordEvent):
                self._outbox.send(self._records.add(event.record, self._time_s))
        for msg in self._records.due(self._time_s):
            self._outbox.send(msg)

    def _run_failsafe(self, time_s: float, wall_time_s: float) -> None:
        fs = self._failsafe
        if not fs.active and not fs.gcs_seen:
            return
        config = self._failsafe_config()
        if not fs.active and not fs.overdue(wall_time_s, config):
            return  # the common case, every tick: no snapshot needed
        snap = self._port.snapshot()
        was_active = fs.active
        action = fs.check(snap.armed, wall_time_s, config)
        if was_active and not fs.active:
            self._clear_gcs_failsafe("vehicle disarmed")
            return
        if action is None:
            return
        self.stats.gcs_failsafes += 1
        lost = f"GCS failsafe: no heartbeat for {config.timeout_s:g} s"
        if action == FailsafeAction.RTL_OR_CONTINUE_MISSION and snap.custom_mode == Mode.AUTO:
            self._outbox.status(Severity.CRITICAL, f"{lost}, continuing mission")
            return
        kind = "land" if action == FailsafeAction.LAND else "rtl"
        result = self._port.trigger_failsafe("gcs", kind)
        if result.accepted:
            self._outbox.status(Severity.CRITICAL, f"{lost}, {kind.upper()}")
        else:
            self._outbox.status(Severity.EMERGENCY, f"{lost}, {kind.upper()} refused: "
                                f"{result.reason}")

    def _set_param(self, name: str, value: float) -> CommandResult:
        """A parameter changed by a command (DO_FENCE_ENABLE), through the table as a
        PARAM_SET would be, so that reads report it."""
        if name not in self._params.table:
            return CommandResult.not_supported(f"no parameter {name}")
        outcome = self._params.table.set(name, value)
        return CommandResult.ok() if outcome.accepted else CommandResult.denied(outcome.reason)

    def _clear_gcs_failsafe(self, why: str) -> None:
        self._port.clear_failsafe("gcs")
        self._outbox.status(Severity.NOTICE, f"GCS failsafe cleared: {why}")

    def _build_message(self, msg_id: int) -> list[MAVLinkMessage] | None:
        """One-shot messages for REQUEST_MESSAGE (None: cannot be produced)."""
        if msg_id == _M.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            return [_M.MAVLink_autopilot_version_message(
                *build.autopilot_version(self._codec.sysid, self._config.flight_sw_version))]
        if not streamed.can_build(msg_id):
            return None
        return streamed.build_stream(msg_id, self._port.snapshot(), self._context())

    # ------------------------------------------------------------------ reboot
    def _reboot(self) -> None:
        """The vehicle accepted a reboot: restart the endpoint's own state."""
        new_sysid = int(self._params.table.get("SYSID_THISMAV"))
        self._codec.sysid = new_sysid
        self._failsafe.own_sysid = new_sysid
        self._failsafe.reset()
        self.manual.reset()
        self._streams.reset()
        self._mission.reset()
