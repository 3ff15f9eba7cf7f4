"""The autopilot's parameter table: each parameter reads and writes its configuration field."""

from __future__ import annotations

import math

import pytest

from fcu.config import AutopilotConfig
from fcu.mavlink.autopilot_params import AUTOPILOT_PARAMS, find_param
from fcu.navigation.settings import NavigatorConfig


def _inside(lo: float, hi: float, current: float) -> float:
    """A value within [lo, hi] that differs from ``current``."""
    lo = max(lo, -1e6)
    hi = min(hi, 1e6)
    for candidate in (lo + 0.25 * (hi - lo), lo + 0.75 * (hi - lo), lo, hi):
        if not math.isclose(candidate, current):
            return candidate
    raise AssertionError("no other value")


@pytest.mark.parametrize("param", [p for p in AUTOPILOT_PARAMS if not p.read_only],
                         ids=lambda p: p.name)
def test_every_parameter_round_trips_through_the_configuration(param) -> None:
    config = AutopilotConfig()
    current = param.get(config)
    if param.allowed is not None:
        value = next(v for v in param.allowed if v != current)
    else:
        value = _inside(param.min_value, param.max_value, current)
    changed = param.set(config, value)
    assert param.get(changed) == pytest.approx(value)
    assert param.get(config) == current  # the configuration is immutable


def test_crash_check_and_detector_parameters_reach_their_groups() -> None:
    config = AutopilotConfig()
    report_only = find_param("FS_CRASH_CHECK").set(config, 0)  # type: ignore[union-attr]
    assert report_only.crash.action == 0 and config.crash.action == 1
    strict = find_param("FD_SIGNIF").set(config, 49.0)  # type: ignore[union-attr]
    assert strict.detector.significance == 49.0


def test_disarm_delay_is_arducopters_10_s_and_its_text_says_which_delay_it_is() -> None:
    param = find_param("DISARM_DELAY")
    assert param is not None
    nav = NavigatorConfig()
    assert param.get(AutopilotConfig()) == nav.idle_disarm_delay_s == 10.0  # ArduCopter's
    assert "without a take-off" in param.description
    # the other delay, after a landing, is not this parameter: the text says how long it is
    assert f"after a landing: {nav.landed_disarm_delay_s:g} s" in param.description


@pytest.mark.parametrize("param", [p for p in AUTOPILOT_PARAMS
                                   if p.name.startswith(("POS_", "ATT_PD_"))],
                         ids=lambda p: p.name)
def test_position_and_pd_gains_have_a_range_around_their_defaults(param) -> None:
    # A gain of 1e9 would slam the motors from one saturation to the other: the range must
    # refuse it yet leave room to tune (at least 4x the default).
    default = param.get(AutopilotConfig())
    assert param.min_value == 0.0
    assert 4.0 * default <= param.max_value <= 100.0 * max(default, 1.0)


def test_stick_parameters_in_arducopter_units_reach_the_pilot_settings() -> None:
    config = AutopilotConfig()
    values = {name: find_param(name).get(config)  # type: ignore[union-attr]
              for name in ("ANGLE_MAX", "LOIT_SPEED", "PILOT_SPEED_UP", "THR_DZ")}
    assert values == {"ANGLE_MAX": 3000.0, "LOIT_SPEED": 100.0, "PILOT_SPEED_UP": 50.0,
                      "THR_DZ": 100.0}  # cdeg, cm/s, cm/s, of 1000
    slower = find_param("LOIT_SPEED").set(config, 250.0)  # type: ignore[union-attr]
    assert slower.navigator.pilot.loiter_speed_m_s == pytest.approx(2.5)
    with pytest.raises(ValueError, match="angle_max_deg = 90"):
        find_param("ANGLE_MAX").set(config, 9000.0)  # type: ignore[union-attr]
