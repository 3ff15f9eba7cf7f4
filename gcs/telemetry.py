"""Reading a flight's MAVLink packets: the vehicle clock, dated events, samples and records.

:class:`TelemetryReader` is fed every packet of a flight in order (live from the link, or from
a .tlog). It finds the vehicle, follows its clock, keeps its state (armed, mode, landed state,
mission progress, home, parameters), dates what it reports as :class:`FlightEvent` (ACKs,
STATUSTEXT, modes, mission progress, injections, detections, the outcome), reads the
simulator's fault, detection and outcome records, and collects the samples the thesis table
is computed from. Which message gives which quantity, and the table and series computed from
the samples: :mod:`gcs.analysis` (:class:`gcs.analysis.FlightAnalyzer` is a reader).

Time
----
Every vehicle message carrying ``time_boot_ms`` (simulated time), and every TIMESYNC answer
(``tc1``, the vehicle's simulated time in ns when it handled the request), advances the clock;
SIM_STATE (which has no time field) takes the clock of the message before it (the vehicle
sends ATTITUDE ahead of SIM_STATE at each tick: keep ATTITUDE at least as fast as
SIM_STATE); a SIM_STATE that finds the clock where the previous one left it (every
time-stamped message of its tick was lost) cannot be dated and is dropped.
SERVO_OUTPUT_RAW's wrapping 32-bit ``time_usec`` is unwrapped against the clock. An event
the vehicle reports between ticks (a STATUSTEXT, a COMMAND_ACK, a PARAM_VALUE) is dated with
the first clock value that follows it: the vehicle answers in the tick whose telemetry comes
right after, and a command's effect starts at that tick's time. A ground station that needs
the exact time of a command sends a TIMESYNC request in the same datagram (the vehicle
handles both in one go, answering the TIMESYNC with the time the command took effect, also
while the simulation is paused); ``ftc-gcs fly`` does that for MISSION_START and every
injection.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from flightdata.geometry import euler_from_quat
from flightdata.metrics import ScoredDetection, score_detection
from flightdata.records import (
    WIRE_NAME,
    DetectionRecord,
    FaultRecord,
    OutcomeRecord,
    Record,
    from_wire,
)
from flightdata.series import FlightEvent
from gcs.mavlink import MAVLinkMessage, mavlink2
from gcs.table import Injection

__all__ = ["BOOT_PROGRESS_PREFIXES", "PWM_MAX", "TelemetryReader", "mavlink_text"]

_M = mavlink2
BOOT_PROGRESS_PREFIXES = ("preparing:", "ready:")
"""A booting vehicle's progress lines (STATUSTEXT) start so: ``preparing: 37 of 131 kernels
compiled, 41 s``."""
PWM_MAX = 0.05  # motor command at full power (Qball-X4, thesis Table 7.1)
_UINT32_US = 1 << 32


def mavlink_text(raw: object) -> str:
    """A MAVLink char[] field (a param_id, a STATUSTEXT's text) as text, up to its first NUL."""
    if isinstance(raw, bytes | bytearray):
        raw = bytes(raw).decode("ascii", errors="replace")
    return str(raw).split("\x00", 1)[0]


def _f32(value: float) -> float:
    return float(np.float32(value))


@dataclass
class _Pending:
    """A vehicle answer waiting for the next clock value to be dated."""

    kind: str
    payload: Any


class TelemetryReader:
    """Turns the packets of a flight, in order, into the vehicle's state, dated events and samples.

    Parameters
    ----------
    pwm_max : float
        Motor command at PWM 2000 us.
    airborne_alt_m : float
        True altitude above home beyond which the vehicle counts as airborne, m (the plant
        holds it at exactly 0 on the ground; raised to two float32 steps of SIM_STATE.alt at
        home's altitude when those are coarser).
    on_event : callable or None
        Called with each :class:`FlightEvent` as soon as it is dated.
    """

    def __init__(self, *, pwm_max: float = PWM_MAX, airborne_alt_m: float = 1e-4,
                 on_event: Callable[[FlightEvent], None] | None = None) -> None:
        self.pwm_max = pwm_max
        self.airborne_alt_m = airborne_alt_m
        self._on_event = on_event
        self.vehicle: tuple[int, int] | None = None  # (sysid, compid)
        self.packets = 0  # packets fed (both directions)
        self.undated_truth = 0  # SIM_STATE samples dropped: no clock value of their own
        self.clock_s: float | None = None
        self.clock_updates = 0  # time-stamped messages seen (a held clock does not move)
        self._pending: list[_Pending] = []
        self._chunks: dict[int, list[str]] = {}
        # samples
        # t, roll, pitch, yaw, lat_e7, lon_e7, alt, lat (float32 deg), lon (float32 deg), vn, ve
        self._truth: list[tuple[float, ...]] = []
        self._pos_ref: list[tuple[float, float, float, float]] = []
        self._att_ref: list[tuple[float, float, float, float]] = []
        self._servo: list[tuple[float, float, float, float, float]] = []
        self._yaw_rate: list[tuple[float, float]] = []  # t, ATTITUDE yawspeed (rad/s)
        self._loe_est: dict[int, list[tuple[float, float]]] = {m: [] for m in (1, 2, 3, 4)}
        # state
        self.home: tuple[int, int, int, float, float, float] | None = None  # e7, e7, mm, xyz
        self.params: dict[str, float] = {}  # the latest PARAM_VALUE of each
        # the parameters when the flight ended (landed and disarmed): what it flew with, not
        # what a ground station set afterwards (its injected faults cleared)
        self.params_at_end: dict[str, float] | None = None
        self.armed: bool | None = None
        self.custom_mode: int | None = None
        self.landed_state: int | None = None
        self.takeoffs = 0  # changes of the landed state into IN_AIR, however briefly seen
        self.mission_seq: int | None = None
        self.mission_state: int | None = None
        self.mission_total: int | None = None
        self.reached: list[tuple[float | None, int]] = []
        self.statustexts: list[tuple[float | None, int, str]] = []
        self.acks: list[tuple[float | None, int, int]] = []
        self.mission_acks: list[tuple[float | None, int]] = []
        self.mission_start_s: float | None = None
        self.injections: list[Injection] = []
        self.detections: list[ScoredDetection] = []
        self.faults: list[FaultRecord] = []
        self.outcome: OutcomeRecord | None = None
        self.crashed = False  # the outcome is a crash or a fly-away
        self.crash_text = ""
        self._sent_params: dict[str, float] = {}
        self._sent_timesync: set[int] = set()  # ts1 of our TIMESYNC requests
        # motor -> {fault id: its loss of effectiveness, NaN when not a constant loss}
        self._active_faults: dict[int, dict[int, float]] = {}
        self._record_seqs: set[int] = set()
        self.malformed_records = 0
        self.last_vehicle_unix_us: int | None = None
        self.vehicle_booting = False  # the vehicle's last HEARTBEAT said MAV_STATE_BOOT
        self.boot_progress = ""  # the newest progress line of a booting vehicle
        self.boot_progress_lines = 0  # progress lines seen
        self.events: list[FlightEvent] = []  # every event emitted, in order

    # ------------------------------------------------------------------ feeding
    def feed(self, msg: MAVLinkMessage, unix_time_us: int | None = None) -> None:
        """Account for one packet (sent by us or received), in log order."""
        kind = msg.get_type()
        if kind == "BAD_DATA":
            return
        self.packets += 1
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.vehicle is None and kind == "HEARTBEAT" and self._is_autopilot(msg):
            self.vehicle = src
        if self.vehicle is not None and src == self.vehicle:
            if unix_time_us is not None:
                self.last_vehicle_unix_us = unix_time_us
            self._vehicle_message(kind, msg)
        elif self.vehicle is None or src[0] != self.vehicle[0]:
            self._gcs_message(kind, msg)

    @staticmethod
    def _is_autopilot(msg: MAVLinkMessage) -> bool:
        return (int(msg.autopilot) != _M.MAV_AUTOPILOT_INVALID
                and int(msg.type) not in (_M.MAV_TYPE_GCS, _M.MAV_TYPE_GIMBAL,
                                          _M.MAV_TYPE_ADSB, _M.MAV_TYPE_ONBOARD_CONTROLLER))

    def _emit(self, time_s: float | None, kind: str, text: str) -> None:
        event = FlightEvent(time_s, kind, text)
        self.events.append(event)
        if self._on_event is not None:
            self._on_event(event)

    def _advance(self, time_s: float) -> None:
        self.clock_updates += 1
        if self.clock_s is None or time_s >= self.clock_s:
            self.clock_s = time_s
        pending, self._pending = self._pending, []
        for p in pending:
            self._resolve(p, time_s)

    def _later(self, kind: str, payload: Any) -> None:
        self._pending.append(_Pending(kind, payload))

    # ------------------------------------------------------------------ ground-station side
    def _gcs_message(self, kind: str, msg: MAVLinkMessage) -> None:
        if kind == "PARAM_SET":
            self._sent_params[mavlink_text(msg.param_id)] = _f32(msg.param_value)
        elif kind == "TIMESYNC" and int(msg.tc1) == 0:
            self._sent_timesync.add(int(msg.ts1))

    # ------------------------------------------------------------------ vehicle side
    def _vehicle_message(self, kind: str, msg: MAVLinkMessage) -> None:
        handler = _HANDLERS.get(kind)
        if handler is not None:
            handler(self, msg)
        elif hasattr(msg, "time_boot_ms"):
            self._advance(int(msg.time_boot_ms) * 1e-3)

    def _timed(self, msg: MAVLinkMessage) -> float:
        t = int(msg.time_boot_ms) * 1e-3
        self._advance(t)
        return t

    def _on_attitude(self, msg: MAVLinkMessage) -> None:
        t = self._timed(msg)
        self._yaw_rate.append((t, float(msg.yawspeed)))

    def _on_attitude_target(self, msg: MAVLinkMessage) -> None:
        t = self._timed(msg)
        self._att_ref.append((t, *euler_from_quat(msg.q)))

    def _on_position_target(self, msg: MAVLinkMessage) -> None:
        t = self._timed(msg)
        self._pos_ref.append((t, float(msg.x), float(msg.y), float(msg.z)))

    def _on_sim_state(self, msg: MAVLinkMessage) -> None:
        if self.clock_s is None:
            return
        if self._truth and self._truth[-1][0] == self.clock_s:
            # the clock did not advance since the last SIM_STATE: every time-stamped
            # message of this tick was lost, so the sample cannot be dated; dropped
            self.undated_truth += 1
            return
        self._truth.append((self.clock_s, float(msg.roll), float(msg.pitch), float(msg.yaw),
                            float(msg.lat_int), float(msg.lon_int), float(msg.alt),
                            float(msg.lat), float(msg.lon), float(msg.vn), float(msg.ve)))

    def _on_servo(self, msg: MAVLinkMessage) -> None:
        raw_us = int(msg.time_usec)
        if self.clock_s is None:
            t = raw_us * 1e-6
        else:
            # unwrap the uint32 microseconds against the clock
            clock_us = int(round(self.clock_s * 1e6))
            base = clock_us - clock_us % _UINT32_US
            candidates = (base - _UINT32_US + raw_us, base + raw_us, base + _UINT32_US + raw_us)
            t = min(candidates, key=lambda c: abs(c - clock_us)) * 1e-6
        k = self.pwm_max / 1000.0
        self._servo.append((t, (msg.servo1_raw - 1000) * k, (msg.servo2_raw - 1000) * k,
                            (msg.servo3_raw - 1000) * k, (msg.servo4_raw - 1000) * k))

    def _on_named_value(self, msg: MAVLinkMessage) -> None:
        t = self._timed(msg)
        name = mavlink_text(msg.name)
        if len(name) == 4 and name.startswith("LOE") and name[3] in "1234":
            self._loe_est[int(name[3])].append((t, float(msg.value)))

    def _on_home(self, msg: MAVLinkMessage) -> None:
        self.home = (int(msg.latitude), int(msg.longitude), int(msg.altitude),
                     float(msg.x), float(msg.y), float(msg.z))

    def note_armed(self) -> None:
        """The vehicle accepted an arm command: armed from now on, until a HEARTBEAT says
        otherwise (the latest one seen may have left before the command arrived)."""
        if self.armed is not True:
            self._emit(self.clock_s, "ARM", "armed")
            self.armed = True

    def _on_heartbeat(self, msg: MAVLinkMessage) -> None:
        self.vehicle_booting = int(msg.system_status) == _M.MAV_STATE_BOOT
        armed = bool(int(msg.base_mode) & _M.MAV_MODE_FLAG_SAFETY_ARMED)
        mode = int(msg.custom_mode)
        if armed != self.armed:
            if self.armed is not None or armed:
                self._emit(self.clock_s, "ARM", "armed" if armed else "disarmed")
            self.armed = armed
            if not armed and self.takeoffs > 0 and self.params_at_end is None:
                self.params_at_end = dict(self.params)
        if mode != self.custom_mode:
            name = _M.enums["COPTER_MODE"][mode].name.removeprefix("COPTER_MODE_") \
                if mode in _M.enums["COPTER_MODE"] else f"MODE_{mode}"
            self._emit(self.clock_s, "MODE", f"mode {name} ({mode})")
            self.custom_mode = mode

    def _on_extended_sys_state(self, msg: MAVLinkMessage) -> None:
        state = int(msg.landed_state)
        if state != self.landed_state:
            name = _M.enums["MAV_LANDED_STATE"][state].name.removeprefix("MAV_LANDED_STATE_") \
                if state in _M.enums["MAV_LANDED_STATE"] else str(state)
            self._emit(self.clock_s, "LANDED", f"landed state {name}")
            self.landed_state = state
            if state == _M.MAV_LANDED_STATE_IN_AIR:
                self.takeoffs += 1

    def _on_mission_current(self, msg: MAVLinkMessage) -> None:
        seq = int(msg.seq)
        state = int(getattr(msg, "mission_state", 0))
        self.mission_total = int(getattr(msg, "total", 0xFFFF))
        if (seq, state) != (self.mission_seq, self.mission_state):
            if self.mission_start_s is not None:
                names = {0: "unknown", 1: "no mission", 2: "not started", 3: "active",
                         4: "paused", 5: "complete"}
                self._emit(self.clock_s, "MISSION",
                           f"current item {seq}, mission {names.get(state, str(state))}")
            self.mission_seq, self.mission_state = seq, state

    def _on_item_reached(self, msg: MAVLinkMessage) -> None:
        self._later("reached", int(msg.seq))

    def _on_statustext(self, msg: MAVLinkMessage) -> None:
        text = mavlink_text(msg.text)
        chunk_id = int(getattr(msg, "id", 0))
        if self.vehicle_booting and text.startswith(BOOT_PROGRESS_PREFIXES):
            self.boot_progress = text  # (fcu.mavlink.transport.boot_beacon's lines)
            self.boot_progress_lines += 1
        if chunk_id == 0:
            self._later("status", (int(msg.severity), text))
            return
        parts = self._chunks.setdefault(chunk_id, [])
        parts.append(text)
        if len(text) < 50:
            del self._chunks[chunk_id]
            self._later("status", (int(msg.severity), "".join(parts)))

    def _on_command_ack(self, msg: MAVLinkMessage) -> None:
        self._later("ack", (int(msg.command), int(msg.result)))

    def _on_param_value(self, msg: MAVLinkMessage) -> None:
        self._later("param", (mavlink_text(msg.param_id), float(msg.param_value)))

    def _on_mission_ack(self, msg: MAVLinkMessage) -> None:
        self._later("mission_ack", int(msg.type))

    def _on_timesync(self, msg: MAVLinkMessage) -> None:
        # an answer to one of our requests (ts1 echoed): tc1 is the vehicle's time, ns
        # (tc1 may be 0 at simulated time 0, so the echo, not tc1, tells an answer)
        ts1 = int(msg.ts1)
        if ts1 in self._sent_timesync:
            self._sent_timesync.discard(ts1)
            self._advance(int(msg.tc1) * 1e-9)

    # ------------------------------------------------------------------ dated answers
    def _resolve(self, p: _Pending, t: float) -> None:
        if p.kind == "status":
            severity, text = p.payload
            self.statustexts.append((t, severity, text))
            self._emit(t, "STATUS", f"[{_severity(severity)}] {text}")
        elif p.kind == "ack":
            command, result = p.payload
            self.acks.append((t, command, result))
            self._emit(t, "ACK", f"{_command_name(command)} {_result_name(result)}")
            self._ack_effects(t, command, result)
        elif p.kind == "param":
            name, value = p.payload
            self.params[name] = value
            requested = self._sent_params.get(name)
            if requested is not None:
                # a value other than the one asked for is a refusal (the ground station
                # says so with the vehicle's reason) or an answer sent before our PARAM_SET
                # arrived: the request stays open for the echo that may follow
                ok = value == requested
                if ok:
                    del self._sent_params[name]
                self._emit(t, "PARAM", f"{name} = {value:g}" + ("" if ok else
                           f" (asked for {requested:g})"))
        elif p.kind == "reached":
            self.reached.append((t, p.payload))
            self._emit(t, "MISSION", f"item {p.payload} reached")
        elif p.kind == "mission_ack":
            self.mission_acks.append((t, p.payload))

    def _ack_effects(self, t: float, command: int, result: int) -> None:
        accepted = result == _M.MAV_RESULT_ACCEPTED
        if command == _M.MAV_CMD_MISSION_START and accepted and self.mission_start_s is None:
            self.mission_start_s = t

    def _on_debug_float_array(self, msg: MAVLinkMessage) -> None:
        """Fault, detection and outcome records (DEBUG_FLOAT_ARRAY ``FTC_REC``,
        :mod:`flightdata.records`): the first copy of each sequence number counts."""
        if mavlink_text(msg.name) != WIRE_NAME:
            return
        try:
            seq, record = from_wire(int(msg.array_id), msg.data, int(msg.time_usec) * 1e-6)
        except (ValueError, IndexError):
            self.malformed_records += 1
            return
        if seq in self._record_seqs:
            return
        self._record_seqs.add(seq)
        self._on_record(record)

    def _on_record(self, record: Record) -> None:
        t = record.time_s
        if isinstance(record, FaultRecord):
            self.faults.append(record)
            self._emit(t, "FAULT", record.text())
            if record.motor is not None:
                self._motor_fault(record)
        elif isinstance(record, DetectionRecord):
            scored = score_detection(record, self.faults)
            self.detections.append(scored)
            lat = "" if scored.latency_s is None else \
                f", latency {scored.latency_s:.3f} s after the injection"
            alarm = " (FALSE ALARM: no injection explains it)" if scored.false_alarm else ""
            self._emit(t, "DETECT", f"{record.text()}{lat}{alarm}{self._since_start(t)}")
        else:
            self.outcome = record
            self._emit(t, "OUTCOME", record.text())
            if record.kind in ("crashed", "flyaway"):
                self.crashed = True
                self.crash_text = record.text()
                self._emit(t, "CRASH", record.text())

    def _motor_fault(self, record: FaultRecord) -> None:
        """The loss of effectiveness in force on the record's motor: active faults' kept
        effectiveness multiply (as the simulator composes them); NaN for a lock, a
        hard-over or a time-varying loss, which no constant gamma describes."""
        assert record.motor is not None
        motor = record.motor
        active = self._active_faults.setdefault(motor, {})
        before = _loe_in_force(active)
        if record.action == "started":
            constant = record.kind == "total_loss" or (record.kind == "loe"
                                                        and record.profile == "step")
            magnitude = 1.0 if record.kind in ("total_loss", "float") else record.magnitude
            active[record.fault_id] = magnitude if constant or record.kind == "float" \
                else math.nan
        elif record.action in ("ended", "cleared"):
            active.pop(record.fault_id, None)
        else:
            return
        after = _loe_in_force(active)
        if self.armed is False and self.takeoffs > 0:
            return  # the flight is over: a change now (faults cleared) is not part of it
        if not (after == before or (math.isnan(after) and math.isnan(before))):
            self._injected(record.time_s, motor, after, record.text())

    def _injected(self, t: float, motor: int, loe: float, text: str) -> None:
        inj = Injection(motor=motor, loe=loe, time_s=t, text=text)
        self.injections.append(inj)
        self._emit(t, "INJECT", f"motor {motor} loss of effectiveness {loe:.3f} in force"
                   f"{self._since_start(t)}")

    def _since_start(self, t: float) -> str:
        if self.mission_start_s is None:
            return ""
        return f", mission +{t - self.mission_start_s:.3f} s"


def _loe_in_force(active: dict[int, float]) -> float:
    """The losses of effectiveness composed: 1 - the product of the kept effectivenesses
    (0 with no fault, the fault's own value with one; NaN if any is NaN)."""
    losses = list(active.values())
    if len(losses) <= 1:
        return losses[0] if losses else 0.0
    kept = 1.0
    for loe in losses:
        kept *= 1.0 - loe
    return 1.0 - kept


def _severity(severity: int) -> str:
    names = _M.enums["MAV_SEVERITY"]
    return names[severity].name.removeprefix("MAV_SEVERITY_") if severity in names else \
        str(severity)


def _command_name(command: int) -> str:
    names = _M.enums["MAV_CMD"]
    if command == _M.MAVLINK_MSG_ID_SET_MODE:
        return "SET_MODE"
    return names[command].name.removeprefix("MAV_CMD_") if command in names else str(command)


def _result_name(result: int) -> str:
    names = _M.enums["MAV_RESULT"]
    return names[result].name.removeprefix("MAV_RESULT_") if result in names else str(result)


_HANDLERS: dict[str, Callable[[TelemetryReader, MAVLinkMessage], None]] = {
    "ATTITUDE": TelemetryReader._on_attitude,
    "ATTITUDE_TARGET": TelemetryReader._on_attitude_target,
    "POSITION_TARGET_LOCAL_NED": TelemetryReader._on_position_target,
    "SIM_STATE": TelemetryReader._on_sim_state,
    "SERVO_OUTPUT_RAW": TelemetryReader._on_servo,
    "NAMED_VALUE_FLOAT": TelemetryReader._on_named_value,
    "HOME_POSITION": TelemetryReader._on_home,
    "HEARTBEAT": TelemetryReader._on_heartbeat,
    "EXTENDED_SYS_STATE": TelemetryReader._on_extended_sys_state,
    "MISSION_CURRENT": TelemetryReader._on_mission_current,
    "MISSION_ITEM_REACHED": TelemetryReader._on_item_reached,
    "STATUSTEXT": TelemetryReader._on_statustext,
    "DEBUG_FLOAT_ARRAY": TelemetryReader._on_debug_float_array,
    "COMMAND_ACK": TelemetryReader._on_command_ack,
    "PARAM_VALUE": TelemetryReader._on_param_value,
    "MISSION_ACK": TelemetryReader._on_mission_ack,
    "TIMESYNC": TelemetryReader._on_timesync,
}
