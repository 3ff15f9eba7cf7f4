"""LoeFaultDetector on synthetic gamma_hat sequences.

The synthetic sequences imitate what the TSKF delivers (tests/fcu/test_tskf.py measures it on
a closed-loop plant): after a step fault the estimate converges to the true loss with a time
constant of a few tenths of a second; a healthy motor's estimate wanders by a few hundredths,
with short excursions when another motor fails or the vehicle manoeuvres. The closed-loop
detection tests live in tests/fcu/test_tskf.py, beside the plant harness they need.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcu.monitoring.loe_detector import FaultDetection, LoeFaultDetector

DT_S = 0.01  # s, the autopilot tick


def _ar1_noise(rng: np.random.Generator, n: int, sigma: float, tau_s: float) -> np.ndarray:
    """Stationary AR(1) noise of standard deviation ``sigma`` and correlation time ``tau_s``."""
    a = math.exp(-DT_S / tau_s)
    out = np.empty(n)
    out[0] = sigma * rng.standard_normal()
    for k in range(1, n):
        out[k] = a * out[k - 1] + sigma * math.sqrt(1.0 - a * a) * rng.standard_normal()
    return out


def _synthetic_gamma(rng: np.random.Generator, duration_s: float,
                     faults: dict[int, tuple[float, float]], *, tau_s: float = 0.5,
                     noise_sigma: float = 0.015) -> tuple[np.ndarray, np.ndarray]:
    """(times (n,), gamma_hat (n, 4)): first-order convergence to each step fault, plus noise.

    ``faults`` maps motor (1..4) to (onset s, loss). ``tau_s`` 0.5 s is slower than the
    TSKF's measured convergence (0.3-0.6 s to within 0.05), so latencies here are pessimistic.
    """
    n = round(duration_s / DT_S)
    t = DT_S * np.arange(1, n + 1)
    gamma = np.zeros((n, 4))
    for motor, (onset, loss) in faults.items():
        after = t >= onset
        gamma[after, motor - 1] = loss * (1.0 - np.exp(-(t[after] - onset) / tau_s))
    for i in range(4):
        gamma[:, i] += _ar1_noise(rng, n, noise_sigma, 0.3)
    return t, np.clip(gamma, 0.0, 1.0)


def _run(detector: LoeFaultDetector, t: np.ndarray, gamma: np.ndarray) -> list[FaultDetection]:
    events: list[FaultDetection] = []
    for k in range(len(t)):
        events.extend(detector.step(float(t[k]), gamma[k]))
    return events


@pytest.mark.parametrize("loss", [0.15, 0.2, 0.3, 0.5, 0.8, 1.0])
@pytest.mark.parametrize("motor", [1, 2, 3, 4])
def test_step_faults_of_15_percent_or_more_are_detected_within_3_s(motor: int,
                                                                   loss: float) -> None:
    rng = np.random.default_rng(100 * motor + round(100 * loss))
    onset = 10.0
    t, gamma = _synthetic_gamma(rng, 30.0, {motor: (onset, loss)})
    events = _run(LoeFaultDetector(), t, gamma)
    faults = [e for e in events if e.kind == "fault"]
    assert len(faults) == 1, events  # once per onset, nothing on the healthy motors
    event = faults[0]
    assert event.motor == motor
    assert onset < event.time_s <= onset + 3.0
    # the level reported is the estimate at the decision: within the noise of the converging
    # estimate, never more than the loss plus 4 noise sigmas
    assert 0.1 < event.loe_estimate <= loss + 4 * 0.015
    assert not [e for e in events if e.kind == "recovered"]


def test_latency_is_threshold_crossing_plus_persistence() -> None:
    detector = LoeFaultDetector(threshold=0.1, persistence_s=0.5)
    t = DT_S * np.arange(1, 401)
    gamma = np.zeros((400, 4))
    gamma[t >= 1.0, 2] = 0.3  # motor 3 loses 30 % at exactly 1.0 s
    events = _run(detector, t, gamma)
    assert [(e.motor, e.kind) for e in events] == [(3, "fault")]
    # first tick above threshold is t = 1.00 s; the decision comes persistence_s later
    assert events[0].time_s == pytest.approx(1.5, abs=1e-9)  # float tick times, exact grid
    assert events[0].loe_estimate == pytest.approx(0.3)
    assert events[0].message == "motor 3 lost about 30 % effectiveness"
    assert detector.active == (3,)


def test_no_false_alarm_in_60_s_of_healthy_noise_with_transients() -> None:
    rng = np.random.default_rng(7)
    t, gamma = _synthetic_gamma(rng, 60.0, {}, noise_sigma=0.02)
    # manoeuvre/fault-onset excursions: 0.3 s bumps to 0.15 on random motors every ~5 s
    for onset in np.arange(3.0, 58.0, 5.0):
        motor = int(rng.integers(0, 4))
        bump = (t >= onset) & (t < onset + 0.3)
        gamma[bump, motor] = np.maximum(gamma[bump, motor], 0.15)
    detector = LoeFaultDetector()
    events = _run(detector, t, gamma)
    assert events == []
    assert detector.active == ()
    # the sequence does cross the threshold, so the test exercises the persistence
    assert np.any(gamma > detector.threshold)


def test_persistence_must_be_uninterrupted() -> None:
    detector = LoeFaultDetector(threshold=0.1, persistence_s=0.5)
    t = DT_S * np.arange(1, 1001)
    gamma = np.zeros((1000, 4))
    # bursts above threshold of 0.4 s separated by one tick below it
    phase = np.round(t / DT_S).astype(int) % 41
    gamma[phase != 0, 0] = 0.3
    assert _run(detector, t, gamma) == []


def test_recovery_with_hysteresis() -> None:
    detector = LoeFaultDetector(threshold=0.1, persistence_s=0.5, recovery_threshold=0.05,
                                recovery_persistence_s=1.0)
    t = DT_S * np.arange(1, 2001)
    gamma = np.zeros((2000, 4))
    gamma[(t >= 2.0), 3] = 0.2
    # dips between the two thresholds do not recover the motor
    gamma[(t >= 6.0) & (t < 9.0), 3] = 0.07
    gamma[(t >= 12.0), 3] = 0.01  # repaired
    events = _run(detector, t, gamma)
    assert [(e.motor, e.kind) for e in events] == [(4, "fault"), (4, "recovered")]
    assert events[0].time_s == pytest.approx(2.5, abs=1e-9)  # 2.0 s + persistence
    assert events[1].time_s == pytest.approx(13.0, abs=1e-9)  # 12.0 s + recovery persistence
    assert events[1].message.startswith("motor 4 recovered")
    assert detector.active == ()
    # a new onset after recovery is reported again
    events2 = _run(detector, t + 20.0, gamma)
    assert [(e.motor, e.kind) for e in events2] == [(4, "fault"), (4, "recovered")]


def test_once_per_onset_for_a_lasting_fault() -> None:
    rng = np.random.default_rng(3)
    t, gamma = _synthetic_gamma(rng, 60.0, {1: (5.0, 0.5), 3: (20.0, 0.45)}, noise_sigma=0.03)
    events = _run(LoeFaultDetector(), t, gamma)
    assert sorted((e.motor, e.kind) for e in events) == [(1, "fault"), (3, "fault")]
    assert len(events) == 2


def test_non_finite_estimates_restart_the_timer() -> None:
    detector = LoeFaultDetector(threshold=0.1, persistence_s=0.5)
    t = DT_S * np.arange(1, 201)
    gamma = np.full((200, 4), 0.0)
    gamma[:, 1] = 0.4
    gamma[::30, 1] = np.nan  # a gap every 0.3 s: never 0.5 s of evidence in a row
    assert _run(detector, t, gamma) == []


@pytest.mark.parametrize(("kwargs", "key"), [
    ({"threshold": 0.0}, "threshold"),
    ({"threshold": 1.5}, "threshold"),
    ({"recovery_threshold": 0.2}, "recovery_threshold"),
    ({"persistence_s": -1.0}, "persistence_s"),
    ({"recovery_persistence_s": math.nan}, "recovery_persistence_s"),
])
def test_bad_settings_name_the_key(kwargs: dict[str, float], key: str) -> None:
    with pytest.raises(ValueError, match=key):
        LoeFaultDetector(**kwargs)  # type: ignore[arg-type]


def test_reset_forgets_faults() -> None:
    detector = LoeFaultDetector(persistence_s=0.0)
    assert [e.motor for e in detector.step(0.0, [0.0, 0.5, 0.0, 0.0])] == [2]
    detector.reset()
    assert detector.active == ()
    assert detector.events == []
