"""Motor fault detector: its weighted fit against numpy's least squares, and what it concludes
from noise-free gamma estimates of a one-motor loss and of a mass change (closed forms of the
module docstring's equations)."""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest

from fcu.model import VehicleModel
from fcu.monitoring.motor_fault_kernel import SIGNATURES, weighted_fit
from fcu.monitoring.motor_faults import DetectorConfig, MotorFaultDetector
from flightdata.records import DetectionRecord

MODEL = VehicleModel()
DT_S = 0.01


@pytest.mark.parametrize("motors", [m for k in range(4) for m in combinations(range(4), k)])
def test_weighted_fit_is_numpys_weighted_least_squares(motors: tuple[int, ...]) -> None:
    rng = np.random.default_rng(len(motors) * 10 + sum(motors))
    for _ in range(20):
        d = rng.normal(size=3) * 0.1
        var = rng.uniform(1e-5, 1e-2, size=3)
        f, rss = weighted_fit(d, var, np.array(motors, dtype=np.int64))
        w = 1.0 / np.sqrt(var)
        a = SIGNATURES[:, list(motors)] * w[:, None]
        f_ref = np.linalg.lstsq(a, d * w, rcond=None)[0]
        rss_ref = float(np.sum((d * w - a @ f_ref) ** 2))
        # elimination against LAPACK's SVD: the same numbers up to a few roundings of the
        # weighted data, whose scale is |d| / sigma <= 1e2
        np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-12)
        assert rss == pytest.approx(rss_ref, rel=1e-9, abs=1e-9)


def fly(gamma: np.ndarray, seconds: float, *, onset_s: float = 0.0
        ) -> tuple[MotorFaultDetector, list[DetectionRecord]]:
    """Feed gamma (zero before ``onset_s``) at hover PWM, every tick free flight."""
    detector = MotorFaultDetector(MODEL, DetectorConfig(), DT_S)
    pwm = np.full(4, MODEL.hover_pwm)
    records = []
    for tick in range(1, round(seconds / DT_S) + 1):
        time_s = tick * DT_S
        now = gamma if time_s >= onset_s else np.zeros(4)
        records += detector.step(time_s, now, pwm, evidence=True, learn=True)
    return detector, records


def test_a_loss_on_one_motor_is_declared_on_that_motor_alone() -> None:
    detector, records = fly(np.array([0.0, 0.3, 0.0, 0.0]), 1.0)
    (record,) = records
    assert (record.action, record.kind, record.motor) == ("detected", "loe", 2)
    # d = M a = [0, 0.3, -0.3]: f = 0.3 on motor 2's signature with no residual; calm air
    # and strong evidence halve the persistence, bounded below by min_persistence_s
    assert record.magnitude == pytest.approx(0.3, rel=1e-12)
    assert record.time_s == pytest.approx(DT_S + 0.1, abs=1e-9)
    assert detector.active == (2,) and detector.lost == ()
    assert detector.declared_flags == (False, True, False, False)
    # after the declaration the common mode is the healthy motors' (none): no mass change
    np.testing.assert_allclose(detector.loe, [0.0, 0.3, 0.0, 0.0], atol=1e-12)
    assert detector.mass_change_kg == pytest.approx(0.0, abs=1e-12)


def test_an_equal_deficit_on_all_motors_is_a_mass_change() -> None:
    onset_s = 3.0  # the common mode's spread learned at its floor first
    detector, records = fly(np.full(4, 0.2), 6.0, onset_s=onset_s)
    # no torque signature, so no motor suspected; dm = 4 K e / g with e = 0.2 u_h is a
    # fifth of the mass, reported after mass_persistence_s above the threshold, settled
    assert [(r.action, r.kind) for r in records] == [("detected", "mass_change")]
    (record,) = records
    # settled: moving less than mass_settle_kg (0.02 kg) over 0.5 s, near its end
    assert record.magnitude == pytest.approx(0.2 * MODEL.mass, abs=0.02)
    # the 0.3 s low-pass of e crosses 0.1 kg (the threshold while the learned spread stays
    # below 0.02 kg) 0.13 s after the onset, then mass_persistence_s = 1 s
    assert onset_s + 1.13 - 1e-9 <= record.time_s < onset_s + 2.0
    # no motor loss: LOE = gamma - e / u is what the low-pass of e has left after 10 time
    # constants, 0.2 exp(-10) = 9e-6
    assert detector.active == () and detector.loe.max() < 2e-5


def test_reset_forgets_everything_the_workspaces_hold() -> None:
    detector, records = fly(np.array([0.0, 0.0, 0.3, 0.0]), 2.0)
    assert records and detector.active == (3,)
    detector.reset()
    assert detector.active == () and detector.mass_change_kg == 0.0
    pwm = np.full(4, MODEL.hover_pwm)
    again = []
    for tick in range(1, round(2.0 / DT_S) + 1):
        again += detector.step(tick * DT_S, np.array([0.0, 0.0, 0.3, 0.0]), pwm,
                               evidence=True, learn=True)
    fresh, fresh_records = fly(np.array([0.0, 0.0, 0.3, 0.0]), 2.0)
    # after reset() the same inputs give the same conclusions, bit for bit
    assert again == fresh_records
    np.testing.assert_array_equal(detector.loe, fresh.loe)
    np.testing.assert_array_equal(detector.evidence.noise, fresh.evidence.noise)
    assert detector.mass_change_kg == fresh.mass_change_kg
