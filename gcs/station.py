"""A MAVLink ground station for one vehicle: streams, parameters, missions, arming, injections.

:class:`GroundStation` is a :class:`gcs.link.Link` (heartbeat, receiving and recording every
packet, COMMAND_LONG with its COMMAND_ACK) that drives a vehicle the way any ground station
does: it asks for the telemetry the table needs, sets parameters and checks the PARAM_VALUE
echo, uploads missions with the MISSION_COUNT / MISSION_REQUEST_INT / MISSION_ITEM_INT /
MISSION_ACK exchange, arms, switches modes, starts the mission and injects faults, timing
them on the vehicle's clock.

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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NoReturn

import numpy as np

from flightdata.series import FlightEvent
from gcs.errors import CommandRefused, FlightTimeout, MissionRejected, VehicleNotFound
from gcs.faults import FaultSpec
from gcs.mavlink import mavlink2
from gcs.mission import WireItem, home_item
from gcs.parameters import ParameterClient, same_float32
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
    "InjectionTiming",
    "mode_name",
    "same_float32",
]

_M = mavlink2
# ArduCopter's mode numbers, from the dialect (ardupilotmega's COPTER_MODE enum)
COPTER_MODE_STABILIZE = _M.COPTER_MODE_STABILIZE
COPTER_MODE_AUTO = _M.COPTER_MODE_AUTO
COPTER_MODE_GUIDED = _M.COPTER_MODE_GUIDED
COPTER_MODE_LAND = _M.COPTER_MODE_LAND
ARMING_MODES = frozenset({_M.COPTER_MODE_STABILIZE, _M.COPTER_MODE_ALT_HOLD,
                          _M.COPTER_MODE_GUIDED, _M.COPTER_MODE_LOITER})
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

_MISSION_NUDGE_S = 1.0  # s wall without a MISSION_REQUEST before we nudge the upload, at most
_MISSION_STALL_S = 15.0  # s wall without progress before an upload starts over
_MISSION_UPLOADS = 3  # uploads started before giving up
_MISSION_TYPE_WORDS = {_M.MAV_MISSION_TYPE_MISSION: "mission",
                       _M.MAV_MISSION_TYPE_FENCE: "geofence",
                       _M.MAV_MISSION_TYPE_RALLY: "rally points"}
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


@dataclass(frozen=True)
class InjectionTiming:
    """Where an injection landed against its target (vehicle simulated time, s).

    Attributes
    ----------
    fault : FaultSpec
    target_s : float
        Vehicle time the schedule asked for (mission start + ``fault.at_s``).
    sent_at_s : float
        Vehicle clock when the command left.
    achieved_s : float or None
        Vehicle time the fault took effect (None: never confirmed).
    """

    fault: FaultSpec
    target_s: float
    sent_at_s: float
    achieved_s: float | None

    @property
    def error_s(self) -> float | None:
        """Achieved minus target, s."""
        return None if self.achieved_s is None else self.achieved_s - self.target_s


@dataclass
class _InFlight:
    """An injection sent and not yet seen taking effect."""

    fault: FaultSpec
    target_s: float  # s, vehicle time it is meant for
    sent_s: float  # s, vehicle clock when it first left
    scheduled: bool  # on the vehicle's clock (no lag to learn from)
    by_param: bool  # it travels as a PARAM_SET, effective on arrival
    last_sent_wall_s: float  # s, wall clock (time.time) when it last left
    # s, vehicle clock when it last left: that of the first message received after it left
    # (None until one is); a station behind on its messages still handles older ones, whose
    # clock is earlier than the vehicle's when the PARAM_SET reached it
    last_sent_s: float | None = None
    received: bool = False  # the vehicle echoed its PARAM_SET
    attempts: int = 1

    def param_name(self) -> str | None:
        """The parameter it sets when it travels as a PARAM_SET (else None)."""
        if not self.by_param:
            return None
        return self.fault.param or f"SIM_MOT{self.fault.motor}_LOE"

    def param_value(self) -> float:
        return self.fault.value if self.fault.param is not None else self.fault.loe


_RESEND_AFTER_S = 0.5  # s of vehicle time without an echo (at least 3 link lags) to resend
_MAX_SENDS = 5  # a PARAM_SET injection is sent this many times at most


class GroundStation(ParameterClient):
    """A ground station on one link to one vehicle (see the module docstring); arguments as
    :class:`gcs.link.Link`."""

    def __init__(self, conn: Any, url: str, *, tlog: TlogWriter | None = None,
                 events: EventLog | None = None, signing_key: bytes | None = None) -> None:
        super().__init__(conn, url, tlog=tlog, events=events, signing_key=signing_key)
        self.injection_timing: list[InjectionTiming] = []
        self._inflight: list[_InFlight] = []
        self._lag_samples_s: list[float] = []
        self.prearm_reason: str | None = None  # the latest "PreArm: ..." STATUSTEXT's reason
        self._status_chunks: dict[int, list[str]] = {}
        # what the injections changed, to undo after the flight: parameter -> value before
        self._restore_params: dict[str, float] = {}
        self._motor_faults_commanded = False  # INJECT_FAILURE motor faults were sent
        self.held_time = False  # this flight set SIM_PAUSE = 1 and has not let go yet

    def _note_event(self, event: FlightEvent) -> None:
        if event.kind == "INJECT":
            self._match_injection(event)

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
            reply = self._take("MESSAGE_INTERVAL", lambda m: int(m.message_id) == msg_id)
            return reply is not None and int(reply.interval_us) == interval_us

        def read_back() -> None:
            self._take_all("MESSAGE_INTERVAL", lambda m: int(m.message_id) == msg_id)
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
        a fast link: :meth:`_retry_wait_s`; ~18 s in all); a stream is confirmed when the
        interval read back is the one asked for. The COMMAND_ACKs cannot
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
        self._take_all("MESSAGE_INTERVAL", lambda m: True)
        give_up = time.monotonic() + sum(_STREAM_ROUNDS_S)
        rounds = 0
        while pending and time.monotonic() < give_up:
            for msg_id, (_, interval_us) in pending.items():
                for command, p1, p2 in ((_M.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, interval_us),
                                        (_M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id, 0)):
                    self.send(_M.MAVLink_command_long_message(
                        sysid, compid, command, 0, float(p1), float(p2), 0, 0, 0, 0, 0))
            sent_at = time.monotonic()
            deadline = sent_at + self._retry_wait_s(
                _STREAM_ROUNDS_S[min(rounds, len(_STREAM_ROUNDS_S) - 1)])
            rounds += 1
            while pending and time.monotonic() < deadline:
                reply = self._wait_reply(["MESSAGE_INTERVAL"], lambda m: True, 0.05)
                if reply is not None and int(reply.message_id) in pending:
                    msg_id = int(reply.message_id)
                    if int(reply.interval_us) == pending[msg_id][1]:
                        del pending[msg_id]
                        if rounds == 1:  # (later, the answer may be to an earlier round)
                            self._note_round_trip(sent_at)
            self._take_all("COMMAND_ACK", lambda m: int(m.command) in (
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
            status = self._take("SYS_STATUS", lambda m: True)
            if status is not None:
                self._take_all("SYS_STATUS", lambda m: True)
                if int(status.onboard_control_sensors_health) & bit:
                    self.prearm_reason = None
                    return True
            self._take_all("COMMAND_ACK",
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
        while (msg := self._take("STATUSTEXT", lambda m: True)) is not None:
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

    def _note_lag(self, effect_s: float) -> None:
        sent = self._sent_clock
        if sent is not None:
            self._lag_samples_s.append(max(0.0, effect_s - sent))

    # ------------------------------------------------------------------ missions
    def upload_mission(self, items: Sequence[WireItem], *, timeout_s: float = 120.0,
                       mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> None:
        """Upload ``items`` (seq 1..n; home from HOME_POSITION is added as seq 0); with
        ``mission_type`` FENCE or RALLY, a geofence or rally points (seq 0..n-1, no home).

        Over a lossy link: when no request comes for a while (:meth:`_retry_wait_s`, 1 s at
        most), the upload is nudged (MISSION_COUNT
        again before the first request; else the item after the last one asked for, which
        the vehicle either wanted or answers by asking again for the one it misses; after
        the last item, that item again, which a vehicle that finished answers with its
        MISSION_ACK again); an upload the vehicle cancelled (it timed out) or that made no
        progress for :data:`_MISSION_STALL_S` starts over, up to :data:`_MISSION_UPLOADS`
        times.

        Raises
        ------
        MissionRejected
            A MISSION_ACK other than ACCEPTED (with the vehicle's reason; ``result`` holds
            the MAV_MISSION_RESULT).
        FlightTimeout
            The vehicle stopped asking for items.
        """
        sysid, compid = self.target
        what = _MISSION_TYPE_WORDS.get(mission_type, f"mission type {mission_type}")
        if mission_type == _M.MAV_MISSION_TYPE_MISSION:
            home = home_item()
            if self.analyzer.home is not None:
                lat_e7, lon_e7, alt_mm = self.analyzer.home[:3]
                home = home_item(lat_e7 * 1e-7, lon_e7 * 1e-7, alt_mm * 1e-3)
            wire = [home, *items]
            self.log("MISSION", f"uploading {len(items)} items (+ home)")
        else:
            wire = list(items)
            self.log("MISSION", f"uploading {what}: {len(items)} items")
        count = len(wire)
        deadline = time.monotonic() + timeout_s
        last_seq = -1
        for upload in range(_MISSION_UPLOADS):
            if upload:
                self.log("MISSION", f"upload stalled after item {last_seq}: starting over")
            last_seq = self._upload_once(wire, deadline, mission_type)
            if last_seq == count:
                self.log("MISSION", f"upload of {len(items)} items accepted" if what == "mission"
                         else f"upload of {what}: {len(items)} items accepted")
                return
        raise FlightTimeout(f"{what} upload stalled after item {last_seq} of {count - 1} "
                            f"({_MISSION_UPLOADS} uploads)")

    def _upload_once(self, wire: Sequence[WireItem], deadline: float,
                     mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> int:
        """One upload; returns ``len(wire)`` when accepted, else the last seq asked for."""
        sysid, compid = self.target
        count = len(wire)
        home_first = mission_type == _M.MAV_MISSION_TYPE_MISSION
        for kind in ("MISSION_ACK", "MISSION_REQUEST_INT", "MISSION_REQUEST", "STATUSTEXT"):
            self._take_all(kind, lambda m: True)

        # time.monotonic() of the last send and of the last progress; whether the last send
        # was a nudge (a round trip is measured only from an answer to a request, never from a
        # nudge, which an answer to an earlier send may follow)
        sent_at = progress_at = 0.0
        nudged = False

        def send_count() -> None:
            nonlocal sent_at
            self.send(_M.MAVLink_mission_count_message(sysid, compid, count, mission_type))
            sent_at = time.monotonic()

        def send_item(seq: int) -> None:
            nonlocal sent_at
            self.send(wire[seq].to_message(seq, sysid, compid, current=home_first and seq == 0,
                                           mission_type=mission_type))
            sent_at = time.monotonic()

        send_count()
        progress_at = sent_at
        last_seq = -1
        while (now := time.monotonic()) < deadline and now - progress_at < _MISSION_STALL_S:
            reply = self._wait_reply(["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"],
                                     lambda m: int(getattr(m, "mission_type", 0)) == mission_type,
                                     self._retry_wait_s(_MISSION_NUDGE_S))
            if reply is None:
                nudged = True
                if last_seq < 0:
                    send_count()
                else:
                    send_item(min(last_seq + 1, count - 1))
                continue
            if reply.get_type() == "MISSION_ACK":
                result = int(reply.type)
                if result == _M.MAV_MISSION_ACCEPTED:
                    return count
                if result == _M.MAV_MISSION_OPERATION_CANCELLED:
                    return last_seq  # the vehicle timed out: start over
                self._mission_rejected(wire, result, last_seq, mission_type)
            seq = int(reply.seq)
            if not 0 <= seq < count:
                continue
            if seq > last_seq:
                progress_at = time.monotonic()
                if not nudged:
                    self._note_round_trip(sent_at)
            last_seq = seq
            send_item(seq)
            nudged = False
        return last_seq

    def _mission_rejected(self, wire: Sequence[WireItem], result: int, last_seq: int,
                          mission_type: int = _M.MAV_MISSION_TYPE_MISSION) -> NoReturn:
        name = _M.enums["MAV_MISSION_RESULT"][result].name.removeprefix(
            "MAV_MISSION_") if result in _M.enums["MAV_MISSION_RESULT"] else str(result)
        reason = self._refusal_reason()
        if last_seq == len(wire) - 1:
            where = " after the last item"  # the vehicle judged the whole mission
        elif last_seq >= 0:
            where = f" at item {last_seq} ({wire[last_seq].describe()})"
        else:
            where = ""
        what = "" if mission_type == _M.MAV_MISSION_TYPE_MISSION else \
            f"{_MISSION_TYPE_WORDS.get(mission_type, str(mission_type))}: "
        raise MissionRejected(f"{what}{name}{where}" + (f": {reason}" if reason else ""),
                              result=result)

    # ------------------------------------------------------------------ faults
    def lead_s(self) -> float:
        """How early (vehicle seconds) a command must leave to take effect on time.

        The median of the measured lags between the clock when a command left and the time it
        took effect (parameters, mission start), at least one telemetry tick (10 ms).
        """
        if not self._lag_samples_s:
            return 0.01
        return max(0.01, float(np.median(self._lag_samples_s[-9:])))

    def inject(self, fault: FaultSpec, target_s: float, *, via: str = "command") -> None:
        """Inject ``fault`` at vehicle time ``target_s``.

        Parameters
        ----------
        fault : FaultSpec
        target_s : float
            Vehicle (simulated) time it is meant for.
        via : {"command", "param"}
            ``command`` (motor faults): PARAM_SET SIM_FI_LOE = loe (echo awaited), then
            MAV_CMD_INJECT_FAILURE (unit MOTOR 101, type WRONG 4, instance = motor; type OK
            0 when loe = 0) with param4 = ``target_s``: the vehicle schedules the fault on its
            own clock, so it takes effect at ``target_s`` exactly whatever the link's delay
            or load; this blocks until the vehicle acknowledges (send it ahead of time).
            ``param``: PARAM_SET SIM_MOTn_LOE = loe now (ArduPilot-SITL style, effective
            when it arrives), with a TIMESYNC request in the same datagram dating it; send
            it :meth:`lead_s` ahead. Parameter faults (SIM_BARO_GLITCH...) are always a
            PARAM_SET of the second kind; one whose echo does not come back is sent again
            (:meth:`resend_lost_injections`).
        """
        sysid, compid = self.target
        clock = self.analyzer.clock_s if self.analyzer.clock_s is not None else math.nan
        scheduled = via == "command" and fault.motor is not None and fault.loe > 0
        flight = _InFlight(fault, target_s, clock, scheduled,
                           by_param=fault.param is not None or via == "param",
                           last_sent_wall_s=time.time())
        self._inflight.append(flight)
        start = self.analyzer.mission_start_s
        rel = f" (mission +{target_s - start:.3f} s)" if start is not None else ""
        self.log("INJECT", f"{'scheduling' if scheduled else 'sending'} {fault.describe()} "
                 f"for t = {target_s:.3f} s{rel}"
                 + ("" if scheduled else f", lead {self.lead_s():.3f} s"))

        if scheduled:
            self._note_change("SIM_FI_LOE")
            self._motor_faults_commanded = True
            self.set_param("SIM_FI_LOE", fault.loe)
            self.command(_M.MAV_CMD_INJECT_FAILURE,
                         (101.0, 4.0, float(fault.motor or 0), float(target_s)),
                         what=f"INJECT_FAILURE motor {fault.motor}")
        elif not flight.by_param:  # a clear (loe 0): effective when it arrives
            self.send(_M.MAVLink_command_long_message(
                sysid, compid, _M.MAV_CMD_INJECT_FAILURE, 0, 101.0, 0.0,
                float(fault.motor or 0), 0.0, 0.0, 0.0, 0.0), with_timesync=True)
        else:
            name = flight.param_name()
            assert name is not None
            self._note_change(name)
            self._send_param_injection(flight)

    def _note_change(self, name: str) -> None:
        """Remember the value ``name`` had before an injection first changed it (0 when it
        was never read: the fault parameters' value when no fault is in force)."""
        if name not in self._restore_params:
            before = self.param_names.get(name, self.analyzer.params.get(name, 0.0))
            self._restore_params[name] = float(before)

    def clear_injected_faults(self) -> None:
        """Undo this flight's injections: motor faults sent as INJECT_FAILURE are cleared
        (type OK, all motors: also those scheduled and not yet due), and every parameter an
        injection changed (SIM_MOTn_LOE, SIM_BARO_GLITCH, SIM_FI_LOE...) goes back to its
        value before the flight, so the next flight starts healthy.

        Raises
        ------
        FlightError
            A command or parameter the vehicle refused or never answered.
        """
        if self._motor_faults_commanded:
            self.command(_M.MAV_CMD_INJECT_FAILURE, (101.0, 0.0, 0.0),
                         what="INJECT_FAILURE motor all OK (clear)")
            self._motor_faults_commanded = False
        for name, before in list(self._restore_params.items()):
            self.set_param(name, before)
            del self._restore_params[name]
        self.log("INJECT", "the flight's injected faults cleared")

    @property
    def injected_anything(self) -> bool:
        """Faults were sent in this flight and not yet cleared."""
        return self._motor_faults_commanded or bool(self._restore_params)

    def _send_param_injection(self, flight: _InFlight) -> None:
        """PARAM_SET of an injection, with a TIMESYNC request in the same datagram dating it."""
        name = flight.param_name()
        assert name is not None
        sysid, compid = self.target
        self.send(_M.MAVLink_param_set_message(sysid, compid, name.encode("ascii"),
                                               float(flight.param_value()),
                                               _M.MAV_PARAM_TYPE_REAL32), with_timesync=True)

    def resend_lost_injections(self, clock_s: float) -> None:
        """Send again each PARAM_SET injection whose echo has not come back
        ``_RESEND_AFTER_S`` (or three link lags) of vehicle time after it left, up to
        ``_MAX_SENDS`` times: on a lossy link a lost PARAM_SET would be a lost fault. A
        repeat is harmless (the vehicle keeps a parameter fault it already holds).

        The wait counts from the clock of the first message received after the PARAM_SET
        left, not from the clock the station had then: a station behind on its messages
        (a loaded machine, a fast simulation) would otherwise count time the PARAM_SET spent
        waiting for nothing and send it again before its echo could arrive."""
        waiting = [f for f in self._inflight if f.by_param and not f.received]
        if not waiting:  # the usual case, on every clock update
            return
        wait_s = max(_RESEND_AFTER_S, 3.0 * self.lead_s())
        for flight in waiting:
            name = flight.param_name()
            assert name is not None  # by_param
            echoed = self.analyzer.params.get(name)
            if echoed is not None and same_float32(echoed, flight.param_value()):
                flight.received = True
            elif flight.last_sent_s is None:
                received = self.received_wall_s
                if received is None or received >= flight.last_sent_wall_s:
                    flight.last_sent_s = clock_s  # the vehicle's clock once it could have it
            elif clock_s - flight.last_sent_s > wait_s and flight.attempts < _MAX_SENDS:
                flight.attempts += 1
                flight.last_sent_s, flight.last_sent_wall_s = None, time.time()
                self.log("INJECT", f"no echo of {name} = {flight.param_value():g} after "
                         f"{wait_s:.2f} s: sending it again (attempt {flight.attempts})")
                self._send_param_injection(flight)

    def _match_injection(self, event: FlightEvent) -> None:
        """An INJECT event from the analyzer: pair it with the oldest in-flight motor fault."""
        for i, flight in enumerate(self._inflight):
            fault = flight.fault
            if fault.motor is not None and f"motor {fault.motor} " in event.text:
                del self._inflight[i]
                achieved = event.time_s
                timing = InjectionTiming(fault, flight.target_s, flight.sent_s, achieved)
                self.injection_timing.append(timing)
                if achieved is not None:
                    # the link's delay, to send the next one ahead of time (a resent one
                    # says nothing of it)
                    if not flight.scheduled and flight.attempts == 1:
                        self._lag_samples_s.append(max(0.0, achieved - flight.sent_s))
                    self.log("INJECT", f"motor {fault.motor} took effect at t = "
                             f"{achieved:.3f} s, timing error {timing.error_s:+.3f} s")
                return

    def confirm_param_faults(self) -> None:
        """Pair parameter faults (SIM_BARO_GLITCH...) with their PARAM_VALUE echoes."""
        still = []
        for flight in self._inflight:
            fault = flight.fault
            value = None if fault.param is None else self.analyzer.params.get(fault.param)
            if value is not None and same_float32(value, fault.value):
                self.injection_timing.append(
                    InjectionTiming(fault, flight.target_s, flight.sent_s, None))
            else:
                still.append(flight)
        self._inflight = still

    def pending_injections(self) -> list[FaultSpec]:
        """Faults sent but not yet confirmed."""
        return [flight.fault for flight in self._inflight]

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
