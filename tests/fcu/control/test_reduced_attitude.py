"""Reduced-attitude control (fcu.control.reduced_attitude) on the simulator's plant, fed the
true state: from a level hover at the instant a rotor is lost to relaxed hover."""

from __future__ import annotations

import numpy as np
import pytest

from fcu.control.reduced_attitude import ReducedAttitudeController, rotation_zyx
from sim.scenario import nominal_model
from sim.world.airframe import Airframe
from sim.world.dynamics import RigidBodyPlant
from sim.world.rotations import euler_to_quat, quat_to_euler, quat_to_rotation

AF = Airframe()
MODEL = nominal_model(AF)
DT = 0.01  # s, the autopilot's tick
PLANT_STEPS = 5  # 500 Hz plant


def fly(motor: int, seconds: float) -> tuple[np.ndarray, np.ndarray, ReducedAttitudeController]:
    """Hover at 1 m, motor ``motor`` dead from t = 0; a PD position loop gives the force."""
    ctrl = ReducedAttitudeController(MODEL, motor, DT)
    plant = RigidBodyPlant(AF, DT / PLANT_STEPS)
    hover = AF.mass * AF.gravity / 4.0
    plant.reset(pos_ned=(0.0, 0.0, -1.0), thrust_n=(hover,) * 4)
    ctrl.reset(np.full(4, hover))
    kp, kd = np.array([2.0, 2.0, 4.0]), np.array([2.5, 2.5, 4.0])
    positions, rates = [], []
    for _ in range(round(seconds / DT)):
        x = plant.state
        mu = kp * (np.array([0.0, 0.0, -1.0]) - x[0:3]) - kd * x[3:6]
        cmd = ctrl.step(quat_to_euler(x[6:10]), x[10:13], mu - np.array([0.0, 0.0, AF.gravity]))
        assert cmd.thrust_n[motor - 1] == 0.0
        u = cmd.pwm.copy()
        u[motor - 1] = 0.0  # the rotor is gone
        for _ in range(PLANT_STEPS):
            plant.step(u, np.zeros(3), AF.mass)
        positions.append(plant.state[0:3].copy())
        rates.append(plant.state[10:13].copy())
    return np.array(positions), np.array(rates), ctrl


@pytest.mark.parametrize("motor", [1, 3])
def test_from_level_hover_to_relaxed_hover_on_the_plant(motor: int) -> None:
    positions, rates, ctrl = fly(motor, 15.0)
    eq = ctrl.equilibrium
    late = slice(-300, None)  # the last 3 s
    # the spin settles on the derived one (1 %: the thrust split differs a little from the
    # equilibrium's once the integral has trimmed the axis)
    assert np.mean(rates[late, 2]) == pytest.approx(eq.yaw_rate_rad_s, rel=0.01)
    # position held within 5 cm throughout (the PD loop here has no integral)
    assert np.max(np.linalg.norm(positions - [0.0, 0.0, -1.0], axis=1)) < 0.05


def test_thrust_axis_points_at_the_commanded_direction_once_settled() -> None:
    positions, _, ctrl = fly(1, 15.0)
    # mean position is where the loop holds it: the mean thrust is vertical, so n points up
    assert np.linalg.norm(np.mean(positions[-300:], axis=0) - [0.0, 0.0, -1.0]) < 0.01


def test_saturation_keeps_the_collective_when_the_torque_cannot_be_made() -> None:
    ctrl = ReducedAttitudeController(MODEL, 1, DT)
    # a huge pitch-up request (motor 2 would need negative thrust): it is clipped, and the
    # pair on the roll axis keeps the collective
    thrust = ctrl._allocate(14.0, 0.0, 2.0, 0.0)
    assert thrust[0] == 0.0 and thrust[1] == 0.0
    assert np.sum(thrust) == pytest.approx(14.0)
    assert thrust[2] == pytest.approx(thrust[3])  # no roll asked: the roll torque kept at 0


def test_saturation_gives_the_torques_priority_over_the_collective() -> None:
    ctrl = ReducedAttitudeController(MODEL, 1, DT)
    top = MODEL.thrust_gain * MODEL.pwm_max
    arm = MODEL.arm_length
    # a roll torque the pair can make only with one motor at full thrust and the other off,
    # beside more collective than that leaves: the roll torque is made, the collective not
    thrust = ctrl._allocate(20.0, arm * top, 0.0, 0.0)
    assert thrust[2] == pytest.approx(top) and thrust[3] == pytest.approx(0.0)
    assert arm * (thrust[2] - thrust[3]) == pytest.approx(arm * top)
    assert np.sum(thrust) < 20.0


def test_a_stuck_motor_is_allocated_around() -> None:
    stuck_n = 3.5  # N, motor 1 stuck near hover thrust
    ctrl = ReducedAttitudeController(MODEL, 1, DT, fixed_thrust_n=stuck_n)
    torque = np.array(MODEL.thrust_mixer())[1:3]  # roll and pitch rows, N*m per N
    thrust = ctrl._allocate(14.0, 0.01, -0.02, stuck_n)
    assert thrust[0] == stuck_n
    assert np.sum(thrust) == pytest.approx(14.0)
    assert torque @ thrust == pytest.approx([0.01, -0.02])


def test_rotation_zyx_matches_the_simulator() -> None:
    euler = (0.3, -0.2, 2.5)
    assert np.allclose(rotation_zyx(np.array(euler)), quat_to_rotation(euler_to_quat(*euler)),
                       atol=1e-12)


@pytest.mark.parametrize("bad", ["rate", "euler", "force"])
def test_a_failed_estimate_gives_the_equilibrium_thrusts_not_an_error(bad: str) -> None:
    """A tumbling vehicle's estimator may diverge: the controller keeps commanding finite
    thrusts (the equilibrium's) instead of raising."""
    ctrl = ReducedAttitudeController(MODEL, 1, DT)
    euler, rate, force = np.zeros(3), np.array([0.0, 0.0, -5.0]), np.array([0.0, 0.0, -9.81])
    {"rate": rate, "euler": euler, "force": force}[bad][0] = np.nan
    cmd = ctrl.step(euler, rate, force)
    assert np.isfinite(cmd.pwm).all()
    np.testing.assert_allclose(cmd.thrust_n, ctrl.equilibrium.thrust_n)
    # and it carries on once the estimate is finite again
    cmd = ctrl.step(np.zeros(3), np.array([0.0, 0.0, -5.0]), np.array([0.0, 0.0, -9.81]))
    assert np.isfinite(cmd.pwm).all()
