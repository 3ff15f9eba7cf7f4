"""Relaxed hover (fcu.control.relaxed_hover): the equilibrium balances the model's equations,
and the simulator's plant, started on it open loop, stays on it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fcu.control.relaxed_hover import relaxed_hover, torque_matrix
from fcu.model import VehicleModel
from sim.scenario import nominal_model
from sim.world.airframe import Airframe
from sim.world.dynamics import RATE_FRD, STATE_SIZE, pack_params, rk4_step

AF = Airframe()
MODEL = nominal_model(AF)
DT = 0.002  # s, the plant's default step


@pytest.mark.parametrize("motor", [1, 2, 3, 4])
def test_equilibrium_balances_forces_and_moments(motor: int) -> None:
    eq = relaxed_hover(MODEL, motor)
    assert eq.thrust_n[motor - 1] == 0.0
    assert np.linalg.norm(eq.axis_frd) == pytest.approx(1.0, abs=1e-12)
    # mean thrust along n holds the weight
    assert eq.collective_n * -eq.axis_frd[2] == pytest.approx(MODEL.mass * MODEL.gravity,
                                                              rel=1e-9)
    omega = eq.rate_frd
    inertia = np.diag(MODEL.inertia)
    moment = (torque_matrix(MODEL) @ eq.thrust_n - np.array(MODEL.rate_damping) * omega
              - np.cross(omega, inertia @ omega))
    assert np.allclose(moment, 0.0, atol=1e-9)  # N*m: the solver's tolerance


def test_yaw_balance_closed_form_and_figures_of_the_docstring() -> None:
    eq = relaxed_hover(MODEL, 1)
    t_side = eq.thrust_n[2]
    # w g_z (-n_z) = K_psi (2 - rho) T_s (module docstring), the spin-setting equation
    spin = MODEL.yaw_gain * (2.0 - eq.opposite_ratio) * t_side / (
        MODEL.rate_damping[2] * -eq.axis_frd[2])
    assert eq.spin_rad_s == pytest.approx(spin, rel=1e-9)
    assert eq.spin_rad_s == pytest.approx(19.65, abs=0.01)  # the docstring's figure
    assert eq.yaw_rate_rad_s < 0.0  # the counter-clockwise rotor is missing
    assert np.degrees(eq.tilt_rad) == pytest.approx(8.5, abs=0.05)
    # motor 3 (clockwise) lost spins the other way at the same rate
    assert relaxed_hover(MODEL, 3).yaw_rate_rad_s == pytest.approx(-eq.yaw_rate_rad_s)


def test_no_yaw_damping_means_no_relaxed_hover() -> None:
    with pytest.raises(ValueError, match="yaw damping must be > 0"):
        relaxed_hover(VehicleModel(rate_damping=(0.0, 0.0, 0.0)), 1)


def test_too_heavy_to_hover_on_three_rotors_is_refused() -> None:
    with pytest.raises(ValueError, match="cannot hover"):
        relaxed_hover(VehicleModel(mass=2.5), 1)


@pytest.mark.parametrize("motor", [1, 2, 3, 4])
def test_two_opposite_rotors_lost_spin_level_on_the_other_pair(motor: int) -> None:
    """rho = 0 without a fixed thrust is the two-propeller relaxed hover (docs/rotor-loss.md):
    the other pair at half the weight each, no tilt, the yaw torque of that pair against the
    yaw damping alone: r = K_psi m g / g_z, 32 rad/s for the Qball-X4, the sense of the pair
    that flies (1 and 2 counter-clockwise: the body turns clockwise, r > 0 when 3 and 4 are
    lost)."""
    eq = relaxed_hover(MODEL, motor, 0.0, 0.0)
    pair = {1: (0, 1), 2: (0, 1), 3: (2, 3), 4: (2, 3)}[motor]
    flying = [i for i in range(4) if i not in pair]
    assert all(eq.thrust_n[i] == 0.0 for i in pair)
    weight = MODEL.mass * MODEL.gravity
    assert all(eq.thrust_n[i] == pytest.approx(weight / 2.0, rel=1e-12) for i in flying)
    assert eq.tilt_rad == 0.0
    spin = MODEL.yaw_gain * weight / MODEL.rate_damping[2]
    assert abs(eq.yaw_rate_rad_s) == pytest.approx(spin, rel=1e-12)
    assert abs(eq.yaw_rate_rad_s) == pytest.approx(32.04, abs=0.01)
    assert np.sign(eq.yaw_rate_rad_s) == (1.0 if motor in (3, 4) else -1.0)


@pytest.mark.parametrize(("motor", "pair"), [(1, False), (3, False), (3, True), (1, True)])
def test_plant_started_on_the_equilibrium_stays_there_open_loop(motor: int, pair: bool
                                                                 ) -> None:
    eq = relaxed_hover(MODEL, motor, 0.0, 0.0) if pair else relaxed_hover(MODEL, motor)
    # attitude with n pointing up: the shortest rotation taking n (body) to -e3 (NED)
    rot, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [eq.axis_frd])
    x = np.zeros(STATE_SIZE)
    x[2] = -10.0
    x[6:10] = rot.as_quat(scalar_first=True)
    x[10:13] = eq.rate_frd
    x[13:17] = eq.thrust_n
    # the thrust's horizontal part turns with the body: start on the circle it flies,
    # v = -(omega_w x a_h) / |omega|^2
    omega_w = rot.apply(eq.rate_frd)
    accel = rot.apply([0.0, 0.0, -eq.collective_n / MODEL.mass])
    accel[2] = 0.0
    x[3:6] = -np.cross(omega_w, accel) / float(omega_w @ omega_w)
    u = eq.thrust_n / AF.thrust_gain
    params = pack_params(AF)
    rates = []
    for _ in range(round(2.0 / DT)):  # 2 s, 6 turns
        x = rk4_step(x, u, np.zeros(3), AF.mass, params, DT)
        rates.append(x[RATE_FRD].copy())
    rate = np.array(rates)
    spin = np.linalg.norm(rate, axis=1)
    # the spin rate stays within 1 % of the derived one (the brief's criterion)
    assert np.max(np.abs(spin - abs(eq.spin_rad_s))) < 0.01 * abs(eq.spin_rad_s)
    # n stays up: R n = -e3 within 2 deg (open loop: an unstable equilibrium drifts slowly)
    up = Rotation.from_quat(x[6:10], scalar_first=True).apply(eq.axis_frd)
    assert np.degrees(np.arccos(np.clip(-up[2], -1.0, 1.0))) < 2.0
    # height held within 5 cm over the 2 s (the mean thrust along n equals the weight)
    assert abs(x[2] + 10.0) < 0.05
