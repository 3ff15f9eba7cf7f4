"""The pilot modes in the navigator: sticks fly STABILIZE, ALT_HOLD, LOITER and POSHOLD,
take off and land by throttle, and change nothing without stick input."""

from __future__ import annotations

import numpy as np
import pytest
from test_navigator import airborne, flight

from fcu.navigation.modes import Mode
from fcu.navigation.sticks import CENTRED, PilotConfig, Sticks

FORWARD = Sticks(0.0, -1.0, 0.5, 0.0)  # full forward pitch, throttle mid-stick
CLIMB = Sticks(0.0, 0.0, 1.0, 0.0)
DESCEND = Sticks(0.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("mode", [Mode.LOITER, Mode.POSHOLD])
def test_position_modes_fly_the_stick_velocity_and_hold_when_centred(mode: Mode) -> None:
    f = airborne(1.0)
    assert f.nav.set_mode(mode).accepted
    f.run_until(f.time_s + 1.0)
    assert f.nav.leg_kind == "hold"  # no sticks yet: the mode's own hold
    start = f.vehicle.pos_ned.copy()
    assert f.nav.set_sticks(FORWARD).accepted
    f.run_until(f.time_s + 5.0)
    assert f.nav.leg_kind == "pilot"
    moved = f.vehicle.pos_ned - start
    cfg = PilotConfig()
    ramp_s = cfg.loiter_speed_m_s / cfg.loiter_accel_m_s2
    assert moved[0] == pytest.approx(cfg.loiter_speed_m_s * (5.0 - ramp_s / 2), abs=0.02)
    assert abs(moved[1]) < 1e-9 and abs(moved[2]) < 1e-9  # straight north (yaw 0), level
    f.nav.set_sticks(CENTRED)
    f.run_until(f.time_s + 3.0)
    held = f.vehicle.pos_ned.copy()
    f.run_until(f.time_s + 3.0)
    np.testing.assert_allclose(f.vehicle.pos_ned, held, atol=1e-12)  # stopped and held
    assert "mode" in f.kinds() and any("flown by the sticks" in e.text for e in f.events)


def test_released_sticks_give_the_mode_its_own_leg_back() -> None:
    f = airborne(1.0)
    assert f.nav.set_mode(Mode.LOITER).accepted
    f.nav.set_sticks(FORWARD)
    f.run_until(f.time_s + 2.0)
    assert f.nav.leg_kind == "pilot"
    f.nav.set_sticks(None)
    f.tick()
    assert f.nav.leg_kind == "hold"


def test_sticks_are_ignored_outside_the_pilot_modes() -> None:
    f = airborne(1.0)  # GUIDED
    start = f.vehicle.pos_ned.copy()
    f.nav.set_sticks(FORWARD)
    f.run_until(f.time_s + 3.0)
    np.testing.assert_allclose(f.vehicle.pos_ned, start, atol=1e-12)
    assert f.nav.leg_kind == "takeoff"  # GUIDED's take-off leg, reached, still held


def test_alt_hold_takes_off_by_throttle_and_lands_by_throttle() -> None:
    f = flight()
    assert f.nav.set_mode(Mode.ALT_HOLD).accepted and f.nav.arm().accepted
    f.nav.set_sticks(Sticks(0.0, 0.0, 0.55, 0.0))  # inside the dead zone: stays down
    f.run_until(1.0)
    assert f.nav.landed and f.nav.armed
    f.nav.set_sticks(CLIMB)
    f.run_until(f.time_s + 0.05)
    assert not f.nav.landed and f.nav.leg_kind in ("takeoff", "pilot")
    assert f.first("takeoff").text == "take-off by throttle in ALT_HOLD"
    f.run_until(f.time_s + 4.0)
    alt = -f.vehicle.pos_ned[2]
    assert alt == pytest.approx(0.5 * (4.05 - 0.25), abs=0.02)  # 0.5 m/s after its ramp
    f.nav.set_sticks(DESCEND)
    f.run_until(f.time_s + alt / 0.3 + 4.0)  # PILOT_SPEED_DN 0.3 m/s, then detection
    assert "landed" in f.kinds()
    f.run_until(f.time_s + 2.5)
    assert not f.nav.armed  # disarmed after the landing, as any landing


def test_stabilize_with_sticks_follows_the_estimate_and_leans() -> None:
    f = airborne(1.0)
    assert f.nav.set_mode(Mode.STABILIZE).accepted
    f.nav.set_sticks(Sticks(0.0, -0.5, 0.5, 0.0))
    out = f.run_until(f.time_s + 0.5)
    ref = out.reference
    assert ref is not None
    assert ref.acc_ned[0] > 0.0 and ref.acc_ned[1] == pytest.approx(0.0, abs=1e-12)
    assert ref.acc_ned[2] == pytest.approx(0.0, abs=1e-12)  # mid-stick: hover


def test_poshold_is_a_supported_armable_mode() -> None:
    f = flight()
    assert f.nav.set_mode(16).accepted
    assert f.nav.mode == Mode.POSHOLD
    assert f.nav.arm().accepted
