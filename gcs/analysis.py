"""The thesis table from telemetry: what a ground station can compute from the MAVLink stream.

:class:`FlightAnalyzer` is fed every packet of a flight in order (live from the link, or
from a .tlog) and produces a :class:`gcs.table.FlightReport` (:meth:`FlightAnalyzer.report`)
and the aligned arrays behind it as a :class:`flightdata.series.FlightSeries`
(:meth:`FlightAnalyzer.series`, for figures and recordings). ``ftc-gcs fly`` and
``ftc-gcs report`` run the same code over the same packets, so a report recomputed from a
flight's .tlog equals the table printed at the end of that flight.

Sources (vehicle messages; docs: fcu/mavlink/messages.py)
---------------------------------------------------------
=========================  ==================================================================
reference position         POSITION_TARGET_LOCAL_NED x, y, z (m, NED about the origin)
reference attitude         ATTITUDE_TARGET q -> ZYX roll, pitch, yaw
true attitude              SIM_STATE roll, pitch, yaw (simulator truth)
true position              SIM_STATE lat_int, lon_int (degE7; the float32 lat, lon where
                           finer) and alt (m AMSL), turned into NED about the origin with the
                           vehicle's flat-earth mapping (the origin from HOME_POSITION: home
                           latitude/longitude/altitude minus home's local x, y, z). degE7
                           resolves only ~1 cm horizontally, so north and east are the
                           integral of SIM_STATE's true velocity vn, ve anchored to the mean
                           geodetic position (:func:`gcs.alignment.truth_ned`)
motor commands             SERVO_OUTPUT_RAW servo1..4 = motors 1..4,
                           u = pwm_max (PWM_us - 1000) / 1000
LOE estimates              NAMED_VALUE_FLOAT LOE1..LOE4 (TSKF)
detections                 STATUSTEXT "motor N lost about P % effectiveness"
injections                 the simulator's own STATUSTEXT, whatever the route (a
                           SIM_MOTn_LOE / SIM_ENGINE_* parameter, MAV_CMD_INJECT_FAILURE, a
                           scenario's scheduled fault): "SIM: fault started: motor 3: loe 20 %
                           (step)", "SIM: injected motor 1: ...", "SIM: SIM motor 4: motor 4:
                           ...", and "... cleared/ended motor N: ..." when it goes away
=========================  ==================================================================

Time
----
Every vehicle message carrying ``time_boot_ms`` (simulated time), and every TIMESYNC answer
(``tc1``, the vehicle's simulated time in ns when it handled the request), advances the clock;
SIM_STATE (which has no time field) takes the clock of the message before it (the vehicle
sends ATTITUDE ahead of SIM_STATE at each tick: keep ATTITUDE at least as fast as
SIM_STATE). SERVO_OUTPUT_RAW's wrapping 32-bit ``time_usec`` is unwrapped against the clock.
An event the vehicle reports between ticks (a STATUSTEXT, a COMMAND_ACK, a PARAM_VALUE) is
dated with the first clock value that follows it: the vehicle answers in the tick whose
telemetry comes right after, and a command's effect starts at that tick's time. A ground
station that needs the exact time of a command sends a TIMESYNC request in the same datagram
(the vehicle handles both in one go, answering the TIMESYNC with the time the command took
effect, also while the simulation is paused); ``ftc-gcs fly`` does that for MISSION_START and
every injection.

Which samples count (mirrors ``sim.runner.flight_metrics``)
-----------------------------------------------------------
The runner takes the ticks where a reference was tracked and the vehicle was off the
ground. Here: each SIM_STATE sample at which a POSITION_TARGET_LOCAL_NED and an
ATTITUDE_TARGET younger than their own period exist (a reference that stops coming means an
idle controller), and the true altitude above home exceeds ``airborne_alt_m``
(0.1 mm: the plant holds it at exactly 0 while on the ground, so this is the runner's "not
on the ground" up to SIM_STATE's float32 resolution). References, truth and motor commands
are aligned by sample-and-hold on the vehicle's time stamps. Stream all five at the
autopilot's 100 Hz for a one-to-one match with the runner's ticks (``ftc-gcs fly`` asks for
that).

Errors are reference minus truth: RMS and maximum of |error| in x, y, z (m) and roll, pitch,
yaw (deg, wrapped to +-180); control effort is the mean over those samples of the sum of
the four motor commands (thesis Table 7.2: 0.0796 at hover), computed by
:mod:`flightdata.metrics` as the runner's are.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from flightdata.geometry import euler_from_quat
from flightdata.metrics import ScoredDetection, control_effort, score_detection, tracking_errors
from flightdata.records import (
    WIRE_NAME,
    DetectionRecord,
    FaultRecord,
    OutcomeRecord,
    Record,
    from_wire,
)
from flightdata.series import FlightEvent, FlightSeries
from flightdata.thesis import AXES
from gcs.alignment import Aligned, align, hold, truth_ned
from gcs.mavlink import MAVLinkMessage, mavlink2, read_tlog
from gcs.table import FlightReport, Injection

__all__ = ["FlightAnalyzer", "analyze_tlog", "replay_tlog"]

_M = mavlink2
PWM_MAX = 0.05  # motor command at full power (Qball-X4, thesis Table 7.1)
_UINT32_US = 1 << 32


def _text(raw: object) -> str:
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


class FlightAnalyzer:
    """Turns the packets of a flight, in order, into events and a :class:`FlightReport`.

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
        self.clock_s: float | None = None
        self._pending: list[_Pending] = []
        self._chunks: dict[int, list[str]] = {}
        # samples
        # t, roll, pitch, yaw, lat_e7, lon_e7, alt, lat (float32 deg), lon (float32 deg), vn, ve
        self._truth: list[tuple[float, ...]] = []
        self._pos_ref: list[tuple[float, float, float, float]] = []
        self._att_ref: list[tuple[float, float, float, float]] = []
        self._servo: list[tuple[float, float, float, float, float]] = []
        self._loe_est: dict[int, list[tuple[float, float]]] = {m: [] for m in (1, 2, 3, 4)}
        # state
        self.home: tuple[int, int, int, float, float, float] | None = None  # e7, e7, mm, xyz
        self.params: dict[str, float] = {}
        self.armed: bool | None = None
        self.custom_mode: int | None = None
        self.landed_state: int | None = None
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
        self.events: list[FlightEvent] = []  # every event emitted, in order

    # ------------------------------------------------------------------ feeding
    def feed(self, msg: MAVLinkMessage, unix_time_us: int | None = None) -> None:
        """Account for one packet (sent by us or received), in log order."""
        kind = msg.get_type()
        if kind == "BAD_DATA":
            return
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
            self._sent_params[_text(msg.param_id)] = _f32(msg.param_value)
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

    def _on_attitude_target(self, msg: MAVLinkMessage) -> None:
        t = self._timed(msg)
        self._att_ref.append((t, *euler_from_quat(msg.q)))

    def _on_position_target(self, msg: MAVLinkMessage) -> None:
        t = self._timed(msg)
        self._pos_ref.append((t, float(msg.x), float(msg.y), float(msg.z)))

    def _on_sim_state(self, msg: MAVLinkMessage) -> None:
        if self.clock_s is None:
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
        name = _text(msg.name)
        if len(name) == 4 and name.startswith("LOE") and name[3] in "1234":
            self._loe_est[int(name[3])].append((t, float(msg.value)))

    def _on_home(self, msg: MAVLinkMessage) -> None:
        self.home = (int(msg.latitude), int(msg.longitude), int(msg.altitude),
                     float(msg.x), float(msg.y), float(msg.z))

    def _on_heartbeat(self, msg: MAVLinkMessage) -> None:
        armed = bool(int(msg.base_mode) & _M.MAV_MODE_FLAG_SAFETY_ARMED)
        mode = int(msg.custom_mode)
        if armed != self.armed:
            if self.armed is not None or armed:
                self._emit(self.clock_s, "ARM", "armed" if armed else "disarmed")
            self.armed = armed
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
        text = _text(msg.text)
        chunk_id = int(getattr(msg, "id", 0))
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
        self._later("param", (_text(msg.param_id), float(msg.param_value)))

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
            requested = self._sent_params.pop(name, None)
            if requested is not None:
                ok = value == requested
                self._emit(t, "PARAM", f"{name} = {value:g}" + ("" if ok else
                           f" (REFUSED: asked for {requested:g})"))
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
        if _text(msg.name) != WIRE_NAME:
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

    # ------------------------------------------------------------------ results
    def truth_ned(self, rows: np.ndarray) -> np.ndarray | None:
        """True NED positions (m) of SIM_STATE rows; None until HOME_POSITION is known
        (:func:`gcs.alignment.truth_ned`)."""
        return None if self.home is None else truth_ned(rows, self.home)

    def _aligned(self) -> Aligned | None:
        """Truth, references and the flying mask on the SIM_STATE samples (None: no data)."""
        truth = np.array(self._truth, dtype=float).reshape(-1, 11)
        if self.home is None or not len(truth) or not self._pos_ref or not self._att_ref:
            return None
        return align(truth, np.array(self._pos_ref), np.array(self._att_ref), self.home,
                     self.airborne_alt_m)

    def _servo_sorted(self) -> np.ndarray:
        servo = np.array(self._servo, dtype=float).reshape(-1, 5)
        return servo[np.argsort(servo[:, 0], kind="stable")]

    def series(self) -> FlightSeries:
        """The aligned time series behind the table, for plots and recordings.

        The same alignment as :meth:`report` (sample-and-hold of the references on the
        SIM_STATE samples, the same flying mask), so errors over ``flying`` rows are exactly
        the ones the table's RMS and maximum are taken over. Motor commands and LOE
        estimates keep their own message times; telemetry carries no wind, no position
        estimate and no take-off/landing phase (those fields are None). Fault onsets are
        the injections that took effect (not the clearings).
        """
        al = self._aligned()
        servo = self._servo_sorted()
        loe_t = tuple(np.array([e[0] for e in self._loe_est[m]], dtype=float)
                      for m in (1, 2, 3, 4))
        loe_v = tuple(np.array([e[1] for e in self._loe_est[m]], dtype=float)
                      for m in (1, 2, 3, 4))
        if al is None:
            t = np.zeros(0)
            pos = euler = ref_pos = ref_euler = np.zeros((0, 3))
            flying = np.zeros(0, dtype=bool)
        else:
            t = al.truth[:, 0]
            pos, euler = al.pos, al.truth[:, 1:4]
            ref_pos = np.where(al.fresh_pos[:, None], al.pos_ref[al.i_pos, 1:4], np.nan)
            ref_euler = np.where(al.fresh_att[:, None], al.att_ref[al.i_att, 1:4], np.nan)
            flying = al.flying
        return FlightSeries(
            time_s=t, flying=flying, pos_ned=pos, euler_rad=euler, ref_pos_ned=ref_pos,
            ref_euler_rad=ref_euler, pwm_time_s=servo[:, 0], pwm=servo[:, 1:5],
            pwm_max=self.pwm_max, loe_estimate_time_s=loe_t, loe_estimate=loe_v,
            loe_injected=self.injected_loe_at(t),
            fault_times_s=tuple(sorted({i.time_s for i in self.injections if i.loe != 0.0})),
            events=tuple(self.events))

    def injected_loe_at(self, time_s: np.ndarray) -> np.ndarray:
        """The loss of effectiveness in force on motors 1..4 at each time, shape (n, 4).

        From the simulator's announcements (:attr:`injections`), held until the next change;
        NaN where the fault in force has no constant effectiveness (lock, hard-over).
        """
        out = np.zeros((len(time_s), 4))
        for inj in sorted(self.injections, key=lambda i: i.time_s):
            out[np.asarray(time_s) >= inj.time_s - 1e-9, inj.motor - 1] = inj.loe
        return out

    def report(self) -> FlightReport:
        """The table over the flight so far."""
        al = self._aligned()
        if al is None:
            return self._make_report()
        truth, pos, flying = al.truth, al.pos, al.flying
        pos_ref, att_ref, i_pos, i_att = al.pos_ref, al.att_ref, al.i_pos, al.i_att
        t = truth[:, 0]
        n = int(np.count_nonzero(flying))
        if n == 0:
            return self._make_report()
        errors = tracking_errors(pos_ref[i_pos[flying], 1:4], pos[flying],
                                 att_ref[i_att[flying], 1:4], truth[flying, 1:4])
        rms: dict[str, float | None] = {axis: fig.rms for axis, fig in errors.items()}
        mx: dict[str, float | None] = {axis: fig.max for axis, fig in errors.items()}
        effort = None
        if self._servo:
            servo = self._servo_sorted()
            i_srv, have = hold(servo[:, 0], t[flying], fresh_s=None)
            if np.all(have):
                effort = control_effort(servo[i_srv, 1:5])
        period = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        t_end = float(t[flying][-1])
        return self._make_report(rms=rms, mx=mx, effort=effort, flight_s=n * period,
                                 samples=n, t_end=t_end)

    def _make_report(self, *, rms: dict[str, float | None] | None = None,
                     mx: dict[str, float | None] | None = None, effort: float | None = None,
                     flight_s: float = 0.0, samples: int = 0,
                     t_end: float | None = None) -> FlightReport:
        empty: dict[str, float | None] = {axis: None for axis, _ in AXES}
        return FlightReport(rms=dict(empty) if rms is None else rms,
                            max=dict(empty) if mx is None else mx, control_effort=effort,
                            flight_s=flight_s, samples=samples,
                            mission_start_s=self.mission_start_s, loe=self._loe_table(t_end),
                            injections=list(self.injections), detections=list(self.detections),
                            crashed=self.crashed, vehicle_time_s=self.clock_s,
                            params=dict(self.params), outcome=self.outcome,
                            faults=list(self.faults))

    def _loe_table(self, t_end: float | None) -> list[dict[str, Any]]:
        rows = []
        for motor in (1, 2, 3, 4):
            inj = [i for i in self.injections if i.motor == motor]
            est = self._loe_est[motor]
            if t_end is not None:
                est = [e for e in est if e[0] <= t_end + 1e-9] or est
            dets = [d for d in self.detections
                    if d.motor == motor and d.record.action == "detected"]
            rows.append({
                "motor": motor,
                "injected": inj[-1].loe if inj else 0.0,
                "injected_at_s": inj[-1].time_s if inj else None,
                "estimated": est[-1][1] if est else None,
                "detected_at_s": dets[0].time_s if dets else None,
                "latency_s": dets[0].latency_s if dets else None,
            })
        return rows


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


_HANDLERS: dict[str, Callable[[FlightAnalyzer, MAVLinkMessage], None]] = {
    "ATTITUDE_TARGET": FlightAnalyzer._on_attitude_target,
    "POSITION_TARGET_LOCAL_NED": FlightAnalyzer._on_position_target,
    "SIM_STATE": FlightAnalyzer._on_sim_state,
    "SERVO_OUTPUT_RAW": FlightAnalyzer._on_servo,
    "NAMED_VALUE_FLOAT": FlightAnalyzer._on_named_value,
    "HOME_POSITION": FlightAnalyzer._on_home,
    "HEARTBEAT": FlightAnalyzer._on_heartbeat,
    "EXTENDED_SYS_STATE": FlightAnalyzer._on_extended_sys_state,
    "MISSION_CURRENT": FlightAnalyzer._on_mission_current,
    "MISSION_ITEM_REACHED": FlightAnalyzer._on_item_reached,
    "STATUSTEXT": FlightAnalyzer._on_statustext,
    "DEBUG_FLOAT_ARRAY": FlightAnalyzer._on_debug_float_array,
    "COMMAND_ACK": FlightAnalyzer._on_command_ack,
    "PARAM_VALUE": FlightAnalyzer._on_param_value,
    "MISSION_ACK": FlightAnalyzer._on_mission_ack,
    "TIMESYNC": FlightAnalyzer._on_timesync,
}


def replay_tlog(path: str | Path, *, pwm_max: float = PWM_MAX,
                on_event: Callable[[FlightEvent], None] | None = None) -> FlightAnalyzer:
    """A :class:`FlightAnalyzer` fed with every packet of a recorded flight."""
    analyzer = FlightAnalyzer(pwm_max=pwm_max, on_event=on_event)
    for record in read_tlog(path):
        analyzer.feed(record.message, record.unix_time_us)
    return analyzer


def analyze_tlog(path: str | Path, *, pwm_max: float = PWM_MAX) -> FlightReport:
    """The :class:`FlightReport` of a recorded flight (what ``ftc-gcs report`` prints)."""
    return replay_tlog(path, pwm_max=pwm_max).report()
