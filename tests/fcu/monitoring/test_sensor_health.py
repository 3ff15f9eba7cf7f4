"""SensorHealth's repeat check and what follows, on grouped batches and on plain ones."""

from __future__ import annotations

import math

import numpy as np

from fcu.estimation.estimator import ChannelCheck
from fcu.estimation.state import group_samples
from fcu.hal import SensorSample
from fcu.monitoring.sensor_health import SensorHealth, SensorHealthConfig

NOISE = {"gyro": 0.003, "accel": 0.03, "mocap_pos": 0.0005, "mocap_att": 0.002, "baro": 0.02}
KINDS = frozenset(NOISE)


def screening(*sensors: str, status: str = "applied") -> dict[str, ChannelCheck]:
    # residual 0 and variance 1 on three rows (the screening table's layout)
    table = np.concatenate((np.zeros(3), np.ones(3)))
    return {s: ChannelCheck(sensor=s, nis=0.0, gate=30.0, status=status,
                            screen=table, row0=0, row1=3, n_rows=3) for s in sensors}


def tick_samples(time_s: float, pos: list[float], att: list[float]) -> list[SensorSample]:
    return [SensorSample("mocap_pos", time_s - 0.005, np.array(pos)),
            SensorSample("mocap_att", time_s - 0.005, np.array(att))]


def test_a_frozen_position_is_excluded_after_frozen_ticks_repeats_in_flight() -> None:
    health = SensorHealth(SensorHealthConfig(frozen_ticks=5), "mocap")
    checks = screening("mocap_pos", "mocap_att")
    records = []
    for k in range(1, 12):
        t = 0.01 * k
        att = [0.0, 0.0, 0.001 * k]  # moving: never frozen
        batches = group_samples(tick_samples(t, [1.0, 2.0, -1.0], att), KINDS)
        records += health.step(t, batches, checks, True, NOISE)
    # the repeats begin at the second tick (0.02 s); the fifth repeat is at 0.06 s
    assert [(r.kind, r.sensor, r.time_s) for r in records] == [
        ("sensor_frozen", "mocap_pos", 0.06)]
    assert math.isclose(records[0].magnitude, 0.04)  # s frozen: 0.06 - 0.02
    assert health.excluded == frozenset({"mocap_pos"})
    assert not health.position_fix


def test_grouped_and_plain_batches_are_watched_alike() -> None:
    a = SensorHealth(SensorHealthConfig(), "mocap")
    b = SensorHealth(SensorHealthConfig(), "mocap")
    checks = screening("mocap_pos", "mocap_att", "baro")
    rng = np.random.default_rng(3)
    for k in range(1, 40):
        t = 0.01 * k
        pos = (rng.normal(size=3) * (0.01 if k % 7 else 1.0)).tolist()  # a jump every 7
        samples = [*tick_samples(t, pos, [0.0, 0.0, 3.14 if k % 2 else -3.14]),
                   SensorSample("baro", t - 0.002, np.array([1.0]))]  # frozen barometer
        grouped = group_samples(samples, KINDS)
        plain = dict(grouped)  # the same batches without the table
        assert a.step(t, grouped, checks, k > 10, NOISE) == b.step(t, plain, checks, k > 10,
                                                                    NOISE)
    assert a.excluded == b.excluded == frozenset({"baro"})  # frozen once in flight


def test_an_estimators_screening_is_read_alike_as_records_and_as_entries() -> None:
    from fcu.estimation.ekf import ExtendedKalmanEstimator
    from fcu.model import VehicleModel

    estimator = ExtendedKalmanEstimator(VehicleModel(), ground_z_ned=None)  # no ground hold
    a = SensorHealth(SensorHealthConfig(), "mocap")
    b = SensorHealth(SensorHealthConfig(), "mocap")
    rng = np.random.default_rng(9)
    seen = set()
    for k in range(1, 120):
        t = 0.01 * k
        noise = 0.0005 if k < 40 else 5.0  # m: then garbage
        pos = (rng.normal(size=3) * noise).tolist()
        att = (rng.normal(size=3) * 0.002).tolist()  # rad, noisy: never frozen
        samples = [*tick_samples(t, pos, att),
                   SensorSample("gyro", t - 0.004, rng.normal(size=3) * 0.003)]
        grouped = group_samples(samples, KINDS)
        estimator.step_grouped(t, np.zeros(4), grouped, excluded=a.excluded, reject=True)
        screening = estimator.screening
        as_records = dict(screening.items())  # ChannelCheck records, a plain mapping
        seen |= {c.status for c in as_records.values()}
        assert a.step(t, grouped, screening, True, NOISE) == \
            b.step(t, dict(grouped), as_records, True, NOISE)
        assert a.excluded == b.excluded
    # the garbage was rejected, then excluded (the entries' path saw both)
    assert {"rejected", "excluded"} <= seen and a.excluded == frozenset({"mocap_pos"})


def test_a_drifting_barometer_is_excluded_by_the_window_mean_and_readmitted() -> None:
    # 1 kHz ticks: the 1 s window holds a thousand rows (its ring grows past its first room)
    cfg = SensorHealthConfig(cross_window_s=1.0, cross_limit_m=0.06, recover_s=0.5)
    health = SensorHealth(cfg, "mocap")
    checks = screening("mocap_pos", "mocap_att", "baro")
    rng = np.random.default_rng(5)
    window: list[tuple[float, float]] = []  # the cross-check's window, kept here too
    records = []
    for k in range(1, 4001):
        t = 0.001 * k
        alt = 1.0
        # the barometer drifts up at 0.1 m/s from 0.5 s on, and is back from 2.5 s on
        offset = 0.1 * min(max(t - 0.5, 0.0), 1.0) if t < 2.5 else 0.0
        baro = alt + offset + 0.001 * rng.normal()
        pos = [0.0, 0.0, -alt + 0.0001 * rng.normal()]
        samples = [*tick_samples(t, pos, [0.0, 0.0, 0.001 * k]),
                   SensorSample("baro", t - 0.0002, np.array([baro]))]
        batches = group_samples(samples, KINDS)
        window.append((t, baro + pos[2]))  # alt = -z
        window = [(ti, v) for ti, v in window if ti > t - cfg.cross_window_s]
        new = health.step(t, batches, checks, True, NOISE)
        if new:
            # the mean of the window, summed oldest first
            assert [r.magnitude for r in new] == [sum(v for _, v in window) / len(window)]
        records += new
    kinds = [(r.action, r.kind, r.sensor) for r in records]
    assert kinds == [("detected", "sensor_inconsistent", "baro"),
                     ("cleared", "sensor_inconsistent", "baro")]
    detected, cleared = records
    # the window mean passes 0.06 m about 1.1 s into the drift (its mean lags by half the
    # window); it falls below 0.03 m about 0.7 s after the drift ends, 0.5 s of recovery on
    assert 1.5 < detected.time_s < 1.7 and detected.magnitude > cfg.cross_limit_m
    assert 3.2 < cleared.time_s < 3.8 and abs(cleared.magnitude) < 0.5 * cfg.cross_limit_m
    assert health.excluded == frozenset()
