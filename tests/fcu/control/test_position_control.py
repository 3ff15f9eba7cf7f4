"""Position control (eq. 5.3/5.4) and the whole control chain on a rigid body with motor lag."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fcu.config import AutopilotConfig
from fcu.control.allocation import Allocator
from fcu.control.attitude_pd import AttitudePD
from fcu.control.attitude_reference import AttitudeReferenceFilter
from fcu.control.position import (
    PositionController,
    PositionGains,
    attitude_from_specific_force,
)
from fcu.control.registry import ATTITUDE_LAW_REGISTRY, DOB_REGISTRY
from fcu.model import VehicleModel

MODEL = VehicleModel()
DT = 0.01  # s, the 100 Hz autopilot loop
E3 = np.array([0.0, 0.0, 1.0])


def rotation(euler_rad: np.ndarray) -> np.ndarray:
    """R = Rz(psi) Ry(theta) Rx(phi), body FRD -> NED."""
    phi, theta, psi = euler_rad
    cx, sx, cy, sy, cz, sz = (np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta),
                              np.cos(psi), np.sin(psi))
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


def plant_acceleration(thrust_n: float, euler_rad: np.ndarray) -> np.ndarray:
    """a = g e3 - (U1/m) R e3 (eq. 3.5 in NED/FRD)."""
    return MODEL.gravity * E3 - thrust_n / MODEL.mass * rotation(euler_rad) @ E3


# --------------------------------------------------------------------------------------------
# the inversion of eq. 5.4
# --------------------------------------------------------------------------------------------
@settings(max_examples=300, deadline=None)
@given(mu_x=st.floats(-4.0, 4.0), mu_y=st.floats(-4.0, 4.0), mu_z=st.floats(-4.0, 4.0),
       yaw=st.floats(-np.pi, np.pi))
def test_commanded_attitude_and_thrust_reproduce_mu(mu_x: float, mu_y: float, mu_z: float,
                                                    yaw: float) -> None:
    """mu -> (U1, phi_d, theta_d) -> a = g e3 - U1/m R e3 gives mu back (within limits)."""
    ctrl = PositionController(MODEL, PositionGains(), DT)
    mu = np.array([mu_x, mu_y, mu_z])
    here = np.array([0.3, -0.2, -0.6])
    cmd = ctrl.step(here, np.zeros(3), here, np.zeros(3), mu, yaw)  # feedback terms are 0
    tilt = np.degrees(np.arctan2(np.hypot(mu_x, mu_y), MODEL.gravity - mu_z))
    if tilt < 30.0:  # inside the default tilt limit; the thrust range covers |mu| < 4
        np.testing.assert_allclose(cmd.accel_cmd_ned, mu, atol=1e-12)  # not limited
    a = plant_acceleration(cmd.thrust_n, np.array([cmd.roll_ref_rad, cmd.pitch_ref_rad, yaw]))
    np.testing.assert_allclose(a, cmd.accel_cmd_ned, atol=1e-12)  # exact inversion


def test_hover_and_the_signs_of_the_conventions() -> None:
    ctrl = PositionController(MODEL, PositionGains(), DT)
    zero = np.zeros(3)
    cmd = ctrl.step(zero, zero, zero, zero, zero, 0.0)
    assert cmd.thrust_n == pytest.approx(MODEL.mass * MODEL.gravity, rel=1e-12)  # hover = mg
    assert cmd.roll_ref_rad == 0.0 and cmd.pitch_ref_rad == 0.0
    north = ctrl.step(zero, zero, np.array([0.1, 0.0, 0.0]), zero, zero, 0.0)
    assert north.pitch_ref_rad < 0.0 and abs(north.roll_ref_rad) < 1e-15  # nose down to go N
    ctrl.reset()
    east = ctrl.step(zero, zero, np.array([0.0, 0.1, 0.0]), zero, zero, 0.0)
    assert east.roll_ref_rad > 0.0  # right side down to go east
    ctrl.reset()
    up = ctrl.step(zero, zero, np.array([0.0, 0.0, -0.1]), zero, zero, 0.0)
    assert up.thrust_n > MODEL.mass * MODEL.gravity  # climbing (z more negative) needs more
    ctrl.reset()
    # with yaw 90 deg, going north means rolling left (the nose points east)
    north_yawed = ctrl.step(zero, zero, np.array([0.1, 0.0, 0.0]), zero, zero, np.pi / 2)
    assert north_yawed.roll_ref_rad < 0.0 and abs(north_yawed.pitch_ref_rad) < 1e-12


def test_atan2_pitch_equals_the_usual_asin_form() -> None:
    """theta_d = asin(-(c_psi f_x + s_psi f_y) / (c_phi |f|)), the usual form (module doc)."""
    rng = np.random.default_rng(7)
    for _ in range(100):
        f = np.array([*rng.uniform(-3.0, 3.0, 2), -MODEL.gravity + rng.uniform(-3.0, 3.0)])
        psi = rng.uniform(-np.pi, np.pi)
        phi, theta = attitude_from_specific_force(f, psi)
        usual = np.arcsin(-(np.cos(psi) * f[0] + np.sin(psi) * f[1])
                          / (np.cos(phi) * np.linalg.norm(f)))
        assert theta == pytest.approx(usual, abs=1e-12)  # same angle, no cos(phi) division


def test_tilt_and_thrust_limits_keep_the_vertical_first() -> None:
    gains = PositionGains()
    ctrl = PositionController(MODEL, gains, DT)
    zero = np.zeros(3)
    cmd = ctrl.step(zero, zero, zero, zero, np.array([20.0, 0.0, -1.0]), 0.0)
    assert cmd.accel_cmd_ned[2] == pytest.approx(-1.0, abs=1e-12)  # vertical kept
    tilt = np.arccos(np.cos(cmd.roll_ref_rad) * np.cos(cmd.pitch_ref_rad))
    assert tilt == pytest.approx(gains.tilt_max_rad, abs=1e-12)  # horizontal cut to 30 deg
    dive = ctrl.step(zero, zero, zero, zero, np.array([0.0, 0.0, 30.0]), 0.0)
    assert dive.thrust_n == pytest.approx(ctrl.thrust_min_n, rel=1e-12)
    climb = ctrl.step(zero, zero, zero, zero, np.array([0.0, 0.0, -30.0]), 0.0)
    assert climb.thrust_n == pytest.approx(ctrl.thrust_max_n, rel=1e-12)
    assert ctrl.thrust_max_n == pytest.approx(0.9 * 4 * MODEL.thrust_gain * MODEL.pwm_max)


def test_the_touchdown_holds_the_tilt_to_its_own_limit_below_its_height() -> None:
    """With the touchdown on the tilt stops at ``touchdown_tilt_max_rad`` (20 deg), with it
    off again at ``tilt_max_rad`` (30 deg); the vertical is kept either way."""
    gains = PositionGains()
    ctrl = PositionController(MODEL, gains, DT)
    zero = np.zeros(3)
    push = np.array([20.0, 0.0, -1.0])  # m/s^2 asked: far beyond either limit

    def tilt() -> float:
        cmd = ctrl.step(zero, zero, zero, zero, push, 0.0)
        assert cmd.accel_cmd_ned[2] == pytest.approx(-1.0, abs=1e-12)
        return float(np.arccos(np.cos(cmd.roll_ref_rad) * np.cos(cmd.pitch_ref_rad)))

    assert tilt() == pytest.approx(gains.tilt_max_rad, abs=1e-12)
    for on, expected in ((True, gains.touchdown_tilt_max_rad), (False, gains.tilt_max_rad),
                         (True, gains.touchdown_tilt_max_rad)):
        ctrl.touchdown(on)
        assert tilt() == pytest.approx(expected, abs=1e-12)
    assert gains.touchdown_tilt_max_rad == pytest.approx(np.radians(20.0))
    with pytest.raises(ValueError, match="touchdown_tilt_max_rad"):
        PositionGains(touchdown_tilt_max_rad=np.radians(40.0))
    with pytest.raises(ValueError, match="touchdown_below_m"):
        PositionGains(touchdown_below_m=-1.0)


def test_integral_is_clamped_and_does_not_wind_up_in_saturation() -> None:
    gains = PositionGains()
    ctrl = PositionController(MODEL, gains, DT)
    zero = np.zeros(3)
    far = np.array([50.0, 0.0, 0.0])  # 50 m away: the tilt limit saturates mu_x
    for _ in range(500):
        ctrl.step(zero, zero, far, zero, zero, 0.0)
    assert ctrl.integral[0] == 0.0  # conditional integration: never integrated while limited
    ctrl.reset()
    small = np.array([0.0, 0.0, -0.05])  # 5 cm below: unsaturated, the integral runs to its clamp
    for _ in range(20000):
        ctrl.step(zero, zero, small, zero, zero, 0.0)
    assert abs(gains.ki[2] * ctrl.integral[2]) == pytest.approx(gains.integral_limit[2],
                                                                rel=1e-12)


# --------------------------------------------------------------------------------------------
# the whole chain on a rigid body with motor lag
# --------------------------------------------------------------------------------------------
def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _euler(r: np.ndarray) -> np.ndarray:
    return np.array([np.arctan2(r[2, 1], r[2, 2]), -np.arcsin(np.clip(r[2, 0], -1.0, 1.0)),
                     np.arctan2(r[1, 0], r[0, 0])])


@dataclass
class RigidBody:
    """Eq. 3.5/3.6 with thrusts T_i' = w (K u_i - T_i), RK4; a test double of sim/."""

    torque_disturbance_nm: np.ndarray

    def __post_init__(self) -> None:
        self.pos = np.zeros(3)
        self.vel = np.zeros(3)
        self.rot = np.eye(3)
        self.rate = np.zeros(3)
        self.thrusts = np.full(4, MODEL.mass * MODEL.gravity / 4.0)  # airborne, in hover
        self._mix = MODEL.thrust_mixer()

    def _deriv(self, state: tuple, pwm: np.ndarray) -> tuple:
        _, vel, rot, rate, thrusts = state
        wrench = self._mix @ thrusts
        acc = MODEL.gravity * E3 - wrench[0] / MODEL.mass * rot[:, 2]
        inertia = MODEL.inertia_diag
        hat = _hat(rate)  # hat(a) @ b = a x b, an order of magnitude cheaper than np.cross
        rate_dot = (wrench[1:] + self.torque_disturbance_nm - hat @ (inertia * rate)) / inertia
        thrust_dot = MODEL.motor_bandwidth * (MODEL.thrust_gain * pwm - thrusts)
        return vel, acc, rot @ hat, rate_dot, thrust_dot

    def step(self, pwm: np.ndarray, h: float) -> None:
        s = (self.pos, self.vel, self.rot, self.rate, self.thrusts)
        k1 = self._deriv(s, pwm)
        k2 = self._deriv(tuple(x + h / 2 * d for x, d in zip(s, k1, strict=True)), pwm)
        k3 = self._deriv(tuple(x + h / 2 * d for x, d in zip(s, k2, strict=True)), pwm)
        k4 = self._deriv(tuple(x + h * d for x, d in zip(s, k3, strict=True)), pwm)
        new = [x + h / 6 * (a + 2 * b + 2 * c + d)
               for x, a, b, c, d in zip(s, k1, k2, k3, k4, strict=True)]
        self.pos, self.vel, rot, self.rate, self.thrusts = new
        u, _, vt = np.linalg.svd(rot)
        self.rot = u @ vt  # re-orthonormalise


def fly(attitude: str, dob_kind: str, reference, seconds: float,
        torque_disturbance_nm: np.ndarray) -> dict[str, np.ndarray]:
    """Position -> reference filter -> attitude - DOB -> allocation -> body, at 100 Hz."""
    body = RigidBody(torque_disturbance_nm)
    position = PositionController(MODEL, PositionGains(), DT)
    shaper = AttitudeReferenceFilter(DT)
    config = AutopilotConfig(model=MODEL)  # default gains, as the autopilot builds them
    att = ATTITUDE_LAW_REGISTRY.factory(attitude)(config, DT)
    dob = DOB_REGISTRY.factory(dob_kind)(config, DT)
    alloc = Allocator(MODEL)
    torque_applied = np.zeros(3)
    log: dict[str, list] = {"t": [], "pos": [], "ref": [], "euler": [], "att_ref": [],
                            "pwm": []}
    substeps = 5  # 500 Hz plant, like sim/
    for k in range(int(round(seconds / DT))):
        t = k * DT
        ref_pos, ref_vel, ref_acc = reference(t)
        euler = _euler(body.rot)
        cmd = position.step(body.pos, body.vel, ref_pos, ref_vel, ref_acc, 0.0)
        shaped = shaper.step(np.array([cmd.roll_ref_rad, cmd.pitch_ref_rad, 0.0]))
        d_hat = dob.step(euler, body.rate, torque_applied)
        torque = att.step(euler, body.rate, shaped.euler_rad, shaped.rate, shaped.acc) - d_hat
        pwm = alloc.allocate(cmd.thrust_n, torque)
        torque_applied = alloc.mix(pwm)[1]  # what the saturated PWM really asks for
        for name, value in (("t", t), ("pos", body.pos.copy()), ("ref", ref_pos),
                            ("euler", euler), ("att_ref", shaped.euler_rad), ("pwm", pwm)):
            log[name].append(value)
        for _ in range(substeps):
            body.step(pwm, DT / substeps)
    return {name: np.array(values) for name, values in log.items()}


COMBINATIONS = [(a, d) for a in ("pd", "lqg") for d in ("none", "vbdob", "abdob")]


@pytest.mark.parametrize(("attitude", "dob_kind"), COMBINATIONS)
def test_hover_step_settles_with_a_torque_disturbance(attitude: str, dob_kind: str) -> None:
    target = np.array([0.3, -0.2, -0.6])  # 0.6 m up, and aside

    def reference(_t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return target, np.zeros(3), np.zeros(3)

    d = np.array([0.02, -0.03, 0.005])  # N*m, e.g. a 2 cm offset of the centre of mass
    log = fly(attitude, dob_kind, reference, 20.0, d)
    err = log["pos"] - log["ref"]
    # m: the slowest closed-loop mode (vertical integral, 0.44 rad/s) leaves < 1 mm at 20 s
    assert np.max(np.abs(err[-100:])) < 1e-3
    assert np.max(np.abs(err[:, 2])) < 0.6 * 1.3  # at most 30 % overshoot on the climb
    tilt = np.degrees(np.arccos(np.cos(log["euler"][:, 0]) * np.cos(log["euler"][:, 1])))
    assert tilt.max() < 30.0  # the tilt limit holds
    # mean effort over the last 5 s: hover, m g / K, to 1 % (the thrust balance is exact)
    assert log["pwm"][-500:].sum(axis=1).mean() == pytest.approx(
        MODEL.mass * MODEL.gravity / MODEL.thrust_gain, rel=0.01)
    # hovering means level; what differs is how the attitude loop gets there
    np.testing.assert_allclose(log["euler"][-1, :2], 0.0, atol=1e-4)  # rad, settled
    att_err = log["att_ref"][-1, :2] - log["euler"][-1, :2]
    if attitude == "pd" and dob_kind == "none":
        # eq. 5.6 has no integral: I kp e + d = 0, and the position loop tilts the reference
        kp = np.array(AttitudePD(MODEL).gains.kp[:2])
        standing = -d[:2] / (MODEL.inertia_diag[:2] * kp)
        np.testing.assert_allclose(att_err, standing, rtol=0.01)  # 1 %: settled to 1e-4 rad
    else:
        np.testing.assert_allclose(att_err, 0.0, atol=1e-5)  # integral or DOB cancel d


def _cubic(p0: np.ndarray, p1: np.ndarray, t0: float, duration: float):
    def reference(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = np.clip((t - t0) / duration, 0.0, 1.0)
        moving = 0.0 < t - t0 < duration
        pos = p0 + (p1 - p0) * (3 * s**2 - 2 * s**3)
        vel = (p1 - p0) * (6 * s - 6 * s**2) / duration if moving else np.zeros(3)
        acc = (p1 - p0) * (6 - 12 * s) / duration**2 if moving else np.zeros(3)
        return pos, vel, acc
    return reference


@pytest.mark.parametrize("attitude", ["pd", "lqg"])
def test_a_side_of_the_mission_square_is_tracked_to_millimetres(attitude: str) -> None:
    """1 m along a cubic in 5 s at 0.6 m (brisker than the thesis's 60 s mission), no noise."""
    start, end = np.array([0.0, 0.0, -0.6]), np.array([1.0, 0.0, -0.6])
    reference = _cubic(start, end, 1.0, 5.0)

    def from_start(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        pos, vel, acc = reference(t)
        return pos - start, vel, acc  # the test body starts at the origin

    log = fly(attitude, "vbdob", from_start, 9.0, np.zeros(3))
    err = np.linalg.norm(log["pos"] - log["ref"], axis=1)
    # m: a cubic's acceleration steps by 6/T^2 = 0.24 m/s^2 at each end; the ~0.2 s lag of
    # the reference filter and attitude loop turns that into ~5 mm of error for a moment
    assert err.max() < 7e-3
    assert np.sqrt(np.mean(err**2)) < 2.5e-3  # m: ~2 mm on average over the segment
    assert np.linalg.norm(log["pos"][-1] - log["ref"][-1]) < 2e-4  # m: and it settles
    tilt = np.degrees(np.abs(log["euler"][:, :2])).max()
    assert tilt < 2.5  # deg: 0.24 m/s^2 needs 1.4 deg, plus the feedback's correction
