"""The thesis table from telemetry, checked on synthetic MAVLink streams with known errors."""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np
import pytest

from fcu.mavlink.telemetry.record_relay import record_message
from flightdata.geometry import euler_from_quat
from flightdata.records import DetectionRecord, FaultRecord, OutcomeRecord, Record
from gcs.alignment import metres_per_degree, velocity_aided
from gcs.analysis import FlightAnalyzer
from gcs.errors import FlightError
from gcs.flight import _watch
from gcs.mavlink import decode_packet, mavlink2
from gcs.table import format_report

M = mavlink2
HOME_LAT_E7, HOME_LON_E7, HOME_ALT_MM = -353632610, 1491652300, 584000
NORTH_STEP_M = 1e-7 * metres_per_degree(HOME_LAT_E7 * 1e-7)[0]  # one degE7 of latitude


def quat_from_euler(roll: float, pitch: float, yaw: float) -> list[float]:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return [cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy]


class Stream:
    """Packs messages as a vehicle (1, 1) or a ground station (255, 190) and feeds them."""

    def __init__(self) -> None:
        self.vehicle = M.MAVLink(None, srcSystem=1, srcComponent=1)
        self.gcs = M.MAVLink(None, srcSystem=255, srcComponent=190)
        self.events: list[tuple[float | None, str, str]] = []
        self.analyzer = FlightAnalyzer(on_event=lambda e: self.events.append(
            (e.time_s, e.kind, e.text)))

    def v(self, msg: object) -> None:
        self._feed(self.vehicle, msg)

    def g(self, msg: object) -> None:
        self._feed(self.gcs, msg)

    def _feed(self, mav: object, msg: object) -> None:
        packet = bytes(msg.pack(mav))  # type: ignore[attr-defined]
        mav.seq = (mav.seq + 1) % 256  # type: ignore[attr-defined]
        decoded = decode_packet(packet)
        assert decoded is not None
        self.analyzer.feed(decoded)

    def boot(self) -> None:
        self.v(M.MAVLink_heartbeat_message(2, 3, 81, 0, 3, 3))
        self.v(M.MAVLink_home_position_message(HOME_LAT_E7, HOME_LON_E7, HOME_ALT_MM, 0, 0, 0,
                                               [1, 0, 0, 0], 0, 0, 0, 0))

    def tick(self, t_s: float, *, north_m: float, ref_north_m: float | None, roll: float,
             ref_roll: float, alt_m: float = 0.6, servo_us: int = 1400,
             vn_m_s: float = 0.0) -> None:
        ms = int(round(t_s * 1e3))
        self.v(M.MAVLink_attitude_message(ms, roll, 0, 0, 0, 0, 0))
        if ref_north_m is not None:
            self.v(M.MAVLink_position_target_local_ned_message(
                ms, 1, 0, ref_north_m, 0, -0.6, 0, 0, 0, 0, 0, 0, 0, 0))
            self.v(M.MAVLink_attitude_target_message(ms, 0, quat_from_euler(ref_roll, 0, 0),
                                                     0, 0, 0, 0.5))
        lat_e7 = HOME_LAT_E7 + int(round(north_m / NORTH_STEP_M))  # degE7: ~1.1 cm steps
        self.v(M.MAVLink_sim_state_message(*quat_from_euler(roll, 0, 0), roll, 0, 0,
                                           0, 0, 0, 0, 0, 0, lat_e7 * 1e-7, HOME_LON_E7 * 1e-7,
                                           HOME_ALT_MM * 1e-3 + alt_m,
                                           0, 0, vn_m_s, 0, 0, lat_e7, HOME_LON_E7))
        self.v(M.MAVLink_servo_output_raw_message(int(round(t_s * 1e6)) & 0xFFFFFFFF, 0,
                                                  *([servo_us] * 4), *([0] * 12)))


def north_of(t_s: float) -> float:
    """A smooth truth trajectory: 0.3 m/s mean, 2 cm wiggle at 1 Hz (m)."""
    return 0.3 * t_s + 0.02 * math.sin(2 * math.pi * t_s)


def vn_of(t_s: float) -> float:
    return 0.3 + 0.02 * 2 * math.pi * math.cos(2 * math.pi * t_s)


def test_errors_and_effort_of_a_known_stream() -> None:
    s = Stream()
    s.boot()
    # without a reference yet: not counted (controller idle)
    s.tick(0.00, north_m=0.0, ref_north_m=None, roll=0.0, ref_roll=0.0, servo_us=1100,
           vn_m_s=vn_of(0.0))
    s.tick(0.01, north_m=north_of(0.01), ref_north_m=None, roll=0.0, ref_roll=0.0,
           servo_us=1100, vn_m_s=vn_of(0.01))
    errs = []
    for k in range(2, 202):
        t = k * 0.01
        err = 0.004 if k % 2 else -0.002
        errs.append(err)
        s.tick(t, north_m=north_of(t), ref_north_m=north_of(t) + err, roll=0.01, ref_roll=0.03,
               vn_m_s=vn_of(t))
    # on the ground with a reference: not counted (the runner's "off the ground")
    s.tick(2.02, north_m=north_of(2.02), ref_north_m=north_of(2.02), roll=0.0, ref_roll=0.0,
           alt_m=0.0, servo_us=1100, vn_m_s=vn_of(2.02))
    rep = s.analyzer.report()
    assert rep.samples == 200
    expected_rms = math.sqrt(np.mean(np.square(errs)))
    # degE7 alone would be off by its 1.1 cm steps (3.2 mm RMS); the velocity-aided truth is
    # off by a constant, the mean of ~200 quantisation errors: 3.2 mm / sqrt(200) = 0.23 mm,
    # so 0.5 mm is about two of its standard deviations
    assert rep.rms["x"] == pytest.approx(expected_rms, abs=5e-4)
    assert rep.max["x"] == pytest.approx(0.004, abs=5e-4)
    assert rep.rms["y"] == pytest.approx(0.0, abs=1e-6)
    # the altitude went as float32 AMSL (584.6 m: ~3e-5 m resolution)
    assert rep.rms["z"] == pytest.approx(0.0, abs=1e-4)
    assert rep.rms["roll"] == pytest.approx(math.degrees(0.02), rel=1e-5)
    # 1400 us = 0.4 of full scale = 0.02 PWM per motor: effort 0.08
    assert rep.control_effort == pytest.approx(0.08, rel=1e-9)
    assert rep.flight_s == pytest.approx(2.0)


class LossyStream(Stream):
    """A stream whose vehicle packets are each lost with probability ``loss`` (seeded)."""

    def __init__(self, loss: float, seed: int) -> None:
        super().__init__()
        self.rng = np.random.default_rng(seed)
        self.loss = loss
        self.lossy = False

    def v(self, msg: object) -> None:
        if self.lossy and self.rng.random() < self.loss:
            self.vehicle.seq = (self.vehicle.seq + 1) % 256  # sent, never received
            return
        super().v(msg)


def fly_lossy(loss: float, seed: int, hover_s: float = 30.0) -> tuple[LossyStream, list[float]]:
    """``hover_s`` of flight at 100 Hz with a known error, then 0.6 s on the ground."""
    s = LossyStream(loss, seed)
    s.boot()
    s.lossy = True
    errs = []
    n = int(round(hover_s * 100))
    for k in range(n):
        t = k * 0.01
        err = 0.004 if k % 2 else -0.002
        errs.append(err)
        s.tick(t, north_m=north_of(t), ref_north_m=north_of(t) + err, roll=0.01,
               ref_roll=0.03, vn_m_s=vn_of(t))
    for k in range(n, n + 60):  # landed, references still coming: not flown
        t = k * 0.01
        s.tick(t, north_m=north_of(hover_s), ref_north_m=north_of(hover_s), roll=0.0,
               ref_roll=0.0, alt_m=0.0, vn_m_s=0.0)
    return s, errs


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_thirty_percent_loss_still_counts_the_whole_flight_time(seed: int) -> None:
    s, errs = fly_lossy(0.30, seed)
    rep = s.analyzer.report()
    # every sample whose truth, position and attitude reference all arrived: about
    # 0.7^3 = 34 % of 3000; the time between them is bridged
    assert 0.25 * 3000 < rep.samples < 0.45 * 3000
    assert rep.flight_s == pytest.approx(30.0, rel=0.01)  # the real 30 s, not ~10 s
    # the errors are those of a random subset of the samples: unbiased
    assert rep.rms["x"] == pytest.approx(math.sqrt(np.mean(np.square(errs))), abs=6e-4)
    assert rep.rms["roll"] == pytest.approx(math.degrees(0.02), rel=1e-4)


def test_a_reference_that_stops_for_longer_than_a_gap_is_an_idle_controller() -> None:
    s = Stream()
    s.boot()
    for k in range(300):  # 3 s airborne; the references stop for 1 s in the middle
        t = k * 0.01
        ref = None if 100 <= k < 200 else north_of(t)
        s.tick(t, north_m=north_of(t), ref_north_m=ref, roll=0.0, ref_roll=0.0,
               vn_m_s=vn_of(t))
    rep = s.analyzer.report()
    assert rep.samples == 200
    assert rep.flight_s == pytest.approx(2.0)
    series = s.analyzer.series()
    assert np.isnan(series.ref_pos_ned[150]).all() and not series.flying[150]


def test_series_bridges_lost_references_for_the_figures() -> None:
    s, _ = fly_lossy(0.30, 7, hover_s=5.0)
    series = s.analyzer.series()
    airborne = -series.pos_ned[:, 2] > 0.1
    # every airborne truth sample has a reference to plot (held exact or interpolated)
    assert np.isfinite(series.ref_pos_ned[airborne]).all()
    assert np.isfinite(series.ref_euler_rad[airborne]).all()
    gap = np.isfinite(series.ref_pos_ned[:, 0]) & ~series.flying & airborne
    assert gap.any()  # bridged samples are plotted but not scored
    offset = series.ref_pos_ned[gap, 0] - np.array([north_of(t) for t in series.time_s[gap]])
    # interpolated between references that are the truth plus -2 or +4 mm: within those
    # bounds, up to the curvature of the 2 cm wiggle over a gap (0.8 m/s^2 * (0.1 s)^2 / 8)
    assert offset.min() > -0.002 - 1e-3 and offset.max() < 0.004 + 1e-3


def test_velocity_aided_position_beats_the_quantisation() -> None:
    t = np.arange(0.0, 20.0, 0.01)
    truth = 0.5 * np.sin(0.7 * t) + 0.003 * np.sin(9.0 * t)
    vel = 0.35 * np.cos(0.7 * t) + 0.027 * np.cos(9.0 * t)
    step = 0.011  # m, one degE7 of latitude
    coarse = np.round(truth / step) * step
    t_gap = np.r_[t[:1000], t[1000:] + 5.0]  # a 5 s hole: two stretches, two anchors
    aided = velocity_aided(t_gap, coarse, vel)
    quantised_rms = float(np.sqrt(np.mean((coarse - truth) ** 2)))
    aided_rms = float(np.sqrt(np.mean((aided - truth) ** 2)))
    assert quantised_rms > 2.5e-3  # step / sqrt(12) = 3.2 mm
    assert aided_rms < 2e-4  # anchor error of ~10^3 unbiased fixes, trapezoid error ~1e-6


def test_float_degrees_are_used_near_0_0_where_they_are_finer() -> None:
    s = Stream()
    s.v(M.MAVLink_heartbeat_message(2, 3, 81, 0, 3, 3))
    s.v(M.MAVLink_home_position_message(0, 0, 0, 0, 0, 0, [1, 0, 0, 0], 0, 0, 0, 0))
    north_per_deg, east_per_deg = metres_per_degree(0.0)
    north_m, east_m = 0.0123456, -0.0071234  # not on the 1e-7 degree (1.1 cm) grid
    lat, lon = north_m / north_per_deg, east_m / east_per_deg
    s.v(M.MAVLink_attitude_message(1000, 0, 0, 0, 0, 0, 0))
    s.v(M.MAVLink_sim_state_message(1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, lat, lon, 0.6,
                                    0, 0, 0, 0, 0, int(round(lat * 1e7)),
                                    int(round(lon * 1e7))))
    rows = np.array(s.analyzer._truth)
    pos = s.analyzer.truth_ned(rows)
    assert pos is not None
    assert pos[0, :2] == pytest.approx([north_m, east_m], abs=1e-7)  # float32 near 0


def test_euler_from_quat_inverts_zyx() -> None:
    for angles in [(0.1, -0.2, 0.3), (-0.5, 0.4, -3.0), (0.0, 0.0, math.pi - 1e-6)]:
        assert euler_from_quat(quat_from_euler(*angles)) == pytest.approx(angles, abs=1e-9)


def _status(s: Stream, t_s: float, text: str, severity: int = 4) -> None:
    s.v(M.MAVLink_statustext_message(severity, text.encode(), 0, 0))
    s.v(M.MAVLink_attitude_message(int(round(t_s * 1e3)), 0, 0, 0, 0, 0, 0))  # dates it


def _record(s: Stream, record: Record, seq: int) -> None:
    """A record as the vehicle sends it (DEBUG_FLOAT_ARRAY FTC_REC)."""
    s.v(record_message(record, seq, record.time_s))


def _motor(t: float, action: str, motor: int, loe: float, fault_id: int,
           kind: str = "loe") -> FaultRecord:
    return FaultRecord(time_s=t, action=action, kind=kind,  # type: ignore[arg-type]
                       motor=motor, magnitude=loe if kind == "loe" else 1.0,
                       fault_id=fault_id, profile="step" if kind == "loe" else None)


def test_injections_follow_the_fault_records() -> None:
    s = Stream()
    s.boot()
    records = [
        _motor(22.0, "started", 3, 0.20, 1),
        _motor(38.0, "started", 1, 0.30, 2),
        _motor(48.0, "started", 4, 0.15, 3),
        # a replacement: the new fault starts, then the old one is cleared
        _motor(50.0, "started", 3, 0.45, 4),
        _motor(50.01, "cleared", 3, 0.20, 1),
        # two faults on one motor multiply their kept effectiveness: 1 - 0.75 * 0.8 = 0.4
        _motor(51.0, "started", 2, 0.25, 5),
        _motor(52.0, "started", 2, 0.20, 6),
        _motor(53.0, "cleared", 2, 0.20, 6),
    ]
    for seq, record in enumerate(records, 1):
        _record(s, record, seq)
        _record(s, record, seq)  # a repeat (the vehicle sends each record several times)
    final = {row["motor"]: row["injected"] for row in s.analyzer.report().loe}
    assert final == pytest.approx({1: 0.30, 2: 0.25, 3: 0.45, 4: 0.15})
    times = [(i.motor, round(i.loe, 9), i.time_s) for i in s.analyzer.injections]
    assert times[:3] == [(3, 0.2, 22.0), (1, 0.3, 38.0), (4, 0.15, 48.0)]
    assert (2, 0.4, 52.0) in times  # the second fault on motor 2, composed
    assert len(s.analyzer.faults) == len(records)  # repeats are dropped


def test_detection_latency_is_measured_from_the_injection() -> None:
    s = Stream()
    s.boot()
    _record(s, _motor(22.0, "started", 3, 0.20, 1), 1)
    _record(s, DetectionRecord(time_s=22.71, action="detected", kind="loe", motor=3,
                               magnitude=0.19), 2)
    _record(s, DetectionRecord(time_s=30.0, action="detected", kind="loe", motor=2,
                               magnitude=0.12), 3)  # false alarm
    d3, d2 = s.analyzer.detections
    assert (d3.motor, d3.percent) == (3, 19.0)
    assert d3.latency_s == pytest.approx(0.71, abs=1e-6)
    assert d2.latency_s is None and d2.false_alarm
    assert any(kind == "DETECT" and "latency 0.710 s" in text for _, kind, text in s.events)


def test_an_unsafe_outcome_record_is_a_crash_and_a_safe_one_is_not() -> None:
    s = Stream()
    s.boot()
    _record(s, OutcomeRecord(kind="landed", time_s=56.0, cause="touchdown",
                             impact_speed_m_s=0.1, tilt_deg=1.0), 1)
    assert not s.analyzer.crashed
    _record(s, OutcomeRecord(kind="crashed", time_s=80.0, cause="impact_speed",
                             impact_speed_m_s=2.6, tilt_deg=48.0), 2)
    assert s.analyzer.crashed and "crashed" in s.analyzer.crash_text
    assert s.analyzer.report().outcome is not None


def test_chunked_statustext_is_reassembled() -> None:
    s = Stream()
    s.boot()
    text = "crash: touchdown at 3.20 m/s, " + "x" * 40
    chunks = [text[i:i + 50] for i in range(0, len(text), 50)]
    for seq, chunk in enumerate(chunks):
        s.v(M.MAVLink_statustext_message(2, chunk.encode(), 7, seq))
    s.v(M.MAVLink_attitude_message(1000, 0, 0, 0, 0, 0, 0))
    assert s.analyzer.statustexts[-1] == (1.0, 2, text)
    assert not s.analyzer.crashed  # words are for people: only an outcome record decides


def test_timesync_answer_dates_a_command_even_at_time_zero() -> None:
    s = Stream()
    s.boot()
    s.g(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_MISSION_START, 0, 0, 0, 0, 0, 0, 0, 0))
    s.g(M.MAVLink_timesync_message(0, 123456789))
    s.v(M.MAVLink_command_ack_message(M.MAV_CMD_MISSION_START, 0, 0, 0, 255, 190))
    s.v(M.MAVLink_timesync_message(0, 123456789))  # tc1 = 0 ns: the paused vehicle at t = 0
    assert s.analyzer.mission_start_s == 0.0
    # a TIMESYNC that answers nobody of ours is not a clock
    s.v(M.MAVLink_timesync_message(5_000_000_000, 42))
    assert s.analyzer.clock_s == 0.0


def test_servo_time_is_unwrapped_against_the_clock() -> None:
    s = Stream()
    s.boot()
    t_s = 4300.0  # beyond 2^32 us = 4294.97 s
    s.v(M.MAVLink_attitude_message(int(t_s * 1e3), 0, 0, 0, 0, 0, 0))
    s.v(M.MAVLink_servo_output_raw_message(int(t_s * 1e6) & 0xFFFFFFFF, 0, *([1500] * 4),
                                           *([0] * 12)))
    assert s.analyzer._servo[-1][0] == pytest.approx(t_s)


def test_format_report_of_an_empty_flight_says_so() -> None:
    s = Stream()
    s.boot()
    text = format_report(s.analyzer.report(), title="t")
    assert "0 in-flight samples" in text and "x m" in text


def test_an_old_parameter_value_before_the_echo_is_not_called_a_refusal() -> None:
    s = Stream()
    s.boot()
    s.g(M.MAVLink_param_set_message(1, 1, b"FTC_MODE", 1.0, M.MAV_PARAM_TYPE_REAL32))
    # the answer to an earlier read, sent before the PARAM_SET arrived, then the echo
    s.v(M.MAVLink_param_value_message(b"FTC_MODE", 0.0, M.MAV_PARAM_TYPE_REAL32, 81, 26))
    s.v(M.MAVLink_param_value_message(b"FTC_MODE", 1.0, M.MAV_PARAM_TYPE_REAL32, 81, 26))
    s.v(M.MAVLink_attitude_message(1000, 0, 0, 0, 0, 0, 0))  # dates the answers
    params = [text for _, kind, text in s.events if kind == "PARAM"]
    assert params == ["FTC_MODE = 0 (asked for 1)", "FTC_MODE = 1"]
    assert not any("REFUSED" in text for text in params)
    assert s.analyzer.params["FTC_MODE"] == 1.0


def test_spin_phase_from_attitude_yawspeed() -> None:
    s = Stream()
    s.boot()
    assert s.analyzer.report().spin is None  # no ATTITUDE yet
    # 2 s calm, then a spin building up to -19.4 rad/s (time constant 1 s) for 8 s
    for k in range(1001):
        t = 0.01 * k
        rate = 0.2 * math.sin(t) if t < 2.0 else -19.4 * (1.0 - math.exp(-(t - 2.0)))
        s.v(M.MAVLink_attitude_message(int(round(t * 1e3)), 0, 0, 0, 0, 0, rate))
    spin = s.analyzer.report().spin
    assert spin is not None
    # |r| passes 3 rad/s at 2 - ln(1 - 3 / 19.4) = 2.168 s; one 10 ms sample of slack
    assert spin["start_s"] == pytest.approx(2.0 - math.log(1.0 - 3.0 / 19.4), abs=0.011)
    assert spin["end_s"] == pytest.approx(10.0)
    # mean over 6.08-10 s of the exponential approach: within 0.3 rad/s of -19.4
    assert spin["yaw_rate_rad_s"] == pytest.approx(-19.4, abs=0.3)
    assert spin["peak_rad_s"] == pytest.approx(19.4 * (1.0 - math.exp(-8.0)), rel=1e-6)
    assert "spin (yaw given up) from" in format_report(s.analyzer.report())


def test_normal_flight_has_no_spin() -> None:
    s = Stream()
    s.boot()
    for k in range(500):
        s.v(M.MAVLink_attitude_message(10 * k, 0, 0, 0, 0, 0, 0.8 * math.sin(0.05 * k)))
    assert s.analyzer.report().spin is None


_FLIGHT_STATES = (M.MAV_LANDED_STATE_ON_GROUND, M.MAV_LANDED_STATE_TAKEOFF,
                  M.MAV_LANDED_STATE_IN_AIR, M.MAV_LANDED_STATE_LANDING,
                  M.MAV_LANDED_STATE_ON_GROUND)


class _BehindStation:
    """A ground station so far behind the vehicle that its first pump handles the rest of a
    flight to the disarm (HEARTBEATs, landed states), what ``_watch`` sees when the machine
    is loaded: the time in the air never shows between two pumps. ``before`` are the landed
    states handled before ``_watch`` (by the start-up steps' own pumps on a slow link)."""

    def __init__(self, before: tuple[int, ...], during: tuple[int, ...]) -> None:
        self.stream = Stream()
        self.stream.boot()
        self.analyzer = self.stream.analyzer
        self.takeoffs_before_arming = self.analyzer.takeoffs
        self._states = during
        self.pumps = 0
        self._send(before, 0)

    def _send(self, states: tuple[int, ...], first_s: int) -> None:
        armed = M.MAV_MODE_FLAG_SAFETY_ARMED | M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        for i, state in enumerate(states, first_s + 1):
            self.stream.v(M.MAVLink_heartbeat_message(2, 3, armed, 3, 4, 3))
            self.stream.v(M.MAVLink_extended_sys_state_message(0, state))
            self.stream.v(M.MAVLink_attitude_message(1000 * i, 0, 0, 0, 0, 0, 0))

    def pump(self, wait_s: float = 0.0) -> int:
        self.pumps += 1
        self._send(self._states, 10)
        self.stream.v(M.MAVLink_heartbeat_message(2, 3, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                                  3, 3, 3))
        return 3 * len(self._states) + 1

    def confirm_param_faults(self) -> None:
        pass

    def wall_since_vehicle_s(self) -> float:
        return 0.0

    def log(self, kind: str, text: str) -> None:
        pass


@pytest.mark.parametrize("before, during", [
    ((), _FLIGHT_STATES),  # the whole flight in one pump
    (_FLIGHT_STATES[:3], _FLIGHT_STATES[3:]),  # in the air before the watch began
])
def test_a_flight_handled_in_one_pump_still_counts_its_time_in_the_air(
        before: tuple[int, ...], during: tuple[int, ...]) -> None:
    gs = _BehindStation(before, during)
    plan = SimpleNamespace(link_timeout_s=10.0, max_flight_s=300.0, wall_timeout_s=60.0)
    injector = SimpleNamespace(left=[])
    _watch(gs, plan, injector, 0.0, None, time.monotonic(),  # type: ignore[arg-type]
           gs.takeoffs_before_arming)
    assert gs.pumps == 1 and gs.analyzer.armed is False and gs.analyzer.takeoffs == 1


def test_a_flight_that_never_left_the_ground_is_a_failure() -> None:
    gs = _BehindStation((), (M.MAV_LANDED_STATE_ON_GROUND,))
    plan = SimpleNamespace(link_timeout_s=10.0, max_flight_s=300.0, wall_timeout_s=60.0)
    with pytest.raises(FlightError, match="without taking off"):
        _watch(gs, plan, SimpleNamespace(left=[]), 0.0, None,  # type: ignore[arg-type]
               time.monotonic(), gs.takeoffs_before_arming)
    assert gs.analyzer.takeoffs == 0


def test_velocity_aided_anchor_is_not_biased_by_a_vehicle_standing_still() -> None:
    # 40 s on the ground 4.4 mm from a grid line (one repeated quantisation error, 40 % of
    # the samples: a mean over all of them would sit 1.8 mm off), then 60 s of flight
    step = 0.011  # m, one degE7 of latitude
    t = np.arange(0.0, 100.0, 0.01)
    flying = t >= 40.0
    tf = np.where(flying, t - 40.0, 0.0)
    truth = 0.0044 + np.where(flying, 0.5 * np.sin(0.7 * tf) ** 2, 0.0)
    vel = np.where(flying, 0.7 * np.sin(1.4 * tf) * 0.5, 0.0)  # d/dt of 0.5 sin^2(0.7 t)
    coarse = np.round(truth / step) * step
    aided = velocity_aided(t, coarse, vel)
    assert abs(float(np.mean(coarse[~flying] - truth[~flying]))) > 4e-3  # the still error
    assert float(np.max(np.abs(aided - truth))) < 5e-4
