"""An example of a telemetry-based integration test written with the ``vehicle_link`` fixture.

The fixture (``gcs.pytest_plugin``, enabled in tests/conftest.py) starts ``ftc-vehicle`` at
the marker's speed-up and yields a connected ground-station link; ``fly`` flies the thesis
mission as ``ftc-gcs fly`` does and returns the table computed from the telemetry.
"""

import pytest

from gcs.faults import FaultSpec


@pytest.mark.slow
@pytest.mark.vehicle(speedup=10, seed=1, scenario="lqg_loe")
def test_a_20_percent_loss_on_motor_3_is_tracked_through_and_detected(vehicle_link):
    outcome = vehicle_link.fly(faults=[FaultSpec(motor=3, loe=0.20, at_s=22.0)])

    assert outcome.error is None  # flown, landed and disarmed
    report = outcome.report
    assert report.rms["x"] < 0.05 and report.rms["y"] < 0.05  # m: a centimetre-level square
    assert report.max["z"] < 0.2  # m: the climb and the landing included
    assert [d.motor for d in report.detections] == [3]
    assert report.detections[0].latency_s < 2.0  # s after the injection took effect
    assert abs(outcome.timing[0].error_s) <= 0.1  # s of simulated time
