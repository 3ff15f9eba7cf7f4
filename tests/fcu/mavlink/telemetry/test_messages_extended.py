"""Extended telemetry messages, built from a snapshot and parsed back through the codec."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest
from test_mavlink_messages import one, snap

from fcu.mavlink.geo import ned_to_geo
from fcu.mavlink.port_records import BatteryState, SimTruth
from fcu.mavlink.telemetry import messages as build
from fcu.mavlink.telemetry import streamed
from fcu.mavlink.telemetry.extended import (
    EkfReport,
    ImuReading,
    NavControllerReport,
    PressureReading,
    SecondaryAttitude,
    VibrationLevels,
)
from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ, STREAM_GROUPS
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
G0 = 9.80665


@dataclasses.dataclass
class Extended:
    """An ExtendedTelemetry answering fixed readings (None: nothing to report)."""

    imu_reading: ImuReading | None = None
    pressure_reading: PressureReading | None = None
    vibration_levels: VibrationLevels | None = None
    ekf_report: EkfReport | None = None
    second: SecondaryAttitude | None = None
    nav: NavControllerReport | None = None

    def imu(self) -> ImuReading | None:
        return self.imu_reading

    def pressure(self) -> PressureReading | None:
        return self.pressure_reading

    def vibration(self) -> VibrationLevels | None:
        return self.vibration_levels

    def ekf(self) -> EkfReport | None:
        return self.ekf_report

    def secondary(self) -> SecondaryAttitude | None:
        return self.second

    def nav_controller(self) -> NavControllerReport | None:
        return self.nav


def with_extended(**readings: Any) -> Any:
    return snap(extended=Extended(**readings))


IMU = ImuReading(time_s=12.5, accel_frd=np.array([0.5, -1.0, -G0]),
                 gyro_frd=np.array([0.1, -0.02, 3.0]), temperature_c=21.37)


def test_raw_and_scaled_imu_carry_the_sample_in_mg_and_mrad_s() -> None:
    s = with_extended(imu_reading=IMU)
    raw = one(M.MAVLINK_MSG_ID_RAW_IMU, s)
    scaled = one(M.MAVLINK_MSG_ID_SCALED_IMU, s)
    for m in (raw, scaled):
        assert (m.xacc, m.yacc, m.zacc) == (51, -102, -1000)  # mG: 1000 a / 9.80665
        assert (m.xgyro, m.ygyro, m.zgyro) == (100, -20, 3000)  # mrad/s
        assert (m.xmag, m.ymag, m.zmag) == (0, 0, 0)  # no magnetometer
        assert m.temperature == 2137  # cdegC
    assert raw.time_usec == 12_500_000 and raw.id == 0
    assert scaled.time_boot_ms == 12_500


def test_scaled_pressure_in_hpa_and_cdeg() -> None:
    s = with_extended(pressure_reading=PressureReading(time_s=3.0, pressure_pa=94_503.2,
                                                       temperature_c=11.2))
    m = one(M.MAVLINK_MSG_ID_SCALED_PRESSURE, s)
    assert m.press_abs == pytest.approx(945.032, rel=1e-6)  # float32
    assert (m.press_diff, m.temperature, m.time_boot_ms) == (0.0, 1120, 3000)


def test_vibration_levels_and_clip_counts() -> None:
    s = with_extended(vibration_levels=VibrationLevels(
        time_s=2.0, vibration_m_s2=np.array([0.03, 12.5, 61.0]), clipping=(7, 0, 0)))
    m = one(M.MAVLINK_MSG_ID_VIBRATION, s)
    assert [m.vibration_x, m.vibration_y, m.vibration_z] == pytest.approx([0.03, 12.5, 61.0])
    assert (m.clipping_0, m.clipping_1, m.clipping_2, m.time_usec) == (7, 0, 0, 2_000_000)


def test_ekf_status_report_passes_variances_and_flags() -> None:
    report = EkfReport(flags=M.EKF_ATTITUDE | M.EKF_POS_HORIZ_ABS, velocity_variance=1e-3,
                       pos_horiz_variance=2e-7, pos_vert_variance=math.nan,
                       compass_variance=9e-8)
    m = one(M.MAVLINK_MSG_ID_EKF_STATUS_REPORT, with_extended(ekf_report=report))
    assert m.flags == M.EKF_ATTITUDE | M.EKF_POS_HORIZ_ABS
    assert [m.velocity_variance, m.pos_horiz_variance, m.compass_variance] == pytest.approx(
        [1e-3, 2e-7, 9e-8], rel=1e-6)
    assert m.pos_vert_variance == 0.0  # NaN is not sent
    assert m.terrain_alt_variance == 0.0


def test_ahrs2_is_the_second_estimate_in_rad_and_global_coordinates() -> None:
    second = SecondaryAttitude(euler_rad=np.array([0.01, -0.02, 3.0]),
                               pos_ned=np.array([1.0, 2.0, -1.5]))
    s = with_extended(second=second)
    m = one(M.MAVLINK_MSG_ID_AHRS2, s)
    lat, lon, alt = ned_to_geo(second.pos_ned, s.origin)
    assert [m.roll, m.pitch, m.yaw] == pytest.approx([0.01, -0.02, 3.0], rel=1e-6)
    assert (m.lat, m.lng) == (round(lat * 1e7), round(lon * 1e7))
    assert m.altitude == pytest.approx(alt, abs=1e-3)


def test_nav_controller_output_in_degrees_and_metres() -> None:
    nav = NavControllerReport(roll_rad=math.radians(-3.0), pitch_rad=math.radians(2.0),
                              bearing_rad=math.radians(-90.0),
                              target_bearing_rad=math.radians(45.4), wp_dist_m=2.6,
                              alt_error_m=-0.25, xtrack_error_m=0.125)
    m = one(M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, with_extended(nav=nav))
    assert (m.nav_roll, m.nav_pitch) == pytest.approx((-3.0, 2.0))
    assert (m.nav_bearing, m.target_bearing, m.wp_dist) == (270, 45, 3)
    assert (m.alt_error, m.aspd_error, m.xtrack_error) == pytest.approx((-0.25, 0.0, 0.125))
    unknown = dataclasses.replace(nav, target_bearing_rad=math.nan, wp_dist_m=math.nan)
    m = one(M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, with_extended(nav=unknown))
    assert (m.target_bearing, m.wp_dist) == (0, 0)


@pytest.mark.parametrize(("wind_ned", "direction", "speed"), [
    ((0.0, 2.0, 0.0), 270.0, 2.0),  # air moving east comes from the west
    ((-3.0, 0.0, 0.0), 0.0, 3.0),  # moving south: from the north
    ((1.0, 1.0, -0.5), 225.0, math.sqrt(2.0)),
])
def test_wind_is_the_simulated_wind_where_it_comes_from(wind_ned: tuple[float, ...],
                                                        direction: float,
                                                        speed: float) -> None:
    truth = SimTruth(pos_ned=np.zeros(3), vel_ned=np.zeros(3),
                     quat_wxyz=np.array([1.0, 0, 0, 0]), rate_frd=np.zeros(3),
                     accel_frd=np.zeros(3), wind_ned=np.array(wind_ned))
    m = one(M.MAVLINK_MSG_ID_WIND, snap(truth=truth))
    assert m.direction == pytest.approx(direction, abs=1e-4)
    assert m.speed == pytest.approx(speed, rel=1e-6)
    assert m.speed_z == pytest.approx(wind_ned[2])


def test_rc_channels_without_a_receiver() -> None:
    m = one(M.MAVLINK_MSG_ID_RC_CHANNELS, snap())
    assert m.chancount == 0 and m.rssi == 255
    assert all(getattr(m, f"chan{i}_raw") == 65535 for i in range(1, 19))


def test_nothing_to_report_sends_nothing() -> None:
    empty = snap(extended=Extended(), truth=None)
    for msg_id in (M.MAVLINK_MSG_ID_RAW_IMU, M.MAVLINK_MSG_ID_SCALED_IMU,
                   M.MAVLINK_MSG_ID_SCALED_PRESSURE, M.MAVLINK_MSG_ID_VIBRATION,
                   M.MAVLINK_MSG_ID_EKF_STATUS_REPORT, M.MAVLINK_MSG_ID_AHRS2,
                   M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, M.MAVLINK_MSG_ID_WIND):
        assert streamed.build_stream(msg_id, empty, build.TelemetryContext()) == []
        assert streamed.build_stream(msg_id, snap(extended=None, truth=None),
                                  build.TelemetryContext()) == []


def test_battery_status_reports_the_monitor() -> None:
    battery = BatteryState(voltage_v=11.42, current_a=12.3, remaining=0.61, low=True,
                           consumed_mah=975.4, consumed_j=40_123.0, time_remaining_s=455.6)
    m = one(M.MAVLINK_MSG_ID_BATTERY_STATUS, snap(battery=battery))
    assert (m.voltages[0], m.current_battery, m.current_consumed, m.energy_consumed) == \
        (11420, 1230, 975, 401)  # mV, cA, mAh, hJ
    assert (m.battery_remaining, m.time_remaining) == (61, 456)
    assert m.charge_state == M.MAV_BATTERY_CHARGE_STATE_LOW  # the monitor's level


def test_the_new_messages_stream_in_arducopters_groups() -> None:
    groups = {
        M.MAV_DATA_STREAM_RAW_SENSORS: {M.MAVLINK_MSG_ID_RAW_IMU, M.MAVLINK_MSG_ID_SCALED_IMU,
                                        M.MAVLINK_MSG_ID_SCALED_PRESSURE},
        M.MAV_DATA_STREAM_EXTENDED_STATUS: {M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT},
        M.MAV_DATA_STREAM_RC_CHANNELS: {M.MAVLINK_MSG_ID_RC_CHANNELS},
        M.MAV_DATA_STREAM_EXTRA1: {M.MAVLINK_MSG_ID_AHRS2},
        M.MAV_DATA_STREAM_EXTRA3: {M.MAVLINK_MSG_ID_WIND, M.MAVLINK_MSG_ID_VIBRATION,
                                   M.MAVLINK_MSG_ID_EKF_STATUS_REPORT,
                                   M.MAVLINK_MSG_ID_BATTERY_STATUS},
    }
    for stream, members in groups.items():
        assert members <= set(STREAM_GROUPS[stream])
        for msg_id in members:
            assert DEFAULT_RATES_HZ[msg_id] > 0 and streamed.can_build(msg_id)
