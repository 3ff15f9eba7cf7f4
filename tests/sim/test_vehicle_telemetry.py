"""The extended telemetry and the battery of a simulated vehicle, against the world's truth.

The vehicle runs in-process (the tick loop of the vehicle process, without the network): its
port's snapshot is what the MAVLink endpoint builds messages from.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcu.autopilot import AutopilotConfig
from fcu.mavlink.autopilot_port import vehicle_autopilot_config
from fcu.mavlink.port_records import GeoPoint
from fcu.mavlink.telemetry.autopilot_telemetry import AutopilotTelemetry
from fcu.mavlink.transport.codec import mavlink2
from flightdata.atmosphere import isa_pressure_pa
from sim.vehicle_port import SimVehicle, VehicleSetup
from sim.world import WorldConfig
from sim.world.wind import WindConfig

M = mavlink2
ORIGIN = GeoPoint(-35.363261, 149.165230, 584.0)
GUIDED, LAND = 4, 9
GOOD_FLAGS = (M.EKF_ATTITUDE | M.EKF_VELOCITY_HORIZ | M.EKF_VELOCITY_VERT
              | M.EKF_POS_HORIZ_REL | M.EKF_POS_HORIZ_ABS | M.EKF_POS_VERT_ABS
              | M.EKF_PRED_POS_HORIZ_REL | M.EKF_PRED_POS_HORIZ_ABS)


def vehicle(wind: WindConfig | None = None) -> SimVehicle:
    world = WorldConfig(wind=wind if wind is not None else WindConfig(mean_speed_m_s=0.0))
    v = SimVehicle(VehicleSetup(world=world,
                                autopilot=vehicle_autopilot_config(AutopilotConfig()),
                                seed=11, origin=ORIGIN))
    v.first_tick()
    return v


def run(v: SimVehicle, seconds: float) -> None:
    end_s = v.time_s + seconds
    while v.time_s < end_s - 1e-9:
        v.tick()


def take_off(v: SimVehicle, alt_m: float) -> None:
    assert v.port.set_mode(GUIDED).accepted
    assert v.port.arm(force=False).accepted
    assert v.port.takeoff(alt_m).accepted
    run(v, 2.0 + alt_m / 0.3 * 1.5)  # climb at 0.3 m/s, then settle


def test_on_the_ground_the_sensors_read_gravity_and_the_home_pressure() -> None:
    v = vehicle()
    run(v, 3.0)
    tel = v.port.telemetry
    imu = tel.imu()
    assert imu is not None
    assert imu.accel_frd == pytest.approx([0.0, 0.0, -9.81], abs=0.15)  # 5 sigma of noise
    assert imu.gyro_frd == pytest.approx([0.0, 0.0, 0.0], abs=0.015)
    pressure = tel.pressure()
    assert pressure is not None
    # the barometer reads 0 m +- 0.02 m: 0.25 Pa per 2 cm near 584 m AMSL
    assert pressure.pressure_pa == pytest.approx(isa_pressure_pa(ORIGIN.alt_m), abs=1.2)
    vib = tel.vibration()
    assert vib is not None and vib.clipping == (0, 0, 0)
    # at rest only the accelerometer's noise (0.03 m/s^2) passes ArduPilot's 5 Hz high-pass
    assert np.all((vib.vibration_m_s2 > 0.015) & (vib.vibration_m_s2 < 0.045))
    ekf = tel.ekf()
    assert ekf is not None and ekf.flags & GOOD_FLAGS == GOOD_FLAGS
    assert not ekf.flags & M.EKF_CONST_POS_MODE
    assert 0.0 < ekf.pos_horiz_variance < 1e-4  # m^2: mocap pins the position to a mm
    assert 0.0 < ekf.velocity_variance < 1e-2 and 0.0 < ekf.compass_variance < 1e-4
    nav = tel.nav_controller()
    assert nav is not None and math.isnan(nav.wp_dist_m) and nav.roll_rad == 0.0
    snap = v.port.snapshot()
    assert snap.battery.current_a == pytest.approx(0.5, abs=0.2)  # avionics only, A
    assert snap.battery.voltage_v == pytest.approx(12.6, abs=0.05)


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_in_flight_pressure_falls_the_battery_sags_and_the_estimators_agree() -> None:
    v = vehicle()
    run(v, 1.0)
    ground = v.port.snapshot().battery
    p_ground = v.port.telemetry.pressure()
    take_off(v, 1.5)
    truth = v.world.truth()
    assert -truth.pos_ned[2] == pytest.approx(1.5, abs=0.05)
    p_air = v.port.telemetry.pressure()
    assert p_ground is not None and p_air is not None
    drop = p_ground.pressure_pa - p_air.pressure_pa
    rho = p_ground.pressure_pa / (287.05 * (p_ground.temperature_c + 273.15))  # kg/m^3
    assert drop == pytest.approx(rho * 9.80665 * 1.5, abs=0.6)  # Pa; 2 baro sigmas
    hover = v.port.snapshot().battery
    assert 9.0 < hover.current_a < 16.0  # A, about 150 W from a 3S pack
    assert hover.voltage_v < ground.voltage_v - 0.2  # sag of ~12 A through 25 mOhm
    run(v, 20.0)
    later = v.port.snapshot().battery
    assert later.voltage_v < hover.voltage_v - 0.02  # discharging down the curve
    # the monitor's count of the power module's 10 Hz readings against the pack's truth
    assert later.consumed_mah == pytest.approx(v.world.battery.state.consumed_ah * 1000.0,
                                               rel=0.02)
    # the TSKF beside the flying EKF sees the same vehicle
    second = v.port.telemetry.secondary()
    est = v.stack.autopilot.status.estimate
    assert second is not None
    assert second.euler_rad[:2] == pytest.approx(est.euler_rad[:2], abs=math.radians(1.0))
    assert second.pos_ned == pytest.approx(est.pos_ned, abs=0.05)


def test_nav_controller_output_follows_a_go_to() -> None:
    v = vehicle()
    take_off(v, 1.0)
    assert v.port.goto(np.array([3.0, 0.0, -1.0]), None).accepted
    run(v, 1.0)
    first = v.port.telemetry.nav_controller()
    run(v, 2.0)
    second = v.port.telemetry.nav_controller()
    assert first is not None and second is not None
    assert 0.0 < second.wp_dist_m < first.wp_dist_m < 3.0  # m, closing in
    assert math.degrees(second.target_bearing_rad) == pytest.approx(0.0, abs=5.0)  # north
    assert abs(second.xtrack_error_m) < 0.05 and abs(second.alt_error_m) < 0.05
    assert second.pitch_rad < 0.0 or first.pitch_rad < 0.0  # nose down to go north


def test_wind_reaches_the_snapshot_as_the_world_blows_it() -> None:
    calm_gust = WindConfig(mean_speed_m_s=2.0, mean_from_deg=90.0, turbulence="none")
    v = vehicle(calm_gust)
    run(v, 1.0)
    truth = v.port.snapshot().truth
    assert truth is not None and truth.wind_ned is not None
    assert truth.wind_ned == pytest.approx([0.0, -2.0, 0.0], abs=1e-12)  # from the east


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_battery_failsafe_lands_when_the_capacity_set_by_parameter_runs_low() -> None:
    v = vehicle()
    run(v, 0.5)
    for name, value in (("BATT_CAPACITY", 60.0), ("BATT_LOW_MAH", 40.0),
                        ("BATT_FS_LOW_ACT", 1.0)):
        assert v.port.set_param(name, value).accepted, name
    take_off(v, 1.0)
    texts = [e.text for e in v.port.drain_events() if hasattr(e, "text")]
    run(v, 10.0)  # ~12 A: the 20 mAh above BATT_LOW_MAH last about 6 s
    texts += [e.text for e in v.port.drain_events() if hasattr(e, "text")]
    assert any(t.startswith("Battery 1 is low") for t in texts), texts
    assert v.stack.autopilot.navigator.mode == LAND
    run(v, 20.0)
    assert not v.stack.autopilot.navigator.armed  # landed and disarmed
    assert v.world.truth().on_ground
    snap = v.port.snapshot()
    assert snap.battery.low and snap.failsafe_active


def test_the_worlds_arrays_and_plain_samples_give_the_same_readings() -> None:
    v = vehicle()
    take_off(v, 0.5)
    arrays = AutopilotTelemetry(v.stack, ORIGIN)
    objects = AutopilotTelemetry(v.stack, ORIGIN)
    for _ in range(150):
        v.tick()
        arrays.observe(v.stack.samples)  # the world's batch: folded as arrays
        objects.observe(list(v.stack.samples))  # the same samples one object each
    a, b = arrays.vibration(), objects.vibration()
    assert a is not None and b is not None
    assert np.array_equal(a.vibration_m_s2, b.vibration_m_s2) and a.time_s == b.time_s
    imu_a, imu_b = arrays.imu(), objects.imu()
    assert imu_a is not None and imu_b is not None
    assert np.array_equal(imu_a.accel_frd, imu_b.accel_frd)
    assert np.array_equal(imu_a.gyro_frd, imu_b.gyro_frd)
    assert arrays.pressure() == objects.pressure()


def test_the_snapshots_late_fields_are_those_of_its_tick() -> None:
    """The port computes the costlier fields when first read: they equal what the autopilot
    and the world hold at the snapshot's tick, keep their value, and are refused after the
    vehicle has moved on."""
    v = vehicle(WindConfig(mean_speed_m_s=2.0, mean_from_deg=90.0, turbulence="none"))
    take_off(v, 1.0)
    run(v, 1.5)
    ap = v.stack.autopilot
    status = ap.status
    assert status is not None and status.reference is not None
    snap = v.port.snapshot()
    assert v.port.snapshot() is snap  # one snapshot per tick
    assert snap.armed and snap.time_s == v.time_s
    assert np.array_equal(snap.pwm, status.pwm) and snap.pwm is not status.pwm  # a copy
    assert np.array_equal(snap.loe, status.loe_estimate)
    assert snap.position_target is not None
    assert np.array_equal(snap.position_target.pos_ned, status.reference.pos_ned)
    assert snap.attitude_target is not None and 0.0 < snap.attitude_target.thrust < 1.0
    truth = v.world.truth()
    assert snap.truth is not None and np.array_equal(snap.truth.pos_ned, truth.pos_ned)
    truth_read = snap.truth
    assert snap.truth is truth_read  # computed once
    assert snap.health.prearm == ap.navigator.prearm_check().ok
    assert snap.health.gps and snap.health.ahrs and snap.health.motors
    assert snap.battery.voltage_v == ap.battery.voltage_v
    assert snap.landed_state == int(ap.navigator.landed_state) != 0
    assert snap.home_pos_ned is not None
    assert np.array_equal(snap.home_pos_ned, ap.navigator.home_pos_ned)
    progress = ap.navigator.mission_progress()
    assert (snap.mission_seq, snap.mission_state) == (progress.current_seq, int(progress.state))
    v.tick()
    late = v.port.snapshot()
    assert late is not snap and late.time_s > snap.time_s
    v.tick()
    assert late.time_s < v.time_s and late.armed  # what was taken stays readable
    with pytest.raises(RuntimeError, match="moved on"):
        late.battery  # noqa: B018 (first read after the next tick)
    assert snap.truth is truth_read  # read in its tick: kept
    assert v.port.snapshot() is not late
