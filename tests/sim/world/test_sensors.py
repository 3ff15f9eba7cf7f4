"""Sensor suite: rates, simulated timestamps, noise statistics, seeding and fault routing."""

from __future__ import annotations

import math
import re
from collections import defaultdict

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flightdata.config import ConfigError, from_mapping
from sim.world.fault_types import SENSOR_NAMES, SensorFault
from sim.world.faults import FaultEngine
from sim.world.sensors import SensorConfig, SensorSuite, quat_to_euler_zyx

PLANT_HZ = 500.0


def make_state() -> np.ndarray:
    """A non-trivial true state: off-origin, moving, rotated about all axes, spinning."""
    x = np.zeros(17)
    x[0:3] = [1.0, -2.0, -0.6]  # m, NED: 0.6 m up
    x[3:6] = [0.2, -0.1, 0.05]  # m/s
    q_xyzw = Rotation.from_euler("ZYX", [0.3, -0.2, 0.1]).as_quat()  # yaw, pitch, roll
    x[6:10] = np.roll(q_xyzw, 1)  # to [w, x, y, z]
    x[10:13] = [0.1, -0.2, 0.05]  # rad/s
    x[13:17] = 3.48  # N
    return x


SPECIFIC_FORCE = np.array([0.5, -0.3, -9.81])  # m/s^2, FRD


def make_suite(seed: int = 0, config: SensorConfig | None = None,
               faults: FaultEngine | None = None) -> SensorSuite:
    eng = faults or FaultEngine(np.random.default_rng(seed + 1000), 0.05, 1.42)
    return SensorSuite(config or SensorConfig(), PLANT_HZ, np.random.default_rng(seed), eng)


def run(suite: SensorSuite, seconds: float, state: np.ndarray | None = None,
        ) -> dict[str, list[tuple[int, float, np.ndarray]]]:
    """Step the suite over the plant grid; samples by sensor as (step, time_s, value)."""
    x = make_state() if state is None else state
    out: dict[str, list[tuple[int, float, np.ndarray]]] = defaultdict(list)
    for k in range(round(seconds * PLANT_HZ)):
        for s in suite.sample(k, k / PLANT_HZ, x, SPECIFIC_FORCE):
            out[s.sensor].append((k, s.time_s, s.value))
    return out


def truth(state: np.ndarray) -> dict[str, np.ndarray]:
    q = state[6:10]
    yaw, pitch, roll = Rotation.from_quat(q, scalar_first=True).as_euler("ZYX")
    return {"gyro": state[10:13], "accel": SPECIFIC_FORCE, "mocap_pos": state[0:3],
            "mocap_att": np.array([roll, pitch, yaw]), "baro": np.array([-state[2]])}


def test_each_sensor_fires_at_its_rate_on_simulated_time() -> None:
    samples = run(make_suite(), 1.0)
    counts = {name: len(samples[name]) for name in SENSOR_NAMES}
    assert counts == {"gyro": 250, "accel": 250, "mocap_pos": 100, "mocap_att": 100,
                      "baro": 50}
    for name, rate in [("gyro", 250), ("mocap_att", 100), ("baro", 50)]:
        steps = [k for k, _, _ in samples[name]]
        assert steps == list(range(0, 500, 500 // rate))
        assert [t for _, t, _ in samples[name]] == [k / PLANT_HZ for k in steps]
    assert [len(v) for _, _, v in samples["baro"]] == [1] * 50
    assert all(v.shape == (3,) for name in SENSOR_NAMES[:4] for _, _, v in samples[name])


def test_nothing_due_returns_the_shared_empty_result() -> None:
    suite = make_suite()
    x = make_state()
    assert suite.sample(1, 0.002, x, SPECIFIC_FORCE) == ()
    assert suite.sample(1, 0.002, x, SPECIFIC_FORCE) is suite.sample(3, 0.006, x,
                                                                     SPECIFIC_FORCE)


def test_noise_has_zero_mean_and_the_configured_sigma() -> None:
    config = SensorConfig()
    x = make_state()
    samples = run(make_suite(3, config), 40.0, x)
    ref = truth(x)
    for name in SENSOR_NAMES:
        err = np.array([v for _, _, v in samples[name]]) - ref[name]
        n = err.shape[0]
        sigma = config.sigma(name)
        # mean within 5 standard errors sigma / sqrt(n); 1e-12 covers the Euler truth's rounding
        np.testing.assert_array_less(np.abs(err.mean(axis=0)), 5 * sigma / math.sqrt(n) + 1e-12)
        # sample std has relative s.e. 1/sqrt(2n) (0.7 % to 1.6 % here); allow 5 s.e.
        np.testing.assert_allclose(err.std(axis=0), sigma, rtol=5 / math.sqrt(2 * n))
    gyro = np.array([v for _, _, v in samples["gyro"]]) - ref["gyro"]
    assert abs(np.corrcoef(gyro[:, 0], gyro[:, 1])[0, 1]) < 0.05  # axes independent: 5 s.e.


def test_noise_scale_zero_gives_the_exact_truth() -> None:
    x = make_state()
    samples = run(make_suite(config=SensorConfig(noise_scale=0.0)), 0.1, x)
    ref = truth(x)
    for name in ("gyro", "accel", "mocap_pos", "baro"):
        for _, _, v in samples[name]:
            np.testing.assert_array_equal(v, ref[name])
    for _, _, v in samples["mocap_att"]:
        np.testing.assert_allclose(v, ref["mocap_att"], rtol=0, atol=1e-14)  # float rounding


def test_same_seed_is_bit_identical_and_another_seed_differs() -> None:
    a, b, c = (run(make_suite(seed), 2.0) for seed in (5, 5, 6))
    for name in SENSOR_NAMES:
        va, vb, vc = (np.array([v for _, _, v in s[name]]) for s in (a, b, c))
        np.testing.assert_array_equal(va, vb)
        assert not np.any(va == vc)  # continuous noise: no reading may coincide


def test_reset_replays_the_noise() -> None:
    suite = make_suite(9)
    first = run(suite, 0.5)
    suite.reset()
    again = run(suite, 0.5)
    for name in SENSOR_NAMES:
        np.testing.assert_array_equal(np.array([v for _, _, v in first[name]]),
                                      np.array([v for _, _, v in again[name]]))


def test_quat_to_euler_matches_scipy_and_the_sign_conventions() -> None:
    rng = np.random.default_rng(2)
    for q_xyzw in Rotation.random(200, random_state=rng).as_quat():
        q = np.roll(q_xyzw, 1)
        yaw, pitch, roll = Rotation.from_quat(q, scalar_first=True).as_euler("ZYX")
        # 1e-9: asin loses precision near pitch = +-90 deg, none of these is that close
        np.testing.assert_allclose(quat_to_euler_zyx(q), [roll, pitch, yaw], atol=1e-9)
    # positive roll about the body x axis puts the right side (body +y) down (+z in NED)
    q_roll = np.array([math.cos(0.05), math.sin(0.05), 0.0, 0.0])
    right_ned = Rotation.from_quat(q_roll, scalar_first=True).apply([0.0, 1.0, 0.0])
    assert right_ned[2] > 0.0
    assert quat_to_euler_zyx(q_roll)[0] == pytest.approx(0.1, abs=1e-15)  # rounding
    # an unnormalised quaternion gives the same angles (1e-15: rounding)
    np.testing.assert_allclose(quat_to_euler_zyx(2.0 * q_roll), [0.1, 0.0, 0.0], atol=1e-15)


def test_sensor_faults_reach_only_their_sensor() -> None:
    eng = FaultEngine(np.random.default_rng(1), 0.05, 1.42)
    eng.schedule(SensorFault(sensor="baro", kind="bias", magnitude=0.1, start_s=0.5))
    suite = make_suite(config=SensorConfig(noise_scale=0.0), faults=eng)
    x = make_state()
    samples = run(suite, 1.0, x)
    ref = truth(x)
    for k, _, v in samples["baro"]:
        expected = ref["baro"] + (0.1 if k >= 250 else 0.0)
        np.testing.assert_array_equal(v, expected)
    for name in ("gyro", "accel", "mocap_pos"):
        for _, _, v in samples[name]:
            np.testing.assert_array_equal(v, ref[name])
    assert [(e.kind, e.time_s) for e in eng.events] == [("injected", 0.0), ("started", 0.5)]


def test_loss_of_accuracy_uses_the_suite_noise_sigma() -> None:
    eng = FaultEngine(np.random.default_rng(1), 0.05, 1.42)
    eng.schedule(SensorFault(sensor="gyro", kind="loss_of_accuracy", magnitude=100.0))
    x = make_state()
    samples = run(make_suite(4, faults=eng), 40.0, x)
    err = np.array([v for _, _, v in samples["gyro"]]) - x[10:13]
    # +100 % -> 2 sigma; 10 000 samples per axis give a 0.7 % s.e. on the std, allow 10 %
    np.testing.assert_allclose(err.std(axis=0), 2 * SensorConfig().gyro_sigma_rad_s, rtol=0.1)


def test_bad_sensor_configuration_is_rejected_by_name() -> None:
    with pytest.raises(ConfigError, match=re.escape("gyro_rate_hz = -1.0: must be a rate > 0 Hz")):
        SensorConfig(gyro_rate_hz=-1.0)
    with pytest.raises(ConfigError, match=re.escape("baro_sigma_m = -0.02: must be a finite")):
        SensorConfig(baro_sigma_m=-0.02)
    with pytest.raises(ConfigError, match=re.escape("noise_scale = -1.0: must be a finite")):
        SensorConfig(noise_scale=-1.0)
    with pytest.raises(ConfigError, match=re.escape(
            "baro_rate_hz = 300.0: must divide the plant rate 500 Hz")):
        make_suite(config=SensorConfig(baro_rate_hz=300.0))
    with pytest.raises(ConfigError, match=re.escape(
            "mocap_pos_rate_hz = 1000.0: must divide the plant rate 500 Hz")):
        make_suite(config=SensorConfig(mocap_pos_rate_hz=1000.0))


def test_sensor_config_loads_from_a_toml_table() -> None:
    config = from_mapping(SensorConfig, {"gyro_rate_hz": 500, "noise_scale": 0.5})
    assert config.gyro_rate_hz == 500.0
    assert config.noise_scale == 0.5
    assert config.baro_rate_hz == 50.0  # unspecified keys keep their defaults
    with pytest.raises(ConfigError, match="unknown key lidar_rate_hz"):
        from_mapping(SensorConfig, {"lidar_rate_hz": 10})
