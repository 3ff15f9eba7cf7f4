"""The one pre-arm check: what arm() refuses with is what prearm_check() reports, without
side effects; and when an armed vehicle on the ground disarms by itself."""

from __future__ import annotations

import numpy as np
import pytest

from fcu.navigation.arming import PrearmCheck, auto_disarm_reason, prearm_check
from fcu.navigation.modes import Mode
from fcu.navigation.navigator import Navigator
from fcu.navigation.settings import NavigatorConfig
from flightdata.mission import thesis_mission

DT_S = 0.01  # s, the autopilot's tick
GROUND = np.zeros(3)


class Ground:
    """A navigator fed a vehicle standing still, one tick at a time."""

    def __init__(self) -> None:
        self.nav = Navigator()
        self.time_s = 0.0
        self.pos_ned = GROUND
        self.healthy = True
        self.hint: bool | None = None

    def tick(self) -> tuple[object, ...]:
        out = self.nav.step(self.time_s, self.pos_ned, np.zeros(3), 0.0,
                            estimator_healthy=self.healthy, on_ground_hint=self.hint)
        self.time_s += DT_S
        return out.events


def refusal_matches_the_check(g: Ground) -> str:
    """prearm_check()'s reason, after checking that it has no side effect and that arm()
    refuses with exactly that reason."""
    g.tick()  # the setup's events out of the way
    check = g.nav.prearm_check()
    assert not check.ok and not check
    assert g.tick() == ()  # the check left no event behind
    assert g.nav.prearm_check() == check and not g.nav.armed
    result = g.nav.arm()
    assert not result.accepted and result.reason == check.reason and not g.nav.armed
    return check.reason


def test_every_refusal_of_arm_is_the_prearm_checks_reason() -> None:
    g = Ground()
    assert g.nav.prearm_check() == PrearmCheck(False, "no state estimate yet")
    assert g.nav.arm().reason == "no state estimate yet"
    g.tick()
    g.nav.load_mission(thesis_mission())
    g.nav.set_mode(Mode.AUTO)
    assert refusal_matches_the_check(g) == ("mode AUTO does not allow arming "
                                            "(use STABILIZE, ALT_HOLD, GUIDED, LOITER, POSHOLD; "
                                            "AUTO_OPTIONS bit 0 allows AUTO)")
    g.nav.set_mode(Mode.GUIDED)
    g.nav.trigger_failsafe("gcs")
    g.nav.trigger_failsafe("battery")
    assert refusal_matches_the_check(g) == "failsafe active: gcs, battery"
    g.nav.clear_failsafe("gcs")
    g.nav.clear_failsafe("battery")
    g.healthy = False
    assert refusal_matches_the_check(g) == "estimator not healthy"
    g.healthy = True
    g.pos_ned = np.array([0.0, 0.0, -1.0])
    assert refusal_matches_the_check(g) == ("not on the ground (altitude 1.00 m, "
                                            "vertical speed 0.00 m/s)")
    g.pos_ned, g.hint = GROUND, False
    assert refusal_matches_the_check(g).startswith("not on the ground")
    g.hint = None
    g.tick()
    assert g.nav.prearm_check() == PrearmCheck(True)
    assert g.nav.arm().accepted and g.nav.armed
    assert g.nav.prearm_check().ok  # armed: nothing left to refuse


def test_the_check_is_a_pure_function_of_what_it_is_given() -> None:
    cfg = NavigatorConfig()
    common = {"has_estimate": True, "failsafe_sources": (), "estimator_healthy": True,
              "on_ground": True, "est_pos_ned": GROUND, "est_vel_ned": np.zeros(3),
              "mode": Mode.STABILIZE, "config": cfg}
    assert prearm_check(**common).ok
    # the first failure wins, in the documented order
    worst = {**common, "has_estimate": False, "failsafe_sources": ("gcs",),
             "estimator_healthy": False, "on_ground": False, "mode": Mode.RTL}
    assert prearm_check(**worst).reason == "no state estimate yet"
    assert prearm_check(**{**worst, "has_estimate": True}).reason == "failsafe active: gcs"
    assert not prearm_check(**{**common, "mode": Mode.LAND}).ok  # not in armable_modes
    assert prearm_check(**{**common, "mode": Mode.LAND,
                           "config": NavigatorConfig(armable_modes=(9,))}).ok


@pytest.mark.parametrize(("landed_like", "since_s", "expected"), [
    (True, 0.0, None),  # 1.99 s after landing: not yet (landed_disarm_delay_s = 2)
    (True, -0.01, "auto-disarm 2 s after landing"),
    (False, -8.0, None),  # idle 9.99 s: not yet (idle_disarm_delay_s = 10)
    (False, -8.01, "auto-disarm: no take-off 10 s after arming (DISARM_DELAY)"),
])
def test_auto_disarm_after_the_configured_delays(landed_like: bool, since_s: float,
                                                 expected: str | None) -> None:
    assert auto_disarm_reason(1.99, since_s, landed_like, NavigatorConfig()) == expected


def test_idle_auto_disarm_can_be_switched_off() -> None:
    cfg = NavigatorConfig(idle_disarm_delay_s=0.0)
    assert auto_disarm_reason(1e6, 0.0, False, cfg) is None
    assert auto_disarm_reason(1e6, 0.0, True, cfg) is not None  # landing still disarms
