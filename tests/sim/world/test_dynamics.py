"""Rigid-body plant: closed forms (hover, free fall, motor lag, torques), RK4 against
solve_ivp, ground contact, accelerometer, and rotation conventions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from sim.world.airframe import Airframe
from sim.world.dynamics import (
    POS_NED,
    QUAT_WXYZ,
    RATE_FRD,
    STATE_SIZE,
    THRUST_N,
    VEL_NED,
    RigidBodyPlant,
    derivative,
    pack_params,
    rk4_step,
    specific_force_frd,
)
from sim.world.rotations import euler_to_quat, quat_to_euler, quat_to_rotation

AF = Airframe()
NO_DRAG = Airframe(drag_coeff_xy=0.0, drag_coeff_z=0.0, drag_quad_coeff=0.0,
                   rate_damping=(0.0, 0.0, 0.0))
DT = 0.002  # s, the default 500 Hz plant rate
G = AF.gravity
M = AF.mass
HOVER_T = M * G / 4.0  # N per motor
NO_WIND = np.zeros(3)


def _state(
    *, pos_ned: tuple[float, float, float] = (0.0, 0.0, -5.0),
    vel_ned: tuple[float, float, float] = (0.0, 0.0, 0.0),
    euler: tuple[float, float, float] = (0.0, 0.0, 0.0),
    rate_frd: tuple[float, float, float] = (0.0, 0.0, 0.0),
    thrust_n: tuple[float, ...] = (HOVER_T,) * 4,
) -> NDArray[np.float64]:
    x = np.zeros(STATE_SIZE)
    x[POS_NED], x[VEL_NED], x[RATE_FRD], x[THRUST_N] = pos_ned, vel_ned, rate_frd, thrust_n
    x[QUAT_WXYZ] = euler_to_quat(*euler)
    return x


def _rx(a: float) -> NDArray[np.float64]:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> NDArray[np.float64]:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> NDArray[np.float64]:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _interp_tol(speed: float) -> float:
    """Twice the bound on the touchdown-speed error of interpolating z linearly in a step.

    Under constant acceleration g, z is quadratic: linear interpolation misplaces it by at
    most g dt^2 / 8, i.e. the contact instant by g dt^2 / (8 v), the speed by g^2 dt^2 / (8 v).
    """
    return 2.0 * G**2 * DT**2 / (8.0 * speed)


# ---- hover, free fall, ground ------------------------------------------------------------
def test_hover_pwm_holds_position_for_10_s() -> None:
    plant = RigidBodyPlant(AF, DT)
    start = np.array([1.0, -2.0, -3.0])
    plant.reset(pos_ned=start, yaw_rad=0.4, thrust_n=(HOVER_T,) * 4)
    u = np.full(4, AF.hover_pwm)
    for _ in range(5000):
        plant.step(u, NO_WIND, M)
    assert plant.time_s == pytest.approx(10.0, abs=1e-12)  # steps * dt, exact up to round-off
    # the requirement: under 1 mm of drift in 10 s
    assert np.linalg.norm(plant.state[POS_NED] - start) < 1e-3
    # thrust stays at weight/4; 1e-9 N: round-off of K * m g / (4 K) through 5000 steps
    np.testing.assert_allclose(plant.state[THRUST_N], HOVER_T, atol=1e-9)
    assert not plant.on_ground


def test_free_fall_follows_closed_form_then_crashes_and_rests() -> None:
    plant = RigidBodyPlant(NO_DRAG, DT)
    z0 = -10.0
    plant.reset(pos_ned=(0.0, 0.0, z0))
    zeros = np.zeros(4)
    times, zs = [], []
    while True:
        plant.step(zeros, NO_WIND, M)
        if plant.on_ground:
            break
        times.append(plant.time_s)
        zs.append(plant.state[2])
    t = np.array(times)
    # RK4 integrates a quadratic exactly: 1e-6 relative is the requirement, round-off is ~1e-15
    np.testing.assert_allclose(zs, z0 + 0.5 * G * t**2, rtol=1e-6, atol=0.0)
    t_hit = math.sqrt(2.0 * -z0 / G)  # 1.428 s
    assert t[-1] < t_hit <= plant.time_s
    assert plant.crashed
    speed = plant.touchdown_speed_m_s
    assert speed is not None
    v_hit = math.sqrt(2.0 * G * -z0)  # 14.0 m/s
    assert speed == pytest.approx(v_hit, abs=_interp_tol(v_hit))
    for _ in range(500):  # 1 s on the ground, still no thrust
        plant.step(zeros, NO_WIND, M)
        assert plant.on_ground and plant.state[2] == 0.0
    np.testing.assert_array_equal(plant.state[VEL_NED], 0.0)
    np.testing.assert_array_equal(plant.state[RATE_FRD], 0.0)
    assert plant.crashed  # sticky
    plant.reset(pos_ned=(0.0, 0.0, -1.0))
    assert not plant.crashed and plant.touchdown_speed_m_s is None


@pytest.mark.parametrize("impact_speed", [0.5, 2.9, 3.1])
def test_touchdown_faster_than_crash_speed_is_a_crash(impact_speed: float) -> None:
    plant = RigidBodyPlant(NO_DRAG, DT)
    plant.reset(pos_ned=(0.0, 0.0, -impact_speed**2 / (2.0 * G)))
    while not plant.on_ground:
        plant.step(np.zeros(4), NO_WIND, M)
        assert plant.state[2] <= 0.0  # never below the ground
    assert plant.touchdown_speed_m_s == pytest.approx(impact_speed, abs=_interp_tol(impact_speed))
    assert plant.crashed == (impact_speed > NO_DRAG.crash_speed_m_s)
    np.testing.assert_array_equal(plant.state[VEL_NED], 0.0)


def test_tilted_spinning_touchdown_levels_and_keeps_yaw() -> None:
    plant = RigidBodyPlant(AF, DT)
    plant.reset(pos_ned=(0.0, 0.0, -0.2), vel_ned=(0.5, 0.0, 0.5), yaw_rad=1.0,
                thrust_n=(HOVER_T,) * 4)
    # yaw torque and roll torque while descending: lands tilted and turning
    u = np.array([1.1, 1.1, 1.02, 0.78]) * AF.hover_pwm * 0.8
    while not plant.on_ground:
        plant.step(u, NO_WIND, M)
    roll, pitch, yaw = quat_to_euler(plant.state[QUAT_WXYZ])
    assert roll == 0.0 and pitch == 0.0 and yaw != 1.0
    np.testing.assert_array_equal(plant.state[RATE_FRD], 0.0)
    np.testing.assert_array_equal(plant.state[VEL_NED], 0.0)
    assert not plant.crashed
    for _ in range(250):  # yaw torque on the ground does not turn the resting vehicle
        plant.step(u, NO_WIND, M)
    assert quat_to_euler(plant.state[QUAT_WXYZ])[2] == pytest.approx(yaw, abs=1e-15)  # kept


def test_rests_below_weight_and_takes_off_when_thrust_exceeds_weight() -> None:
    plant = RigidBodyPlant(AF, DT)
    plant.reset(yaw_rad=0.7)
    below = np.full(4, 0.95 * AF.hover_pwm)
    for _ in range(1000):
        plant.step(below, np.array([3.0, 0.0, 0.0]), M)  # with a 3 m/s wind
        assert plant.on_ground
    np.testing.assert_array_equal(plant.state[POS_NED], 0.0)
    assert quat_to_euler(plant.state[QUAT_WXYZ])[2] == pytest.approx(0.7, abs=1e-15)  # kept

    plant.reset()
    above = np.full(4, 1.05 * AF.hover_pwm)
    # sum T = 4 K u (1 - exp(-w t)) passes m g at t = ln(21) / w = 0.203 s
    t_cross = math.log(21.0) / AF.motor_bandwidth
    while plant.on_ground:
        plant.step(above, NO_WIND, M)
        assert plant.time_s < 1.0
    # lift-off is detected when a whole step from rest ends above the ground, i.e. within
    # two steps after the crossing (the step containing it may still net downwards)
    assert t_cross < plant.time_s <= t_cross + 2 * DT
    for _ in range(500):
        plant.step(above, NO_WIND, M)
    assert plant.state[2] < -0.05 and not plant.on_ground and not plant.crashed


# ---- motors ------------------------------------------------------------------------------
def test_thrust_lag_time_constant_is_one_over_w() -> None:
    plant = RigidBodyPlant(AF, DT)
    plant.reset(pos_ned=(0.0, 0.0, -50.0))
    u = 0.03
    final = AF.thrust_gain * u
    t_reach = None
    for _ in range(100):
        plant.step(np.full(4, u), NO_WIND, M)
        thrust = plant.state[13]
        exact = final * (1.0 - math.exp(-AF.motor_bandwidth * plant.time_s))
        # 1e-7 N: RK4 local error (w dt)^5 / 120 ~ 2e-10 relative, accumulated over 100 steps
        assert thrust == pytest.approx(exact, abs=1e-7)
        if t_reach is None and thrust >= (1.0 - math.exp(-1.0)) * final:
            t_reach = plant.time_s
    assert t_reach is not None
    assert abs(t_reach - 1.0 / 15.0) <= DT  # 63.2 % at t = 1/w, within a step


def test_pwm_is_saturated_to_the_allowed_range() -> None:
    plant = RigidBodyPlant(AF, DT)
    plant.reset(pos_ned=(0.0, 0.0, -100.0))
    u = np.array([0.2, -0.1, np.nan, 0.05])
    for _ in range(1000):  # 2 s = 30 time constants
        plant.step(u, NO_WIND, M)
    # exp(-30) * 8.75 N ~ 1e-12 N of residual lag
    np.testing.assert_allclose(plant.state[THRUST_N], [8.75, 0.0, 0.0, 8.75], atol=1e-9)


# ---- torques (eq. 3.17) ------------------------------------------------------------------
@pytest.mark.parametrize(
    ("thrust_n", "axis", "torque_nm"),
    [
        # roll U2 = L (T3 - T4): the left rotor lifts the left side, right side down
        ((HOVER_T, HOVER_T, HOVER_T + 0.5, HOVER_T - 0.5), 0, 0.2 * 1.0),
        # pitch U3 = L (T1 - T2): the front rotor lifts the nose
        ((HOVER_T + 0.5, HOVER_T - 0.5, HOVER_T, HOVER_T), 1, 0.2 * 1.0),
        # yaw U4 = K_psi (T1 + T2 - T3 - T4): counter-clockwise pair turns the nose right
        ((HOVER_T + 0.5, HOVER_T + 0.5, HOVER_T - 0.5, HOVER_T - 0.5), 2, 0.023 * 2.0),
    ],
)
def test_differential_thrust_gives_u_over_i(
    thrust_n: tuple[float, ...], axis: int, torque_nm: float
) -> None:
    x = _state(thrust_n=thrust_n)
    u = np.array(thrust_n) / AF.thrust_gain  # PWM holding those thrusts
    xdot = derivative(x, u, NO_WIND, M, pack_params(AF))
    expected = np.zeros(3)
    expected[axis] = torque_nm / AF.inertia[axis]
    # rel 1e-12: the same few float64 operations as the closed form
    np.testing.assert_allclose(xdot[RATE_FRD], expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(xdot[THRUST_N], 0.0, atol=1e-12)  # held thrusts: no lag motion
    # total thrust is still the weight: no vertical acceleration (round-off only)
    np.testing.assert_allclose(xdot[VEL_NED], 0.0, atol=1e-12)


def test_roll_pitch_yaw_commands_turn_and_move_the_vehicle_the_documented_way() -> None:
    params = pack_params(NO_DRAG)  # no drag torque: each rotation stays about one axis
    steps = 200
    t = steps * DT

    def fly(thrust_n: tuple[float, ...]) -> NDArray[np.float64]:
        x = _state(thrust_n=thrust_n)
        u = np.array(thrust_n) / AF.thrust_gain
        for _ in range(steps):
            x = rk4_step(x, u, NO_WIND, M, params, DT)
        return x

    # angle = (U / I) t^2 / 2 about one body axis; rel 1e-8: RK4 error of the quaternion
    # kinematics (angle is quadratic, q is not polynomial), (omega dt)^4 ~ 1e-12 per step
    rolled = fly((HOVER_T, HOVER_T, HOVER_T + 0.1, HOVER_T - 0.1))
    roll = quat_to_euler(rolled[QUAT_WXYZ])[0]
    assert roll == pytest.approx(0.5 * (0.2 * 0.2 / 0.03) * t**2, rel=1e-8)  # right side down
    assert rolled[4] > 0.0  # thrust tilted to the right: drifts east (+y NED) at yaw 0
    pitched = fly((HOVER_T + 0.1, HOVER_T - 0.1, HOVER_T, HOVER_T))
    pitch = quat_to_euler(pitched[QUAT_WXYZ])[1]
    assert pitch == pytest.approx(0.5 * (0.2 * 0.2 / 0.03) * t**2, rel=1e-8)  # nose up
    assert pitched[3] < 0.0  # thrust tilted backwards: drifts south (-x NED)
    yawed = fly((HOVER_T + 0.1,) * 2 + (HOVER_T - 0.1,) * 2)
    yaw = quat_to_euler(yawed[QUAT_WXYZ])[2]
    assert yaw == pytest.approx(0.5 * (0.023 * 0.4 / 0.04) * t**2, rel=1e-8)  # nose right
    # 1e-9 m: a pure yaw does not tilt the thrust, so no horizontal drift beyond round-off
    np.testing.assert_allclose(yawed[POS_NED][:2], 0.0, atol=1e-9)


@pytest.mark.parametrize("inertia", [AF.inertia, (0.02, 0.03, 0.04)])
def test_torque_free_tumble_conserves_angular_momentum_and_energy(
    inertia: tuple[float, float, float],
) -> None:
    """Eq. 3.6 with tau = 0: world-frame L = R I omega and 0.5 omega' I omega are constant."""
    af = Airframe(inertia=inertia, drag_coeff_xy=0.0, drag_coeff_z=0.0, drag_quad_coeff=0.0,
                  rate_damping=(0.0, 0.0, 0.0))
    params = pack_params(af)
    i_b = np.diag(inertia)
    x = _state(euler=(0.3, -0.2, 1.0), rate_frd=(2.0, -3.0, 4.0), thrust_n=(0.0,) * 4)

    def momentum(s: NDArray[np.float64]) -> NDArray[np.float64]:
        return quat_to_rotation(s[QUAT_WXYZ]) @ i_b @ s[RATE_FRD]

    def energy(s: NDArray[np.float64]) -> float:
        return float(0.5 * s[RATE_FRD] @ i_b @ s[RATE_FRD])

    l0, e0 = momentum(x), energy(x)
    for _ in range(1000):  # 2 s, several turns
        x = rk4_step(x, np.zeros(4), NO_WIND, M, params, DT)
    # rel 1e-8: RK4 truncation at |omega| dt = 0.011 rad per step, (omega dt)^5 per step
    np.testing.assert_allclose(momentum(x), l0, rtol=1e-8, atol=1e-10)
    assert energy(x) == pytest.approx(e0, rel=1e-8)


def test_rate_damping_is_the_documented_linear_law() -> None:
    x = _state(rate_frd=(0.5, -0.4, 3.0))
    xdot = derivative(x, np.full(4, AF.hover_pwm), NO_WIND, M, pack_params(AF))
    i_b = np.array(AF.inertia)
    omega = x[RATE_FRD]
    # I dw/dt = -diag(g) w - w x I w at hover thrust, level, no wind; rel 1e-12: same operations
    expected = (-np.array(AF.rate_damping) * omega - np.cross(omega, i_b * omega)) / i_b
    np.testing.assert_allclose(xdot[RATE_FRD], expected, rtol=1e-12, atol=1e-12)


def test_constant_yaw_torque_settles_at_torque_over_damping() -> None:
    """The missing equilibrium of an undamped plant: r -> U4 / g_z with time constant
    Izz / g_z (4 s); after 8 time constants the rate is within 0.04 % of it."""
    params = pack_params(AF)
    thrust = (HOVER_T + 0.5, HOVER_T + 0.5, HOVER_T - 0.5, HOVER_T - 0.5)
    x = _state(thrust_n=thrust)
    u = np.array(thrust) / AF.thrust_gain
    for _ in range(round(32.0 / DT)):
        x = rk4_step(x, u, NO_WIND, M, params, DT)
    r_inf = AF.yaw_gain * 2.0 / AF.rate_damping[2]  # 4.6 rad/s
    # rel 1e-3: exp(-8) = 3.4e-4 of the transient is left
    assert x[12] == pytest.approx(r_inf, rel=1e-3)


def test_drag_pushes_downwind_and_pitches_like_blade_flapping() -> None:
    params = pack_params(AF)
    wind = np.array([5.0, 0.0, 0.0])  # 5 m/s blowing towards north
    xdot = derivative(_state(), np.full(4, AF.hover_pwm), wind, M, params)
    # air-relative velocity (-5, 0, 0): F = (d_xy + c_q * 5) * 5 N towards north
    force = (AF.drag_coeff_xy + AF.drag_quad_coeff * 5.0) * 5.0
    # rel 1e-12: closed form of the same float64 operations
    np.testing.assert_allclose(xdot[VEL_NED], [force / M, 0.0, 0.0], rtol=1e-12, atol=1e-12)
    # tau_y = z_cp * F_x, z_cp above the CG: a tail wind (the vehicle flies backwards through
    # the air) pushes the rotor plane forward and pitches the nose down
    assert xdot[11] == pytest.approx(AF.cp_offset_z * force / AF.inertia[1], rel=1e-12)
    assert xdot[11] < 0.0


def test_drag_force_and_torque_match_the_documented_model_at_any_attitude() -> None:
    """F_b = -(D + c_q |v_b|) v_b on v_b = R^T (v - wind), tau_w = (0, 0, z_cp) x F_b."""
    params = pack_params(AF)
    roll, pitch, yaw = 0.2, -0.3, 0.5
    vel, wind = np.array([1.0, -2.0, 3.0]), np.array([-0.5, 1.0, 0.4])
    x = _state(euler=(roll, pitch, yaw), vel_ned=tuple(vel))
    r = _rz(yaw) @ _ry(pitch) @ _rx(roll)
    v_b = r.T @ (vel - wind)
    d = np.array([AF.drag_coeff_xy, AF.drag_coeff_xy, AF.drag_coeff_z])
    f_drag = -(d + AF.drag_quad_coeff * np.linalg.norm(v_b)) * v_b
    f_b = f_drag + [0.0, 0.0, -4.0 * HOVER_T]
    tau = np.cross([0.0, 0.0, AF.cp_offset_z], f_drag)
    xdot = derivative(x, np.full(4, AF.hover_pwm), wind, M, params)
    # 1e-12: round-off of the same closed form evaluated another way
    np.testing.assert_allclose(xdot[VEL_NED], [0.0, 0.0, G] + r @ f_b / M, atol=1e-12)
    np.testing.assert_allclose(xdot[RATE_FRD], tau / np.array(AF.inertia), atol=1e-12)


# ---- RK4 against solve_ivp ---------------------------------------------------------------
def test_rk4_agrees_with_solve_ivp_over_an_aggressive_manoeuvre() -> None:
    params = pack_params(AF)
    wind = np.array([2.0, -1.0, 0.3])
    inertia = np.array(AF.inertia)
    k, arm, kpsi = AF.thrust_gain, AF.arm_length, AF.yaw_gain

    def pwm(x: NDArray[np.float64], t: float) -> NDArray[np.float64]:
        """100 Hz PD attitude tracking of +-34/29/57 deg sinusoids with altitude hold."""
        ref = np.array([0.6 * math.sin(math.pi * t), 0.5 * math.sin(1.4 * math.pi * t),
                        1.0 * math.sin(0.6 * math.pi * t)])
        euler = quat_to_euler(x[QUAT_WXYZ])
        tau = inertia * (40.0 * (ref - euler) - 10.0 * x[RATE_FRD])
        u1 = M * (G + 2.0 * x[5] + (x[2] + 50.0)) / (math.cos(euler[0]) * math.cos(euler[1]))
        s12, s34 = 0.5 * (u1 + tau[2] / kpsi), 0.5 * (u1 - tau[2] / kpsi)
        thrust = np.array([s12 + tau[1] / arm, s12 - tau[1] / arm,
                           s34 + tau[0] / arm, s34 - tau[0] / arm]) * 0.5
        return np.clip(thrust / k, AF.pwm_min, AF.pwm_max)

    x = _state(pos_ned=(0.0, 0.0, -50.0))
    y = x.copy()
    sub = 5  # plant steps per 100 Hz autopilot tick
    max_pos_err = 0.0
    max_tilt = 0.0
    for tick in range(500):  # 5 s
        t = tick * sub * DT
        u_x, u_y = pwm(x, t), pwm(y, t)  # each trajectory closes its own loop
        for _ in range(sub):
            x = rk4_step(x, u_x, wind, M, params, DT)
        sol = solve_ivp(lambda _t, s, u=u_y: derivative(s, u, wind, M, params),
                        (t, t + sub * DT), y, method="DOP853", rtol=1e-10, atol=1e-12)
        y = sol.y[:, -1]
        max_pos_err = max(max_pos_err, float(np.max(np.abs(x[POS_NED] - y[POS_NED]))))
        max_tilt = max(max_tilt, float(np.max(np.abs(quat_to_euler(x[QUAT_WXYZ])[:2]))))
        # RK4 renormalises; 1e-12: a few ulps of round-off in the normalisation
        assert abs(np.linalg.norm(x[QUAT_WXYZ]) - 1.0) < 1e-12
    assert max_tilt > math.radians(25.0)  # the manoeuvre is aggressive, as intended
    assert max_pos_err < 1e-6  # the requirement; measured ~2e-9 m


# ---- accelerometer -----------------------------------------------------------------------
def test_specific_force_at_rest_in_hover_and_in_free_fall() -> None:
    params = pack_params(AF)
    on_ground = _state(pos_ned=(0.0, 0.0, 0.0), thrust_n=(0.0,) * 4)
    hover = _state()
    falling = _state(thrust_n=(0.0,) * 4)
    # 1e-12 m/s^2: round-off of closed forms
    np.testing.assert_allclose(specific_force_frd(on_ground, NO_WIND, M, params), [0, 0, -G],
                               atol=1e-12)
    np.testing.assert_allclose(specific_force_frd(hover, NO_WIND, M, params), [0, 0, -G],
                               atol=1e-12)
    np.testing.assert_allclose(specific_force_frd(falling, NO_WIND, M, params), 0.0, atol=1e-12)
    # on the ground but pushing more than the weight: the ground no longer holds it
    lifting = _state(pos_ned=(0.0, 0.0, 0.0), thrust_n=(2 * HOVER_T,) * 4)
    np.testing.assert_allclose(specific_force_frd(lifting, NO_WIND, M, params), [0, 0, -2 * G],
                               atol=1e-12)


def test_plant_resting_and_hovering_read_minus_g() -> None:
    params = pack_params(AF)
    plant = RigidBodyPlant(AF, DT)
    for _ in range(10):
        plant.step(np.zeros(4), NO_WIND, M)
    np.testing.assert_allclose(specific_force_frd(plant.state, NO_WIND, M, params), [0, 0, -G],
                               atol=1e-12)  # round-off only


finite_angle = st.floats(-math.pi, math.pi, allow_nan=False)
pitch_angle = st.floats(-1.5, 1.5, allow_nan=False)  # away from the +-90 deg singularity
small = st.floats(-10.0, 10.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(roll=finite_angle, pitch=pitch_angle, yaw=finite_angle, vx=small, vy=small, vz=small,
       wx=small, wy=small, t1=st.floats(0, 9), t2=st.floats(0, 9), t3=st.floats(0, 9),
       t4=st.floats(0, 9))
def test_accelerometer_is_consistent_with_the_translational_dynamics(
    roll: float, pitch: float, yaw: float, vx: float, vy: float, vz: float, wx: float,
    wy: float, t1: float, t2: float, t3: float, t4: float,
) -> None:
    """R f + g e3 = dv/dt (eq. 3.5) for any airborne attitude, velocity, wind and thrust."""
    params = pack_params(AF)
    x = _state(euler=(roll, pitch, yaw), vel_ned=(vx, vy, vz), thrust_n=(t1, t2, t3, t4))
    wind = np.array([wx, wy, 0.5])
    f = specific_force_frd(x, wind, M, params)
    vdot = derivative(x, np.zeros(4), wind, M, params)[VEL_NED]
    # 1e-9 m/s^2: round-off of forces up to ~40 N through a rotation and a division by m
    np.testing.assert_allclose(quat_to_rotation(x[QUAT_WXYZ]) @ f + [0, 0, G], vdot, atol=1e-9)


# ---- rotation conventions ----------------------------------------------------------------
@settings(max_examples=300, deadline=None)
@given(roll=finite_angle, pitch=pitch_angle, yaw=finite_angle)
def test_euler_quat_round_trip_and_zyx_rotation(roll: float, pitch: float, yaw: float) -> None:
    q = euler_to_quat(roll, pitch, yaw)
    assert abs(np.linalg.norm(q) - 1.0) < 1e-14  # unit by construction, round-off only
    back = quat_to_euler(q)
    # 1e-9 rad: asin loses precision near |pitch| = 1.5 (derivative 1/cos ~ 14); wrap +-pi
    diff = (back - np.array([roll, pitch, yaw]) + math.pi) % (2 * math.pi) - math.pi
    np.testing.assert_allclose(diff, 0.0, atol=1e-9)
    # R = Rz(yaw) Ry(pitch) Rx(roll); 1e-14: round-off of products of unit-size numbers
    np.testing.assert_allclose(quat_to_rotation(q), _rz(yaw) @ _ry(pitch) @ _rx(roll),
                               atol=1e-14)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=4, max_size=4))
def test_quat_euler_quat_round_trip_up_to_sign(components: list[float]) -> None:
    q = np.array(components)
    norm = np.linalg.norm(q)
    if norm < 1e-3:
        return
    q /= norm
    r = quat_to_rotation(q)
    # orthonormal with det +1; 1e-14: round-off
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-14)
    back = euler_to_quat(*quat_to_euler(q))
    # q and -q are the same rotation; 1e-6: asin's conditioning near gimbal lock
    # (|pitch| -> 90 deg) costs up to sqrt(eps) ~ 1e-8 rad, kept with margin
    sign = 1.0 if np.dot(back, q) >= 0 else -1.0
    np.testing.assert_allclose(sign * back, q, atol=1e-6)


def test_positive_angles_have_the_documented_meaning() -> None:
    # positive roll: the body right axis (0, 1, 0) points down (+z NED)
    assert (quat_to_rotation(euler_to_quat(0.3, 0.0, 0.0)) @ [0, 1, 0])[2] > 0
    # positive pitch: the nose (1, 0, 0) points up (-z NED)
    assert (quat_to_rotation(euler_to_quat(0.0, 0.3, 0.0)) @ [1, 0, 0])[2] < 0
    # positive yaw: the nose turns from north towards east (+y NED)
    assert (quat_to_rotation(euler_to_quat(0.0, 0.0, 0.3)) @ [1, 0, 0])[1] > 0


# ---- wrapper behaviour -------------------------------------------------------------------
def test_state_is_a_read_only_live_view() -> None:
    plant = RigidBodyPlant(AF, DT)
    plant.reset(pos_ned=(0.0, 0.0, -1.0))
    view = plant.state
    with pytest.raises(ValueError, match="read-only"):
        view[0] = 1.0
    plant.step(np.zeros(4), NO_WIND, M)
    assert view[5] > 0.0  # the same view shows the new (falling) velocity


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"pos_ned": (0.0, 0.0, 0.1)}, "z <= 0"),
        ({"vel_ned": (0.0, 0.0, 1.0)}, "zero on the ground"),
        ({"thrust_n": (1.0, -1.0, 0.0, 0.0)}, ">= 0 N"),
    ],
)
def test_reset_rejects_impossible_states(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        RigidBodyPlant(AF, DT).reset(**kwargs)  # type: ignore[arg-type]


def test_step_rejects_bad_shapes_and_mass() -> None:
    plant = RigidBodyPlant(AF, DT)
    with pytest.raises(ValueError, match="want \\(4,\\)"):
        plant.step(np.zeros(3), NO_WIND, M)
    with pytest.raises(ValueError, match="want > 0"):
        plant.step(np.zeros(4), NO_WIND, 0.0)
    with pytest.raises(ValueError, match="dt_s"):
        RigidBodyPlant(AF, 0.0)


@pytest.mark.parametrize("pitch", [math.pi / 2, -math.pi / 2])
@pytest.mark.parametrize(("roll", "yaw"), [(0.0, 0.0), (0.4, -1.1), (-2.5, 3.0)])
def test_quat_to_euler_at_gimbal_lock_keeps_the_rotation(
    roll: float, pitch: float, yaw: float
) -> None:
    q = euler_to_quat(roll, pitch, yaw)
    euler = quat_to_euler(q)
    assert euler[0] == 0.0  # the convention at the pole: all of the heading goes into yaw
    # 1e-7: asin of sin(theta) rounded near 1 is off by up to sqrt(2 eps) ~ 2e-8 rad
    np.testing.assert_allclose(quat_to_rotation(euler_to_quat(*euler)), quat_to_rotation(q),
                               atol=1e-7)
