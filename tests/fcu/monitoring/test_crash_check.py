"""The crash checks of :mod:`fcu.monitoring.crash_check`, fed by hand in simulated time."""

from __future__ import annotations

import math

import pytest

from fcu.monitoring.crash_check import CrashCheck, CrashCheckConfig, contact_counts
from flightdata.records import DetectionRecord

TICK_S = 0.01  # s, the autopilot's tick


def on_the_ground_for(check: CrashCheck, seconds: float, leg: str, ref_alt_m: float) -> bool:
    """Feed ``seconds`` of a vehicle at rest on the ground, armed and flying (the navigator's
    view), with the given leg and reference altitude; whether a crash was found."""
    for k in range(round(seconds / TICK_S) + 1):
        records = check.step(k * TICK_S, flying=True, leg=leg, ref_alt_m=ref_alt_m,
                             alt_m=0.0, vel_down_m_s=0.0, speed_m_s=0.0, lean_rad=0.0,
                             attitude_error_rad=0.0, collective=0.3)
        if any(r.kind == "crash" for r in records):
            return True
    return False


def test_ground_contact_is_a_crash_once_it_lasts_contact_time_s() -> None:
    config = CrashCheckConfig()
    assert not on_the_ground_for(CrashCheck(config), config.contact_time_s - 0.05, "goto", 2.0)
    assert on_the_ground_for(CrashCheck(config), config.contact_time_s + 0.05, "goto", 2.0)


@pytest.mark.parametrize("leg", ["takeoff", "land"])
def test_ground_contact_in_a_take_off_or_landing_is_no_crash(leg: str) -> None:
    assert not on_the_ground_for(CrashCheck(CrashCheckConfig()), 5.0, leg, 2.0)


def test_ground_contact_while_the_reference_is_still_on_the_ground_is_no_crash() -> None:
    """A go-to sent at lift-off starts its reference where the vehicle is: on the ground."""
    config = CrashCheckConfig()
    assert not on_the_ground_for(CrashCheck(config), 5.0, "goto",
                                 config.contact_ref_alt_m - 0.01)
    assert on_the_ground_for(CrashCheck(config), 5.0, "goto", config.contact_ref_alt_m)


def test_contact_counts_only_in_a_flying_leg_with_the_reference_up() -> None:
    assert contact_counts("goto", 0.6, 0.2)
    assert not contact_counts("goto", 0.1, 0.2)
    assert not contact_counts("takeoff", 5.0, 0.2)
    assert not contact_counts("land", 5.0, 0.2)
    assert contact_counts("goto", math.inf, 0.2)


def test_an_impact_is_a_crash_whatever_the_reference() -> None:
    """A fall: on the ground within impact_window_s of descending faster than
    impact_speed_m_s, even in a landing with the reference on the ground."""
    config = CrashCheckConfig()
    check = CrashCheck(config)

    def falling(time_s: float, alt_m: float) -> list[DetectionRecord]:
        return check.step(time_s, flying=True, leg="land", ref_alt_m=0.0, alt_m=alt_m,
                          vel_down_m_s=3.0, speed_m_s=3.0, lean_rad=0.0,
                          attitude_error_rad=0.0, collective=0.3)

    assert falling(0.0, 0.5) == []
    records = falling(0.1, 0.0)
    assert [r.kind for r in records] == ["crash"]


def test_a_bad_contact_reference_altitude_is_named() -> None:
    with pytest.raises(ValueError, match="contact_ref_alt_m"):
        CrashCheckConfig(contact_ref_alt_m=-1.0)
