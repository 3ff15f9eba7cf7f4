"""ArduPilot's vibration levels and clipping against closed forms of its two low-passes."""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest

from fcu.monitoring.vibration import (
    ACCEL_FULL_SCALE_M_S2,
    CLIP_MARGIN_M_S2,
    VIBE_FLOOR_HZ,
    VibrationMonitor,
)

RATE_HZ = 250.0  # the simulated IMU's rate
DT_S = 1.0 / RATE_HZ


def alpha(fc_hz: float) -> float:
    """ArduPilot's LowPassFilter gain for one step of DT_S."""
    return DT_S / (DT_S + 1.0 / (2.0 * math.pi * fc_hz))


def run(accel: np.ndarray, monitor: VibrationMonitor | None = None) -> VibrationMonitor:
    monitor = monitor if monitor is not None else VibrationMonitor()
    times = np.arange(accel.shape[0]) * DT_S
    monitor.update(times, accel)
    return monitor


def test_a_steady_specific_force_does_not_vibrate() -> None:
    hover = np.tile([0.1, -0.2, -9.81], (2500, 1))  # 10 s at rest in hover attitude
    monitor = run(hover)
    assert np.all(monitor.levels_m_s2 < 1e-9)
    assert monitor.clipped == 0 and monitor.time_s == pytest.approx(2499 * DT_S)


def test_white_noise_vibrates_at_the_high_passed_sigma() -> None:
    # y = x - LP5(x) = (1 - a)(x_n - LP_{n-1}): var = (1 - a)^2 sigma^2 2 / (2 - a)
    sigma = 0.3  # m/s^2
    rng = np.random.default_rng(7)
    monitor = VibrationMonitor()
    squares = []
    for _ in range(40):  # 40 s in 1 s batches, as the VIBRATION stream takes them
        start = len(squares) * RATE_HZ * DT_S
        times = start + np.arange(int(RATE_HZ)) * DT_S
        monitor.update(times, rng.normal(0.0, sigma, size=(int(RATE_HZ), 3)))
        squares.append(monitor.levels_m_s2 ** 2)
    a = alpha(VIBE_FLOOR_HZ)
    expected = (1.0 - a) ** 2 * sigma ** 2 * 2.0 / (2.0 - a)
    # mean of 39 reports 1 s apart (each ~ a 0.5 s average): a few per cent of spread
    assert np.mean(squares[1:], axis=0) == pytest.approx([expected] * 3, rel=0.06)


@pytest.mark.parametrize("freq_hz", [20.0, 50.0])
def test_a_sinusoid_vibrates_at_its_rms_through_the_floor_filter(freq_hz: float) -> None:
    # the 5 Hz floor's complement at w: (1 - a)(1 - z^-1) / (1 - (1 - a) z^-1), z = e^(jw dt)
    amplitude = 2.0  # m/s^2
    t = np.arange(int(20 * RATE_HZ)) * DT_S
    x = amplitude * np.sin(2.0 * math.pi * freq_hz * t)
    monitor = run(np.column_stack((x, 0.5 * x, np.zeros_like(x))))
    a = alpha(VIBE_FLOOR_HZ)
    z = cmath.exp(1j * 2.0 * math.pi * freq_hz * DT_S)
    gain = abs((1.0 - a) * (1.0 - 1.0 / z) / (1.0 - (1.0 - a) / z))
    rms = amplitude / math.sqrt(2.0) * gain
    # the 2 Hz mean-square filter leaves a ripple at 2 f of a few per cent
    assert monitor.levels_m_s2[:2] == pytest.approx([rms, 0.5 * rms], rel=0.05)
    assert monitor.levels_m_s2[2] == 0.0


def test_clipping_counts_samples_beyond_the_full_scale_less_half_a_g() -> None:
    limit = ACCEL_FULL_SCALE_M_S2 - CLIP_MARGIN_M_S2
    accel = np.zeros((10, 3))
    accel[2, 0] = limit + 0.01  # clipped
    accel[4, 1] = -(limit + 1.0)  # clipped
    accel[5] = [limit + 1.0, limit + 1.0, 0.0]  # one sample, however many axes
    accel[7, 2] = limit - 0.01  # not clipped
    accel[8] = [math.nan, 0.0, 0.0]  # skipped (not a reading)
    monitor = run(accel)
    assert monitor.clipped == 3


def test_batches_give_the_numbers_of_one_pass() -> None:
    rng = np.random.default_rng(3)
    accel = rng.normal(0.0, 1.0, size=(1000, 3)) + [0.0, 0.0, -9.81]
    whole = run(accel)
    split = VibrationMonitor()
    times = np.arange(1000) * DT_S
    for lo, hi in ((0, 1), (1, 333), (333, 334), (334, 1000)):
        split.update(times[lo:hi], accel[lo:hi])
    assert np.array_equal(split.levels_m_s2, whole.levels_m_s2)


def test_bad_full_scale_and_mismatched_batches_are_refused() -> None:
    with pytest.raises(ValueError, match="full_scale_m_s2"):
        VibrationMonitor(full_scale_m_s2=1.0)
    with pytest.raises(ValueError, match="3 times for 2 samples"):
        VibrationMonitor().update(np.zeros(3), np.zeros((2, 3)))
