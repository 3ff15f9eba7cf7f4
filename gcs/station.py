"""A MAVLink ground station for one vehicle: streams, parameters, missions, arming, injections.

:class:`GroundStation` is a :class:`gcs.link.Link` (heartbeat, receiving and recording every
packet, COMMAND_LONG with its COMMAND_ACK) that drives a vehicle the way any ground station
does: it asks for the telemetry the table needs, sets parameters and checks the PARAM_VALUE
echo (:mod:`gcs.parameters`), uploads missions (:mod:`gcs.mission_upload`), arms, switches
modes, starts the mission and injects faults, timing them on the vehicle's clock
(:mod:`gcs.injection`).

Clocks: socket waits and protocol time-outs are wall-clock seconds (what a person waits);
flight progress, fault times and the mission time-out are the vehicle's simulated seconds,
read from its telemetry (``time_boot_ms``). The two never mix.

Usage::

    with GroundStation.open("udpin:127.0.0.1:14550", tlog="flight.tlog") as gs:
        gs.wait_vehicle(timeout_s=10)
        gs.set_param("ATT_CTRL", 1)
        gs.upload_mission(thesis_mission())
        gs.arm(); gs.set_mode(COPTER_MODE_AUTO); gs.start_mission()
        while gs.analyzer.armed is not False:  # gcs.flight.fly does this, with time-outs
            gs.pump(0.02)
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable
from typing import Any

from gcs.errors import CommandRefused, FlightTimeout, VehicleNotFound
from gcs.injection import FaultInjector
from gcs.mavlink import mavlink2
from gcs.mission_upload import MissionUploader
from gcs.records import EventLog, TlogWriter
from gcs.table import FlightReport
from gcs.telemetry import mavlink_text

__all__ = [
    "ARMING_MODES",
    "COPTER_MODE_AUTO",
    "COPTER_MODE_GUIDED",
    "COPTER_MODE_LAND",
    "COPTER_MODE_STABILIZE",
    "TELEMETRY_HZ",
    "GroundStation",
    "mode_name",
]

_M = mavlink2
# ArduCopter's mode numbers, from the dialect (ardupilotmega's COPTER_MODE enum)
COPTER_MODE_STABILIZE = _M.COPTER_MODE_STABILIZE
COPTER_MODE_AUTO = _M.COPTER_MODE_AUTO
COPTER_MODE_GUIDED = _M.COPTER_MODE_GUIDED
COPTER_MODE_LAND = _M.COPTER_MODE_LAND
ARMING_MODES = frozenset({_M.COPTER_MODE_STABILIZE, _M.COPTER_MODE_ALT_HOLD,
                          _M.COPTER_MODE_GUIDED, _M.COPTER_MODE_LOITER,
                          _M.COPTER_MODE_POSHOLD})
"""ArduCopter modes that allow arming (AUTO, LAND, RTL do not, without AUTO_OPTIONS)."""
TELEMETRY_HZ: dict[str, float] = {
    # the table's inputs at the autopilot's 100 Hz: one sample per tick, as the runner logs
    "ATTITUDE": 100.0,  # carries the clock ahead of SIM_STATE at every tick
    "SIM_STATE": 100.0,
    "POSITION_TARGET_LOCAL_NED": 100.0,
    "ATTITUDE_TARGET": 100.0,
    "SERVO_OUTPUT_RAW": 100.0,
    # progress and estimates
    "NAMED_VALUE_FLOAT": 10.0,
    "EXTENDED_SYS_STATE": 10.0,
    "MISSION_CURRENT": 2.0,
    "HOME_POSITION": 1.0,
}
"""Rates the ground station asks for (Hz of simulated time), by message name."""

_STREAM_ROUNDS_S = (0.5, 0.5, 1.0, 1.0, 1.5, 1.5, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0)
"""Wall seconds of each round of stream requests, at most (~18 s in all)."""
_DATE_REQUEST_S = 0.5  # s wall between TIMESYNC requests that date the mission start
_STATUS_REQUEST_S = 1.0  # s wall between SYS_STATUS requests while waiting to be armable
_PREARM_REQUEST_S = 2.0  # s wall between RUN_PREARM_CHECKS while waiting to be armable
_MODE_CONFIRM_S = 3.0  # s wall for a HEARTBEAT in the mode asked for (HEARTBEAT is 1 Hz)
_MODE_TRIES = 4  # mode changes sent before giving up on seeing the mode
_REBOOT_QUIET_S = 1.0  # s wall after a reboot's ACK before the vehicle counts as back
_RESTART_WORDS = re.compile(r"\b(restart|reboot)", re.IGNORECASE)
"""A pre-arm reason that only a restart clears (this vehicle: a motor declared failed)."""


class GroundStation(FaultInjector, MissionUploader):
    """A ground station on one link to one vehicle (see the module docstring); arguments as
    :class:`gcs.link.Link`. Parameters come from :class:`gcs.parameters.ParameterClient`,
    mission uploads from :class:`gcs.mission_upload.MissionUploader`, fault injection from
    :class:`gcs.injection.FaultInjector`."""

    def __init__(self, conn: Any, url: str, *, tlog: TlogWriter | None = None,
                 events: EventLog | None = None, signing_key: bytes | None = None) -> None:
        super().__init__(conn, url, tlog=tlog, events=events, signing_key=signing_key)
        self.prearm_reason: str | None = None  # the latest "PreArm: ..." STATUSTEXT's reason
        self._status_chunks: dict[int, list[str]] = {}
        self.held_time = False  # this flight set SIM_PAUSE = 1 and has not let go yet

    # ------------------------------------------------------------------ telemetry, arming, modes
    def set_message_rate(self, name: str, rate_hz: float) -> bool:
        """SET_MESSAGE_INTERVAL for message ``name`` at ``rate_hz`` (simulated time).

        A lost answer is made up for by reading the interval back (GET_MESSAGE_INTERVAL):
        the rate in force is the proof.

        Returns
        -------
        bool
            False (and an event) when the vehicle refused; it keeps its own rate.
        """
        msg_id = getattr(_M, f"MAVLINK_MSG_ID_{name}")
        interval_us = round(1e6 / rate_hz)
        sysid, compid = self.target

        def in_force() -> bool:
            reply = self.inbox.take("MESSAGE_INTERVAL", lambda m: int(m.message_id) == msg_id)
            return reply is not None and int(reply.interval_us) == interval_us

        def read_back() -> None:
            self.inbox.take_all("MESSAGE_INTERVAL", lambda m: int(m.message_id) == msg_id)
            self.send(_M.MAVLink_command_long_message(
                sysid, compid, _M.MAV_CMD_GET_MESSAGE_INTERVAL, 0, float(msg_id), 0, 0, 0, 0,
                0, 0))

        try:
            self.command(_M.MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, float(interval_us)),
                         what=f"SET_MESSAGE_INTERVAL {name}", applied=in_force,
                         read_back=read_back)
        except CommandRefused as err:
            self.log("STREAM", f"{name} at {rate_hz:g} Hz refused ({err.reason})")
            return False
        return True

    def request_streams(self, rates_hz: dict[str, float] | None = None) -> list[str]:
        """Ask for the telemetry the table needs (:data:`TELEMETRY_HZ`), all at once.

        Every stream not yet confirmed gets a SET_MESSAGE_INTERVAL and a
        GET_MESSAGE_INTERVAL per round (rounds of :data:`_STREAM_ROUNDS_S` at most, shorter on
        a fast link: :meth:`gcs.round_trips.RoundTrips.retry_wait_s`; ~18 s in all); a stream
        is confirmed when the interval read back is the one asked for. The COMMAND_ACKs cannot
        tell which stream they answer, so the read-back is the proof. A stream never
        confirmed (refused, or a link too bad) keeps the vehicle's rate; the table is then
        computed from fewer samples, and an event says so.

        Returns
        -------
        list of str
            The streams not confirmed.
        """
        rates = TELEMETRY_HZ if rates_hz is None else rates_hz
        sysid, compid = self.target
        wanted = {getattr(_M, f"MAVLINK_MSG_ID_{name}"): (name, round(1e6 / rate))
                  for name, rate in rates.items()}
        pending = dict(wanted)
        self.inbox.take_all("MESSAGE_INTERVAL", lambda m: True)
        give_up = time.monotonic() + sum(_STREAM_ROUNDS_S)
        rounds = 0
        while pending and time.monotonic() < give_up:
            for msg_id, (_, interval_us) in pending.items():
                for command, p1, p2 in ((_M.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, interval_us),
                                        (_M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id, 0)):
                    self.send(_M.MAVLink_command_long_message(
                        sysid, compid, command, 0, float(p1), float(p2), 0, 0, 0, 0, 0))
            sent_at = time.monotonic()
            deadline = sent_at + self.round_trips.retry_wait_s(
                _STREAM_ROUNDS_S[min(rounds, len(_STREAM_ROUNDS_S) - 1)])
            rounds += 1
            while pending and time.monotonic() < deadline:
                reply = self._wait_reply(["MESSAGE_INTERVAL"], lambda m: True, 0.05)
                if reply is not None and int(reply.message_id) in pending:
                    msg_id = int(reply.message_id)
                    if int(reply.interval_us) == pending[msg_id][1]:
                        del pending[msg_id]
                        if rounds == 1:  # (later, the answer may be to an earlier round)
                            self.round_trips.note(sent_at)
            self.inbox.take_all("COMMAND_ACK", lambda m: int(m.command) in (
                _M.MAV_CMD_SET_MESSAGE_INTERVAL, _M.MAV_CMD_GET_MESSAGE_INTERVAL))
        self.log("STREAM", ", ".join(f"{n} {r:g} Hz" for n, r in rates.items()))
        missing = [name for name, _ in pending.values()]
        if missing:
            self.log("STREAM", "not confirmed (refused, or every answer lost), kept at the "
                     f"vehicle's rate: {', '.join(missing)}")
        return missing

    def wait_home(self, timeout_s: float = 10.0) -> None:
        """Ask for HOME_POSITION until it arrives (the truth position needs it)."""
        deadline = time.monotonic() + timeout_s
        while self.analyzer.home is None:
            if time.monotonic() >= deadline:
                raise FlightTimeout(f"no HOME_POSITION within {timeout_s:g} s")
            self.command(_M.MAV_CMD_REQUEST_MESSAGE, (_M.MAVLINK_MSG_ID_HOME_POSITION,),
                         accept_temporarily_rejected=True)
            self.pump(0.2)

    def wait_armable(self, timeout_s: float = 30.0) -> bool:
        """Wait until SYS_STATUS shows the PREARM_CHECK health bit; False on time-out, or at
        once when the vehicle says only a restart lets it arm (:meth:`restart_needed`).

        SYS_STATUS is asked for once per wall second meanwhile (REQUEST_MESSAGE, no answer
        awaited): a paused simulation streams nothing, and a lossy link may lose the one
        that came. While it is not armable, MAV_CMD_RUN_PREARM_CHECKS goes out every 2 s
        (ArduPilot's: the vehicle answers with a ``PreArm: <reason>`` STATUSTEXT), and the
        latest reason is kept in :attr:`prearm_reason`.
        """
        bit = _M.MAV_SYS_STATUS_PREARM_CHECK
        sysid, compid = self.target
        deadline = time.monotonic() + timeout_s
        last_request = last_probe = -math.inf
        self.prearm_reason = None
        while time.monotonic() < deadline:
            status = self.inbox.take("SYS_STATUS", lambda m: True)
            if status is not None:
                self.inbox.take_all("SYS_STATUS", lambda m: True)
                if int(status.onboard_control_sensors_health) & bit:
                    self.prearm_reason = None
                    return True
            self.inbox.take_all("COMMAND_ACK",
                           lambda m: int(m.command) == _M.MAV_CMD_RUN_PREARM_CHECKS)
            for text in self._take_status_texts():
                if text.startswith("PreArm:"):
                    self.prearm_reason = text.removeprefix("PreArm:").strip()
            if self.restart_needed():
                self.log("FLIGHT", f"vehicle not armable until restarted: {self.prearm_reason}")
                return False
            now = time.monotonic()
            if now - last_request >= _STATUS_REQUEST_S:
                last_request = now
                self.send(_M.MAVLink_command_long_message(
                    sysid, compid, _M.MAV_CMD_REQUEST_MESSAGE, 0,
                    float(_M.MAVLINK_MSG_ID_SYS_STATUS), 0, 0, 0, 0, 0, 0))
            if status is not None and now - last_probe >= _PREARM_REQUEST_S:
                last_probe = now  # (only once a SYS_STATUS said not armable)
                self.send(_M.MAVLink_command_long_message(
                    sysid, compid, _M.MAV_CMD_RUN_PREARM_CHECKS, 0, 0, 0, 0, 0, 0, 0, 0))
            self.pump(0.1)
        self.log("FLIGHT", f"vehicle not reporting ready to arm after {timeout_s:g} s"
                 + (f" ({self.prearm_reason})" if self.prearm_reason else ""))
        return False

    def restart_needed(self) -> bool:
        """The latest pre-arm reason says only a restart of the autopilot clears it (a
        failure detected in an earlier flight: ArduCopter, too, arms only after a reboot)."""
        return self.prearm_reason is not None and bool(_RESTART_WORDS.search(self.prearm_reason))

    def _take_status_texts(self) -> list[str]:
        """The STATUSTEXTs waiting in the inbox, chunks put back together."""
        texts = []
        while (msg := self.inbox.take("STATUSTEXT", lambda m: True)) is not None:
            text = mavlink_text(msg.text)
            chunk_id = int(getattr(msg, "id", 0))
            if chunk_id == 0:
                texts.append(text)
                continue
            parts = self._status_chunks.setdefault(chunk_id, [])
            parts.append(text)
            if len(text) < 50:
                texts.append("".join(self._status_chunks.pop(chunk_id)))
        return texts

    def ensure_arming_mode(self, mode: int = COPTER_MODE_STABILIZE) -> None:
        """Unless the vehicle's HEARTBEAT shows a mode that allows arming
        (:data:`ARMING_MODES`), switch it to ``mode`` (STABILIZE, the mode it boots in, so
        that a flight after another starts as the first one did) and wait for a HEARTBEAT
        in that mode; the change is sent again when none comes (a lossy link).

        Raises
        ------
        CommandRefused
            The vehicle refused the mode change.
        FlightTimeout
            No HEARTBEAT in ``mode`` after :data:`_MODE_TRIES` changes.
        """
        if self.analyzer.custom_mode in ARMING_MODES:
            return
        before = self.analyzer.custom_mode
        for _ in range(_MODE_TRIES):
            self.set_mode(mode)
            deadline = time.monotonic() + _MODE_CONFIRM_S
            while time.monotonic() < deadline:
                if self.analyzer.custom_mode == mode:
                    self.log("FLIGHT", f"mode {mode_name(before)} does not allow arming: "
                             f"switched to {mode_name(mode)}")
                    return
                self.pump(0.05)
        raise FlightTimeout(f"no HEARTBEAT in mode {mode_name(mode)} after {_MODE_TRIES} "
                            "mode changes")

    def reboot(self, timeout_s: float = 60.0) -> None:
        """Restart the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, param1 = 1) and wait
        until it is back: heard again after :data:`_REBOOT_QUIET_S`, its HEARTBEAT past
        MAV_STATE_BOOT. The vehicle's stream rates are back to its defaults afterwards
        (ask for them again).

        Raises
        ------
        CommandRefused
            The vehicle refused (e.g. armed).
        VehicleNotFound
            Not back within ``timeout_s`` wall seconds.
        """
        self.log("FLIGHT", "restarting the autopilot (PREFLIGHT_REBOOT_SHUTDOWN)")
        self.command(_M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (1.0,), what="reboot")
        acked = time.monotonic()
        deadline = acked + timeout_s
        while True:
            now = time.monotonic()
            back = (now - acked >= _REBOOT_QUIET_S and self.wall_since_vehicle_s() < 0.5
                    and not self.analyzer.vehicle_booting)
            if back:
                break
            if now >= deadline:
                raise VehicleNotFound(f"the autopilot was not back {timeout_s:g} s after its "
                                      "restart")
            self.pump(0.05)
        self.prearm_reason = None
        self.log("FLIGHT", "autopilot restarted")

    def arm(self) -> None:
        """Arm (COMPONENT_ARM_DISARM p1 = 1); a HEARTBEAT showing it armed also confirms."""
        self.command(_M.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,), what="arm",
                     applied=lambda: self.analyzer.armed is True)
        self.analyzer.note_armed()  # accepted (else it raised)

    def disarm(self, force: bool = False) -> None:
        """Disarm (p2 = 21196 forces it in flight)."""
        self.command(_M.MAV_CMD_COMPONENT_ARM_DISARM, (0.0, 21196.0 if force else 0.0),
                     what="disarm", applied=lambda: self.analyzer.armed is False)

    def set_mode(self, custom_mode: int) -> None:
        """DO_SET_MODE with an ArduCopter mode number; a HEARTBEAT in that mode confirms."""
        self.command(_M.MAV_CMD_DO_SET_MODE,
                     (float(_M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(custom_mode)),
                     what=f"set mode {custom_mode}",
                     applied=lambda: self.analyzer.custom_mode == custom_mode)

    def start_mission(self) -> float:
        """MISSION_START; returns the vehicle time at which the mission started (s).

        A lost answer is made up for by MISSION_CURRENT (asked for with REQUEST_MESSAGE)
        showing the mission active; the start is then dated by the next clock value, exact
        when simulated time is held (SIM_PAUSE), and an event says so.
        """
        sysid, compid = self.target

        def running() -> bool:
            return self.analyzer.mission_state == _M.MISSION_STATE_ACTIVE

        def ask_progress() -> None:
            self.send(_M.MAVLink_command_long_message(
                sysid, compid, _M.MAV_CMD_REQUEST_MESSAGE, 0,
                float(_M.MAVLINK_MSG_ID_MISSION_CURRENT), 0, 0, 0, 0, 0, 0))

        self.command(_M.MAV_CMD_MISSION_START, (0.0, 0.0), what="mission start",
                     with_timesync=True, applied=running, read_back=ask_progress)
        analyzer = self.analyzer
        if not self.last_command_acked:
            # the mission runs but its ACK never came: the next clock value dates its start
            updates = analyzer.clock_updates
            self._ask_time_until(lambda: analyzer.mission_start_s is not None or (
                analyzer.clock_updates > updates and analyzer.clock_s is not None),
                first_request_now=True)
            if analyzer.mission_start_s is None:
                analyzer.mission_start_s = analyzer.clock_s
                self.log("FLIGHT", f"mission start dated t = {analyzer.clock_s:.3f} s by "
                         "the clock after it (its answer was lost)")
        # The ACK is dated by the next clock value: the TIMESYNC answer sent with it, or the
        # telemetry that follows. A paused vehicle streams nothing, so if that answer was
        # lost, ask the time again until one comes back.
        self._ask_time_until(lambda: analyzer.mission_start_s is not None,
                             first_request_now=False)
        assert analyzer.mission_start_s is not None
        self._note_lag(analyzer.mission_start_s)
        return analyzer.mission_start_s

    def _ask_time_until(self, done: Callable[[], bool], first_request_now: bool,
                        timeout_s: float = 10.0) -> None:
        """Pump until ``done()``, asking the vehicle's time (TIMESYNC) every
        ``_DATE_REQUEST_S`` (at once if ``first_request_now``): a paused vehicle streams
        nothing else that carries its clock.

        Raises
        ------
        FlightTimeout
            Not done within ``timeout_s`` (s wall).
        """
        deadline = time.monotonic() + timeout_s
        last_request = -math.inf if first_request_now else time.monotonic()
        while not done():
            now = time.monotonic()
            if now >= deadline:
                raise FlightTimeout("no telemetry after the mission start")
            if now - last_request >= _DATE_REQUEST_S:
                last_request = now
                self.send(_M.MAVLink_timesync_message(0, time.time_ns()))
            self.pump(0.02)

    # ------------------------------------------------------------------ results
    def report(self) -> FlightReport:
        """The table over what was received so far."""
        return self.analyzer.report()


def mode_name(mode: int | None) -> str:
    """ArduCopter's name of a mode number (``AUTO``), or the number."""
    if mode is None:
        return "unknown"
    entry = _M.enums["COPTER_MODE"].get(mode)
    return entry.name.removeprefix("COPTER_MODE_") if entry is not None else str(mode)
