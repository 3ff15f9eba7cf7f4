"""The outcome judge on hand-made truth sequences: each limit decides, and only once."""

from __future__ import annotations

import math

import pytest

from flightdata.geometry import quat_from_euler
from sim.outcome import MissionArea, OutcomeJudge, OutcomeLimits, tilt_deg

LEVEL = (0.0, 0.0, 0.0)
LEVEL_QUAT = (1.0, 0.0, 0.0, 0.0)
AREA = [(0.0, 0.0, 0.0), (1.0, 1.0, -0.6)]  # home and the thesis square at 0.6 m


def fly(judge: OutcomeJudge, seconds: float, t0: float = 0.0, z: float = -0.6,
        north: float = 0.5, euler: tuple[float, float, float] = LEVEL) -> float:
    t = t0
    for _ in range(int(round(seconds / 0.01))):
        t += 0.01
        judge.observe(t, (north, 0.5, z), quat_from_euler(euler), False, (), True)
    return t


def touch(judge: OutcomeJudge, t: float, speed: float | None, armed: bool = True,
          euler: tuple[float, float, float] = LEVEL) -> float:
    """A tick on the ground; ``speed``: of a touchdown during it (None: it sat there)."""
    t += 0.01
    judge.observe(t, (0.5, 0.5, 0.0), quat_from_euler(euler), True,
                  [] if speed is None else [(t - 0.005, speed)], armed)
    return t


def test_a_gentle_landing_then_disarm_is_landed_at_the_touchdown() -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    t = fly(judge, 5.0)
    t_down = touch(judge, t, 0.1)
    assert judge.outcome is None  # still armed on the ground
    touch(judge, t_down + 1.0, None, armed=False)
    assert judge.outcome is not None
    assert (judge.outcome.kind, judge.outcome.cause) == ("landed", "touchdown")
    assert judge.outcome.time_s == pytest.approx(t_down - 0.005)  # the contact instant
    assert judge.drain() == [judge.outcome] and judge.drain() == []


@pytest.mark.parametrize(("speed", "roll_deg", "cause"), [(2.6, 0.0, "impact_speed"),
                                                          (0.5, 48.0, "impact_tilt")])
def test_a_hard_or_tilted_touchdown_is_a_crash(speed: float, roll_deg: float,
                                               cause: str) -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    t = fly(judge, 2.0, euler=(math.radians(roll_deg), 0.0, 0.0))
    t_down = touch(judge, t, speed)
    assert judge.outcome is not None
    assert (judge.outcome.kind, judge.outcome.cause) == ("crashed", cause)
    assert judge.outcome.time_s == pytest.approx(t_down - 0.005)
    # what follows (hops, a later gentle landing) does not change a crash
    t = fly(judge, 1.0, t0=t_down)
    touch(judge, t, 0.1, armed=False)
    assert judge.outcome.kind == "crashed" and judge.drain() == [judge.outcome]


def test_limits_are_exclusive_bounds() -> None:
    judge = OutcomeJudge(MissionArea(AREA), OutcomeLimits(impact_speed_m_s=1.5))
    touch(judge, fly(judge, 1.0), 1.5, armed=False)  # exactly the limit: not a crash
    assert judge.outcome is not None and judge.outcome.kind == "landed"


def test_leaving_the_mission_area_by_five_metres_is_a_flyaway() -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    t = fly(judge, 1.0, north=1.0 + 4.99)  # 4.99 m north of the square: not yet
    assert judge.outcome is None
    t = fly(judge, 0.01, t0=t, north=1.0 + 5.01)
    assert judge.outcome is not None and judge.outcome.kind == "flyaway"
    assert judge.outcome.time_s == pytest.approx(t)
    assert judge.outcome.distance_m == pytest.approx(5.01)


def test_the_farthest_excursion_outside_the_area_is_kept_until_the_landing() -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    t = fly(judge, 1.0)  # inside the square
    t = fly(judge, 0.5, t0=t, north=1.0 + 0.4)  # 0.4 m north of it
    t = fly(judge, 0.5, t0=t, z=-0.6 - 0.25)  # back over it, 0.25 m above its top
    t = fly(judge, 2.0, t0=t)  # inside again
    touch(judge, touch(judge, t, 0.1), None, armed=False)
    assert judge.outcome is not None and judge.outcome.kind == "landed"
    assert judge.outcome.distance_m == pytest.approx(0.4, abs=1e-12)  # (a difference of m)


def test_climbing_away_is_a_flyaway_too() -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    fly(judge, 1.0, z=-0.6 - 5.2)
    assert judge.outcome is not None and judge.outcome.kind == "flyaway"


def test_end_of_run_in_the_air_on_the_ground_and_never_flown() -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    t = fly(judge, 1.0)
    assert judge.finish(t).kind == "airborne"
    judge = OutcomeJudge(MissionArea(AREA))
    t = touch(judge, fly(judge, 1.0), 0.2)
    outcome = judge.finish(t + 3.0)
    assert (outcome.kind, outcome.time_s) == ("landed", pytest.approx(t - 0.005))
    judge = OutcomeJudge(MissionArea(AREA))
    judge.observe(0.01, (0.0, 0.0, 0.0), LEVEL_QUAT, True, (), False)
    assert (judge.finish(60.0).kind, judge.finish(60.0).cause) == ("landed", "no_flight")


def test_a_crash_between_two_ticks_counts_even_if_a_soft_contact_follows() -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    t = fly(judge, 1.0)
    # within one tick: a hard touchdown, a bounce, a soft one (what the plant reports)
    judge.observe(t + 0.01, (0.5, 0.5, 0.0), LEVEL_QUAT, True, [(t + 0.002, 5.1), (t + 0.006, 0.0)],
                  True)
    assert judge.outcome is not None
    assert (judge.outcome.kind, judge.outcome.impact_speed_m_s) == ("crashed", 5.1)


def test_rearming_starts_a_new_flight() -> None:
    judge = OutcomeJudge(MissionArea(AREA))
    touch(judge, fly(judge, 1.0), 0.1, armed=False)
    assert judge.outcome is not None and judge.outcome.kind == "landed"
    judge.rearm()
    touch(judge, fly(judge, 1.0, t0=10.0), 3.0)
    assert [o.kind for o in judge.drain()] == ["landed", "crashed"]


def test_tilt_is_the_angle_of_the_body_z_axis_from_the_vertical() -> None:
    assert tilt_deg(quat_from_euler((math.radians(30.0), 0.0, 1.0))) == pytest.approx(30.0)
    expected = math.degrees(math.acos(math.cos(math.radians(30.0))
                                      * math.cos(math.radians(40.0))))
    assert tilt_deg(quat_from_euler((math.radians(30.0), math.radians(40.0), 0.0))) == \
        pytest.approx(expected)
