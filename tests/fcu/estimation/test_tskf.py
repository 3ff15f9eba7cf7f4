"""TwoStageKalmanFilter: hover model, equivalence with the augmented Kalman filter,
consistency, and the Table 6.1 step profile on a closed-loop nonlinear harness (with the
fault detector run on it).

The harness (``HarnessPlant``, ``HarnessController``, ``run_closed_loop``) is self-contained,
so these tests do not depend on sim/: a quaternion rigid body with first-order motors and loss
of effectiveness, linear rotor drag on the air-relative velocity acting 3 cm above the CG,
Ornstein-Uhlenbeck gusts, a ground plane, sensors at their own rates and noise (gyro and
accel 250 Hz, mocap 100 Hz, baro 50 Hz), and a PID cascade with integral action on position
and attitude (fed the true state: the harness tests the estimator, not feedback through it).
Everything random comes from one seeded Generator.

Run ``python tests/fcu/test_tskf.py`` for a per-step cost benchmark (prints, never asserts).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from scipy.linalg import block_diag, expm
from scipy.stats import chi2

from fcu.estimation.ekf_model import model_jacobian, pack_params
from fcu.estimation.state import STATE_DIM, StateEstimate
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.estimation.tskf_model import TskfProcessNoise, hover_model
from fcu.hal import SensorSample
from fcu.model import VehicleModel
from fcu.monitoring.motor_faults import DetectorConfig, MotorFaultDetector
from flightdata.records import DetectionRecord

MODEL = VehicleModel()
DT = 0.01  # s, the filter and control tick
HOVER_T = MODEL.mass * MODEL.gravity / 4.0  # N per motor
U_HOVER = np.full(4, MODEL.hover_pwm)
SIGMA = {"gyro": 0.003, "accel": 0.03, "mocap_pos": 0.0005, "mocap_att": 0.002, "baro": 0.02}
STEP_PROFILE = {1: (38.0, 0.50), 3: (22.0, 0.45), 4: (48.0, 0.15)}  # Table 6.1, step row
LINEAR = hover_model(MODEL, DT, TskfProcessNoise().diagonal())  # the TSKF's default model


def hover_state(alt_m: float = 0.6) -> np.ndarray:
    x = np.zeros(STATE_DIM)
    x[2] = -alt_m
    x[12:16] = HOVER_T
    return x


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


# =============================================================================================
# Closed-loop harness
# =============================================================================================
DRAG_FRD = (0.25, 0.25, 0.35)  # N/(m/s), linear rotor drag along body x, y, z
CP_Z_M = -0.03  # m, drag acts 3 cm above the CG (FRD z is down)
PLANT_DT = 0.002  # s, 500 Hz
SENSOR_PERIOD_STEPS = {"gyro": 2, "accel": 2, "mocap_pos": 5, "mocap_att": 5, "baro": 10}


def quat_to_euler(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)),
        math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x)))),
        math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)),
    ])


class HarnessPlant:
    """Quaternion rigid body (state: pos, vel NED, quat wxyz, rates FRD, thrusts; 17)."""

    def __init__(self, model: VehicleModel, pos_ned: np.ndarray, thrust_n: float) -> None:
        self.model = model
        self.x = np.zeros(17)
        self.x[0:3] = pos_ned
        self.x[6] = 1.0
        self.x[13:17] = thrust_n
        self.specific_force_frd = np.array([0.0, 0.0, -model.gravity])

    def derivative(self, x: np.ndarray, u_eff: np.ndarray, wind_ned: np.ndarray) -> np.ndarray:
        m = self.model
        ixx, iyy, izz = m.inertia
        _, _, _, vx, vy, vz, qw, qx, qy, qz, p, q, r, t1, t2, t3, t4 = x.tolist()
        # R (body FRD -> NED) from the quaternion
        r11, r12 = 1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz)
        r13, r21 = 2 * (qx * qz + qw * qy), 2 * (qx * qy + qw * qz)
        r22, r23 = 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx)
        r31, r32 = 2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx)
        r33 = 1 - 2 * (qx * qx + qy * qy)
        ax, ay, az = vx - wind_ned[0], vy - wind_ned[1], vz - wind_ned[2]
        # drag on the air-relative velocity in body axes
        fdx = -DRAG_FRD[0] * (r11 * ax + r21 * ay + r31 * az)
        fdy = -DRAG_FRD[1] * (r12 * ax + r22 * ay + r32 * az)
        fdz = -DRAG_FRD[2] * (r13 * ax + r23 * ay + r33 * az)
        fbz = fdz - (t1 + t2 + t3 + t4)
        self.specific_force_frd = np.array([fdx, fdy, fbz]) / m.mass
        # body torques: eq. 3.17 plus the drag's moment (0, 0, cp_z) x F_drag
        tx = m.arm_length * (t3 - t4) - CP_Z_M * fdy
        ty = m.arm_length * (t1 - t2) + CP_Z_M * fdx
        tz = m.yaw_gain * (t1 + t2 - t3 - t4)
        w, k = m.motor_bandwidth, m.thrust_gain
        return np.array([
            vx, vy, vz,
            (r11 * fdx + r12 * fdy + r13 * fbz) / m.mass,
            (r21 * fdx + r22 * fdy + r23 * fbz) / m.mass,
            (r31 * fdx + r32 * fdy + r33 * fbz) / m.mass + m.gravity,
            0.5 * (-qx * p - qy * q - qz * r),
            0.5 * (qw * p + qy * r - qz * q),
            0.5 * (qw * q + qz * p - qx * r),
            0.5 * (qw * r + qx * q - qy * p),
            (tx - (izz - iyy) * q * r) / ixx,
            (ty - (ixx - izz) * p * r) / iyy,
            (tz - (iyy - ixx) * p * q) / izz,
            w * (k * u_eff[0] - t1), w * (k * u_eff[1] - t2),
            w * (k * u_eff[2] - t3), w * (k * u_eff[3] - t4),
        ])

    def step(self, u_eff: np.ndarray, wind_ned: np.ndarray) -> None:
        """RK4 over PLANT_DT, then the ground plane z = 0 (resting: level, yaw kept)."""
        h, x = PLANT_DT, self.x
        k1 = self.derivative(x, u_eff, wind_ned)
        k2 = self.derivative(x + 0.5 * h * k1, u_eff, wind_ned)
        k3 = self.derivative(x + 0.5 * h * k2, u_eff, wind_ned)
        k4 = self.derivative(x + h * k3, u_eff, wind_ned)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[6:10] /= np.linalg.norm(x[6:10])
        self.on_ground = bool(x[2] >= 0.0)
        if self.on_ground:
            yaw = quat_to_euler(x[6:10])[2]
            x[2] = 0.0
            x[3:6] = 0.0
            x[6:10] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
            x[10:13] = 0.0
            self.specific_force_frd = np.array([0.0, 0.0, -self.model.gravity])
        self.x = x

    @property
    def euler(self) -> np.ndarray:
        return quat_to_euler(self.x[6:10])

    def sample(self, name: str) -> np.ndarray:
        x = self.x
        if name == "gyro":
            return x[10:13].copy()
        if name == "accel":
            return self.specific_force_frd.copy()
        if name == "mocap_pos":
            return x[0:3].copy()
        if name == "mocap_att":
            return self.euler
        return np.array([-x[2]])  # baro: altitude, up positive


class HarnessController:
    """PID position loop (integral on every axis) around a PID attitude loop; inverse mixer.

    Each loop's gains put its closed-loop poles at a triple real pole -w:
    ``(s + w)^3 = s^3 + 3 w s^2 + 3 w^2 s + w^3``, so kd = 3 w, kp = 3 w^2, ki = w^3 (per unit
    mass or inertia). The integrators are what keep it hovering after a loss of effectiveness
    (the attitude ones restore the torque balance, the altitude one the lift). When a motor
    would saturate, the yaw torque is given up first.
    """

    def __init__(self, model: VehicleModel, dt_s: float) -> None:
        self.model = model
        self.dt_s = dt_s
        self.mixer_inv = np.linalg.inv(model.mixer())
        w_pos = np.array([1.5, 1.5, 2.5])  # rad/s, outer loop well below the inner one
        w_att = np.array([6.0, 6.0, 4.0])  # rad/s, below the 15 rad/s motor lag
        self.kd_pos, self.kp_pos, self.ki_pos = 3 * w_pos, 3 * w_pos ** 2, w_pos ** 3
        self.kd_att, self.kp_att, self.ki_att = 3 * w_att, 3 * w_att ** 2, w_att ** 3
        self.int_pos = np.zeros(3)
        self.int_att = np.zeros(3)

    def __call__(self, pos: np.ndarray, vel: np.ndarray, euler: np.ndarray, rate: np.ndarray,
                 pos_ref: np.ndarray) -> np.ndarray:
        m, g = self.model, self.model.gravity
        e_p = pos_ref - pos
        self.int_pos = np.clip(self.int_pos + e_p * self.dt_s, -2.0, 2.0)
        a = self.kp_pos * e_p - self.kd_pos * vel + self.ki_pos * self.int_pos
        a = np.clip(a, [-4.0, -4.0, -9.0], [4.0, 4.0, 6.0])
        phi, theta, psi = euler
        g_eff = g - a[2]
        u1 = m.mass * g_eff / (math.cos(phi) * math.cos(theta))
        ax_h = math.cos(psi) * a[0] + math.sin(psi) * a[1]
        ay_h = -math.sin(psi) * a[0] + math.cos(psi) * a[1]
        eta_d = np.array([np.clip(ay_h / g_eff, -0.3, 0.3), np.clip(-ax_h / g_eff, -0.3, 0.3),
                          0.0])
        e_a = eta_d - euler
        e_a[2] = wrap(e_a[2])
        self.int_att = np.clip(self.int_att + e_a * self.dt_s, -1.0, 1.0)
        tau = m.inertia_diag * (self.kp_att * e_a - self.kd_att * rate
                                + self.ki_att * self.int_att)
        for yaw_share in (1.0, 0.5, 0.0):
            u = self.mixer_inv @ np.array([u1, tau[0], tau[1], yaw_share * tau[2]])
            if u.min() >= m.pwm_min and u.max() <= m.pwm_max:
                break
        return np.clip(u, m.pwm_min, m.pwm_max)


@dataclass
class ClosedLoopRun:
    """Per-tick records of a harness flight."""

    t: np.ndarray  # (n,) s
    gamma_raw: np.ndarray  # (n, 4) the TSKF's unclipped gamma_hat
    loe_estimate: np.ndarray  # (n, 4) clipped to [0, 1]
    loe_reported: np.ndarray  # (n, 4) the detector's, common mode (mass) removed
    gamma_true: np.ndarray  # (n, 4)
    pos_true: np.ndarray  # (n, 3) m
    state_error: np.ndarray  # (n, 16) truth minus estimate (yaw wrapped)
    events: list[DetectionRecord] = field(default_factory=list)
    step_cpu_s: np.ndarray = field(default_factory=lambda: np.zeros(0))


def run_closed_loop(make_filter: Callable[[VehicleModel], TwoStageKalmanFilter], *,
                    duration_s: float, faults: dict[int, tuple[float, float]], seed: int,
                    wind_mean_ned: tuple[float, float, float] = (0.5, 0.0, 0.0),
                    gust_sigma: float = 0.3, start_on_ground: bool = False,
                    alt_m: float = 0.6) -> ClosedLoopRun:
    """Fly the harness with a TSKF and a MotorFaultDetector in the loop.

    ``faults`` maps motor (1..4) to (onset s, loss fraction). Gusts: Ornstein-Uhlenbeck,
    2 s correlation, ``gust_sigma`` m/s horizontally and half that vertically. From the
    ground the reference climbs to ``alt_m`` along a cubic from 1 s to 4 s (motors off
    before 1 s).
    """
    rng = np.random.default_rng(seed)
    tskf = make_filter(MODEL)
    detector = MotorFaultDetector(MODEL, DetectorConfig(), DT)
    pos0 = np.zeros(3) if start_on_ground else np.array([0.0, 0.0, -alt_m])
    plant = HarnessPlant(MODEL, pos0, 0.0 if start_on_ground else HOVER_T)
    ctrl = HarnessController(MODEL, DT)
    if start_on_ground:
        tskf.reset(0.0)
    else:
        x0 = hover_state(alt_m)
        tskf.reset(0.0, StateEstimate.from_vector(0.0, x0, np.full(STATE_DIM, 1e-4)))
    wind_mean = np.array(wind_mean_ned)
    a_w = math.exp(-PLANT_DT / 2.0)
    gust_sig = np.array([gust_sigma, gust_sigma, gust_sigma / 2])
    wind = wind_mean + gust_sig * rng.standard_normal(3)
    u = np.zeros(4) if start_on_ground else U_HOVER.copy()
    rec: dict[str, list[np.ndarray]] = {k: [] for k in ("g", "l", "r", "gt", "p", "e")}
    t_rec: list[float] = []
    cpu: list[float] = []
    events: list[DetectionRecord] = []
    k_plant = 0
    for tick in range(1, round(duration_s / DT) + 1):
        t_tick = tick * DT
        samples = []
        gamma = np.zeros(4)
        for _ in range(round(DT / PLANT_DT)):
            gamma = np.zeros(4)
            for motor, (onset, loss) in faults.items():
                if k_plant * PLANT_DT >= onset - 1e-9:
                    gamma[motor - 1] = loss
            plant.step((1.0 - gamma) * u, wind)
            wind = wind_mean + a_w * (wind - wind_mean) + \
                gust_sig * math.sqrt(1 - a_w * a_w) * rng.standard_normal(3)
            k_plant += 1
            for name, period in SENSOR_PERIOD_STEPS.items():
                if k_plant % period == 0:
                    val = plant.sample(name)
                    val = val + SIGMA[name] * rng.standard_normal(val.shape)
                    samples.append(SensorSample(name, k_plant * PLANT_DT, val))
        t0 = time.process_time()
        est = tskf.step(t_tick, u, samples)  # u: the PWM held over the tick just ended
        cpu.append(time.process_time() - t0)
        events += detector.step(t_tick, tskf.gamma_raw, u, evidence=True, learn=True)
        if start_on_ground:
            s = min(max((t_tick - 1.0) / 3.0, 0.0), 1.0)
            pos_ref = np.array([0.0, 0.0, -alt_m * (3 * s * s - 2 * s ** 3)])
        else:
            pos_ref = np.array([0.0, 0.0, -alt_m])
        u = ctrl(plant.x[0:3], plant.x[3:6], plant.euler, plant.x[10:13], pos_ref)
        if start_on_ground and t_tick < 1.0:
            u = np.zeros(4)
            ctrl.int_pos[:] = 0.0
            ctrl.int_att[:] = 0.0
        truth = np.concatenate((plant.x[0:6], plant.euler, plant.x[10:17]))
        err = truth - est.to_vector()
        err[8] = wrap(err[8])
        t_rec.append(t_tick)
        rec["g"].append(tskf.gamma_raw.copy())
        rec["l"].append(tskf.loe_estimate)
        rec["r"].append(detector.evidence.loe)
        rec["gt"].append(gamma)
        rec["p"].append(plant.x[0:3].copy())
        rec["e"].append(err)
    return ClosedLoopRun(np.array(t_rec), np.array(rec["g"]), np.array(rec["l"]),
                         np.array(rec["r"]), np.array(rec["gt"]), np.array(rec["p"]),
                         np.array(rec["e"]), events, np.array(cpu))


@pytest.fixture(scope="module")
def step_profile_run() -> ClosedLoopRun:
    return run_closed_loop(lambda m: TwoStageKalmanFilter(m), duration_s=60.0,
                           faults=STEP_PROFILE, seed=1)


@pytest.fixture(scope="module")
def fault_free_takeoff_run() -> ClosedLoopRun:
    return run_closed_loop(lambda m: TwoStageKalmanFilter(m, height_source="baro"),
                           duration_s=60.0, faults={}, seed=2, gust_sigma=0.6,
                           start_on_ground=True)


# =============================================================================================
# Model
# =============================================================================================
def test_hover_model_is_eq_6_1_in_ned() -> None:
    lm = hover_model(MODEL, DT, TskfProcessNoise().diagonal())
    a, g, m = lm.a_c, MODEL.gravity, MODEL.mass
    assert a[3, 7] == -g  # x'' = -g theta: nose up tilts the thrust backwards
    assert a[4, 6] == g  # y'' = g phi: right side down drifts right
    np.testing.assert_array_equal(a[5, 12:16], -1.0 / m)  # z'' = g - U1/m ...
    assert lm.g_c[5] == g  # ... with g as the known constant input
    # U2 = L (T3 - T4), U3 = L (T1 - T2), U4 = K_psi (T1 + T2 - T3 - T4), over the inertia
    ixx, iyy, izz = MODEL.inertia
    arm, kpsi = MODEL.arm_length, MODEL.yaw_gain
    np.testing.assert_allclose(a[9, 12:16], [0, 0, arm / ixx, -arm / ixx])
    np.testing.assert_allclose(a[10, 12:16], [arm / iyy, -arm / iyy, 0, 0])
    np.testing.assert_allclose(a[11, 12:16], np.array([1, 1, -1, -1]) * kpsi / izz)
    # the PWM acts only through the thrust lag: B_a = K w in the thrust rows (eq. 6.4)
    np.testing.assert_array_equal(lm.b_c[:12], 0.0)
    np.testing.assert_allclose(lm.b_c[12:], MODEL.thrust_gain * MODEL.motor_bandwidth * np.eye(4))


def test_linear_model_is_the_ekf_jacobian_at_hover() -> None:
    """Two implementations, one linearisation: the TSKF's A_a is the EKF's df/dx at hover."""
    lm = hover_model(MODEL, DT, TskfProcessNoise().diagonal())
    a_ekf = model_jacobian(hover_state(), pack_params(MODEL), False)
    np.testing.assert_allclose(lm.a_c, a_ekf, atol=1e-12)  # float rounding of U1/m = g


def test_zoh_discretisation_keeps_hover_and_matches_expm() -> None:
    lm = hover_model(MODEL, DT, TskfProcessNoise().diagonal())
    xs = hover_state()
    # hover is a fixed point of the discrete model with gravity as a known input
    np.testing.assert_allclose(lm.a_d @ xs + lm.b_d @ U_HOVER + lm.g_d, xs, atol=1e-12)
    # ZOH: [A_d, B_d, g_d] from expm of the augmented matrix [[A, B, g], [0, 0, 0]] dt
    n = STATE_DIM
    big = np.zeros((n + 5, n + 5))
    big[:n, :n] = lm.a_c
    big[:n, n:n + 4] = lm.b_c
    big[:n, n + 4] = lm.g_c
    e = expm(big * DT)
    np.testing.assert_allclose(lm.a_d, e[:n, :n], atol=1e-12)  # same algorithm, rounding
    np.testing.assert_allclose(lm.b_d, e[:n, n:n + 4], atol=1e-10)
    np.testing.assert_allclose(lm.g_d, e[:n, n + 4], atol=1e-12)
    # a falling vehicle with motors off drops g dt^2 / 2 in one tick
    assert lm.g_d[2] == pytest.approx(0.5 * MODEL.gravity * DT ** 2, rel=1e-9)
    # ground model: no gravity, no thrust coupling
    gm = hover_model(MODEL, DT, TskfProcessNoise().diagonal(), on_ground=True)
    np.testing.assert_array_equal(gm.g_d, 0.0)
    np.testing.assert_array_equal(gm.a_d[0:12, 12:16], 0.0)


# =============================================================================================
# Equivalence with plain Kalman filters on the linear model
# =============================================================================================
def _linear_pd(x: np.ndarray) -> np.ndarray:
    """Stabilising hover PD on a linear-model state (test scaffolding for the linear plant)."""
    g = MODEL.gravity
    e_p = hover_state()[0:3] - x[0:3]
    a = np.array([1.0, 1.0, 4.0]) * e_p - np.array([1.5, 1.5, 3.0]) * x[3:6]
    eta_d = np.array([a[1] / g, -a[0] / g, 0.0])
    tau = MODEL.inertia_diag * (np.array([60.0, 60.0, 20.0]) * (eta_d - x[6:9])
                                - np.array([14.0, 14.0, 8.0]) * x[9:12])
    wrench = np.concatenate(([MODEL.mass * (g - a[2])], tau))
    return np.linalg.solve(MODEL.mixer(), wrench)


def _linear_samples(rng: np.random.Generator, t: float, x: np.ndarray,
                    drop_mocap: bool) -> list[SensorSample]:
    """mocap at the tick; the gyro as two samples 6 and 2 ms before it (mean 4 ms back)."""
    out = []
    if not drop_mocap:
        out.append(SensorSample("mocap_pos", t, x[0:3] + SIGMA["mocap_pos"] * rng.normal(size=3)))
        out.append(SensorSample("mocap_att", t, x[6:9] + SIGMA["mocap_att"] * rng.normal(size=3)))
    for dt_back in (0.006, 0.002):
        # a linear-plant gyro reading dt_back before the tick, to first order
        rate = x[9:12] - dt_back * (LINEAR.a_c @ x)[9:12]
        out.append(SensorSample("gyro", t - dt_back, rate + SIGMA["gyro"] * rng.normal(size=3)))
    return out


def _measurement_rows(samples: list[SensorSample], t: float) -> tuple[np.ndarray, np.ndarray,
                                                                       np.ndarray]:
    """C (m, 16), y (m,), R diagonal (m,) as the TSKF builds them (eq. 6.8)."""
    lm = LINEAR
    rows, ys, rs = [], [], []
    for name, cols in (("mocap_pos", [0, 1, 2]), ("mocap_att", [6, 7, 8]), ("gyro", [9, 10, 11])):
        batch = [s for s in samples if s.sensor == name]
        if not batch:
            continue
        delta = t - float(np.mean([s.time_s for s in batch]))
        sel = np.zeros((3, STATE_DIM))
        sel[np.arange(3), cols] = 1.0
        rows.append(sel - delta * sel @ lm.a_c)
        ys.append(np.mean([s.value for s in batch], axis=0))
        rs.append(np.full(3, SIGMA[name] ** 2 / len(batch)))
    return np.vstack(rows), np.concatenate(ys), np.concatenate(rs)


def test_tskf_equals_the_augmented_state_kalman_filter() -> None:
    """Hsieh-Chen: the TSKF is algebraically the KF on [x; gamma] (eq. 6.8-6.9)."""
    rng = np.random.default_rng(31)
    q_gamma = 1e-4
    tskf = TwoStageKalmanFilter(MODEL, DT, q_gamma, gamma_std0=0.1, ground_z_ned=None)
    lm = tskf.flight_model
    std0 = np.r_[[1e-3] * 3, [1e-2] * 3, [2e-3] * 3, [1e-2] * 3, [0.1] * 4]
    x_hat0 = hover_state()
    tskf.reset(0.0, StateEstimate.from_vector(0.0, x_hat0, std0 ** 2))
    kf = KalmanFilter(dim_x=20, dim_z=9, dim_u=5)
    kf.x = np.concatenate((x_hat0, np.zeros(4)))
    kf.P = block_diag(np.diag(std0 ** 2), 0.01 * np.eye(4))
    x = x_hat0 + std0 * rng.standard_normal(STATE_DIM)
    gamma = np.array([0.0, 0.1, 0.3, 0.0])
    worst_x = worst_p = 0.0
    for k in range(1, 301):
        t = k * DT
        u = _linear_pd(x) + 0.002 * rng.standard_normal(4)
        # truth: x' = A x + B (I - Gamma) u + g + w
        x = lm.a_d @ x + lm.b_d @ ((1 - gamma) * u) + lm.g_d + \
            np.linalg.cholesky(lm.q_d) @ rng.standard_normal(STATE_DIM)
        samples = _linear_samples(rng, t, x, drop_mocap=(k % 7 == 0))
        tskf.step(t, u, samples)
        # augmented KF: F = [[A, E], [0, I]], E = -B diag(u); input [u; 1]
        f_aug = np.block([[lm.a_d, -lm.b_d * u], [np.zeros((4, 16)), np.eye(4)]])
        b_aug = np.vstack((np.hstack((lm.b_d, lm.g_d[:, None])), np.zeros((4, 5))))
        kf.predict(u=np.append(u, 1.0), B=b_aug, F=f_aug,
                   Q=block_diag(lm.q_d, q_gamma * np.eye(4)))
        c, y, r_diag = _measurement_rows(samples, t)
        kf.dim_z = len(y)  # this tick's measurement set (mocap may be missing)
        kf.update(y, R=np.diag(r_diag), H=np.hstack((c, np.zeros((len(y), 4)))))
        sd = np.sqrt(np.diag(kf.P))
        worst_x = max(worst_x, float(np.max(np.abs(np.append(tskf.x_hat, tskf.gamma_raw)
                                                   - kf.x) / sd)))
        worst_p = max(worst_p, float(np.max(np.abs(tskf.joint_covariance - kf.P)
                                            / np.outer(sd, sd))))
    # same estimate and covariance up to rounding (in units of the estimate's sigma)
    assert worst_x < 1e-6, worst_x
    assert worst_p < 1e-6, worst_p
    assert np.all(np.abs(tskf.gamma_raw - gamma) < 4 * tskf.loe_std)  # and it did learn gamma


def test_gamma_held_at_zero_reduces_to_a_plain_kalman_filter() -> None:
    """With Q^gamma = 0 and P^gamma ~ 0, the bias-free filter is the KF of eq. 6.3."""
    rng = np.random.default_rng(32)
    tskf = TwoStageKalmanFilter(MODEL, DT, q_gamma=0.0, gamma_std0=1e-9, ground_z_ned=None)
    lm = tskf.flight_model
    std0 = np.r_[[1e-3] * 3, [1e-2] * 3, [2e-3] * 3, [1e-2] * 3, [0.1] * 4]
    tskf.reset(0.0, StateEstimate.from_vector(0.0, hover_state(), std0 ** 2))
    kf = KalmanFilter(dim_x=16, dim_z=9, dim_u=5)
    kf.x = hover_state()
    kf.P = np.diag(std0 ** 2)
    x = hover_state() + std0 * rng.standard_normal(STATE_DIM)
    for k in range(1, 301):
        t = k * DT
        u = _linear_pd(x)
        x = lm.a_d @ x + lm.b_d @ u + lm.g_d + \
            np.linalg.cholesky(lm.q_d) @ rng.standard_normal(STATE_DIM)
        samples = _linear_samples(rng, t, x, drop_mocap=False)
        tskf.step(t, u, samples)
        kf.predict(u=np.append(u, 1.0), B=np.hstack((lm.b_d, lm.g_d[:, None])), F=lm.a_d,
                   Q=lm.q_d)
        c, y, r_diag = _measurement_rows(samples, t)
        kf.update(y, R=np.diag(r_diag), H=c)
        sd = np.sqrt(np.diag(kf.P))
        # P^gamma = 1e-18 leaves contributions ~1e-9 of a sigma
        assert np.max(np.abs(tskf.x_hat - kf.x) / sd) < 1e-6
        assert np.max(np.abs(tskf.P - kf.P) / np.outer(sd, sd)) < 1e-6
    assert np.max(np.abs(tskf.gamma_raw)) < 1e-6  # gamma cannot move


def test_nees_over_monte_carlo_runs_on_the_linear_plant() -> None:
    """Truth = the TSKF's own model (eq. 6.8, 6.9): the joint [x; gamma] NEES is chi2(20)."""
    rng = np.random.default_rng(33)
    q_gamma = 1e-4
    std0 = np.r_[[1e-3] * 3, [1e-2] * 3, [2e-3] * 3, [1e-2] * 3, [0.1] * 4]
    g_std0 = 0.1
    n_runs, checkpoints = 30, (10, 100, 300)
    nees = np.zeros((n_runs, max(checkpoints)))
    for run in range(n_runs):
        tskf = TwoStageKalmanFilter(MODEL, DT, q_gamma, gamma_std0=g_std0, ground_z_ned=None)
        lm = tskf.flight_model
        tskf.reset(0.0, StateEstimate.from_vector(0.0, hover_state(), std0 ** 2))
        x = hover_state() + std0 * rng.standard_normal(STATE_DIM)
        gamma = g_std0 * rng.standard_normal(4)
        chol_q = np.linalg.cholesky(lm.q_d)
        for k in range(1, max(checkpoints) + 1):
            t = k * DT
            u = _linear_pd(x)
            x = lm.a_d @ x + lm.b_d @ ((1 - gamma) * u) + lm.g_d + \
                chol_q @ rng.standard_normal(STATE_DIM)
            gamma = gamma + math.sqrt(q_gamma) * rng.standard_normal(4)
            tskf.step(t, u, _linear_samples(rng, t, x, drop_mocap=False))
            err = np.append(x - tskf.x_hat, gamma - tskf.gamma_raw)
            err[8] = wrap(err[8])
            nees[run, k - 1] = err @ np.linalg.solve(tskf.joint_covariance, err)
    lo, hi = chi2.ppf([0.005, 0.995], 20 * n_runs) / n_runs
    for k in checkpoints:
        # independent runs: the sum over runs of the NEES at one tick is chi2(20 n_runs)
        assert lo < nees[:, k - 1].mean() < hi, (k, nees[:, k - 1].mean(), lo, hi)


# =============================================================================================
# Interface details
# =============================================================================================
def test_yaw_innovation_wraps_and_estimate_is_wrapped() -> None:
    tskf = TwoStageKalmanFilter(MODEL, ground_z_ned=None)
    x0 = hover_state()
    x0[8] = math.pi - 0.005
    tskf.reset(0.0, StateEstimate.from_vector(0.0, x0, np.full(STATE_DIM, 1e-4)))
    att = np.array([0.0, 0.0, -math.pi + 0.005])  # 0.01 rad further on, across the seam
    est = tskf.step(DT, U_HOVER, [SensorSample("mocap_att", DT, att)])
    inn = tskf.last_innovation["mocap_att"]
    assert abs(inn.residual[2] - 0.01) < 1e-3  # not -2 pi + 0.01
    assert abs(wrap(est.euler_rad[2] - att[2])) < 0.01
    assert -math.pi <= est.euler_rad[2] < math.pi


def test_loe_estimate_is_clipped_but_raw_value_kept() -> None:
    tskf = TwoStageKalmanFilter(MODEL)
    tskf.reset(0.0, gamma0=[-0.2, 0.3, 1.4, 0.0])
    np.testing.assert_array_equal(tskf.loe_estimate, [0.0, 0.3, 1.0, 0.0])
    np.testing.assert_array_equal(tskf.gamma_raw, [-0.2, 0.3, 1.4, 0.0])


def test_step_timing_rules() -> None:
    tskf = TwoStageKalmanFilter(MODEL, DT)
    tskf.step(0.0, U_HOVER, [])  # same time as reset: update only
    tskf.step(0.03, U_HOVER, [])  # a late tick: three predictions
    assert tskf.time_s == pytest.approx(0.03)
    with pytest.raises(ValueError, match="dt_s"):
        tskf.step(0.035, U_HOVER, [])  # half a period
    with pytest.raises(ValueError, match="dt_s"):
        tskf.step(0.02, U_HOVER, [])  # backwards


@pytest.mark.parametrize(("kwargs", "key"), [
    ({"dt_s": 0.0}, "dt_s"),
    ({"q_gamma": -1.0}, "q_gamma"),
    ({"gamma_std0": 0.0}, "gamma_std0"),
    ({"height_source": "lidar"}, "height_source"),
])
def test_bad_settings_name_the_key(kwargs: dict[str, object], key: str) -> None:
    with pytest.raises(ValueError, match=key):
        TwoStageKalmanFilter(MODEL, **kwargs)  # type: ignore[arg-type]


# =============================================================================================
# Closed loop: Table 6.1 step profile and the fault detector
# =============================================================================================
@pytest.mark.slow
def test_step_profile_loe_within_005_in_3_s_healthy_below_005(
        step_profile_run: ClosedLoopRun) -> None:
    run = step_profile_run
    for motor in range(1, 5):
        # the reported estimate: the TSKF's gamma with the common mode (mass) removed
        g = run.loe_reported[:, motor - 1]
        if motor in STEP_PROFILE:
            onset, loss = STEP_PROFILE[motor]
            healthy = run.t < onset
            off = np.abs(g - loss) >= 0.05
            late_off = run.t[off & (run.t >= onset)]
            settled = late_off[-1] - onset if late_off.size else 0.0
            print(f"motor {motor}: within 0.05 of {loss} from {settled:.2f} s after onset; "
                  f"max error from 1 s after onset {np.abs(g - loss)[run.t > onset + 1].max():.3f}")
            # enters the band within 3 s of the fault and never leaves it again
            assert settled <= 3.0
        else:
            healthy = np.ones_like(run.t, dtype=bool)
        print(f"motor {motor}: healthy max {g[healthy].max():.3f}")
        assert g[healthy].max() < 0.05


@pytest.mark.slow
def test_step_profile_state_estimate(step_profile_run: ClosedLoopRun) -> None:
    err = step_profile_run.state_error[step_profile_run.t > 1.0]
    rms = np.sqrt(np.mean(err ** 2, axis=0))
    print("state error rms:", np.array2string(rms, precision=4))
    assert np.all(rms[0:3] < 0.001)  # m: mocap 0.5 mm noise, filtered
    assert np.all(rms[3:6] < 0.03)  # m/s
    assert np.all(rms[6:9] < 0.005)  # rad: mocap 2 mrad, plus the linearisation
    assert np.all(rms[9:12] < 0.01)  # rad/s: gyro 3 mrad/s
    # thrusts, i.e. the gamma-compensated actuator states (eq. 6.25): 3 % of hover thrust
    assert np.all(rms[12:16] < 0.1 * HOVER_T)
    # the vehicle kept hovering through all three faults (the harness did its job)
    assert np.max(np.abs(step_profile_run.pos_true - [0.0, 0.0, -0.6])) < 0.4


@pytest.mark.slow
def test_detector_reports_each_step_fault_within_3_s(step_profile_run: ClosedLoopRun) -> None:
    events = step_profile_run.events
    assert [e.kind for e in events] == ["loe", "loe", "loe"]
    assert [e.motor for e in events] == [3, 1, 4]  # in onset order: 22 s, 38 s, 48 s
    for e in events:
        assert e.motor is not None
        onset, loss = STEP_PROFILE[e.motor]
        print(f"{e.time_s:.2f} s: {e.text()} (true {loss:.0%}, latency {e.time_s - onset:.2f} s)")
        assert onset < e.time_s <= onset + 3.0
        assert 0.1 < e.magnitude < loss + 0.05


@pytest.mark.slow
def test_no_detection_in_a_fault_free_flight_with_wind(
        fault_free_takeoff_run: ClosedLoopRun) -> None:
    run = fault_free_takeoff_run
    assert run.events == []
    airborne = run.t > 1.5
    print(f"healthy gamma_hat range after take-off: {run.gamma_raw[airborne].min():.3f} .. "
          f"{run.gamma_raw[airborne].max():.3f}")
    assert run.loe_reported[airborne].max() < 0.05
    assert run.pos_true[-1, 2] == pytest.approx(-0.6, abs=0.05)  # it did take off and hover
    # before the motors start the filter's ground model holds gamma still
    np.testing.assert_array_equal(run.gamma_raw[run.t < 1.0], 0.0)
