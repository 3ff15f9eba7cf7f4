"""Stick laws (ArduCopter's get_pilot_desired_*) and each pilot law's reference, against
closed forms; the STABILIZE reference inverted through the position loop's own attitude
inversion gives back the stick's lean angles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcu.control.position import PositionController, PositionGains
from fcu.model import VehicleModel
from fcu.navigation.pilot_leg import GRAVITY_M_S2, LEASH_XY_M, LEASH_Z_M, Demand, PilotLeg
from fcu.navigation.sticks import (
    CENTRED,
    PilotConfig,
    Sticks,
    climb_rate_m_s,
    collective_of_hover,
    dead_band,
    lean_angles_rad,
    stick_velocity_ned,
    yaw_rate_rad_s,
)
from flightdata.config import ConfigError

CFG = PilotConfig()
DT_S = 0.01  # s, the autopilot tick


def test_sticks_refuse_out_of_range_values_naming_them() -> None:
    with pytest.raises(ConfigError, match=r"roll = 1\.5: must be a stick position"):
        Sticks(1.5, 0.0, 0.5, 0.0)
    with pytest.raises(ConfigError, match=r"throttle = -0\.1"):
        Sticks(0.0, 0.0, -0.1, 0.0)
    with pytest.raises(ConfigError, match="angle_max_deg = 90"):
        PilotConfig(angle_max_deg=90.0)
    assert CENTRED.centred and not Sticks(0.0, 0.0, 0.6, 0.0).centred


def test_dead_band_removes_the_centre_and_still_reaches_full_stick() -> None:
    assert dead_band(0.03, 0.04) == 0.0
    assert dead_band(1.0, 0.04) == 1.0 and dead_band(-1.0, 0.04) == -1.0
    assert dead_band(0.52, 0.04) == pytest.approx(0.5)  # (0.52 - 0.04) / 0.96


def test_lean_angles_scale_to_angle_max_within_a_round_gate() -> None:
    assert lean_angles_rad(Sticks(1.0, 0.0, 0.5, 0.0), CFG) == pytest.approx(
        (math.radians(30.0), 0.0))
    assert lean_angles_rad(Sticks(0.0, -1.0, 0.5, 0.0), CFG) == pytest.approx(
        (0.0, -math.radians(30.0)))  # full forward: nose down
    roll, pitch = lean_angles_rad(Sticks(1.0, 1.0, 0.5, 0.0), CFG)
    assert math.hypot(roll, pitch) == pytest.approx(math.radians(30.0))  # corner: limited


def test_climb_rate_has_a_dead_zone_about_mid_stick_and_reaches_the_pilot_speeds() -> None:
    for throttle in (0.4, 0.45, 0.5, 0.55, 0.6):  # THR_DZ 100 of 1000 either side
        assert climb_rate_m_s(throttle, CFG) == 0.0
    assert climb_rate_m_s(1.0, CFG) == pytest.approx(CFG.speed_up_m_s)
    assert climb_rate_m_s(0.8, CFG) == pytest.approx(0.5 * CFG.speed_up_m_s)
    assert climb_rate_m_s(0.0, CFG) == pytest.approx(-CFG.speed_down_m_s)
    assert climb_rate_m_s(0.2, CFG) == pytest.approx(-0.5 * CFG.speed_down_m_s)
    same = PilotConfig(speed_down_m_s=0.0)  # PILOT_SPEED_DN 0: PILOT_SPEED_UP
    assert climb_rate_m_s(0.0, same) == pytest.approx(-same.speed_up_m_s)


def test_collective_passes_hover_at_mid_stick_on_arducopters_curve() -> None:
    assert collective_of_hover(0.5, CFG) == pytest.approx(1.0)
    assert collective_of_hover(0.0, CFG) == 0.0
    # out = in (1 - e) + e in^3 with e = -(0.35 - 0.5) / 0.375 = 0.4; mid gives 0.35
    assert collective_of_hover(1.0, CFG) == pytest.approx(1.0 / 0.35)
    values = [collective_of_hover(t, CFG) for t in np.linspace(0.0, 1.0, 11)]
    assert all(b > a for a, b in zip(values, values[1:], strict=False))  # monotonic


def test_yaw_rate_and_stick_velocity_in_the_heading_frame() -> None:
    assert yaw_rate_rad_s(Sticks(0.0, 0.0, 0.5, 1.0), CFG) == pytest.approx(math.radians(45))
    forward = Sticks(0.0, -1.0, 0.5, 0.0)
    assert stick_velocity_ned(forward, 0.0, CFG) == pytest.approx((1.0, 0.0))
    assert stick_velocity_ned(forward, math.pi / 2, CFG) == pytest.approx((0.0, 1.0))
    right = Sticks(1.0, 0.0, 0.5, 0.0)
    assert stick_velocity_ned(right, 0.0, CFG) == pytest.approx((0.0, 1.0))  # east
    assert stick_velocity_ned(right, math.pi / 2, CFG) == pytest.approx((-1.0, 0.0))


def run(leg: PilotLeg, sticks: Sticks, seconds: float, pos: np.ndarray | None = None
        ) -> list[tuple[np.ndarray, ...]]:
    """Advance ``leg`` tick by tick with the estimate on the reference (a vehicle that
    follows exactly, unless ``pos`` pins the estimate); returns (pos, vel, acc) refs."""
    out: list[tuple[np.ndarray, ...]] = []
    t = leg.time_s
    for _ in range(round(seconds / DT_S)):
        t += DT_S
        ref = leg.reference
        est = ref.pos_ned if pos is None else pos
        new = leg.advance(t, Demand.of_sticks(sticks, CFG), est, ref.vel_ned)
        out.append((new.pos_ned, new.vel_ned, new.acc_ned))
    return out


def test_stabilize_reference_is_open_loop_and_inverts_to_the_stick_angles() -> None:
    leg = PilotLeg("stabilize", CFG, 0.0, np.array([1.0, 2.0, -3.0]), np.zeros(3), 0.7)
    sticks = Sticks(0.5, -0.8, 0.7, 0.0)
    est_pos, est_vel = np.array([1.2, 2.1, -3.3]), np.array([0.3, -0.1, 0.2])
    ref = leg.advance(DT_S, Demand.of_sticks(sticks, CFG), est_pos, est_vel)
    np.testing.assert_array_equal(ref.pos_ned, est_pos)  # no feedback: P, D terms zero
    np.testing.assert_array_equal(ref.vel_ned, est_vel)
    up = GRAVITY_M_S2 * collective_of_hover(0.7, CFG)
    assert ref.acc_ned[2] == pytest.approx(GRAVITY_M_S2 - up)
    # the position loop (no integral yet) turns the feed-forward into the stick's angles
    model = VehicleModel()
    ctl = PositionController(model, PositionGains(tilt_max_rad=math.radians(60.0)), 0.01)
    cmd = ctl.step(est_pos, est_vel, ref.pos_ned, ref.vel_ned, ref.acc_ned, ref.yaw_rad)
    roll, pitch = lean_angles_rad(sticks, CFG)
    assert cmd.roll_ref_rad == pytest.approx(roll, abs=1e-9)
    assert cmd.pitch_ref_rad == pytest.approx(pitch, abs=1e-9)
    assert cmd.thrust_n == pytest.approx(
        model.mass * up * math.hypot(1.0, math.hypot(math.tan(roll) / math.cos(pitch),
                                                     math.tan(pitch))))


def test_alt_hold_climbs_at_the_stick_rate_reached_at_pilot_accel_z() -> None:
    leg = PilotLeg("alt_hold", CFG, 0.0, np.array([0.0, 0.0, -1.0]), np.zeros(3), 0.0)
    refs = run(leg, Sticks(0.0, 0.0, 1.0, 0.0), 2.0)
    vz = [r[1][2] for r in refs]
    assert vz[0] == pytest.approx(-CFG.accel_z_m_s2 * DT_S)  # ramps at PILOT_ACCEL_Z
    assert vz[-1] == pytest.approx(-CFG.speed_up_m_s)  # then climbs at PILOT_SPEED_UP
    ramp_s = CFG.speed_up_m_s / CFG.accel_z_m_s2
    climbed = CFG.speed_up_m_s * (2.0 - ramp_s / 2.0)  # trapezoid
    assert -refs[-1][0][2] - 1.0 == pytest.approx(climbed, abs=1e-9)
    refs = run(leg, CENTRED, 1.0)  # centred: stops and holds
    assert refs[-1][1][2] == 0.0
    held = refs[-1][0][2]
    refs = run(leg, Sticks(0.0, 0.0, 0.55, 0.0), 1.0)  # inside the dead zone: still held
    assert refs[-1][0][2] == held


def test_loiter_flies_the_stick_velocity_then_brakes_and_holds() -> None:
    leg = PilotLeg("loiter", CFG, 0.0, np.array([0.0, 0.0, -1.0]), np.zeros(3), 0.0)
    refs = run(leg, Sticks(1.0, 0.0, 0.5, 0.0), 3.0)  # full right at yaw 0: east
    np.testing.assert_allclose(refs[-1][1], [0.0, CFG.loiter_speed_m_s, 0.0], atol=1e-12)
    assert refs[0][2][1] == pytest.approx(CFG.loiter_accel_m_s2)  # accel feed-forward
    east = refs[-1][0][1]
    assert east == pytest.approx(CFG.loiter_speed_m_s * (3.0 - 0.5), abs=1e-9)
    refs = run(leg, CENTRED, 2.0)  # brake at LOIT_ACC_MAX: 1 s, 0.5 m
    assert np.all(refs[-1][1] == 0.0)
    assert refs[-1][0][1] == pytest.approx(east + 0.5, abs=1e-9)
    assert refs[-1][0][2] == -1.0  # altitude untouched


def test_targets_stay_on_a_leash_of_the_estimate() -> None:
    leg = PilotLeg("loiter", CFG, 0.0, np.zeros(3), np.zeros(3), 0.0)
    stuck = np.zeros(3)  # a vehicle that does not move
    refs = run(leg, Sticks(0.0, -1.0, 0.0, 0.0), 5.0, pos=stuck)
    assert refs[-1][0][0] == pytest.approx(LEASH_XY_M)
    assert refs[-1][0][2] == pytest.approx(LEASH_Z_M)


def test_yaw_turns_at_the_stick_rate() -> None:
    leg = PilotLeg("alt_hold", CFG, 0.0, np.zeros(3), np.zeros(3), 0.0)
    run(leg, Sticks(0.0, 0.0, 0.5, -1.0), 1.0)
    assert leg.reference.yaw_rad == pytest.approx(-math.radians(45.0))
    assert leg.reference.yaw_rate_rad_s == pytest.approx(-math.radians(45.0))
