"""The battery monitor: charge and energy counted, failsafe levels as ArduPilot sets them."""

from __future__ import annotations

import math

import pytest

from fcu.monitoring.battery import BatteryMonitor, BatteryMonitorConfig
from flightdata.config import ConfigError


def feed(monitor: BatteryMonitor, start_s: float, end_s: float, volts: float, amps: float,
         rate_hz: float = 10.0) -> list:
    """Readings every 1/rate_hz s from start_s to end_s (inclusive); the events returned."""
    events = []
    n = round((end_s - start_s) * rate_hz)
    for k in range(n + 1):
        event = monitor.step(start_s + k / rate_hz, volts, amps)
        if event is not None:
            events.append(event)
    return events


def test_charge_and_energy_are_the_integrals_of_current_and_power() -> None:
    monitor = BatteryMonitor(BatteryMonitorConfig(capacity_mah=1000.0))
    feed(monitor, 0.0, 36.0, 12.0, 10.0)  # 10 A for 36 s = 100 mAh; 120 W = 4320 J
    assert monitor.consumed_mah == pytest.approx(100.0, rel=1e-9)
    assert monitor.consumed_j == pytest.approx(4320.0, rel=1e-9)
    assert monitor.remaining == pytest.approx(0.9)
    assert monitor.time_remaining_s == pytest.approx(900.0 / 1000.0 / 10.0 * 3600.0)
    # a ramp: the trapezoid is exact for a linear current
    ramp = BatteryMonitor()
    for k in range(11):
        ramp.step(k * 0.1, 12.0, 10.0 * k * 0.1)  # 0 -> 10 A over 1 s
    assert ramp.consumed_mah == pytest.approx(5.0 / 3.6)


def test_low_voltage_needs_the_timer_without_a_break() -> None:
    cfg = BatteryMonitorConfig(low_volt_v=10.5, low_timer_s=10.0, low_action=1)
    monitor = BatteryMonitor(cfg)
    assert feed(monitor, 0.0, 9.9, 10.4, 12.0) == []  # 9.9 s below: not yet
    assert feed(monitor, 10.0, 10.0, 10.6, 12.0) == []  # one reading above: timer restarts
    assert feed(monitor, 10.1, 20.0, 10.4, 12.0) == []  # 9.9 s again
    events = feed(monitor, 20.1, 21.0, 10.4, 12.0)
    assert [(e.level, e.action, e.time_s) for e in events] == [("low", "land",
                                                                pytest.approx(20.1))]
    assert events[0].text.startswith("Battery 1 is low 10.40V used ")
    assert monitor.level == "low"
    assert feed(monitor, 21.1, 40.0, 12.0, 1.0) == []  # latched: no recovery, no repeat
    assert monitor.level == "low"


def test_remaining_charge_triggers_at_once_and_critical_follows_low() -> None:
    cfg = BatteryMonitorConfig(capacity_mah=100.0, low_mah=50.0, critical_mah=20.0,
                               low_action=2, critical_action=1)
    monitor = BatteryMonitor(cfg)
    events = feed(monitor, 0.0, 90.0, 11.5, 3.6)  # 3.6 A = 1 mAh/s
    assert [(e.level, e.action) for e in events] == [("low", "rtl"), ("critical", "land")]
    low, critical = events
    assert low.time_s == pytest.approx(50.1)  # the first reading with under 50 mAh left
    assert critical.time_s == pytest.approx(80.1)  # under 20 mAh left
    assert monitor.remaining_mah == pytest.approx(10.0)


def test_thresholds_of_zero_are_off_and_no_reading_changes_nothing() -> None:
    cfg = BatteryMonitorConfig(low_volt_v=0.0, low_mah=0.0, capacity_mah=10.0)
    monitor = BatteryMonitor(cfg)
    assert feed(monitor, 0.0, 60.0, 5.0, 36.0) == []  # empty and at 5 V: nothing enabled
    fresh = BatteryMonitor()
    assert fresh.step(1.0, None, None) is None
    assert math.isnan(fresh.voltage_v) and fresh.consumed_mah == 0.0
    assert fresh.step(1.1, math.nan, 1.0) is None and fresh.consumed_mah == 0.0


def test_take_over_continues_the_count() -> None:
    first = BatteryMonitor()
    feed(first, 0.0, 36.0, 12.0, 10.0)
    second = BatteryMonitor()
    second.take_over(first)
    feed(second, 36.1, 72.0, 12.0, 10.0)
    assert second.consumed_mah == pytest.approx(200.0, rel=1e-3)


@pytest.mark.parametrize(("field", "value"), [("capacity_mah", 0.0), ("low_volt_v", -1.0),
                                              ("low_action", 3), ("critical_action", True),
                                              ("low_timer_s", math.nan)])
def test_bad_settings_name_the_field(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field):
        BatteryMonitorConfig(**{field: value})  # type: ignore[arg-type]
