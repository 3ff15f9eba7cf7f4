"""The extended telemetry of the vehicle process, as ArduPilot SITL streams it, against truth.

Rates are counted in simulated time: between two ATTITUDE messages (20 Hz, time-stamped) a
stream of rate r sends r times the simulated interval, within one message (the schedule's
phase). The vehicle sends in order over loopback, so the ground station's log keeps it.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence

import numpy as np
import pytest
from vehicle_harness import Gcs, M

from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ
from sim.world.dryden import dryden_sigmas_m_s

GUIDED, LAND = 4, 9
ACCEPTED = M.MAV_RESULT_ACCEPTED
SPEEDUP = "5"
EXTENDED = ("RAW_IMU", "SCALED_IMU", "SCALED_PRESSURE", "VIBRATION", "EKF_STATUS_REPORT",
            "AHRS2", "NAV_CONTROLLER_OUTPUT", "WIND", "RC_CHANNELS", "BATTERY_STATUS")
GOOD_FLAGS = (M.EKF_ATTITUDE | M.EKF_VELOCITY_HORIZ | M.EKF_VELOCITY_VERT
              | M.EKF_POS_HORIZ_REL | M.EKF_POS_HORIZ_ABS | M.EKF_POS_VERT_ABS
              | M.EKF_PRED_POS_HORIZ_REL | M.EKF_PRED_POS_HORIZ_ABS)


def rate_hz_in(log: Sequence, kind: str) -> tuple[int, float]:
    """(count of ``kind`` between the first and last ATTITUDE of ``log``, simulated s)."""
    idx = [i for i, m in enumerate(log) if m.get_type() == "ATTITUDE"]
    assert len(idx) > 20, "too few ATTITUDE messages to time the window"
    span_s = (log[idx[-1]].time_boot_ms - log[idx[0]].time_boot_ms) / 1e3
    count = sum(1 for m in log[idx[0]:idx[-1]] if m.get_type() == kind)
    return count, span_s


def sim_window(gcs: Gcs, seconds: float) -> list:
    """Everything the vehicle sends over the next ``seconds`` of *simulated* time (bounded
    by a generous wall-clock wait: a loaded machine runs the vehicle slower)."""
    since = gcs.mark()
    first = gcs.wait("ATTITUDE", timeout_s=30.0, since=since)
    end_ms = first.time_boot_ms + 1e3 * seconds
    gcs.wait("ATTITUDE", lambda m: m.time_boot_ms >= end_ms, timeout_s=30.0 + 20.0 * seconds,
             since=since)
    return gcs.messages(since=since)


def barrier(gcs: Gcs) -> int:
    """A command's ACK: everything sent to the vehicle before it has been handled; returns
    the log index from which the vehicle's messages follow it."""
    ack = gcs.command(M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE)
    assert ack.result == ACCEPTED
    return gcs.mark()


def no_idle_disarm(gcs: Gcs) -> None:
    """DISARM_DELAY 0: armed on the ground, the vehicle waits for the take-off however long
    a loaded machine takes to send it (10 s simulated is 1 s wall at 10x)."""
    assert gcs.param_set("DISARM_DELAY", 0.0).param_value == 0.0


def wind_ned(m) -> np.ndarray:
    """The air's velocity (NED, m/s) from a WIND message (direction it comes from)."""
    d = math.radians(m.direction)
    return np.array([-m.speed * math.cos(d), -m.speed * math.sin(d), m.speed_z])


def test_extended_messages_stream_at_their_rates_and_obey_the_groups(start_vehicle,
                                                                     gcs: Gcs) -> None:
    start_vehicle("--speedup", SPEEDUP, outs=[gcs.port])
    gcs.wait_heartbeat()
    log = sim_window(gcs, 20.0)
    for kind in EXTENDED:
        msg_id = getattr(M, f"MAVLINK_MSG_ID_{kind}")
        count, span_s = rate_hz_in(log, kind)
        expected = DEFAULT_RATES_HZ[msg_id] * span_s
        assert abs(count - expected) <= 1.0, (kind, count, expected)

    # VIBRATION can be re-timed (it used to be DENIED: not a stream)
    ack = gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_VIBRATION, 100_000)
    assert ack.result == ACCEPTED
    barrier(gcs)
    count, span_s = rate_hz_in(sim_window(gcs, 5.0), "VIBRATION")
    assert abs(count - 10.0 * span_s) <= 1.0

    # REQUEST_DATA_STREAM: RAW_SENSORS off stops the IMU and pressure messages, on restarts
    gcs.send(M.MAVLink_request_data_stream_message(1, 1, M.MAV_DATA_STREAM_RAW_SENSORS, 0, 0))
    barrier(gcs)
    quiet = sim_window(gcs, 5.0)
    assert not [m for m in quiet if m.get_type() in ("RAW_IMU", "SCALED_IMU",
                                                     "SCALED_PRESSURE")]
    assert sum(m.get_type() == "ATTITUDE" for m in quiet) >= 100  # the rest goes on
    gcs.send(M.MAVLink_request_data_stream_message(1, 1, M.MAV_DATA_STREAM_RAW_SENSORS, 4, 1))
    barrier(gcs)
    count, span_s = rate_hz_in(sim_window(gcs, 5.0), "RAW_IMU")
    assert abs(count - 4.0 * span_s) <= 1.0


def test_on_the_ground_values_agree_with_the_world(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", SPEEDUP, outs=[gcs.port])
    gcs.wait_heartbeat()
    log = sim_window(gcs, 3.0)

    def last(kind: str):
        return [m for m in log if m.get_type() == kind][-1]

    imu = last("RAW_IMU")
    assert abs(imu.zacc + 1000) < 20 and abs(imu.xacc) < 20  # mG: gravity only, 5 sigma
    pressure = last("SCALED_PRESSURE")
    assert pressure.press_abs == pytest.approx(945.03, abs=0.02)  # hPa: ISA at 584 m AMSL
    vib = last("VIBRATION")
    assert max(vib.vibration_x, vib.vibration_y, vib.vibration_z) < 0.1  # m/s^2, noise only
    assert vib.clipping_0 == 0
    ekf = last("EKF_STATUS_REPORT")
    assert ekf.flags & GOOD_FLAGS == GOOD_FLAGS
    assert 0.0 < ekf.pos_horiz_variance < 1e-4 and 0.0 < ekf.velocity_variance < 1e-2
    assert all(math.isfinite(v) for v in (ekf.pos_vert_variance, ekf.compass_variance))
    rc = last("RC_CHANNELS")
    assert (rc.chancount, rc.chan3_raw, rc.rssi) == (0, 65535, 255)
    battery = last("BATTERY_STATUS")
    # mV: a full 3S pack (12.6 V) less 0.5 A through 25 mOhm, +- 6 sigma of 0.01 V; cA
    assert 12_520 < battery.voltages[0] < 12_650 and battery.current_battery < 100

    # an accelerometer reading garbage over its full scale clips, and vibrates
    ack = gcs.command(M.MAV_CMD_INJECT_FAILURE, M.FAILURE_UNIT_SENSOR_ACCEL,
                      M.FAILURE_TYPE_GARBAGE, 0)
    assert ack.result == ACCEPTED
    since = barrier(gcs)
    garbage = gcs.wait("VIBRATION", lambda m: m.clipping_0 > 100, timeout_s=60.0, since=since)
    assert min(garbage.vibration_x, garbage.vibration_y, garbage.vibration_z) > 30.0

    # the simulator's wind, as configured: steady without turbulence
    for name, value in (("SIM_WIND_TURB", 0.0), ("SIM_WIND_SPD", 2.0),
                        ("SIM_WIND_DIR", 90.0)):
        assert gcs.param_set(name, value).param_value == value
    barrier(gcs)
    winds = [m for m in sim_window(gcs, 5.0) if m.get_type() == "WIND"]
    assert len(winds) >= 4
    for m in winds:  # from the east at 2 m/s (float32 on the wire)
        assert (m.direction, m.speed, m.speed_z) == pytest.approx((90.0, 2.0, 0.0), abs=1e-4)
    # with turbulence: about the mean, within the Dryden intensities at the ground
    w20 = 1.5
    assert gcs.param_set("SIM_WIND_TURB", w20).param_value == w20
    barrier(gcs)
    winds = [m for m in sim_window(gcs, 10.0) if m.get_type() == "WIND"]
    sigma = np.array(dryden_sigmas_m_s(w20, 3.048))  # 10 ft: the low-altitude floor
    mean = np.array([0.0, -2.0, 0.0])
    gusts = np.array([wind_ned(m) - mean for m in winds])
    assert len(winds) >= 8
    assert np.all(np.abs(gusts) < 6.0 * sigma.max())  # each sample inside 6 sigma
    assert np.std(gusts[:, 1]) > 0.0  # and it does blow


def test_in_flight_pressure_battery_estimators_and_guidance(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", "10", outs=[gcs.port])
    gcs.wait_heartbeat()
    ground = sim_window(gcs, 5.0)
    p_ground = statistics.fmean(m.press_abs for m in ground
                                if m.get_type() == "SCALED_PRESSURE")
    v_ground = statistics.fmean(m.voltages[0] for m in ground
                                if m.get_type() == "BATTERY_STATUS")
    no_idle_disarm(gcs)
    gcs.take_off(1.5)
    sim_window(gcs, 5.0)  # settle
    hover = sim_window(gcs, 20.0)
    p_air = statistics.fmean(m.press_abs for m in hover if m.get_type() == "SCALED_PRESSURE")
    # dp = rho g dh: 1.16 kg/m^3 at 584 m, 1.5 m up: 0.17 hPa (baro noise 0.2 Pa per reading)
    assert p_ground - p_air == pytest.approx(0.171, abs=0.03)
    batteries = [m for m in hover if m.get_type() == "BATTERY_STATUS"]
    volts = [m.voltages[0] for m in batteries]
    assert v_ground - statistics.fmean(volts) > 200  # mV of sag under ~12 A
    assert all(900 < m.current_battery < 1600 for m in batteries)  # cA
    assert statistics.fmean(volts[-5:]) < statistics.fmean(volts[:5])  # discharging
    assert batteries[-1].current_consumed > batteries[0].current_consumed
    for ekf in (m for m in hover if m.get_type() == "EKF_STATUS_REPORT"):
        assert ekf.flags & GOOD_FLAGS == GOOD_FLAGS
        assert 0.0 < ekf.pos_horiz_variance < 1e-3 and 0.0 < ekf.velocity_variance < 1e-2
    attitude = [m for m in hover if m.get_type() == "ATTITUDE"][-1]
    ahrs2 = [m for m in hover if m.get_type() == "AHRS2"][-1]
    assert abs(ahrs2.roll - attitude.roll) < math.radians(2.0)
    assert abs(ahrs2.pitch - attitude.pitch) < math.radians(2.0)
    vib = [m for m in hover if m.get_type() == "VIBRATION"][-1]
    assert 0.0 < vib.vibration_z < 1.0 and vib.clipping_0 == 0  # m/s^2: a smooth hover

    # a 3 m leg north: NAV_CONTROLLER_OUTPUT counts the metres down, on the line
    since = gcs.mark()
    gcs.send(M.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0b110111111000, 3.0, 0.0, -1.5, 0, 0, 0, 0, 0, 0, 0,
        0))
    gcs.wait("LOCAL_POSITION_NED", lambda m: m.x > 2.9, timeout_s=60.0, since=since)
    navs = gcs.messages("NAV_CONTROLLER_OUTPUT", since=since)
    moving = [m for m in navs if m.wp_dist > 0]
    assert moving and [m.wp_dist for m in moving] == sorted((m.wp_dist for m in moving),
                                                             reverse=True)
    assert moving[0].wp_dist == 3 and all(m.target_bearing in (0, 359) for m in moving)
    assert all(abs(m.xtrack_error) < 0.1 and abs(m.alt_error) < 0.1 for m in navs)
    assert any(m.nav_pitch < -0.5 for m in navs)  # deg: the nose goes down to go north

    assert gcs.command(M.MAV_CMD_NAV_LAND).result == ACCEPTED
    gcs.wait("HEARTBEAT", lambda m: not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED,
             timeout_s=120.0)


def test_battery_failsafe_lands_with_a_tiny_capacity_set_by_parameter(start_vehicle,
                                                                     gcs: Gcs) -> None:
    start_vehicle("--speedup", "10", outs=[gcs.port])
    gcs.wait_heartbeat()
    for name, value in (("BATT_CAPACITY", 60.0), ("BATT_LOW_MAH", 40.0),
                        ("BATT_FS_LOW_ACT", 1.0)):
        assert gcs.param_set(name, value).param_value == value
    no_idle_disarm(gcs)
    assert gcs.set_mode(GUIDED).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    since = gcs.mark()
    assert gcs.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 1.0).result == ACCEPTED
    gcs.wait("GLOBAL_POSITION_INT", lambda m: m.relative_alt > 500, timeout_s=60.0)
    text = gcs.wait_text("Battery 1 is low", since, timeout_s=60.0)
    assert "used" in text
    gcs.wait_mode(LAND, timeout_s=30.0)  # the failsafe's action: LAND
    gcs.wait("HEARTBEAT", lambda m: not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED,
             timeout_s=120.0)
    status = gcs.wait("BATTERY_STATUS", timeout_s=30.0)
    assert status.charge_state == M.MAV_BATTERY_CHARGE_STATE_LOW
    assert status.current_consumed > 20  # mAh: the 60 mAh "pack" went below 40 left
    assert abs(gcs.wait("SIM_STATE").vd) < 0.05  # down and at rest (truth)
    # arming is refused while the failsafe lasts
    ack = gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == M.MAV_RESULT_DENIED
