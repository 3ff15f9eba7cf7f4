"""Sticks over MAVLink: MANUAL_CONTROL and RC_CHANNELS_OVERRIDE as ArduCopter maps them, and
the RC failsafe's timing on made-up wall-clock times."""

from __future__ import annotations

import pytest
from mavlink_testkit import memory_endpoint

from fcu.mavlink.protocols.manual_input import (
    RcChannels,
    RcFailsafe,
    RcFailsafeAction,
    RcFailsafeConfig,
    manual_control_pwm,
)
from fcu.mavlink.transport.codec import mavlink2
from fcu.navigation.modes import Mode
from fcu.navigation.sticks import Sticks

M = mavlink2
LAND = RcFailsafeConfig(action=RcFailsafeAction.LAND, timeout_s=1.0)
FREE = 0  # RC_CHANNELS_OVERRIDE: release
KEEP = 65535  # RC_CHANNELS_OVERRIDE: leave as it was


def sticks_of(pwm: tuple[int | None, ...], keep: int | None = None) -> Sticks | None:
    channels = RcChannels()
    channels.set(pwm, keep=keep)
    return channels.sticks(0.0)


def test_manual_control_maps_as_arducopter_pitch_reversed_throttle_from_zero() -> None:
    # MAVSDK's set_manual_control_input(x=1 forward, y=-1 left, z=0.5, r=1): x, y, z, r * 1000
    assert manual_control_pwm(1000, -1000, 500, 1000) == (1000, 1000, 1500, 2000)
    assert manual_control_pwm(0, 0, 0, 0) == (1500, 1500, 1000, 1500)
    assert manual_control_pwm(32767, 0, 1000, 32767) == (1500, None, 2000, None)  # unused
    sticks = sticks_of(manual_control_pwm(1000, -1000, 500, 1000))
    assert sticks == Sticks(roll=-1.0, pitch=-1.0, throttle=0.5, yaw=1.0)  # forward: -1


def test_rc_override_release_and_keep() -> None:
    channels = RcChannels()
    channels.set((FREE, FREE, 1700, FREE), keep=KEEP)  # MAVProxy's "rc 3 1700"
    assert channels.sticks(0.0) == Sticks(0.0, 0.0, 0.7, 0.0)  # released: centred
    channels.set((1600, KEEP, KEEP, KEEP), keep=KEEP)
    assert channels.sticks(0.0) == Sticks(0.2, 0.0, 0.7, 0.0)  # throttle kept
    channels.set((FREE, FREE, FREE, FREE), keep=KEEP)  # "rc 3 0" / "rc clear"
    assert channels.sticks(0.0) is None  # every channel released: no sticks
    assert sticks_of((900, 2100, 3000, 1500)) == Sticks(-1.0, 1.0, 1.0, 0.0)  # clamped


def test_failsafe_fires_once_after_the_timeout_of_sticks_in_use_and_clears() -> None:
    fs = RcFailsafe()
    assert not fs.on_input(10.0, Mode.LOITER, released=False)
    assert fs.in_use
    assert not fs.stale(10.99, LAND)
    assert fs.stale(11.0, LAND)
    assert fs.check(True, Mode.LOITER, 11.0, LAND) == RcFailsafeAction.LAND
    assert fs.active and not fs.stale(20.0, LAND)  # once per loss, sticks released
    assert fs.on_input(21.0, Mode.LAND, released=False)  # back: cleared
    assert not fs.active and not fs.in_use  # (in LAND the sticks fly nothing)


@pytest.mark.parametrize("flying, mode, released, action", [
    (False, Mode.LOITER, False, RcFailsafeAction.LAND),  # disarmed or on the ground
    (True, Mode.GUIDED, False, RcFailsafeAction.LAND),  # sticks never flew anything
    (True, Mode.LOITER, True, RcFailsafeAction.LAND),  # released on purpose
    (True, Mode.LOITER, False, RcFailsafeAction.DISABLED),  # FS_THR_ENABLE 0
])
def test_failsafe_never_fires_on_the_ground_unused_released_or_disabled(
        flying: bool, mode: Mode, released: bool, action: RcFailsafeAction) -> None:
    config = RcFailsafeConfig(action=action, timeout_s=1.0)
    fs = RcFailsafe()
    fs.on_input(0.0, mode, released)
    if fs.stale(5.0, config):
        assert fs.check(flying, mode, 5.0, config) is None
    assert not fs.active


def test_sticks_used_in_loiter_then_guided_do_not_fire_it() -> None:
    fs = RcFailsafe()
    fs.on_input(0.0, Mode.LOITER, released=False)
    assert fs.stale(2.0, LAND)
    assert fs.check(True, Mode.GUIDED, 2.0, LAND) is None  # now in GUIDED: no action


def manual_control(x: int, y: int, z: int, r: int, target: int = 1) -> object:
    return M.MAVLink_manual_control_message(target, x, y, z, r, 0)


def test_endpoint_forwards_sticks_releases_stale_ones_and_lands_on_loss() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    vehicle.armed, vehicle.mode, vehicle.pos_ned[2] = True, int(Mode.POSHOLD), -2.0
    for k in range(50):  # 10 Hz wall for 5 s, the simulation 10x faster
        gcs.put(manual_control(1000, 0, 500, 0))
        endpoint.tick(k * 1.0, k * 0.1)
    assert vehicle.sticks == Sticks(0.0, -1.0, 0.5, 0.0, time_s=vehicle.sticks.time_s)
    assert vehicle.mode == Mode.POSHOLD and not vehicle.failsafes
    gcs.put(manual_control(0, 0, 500, 0, target=7))  # another vehicle's: ignored
    last_s = 4.9
    endpoint.tick(50.0, last_s + 0.99)
    assert vehicle.sticks is not None and vehicle.mode == Mode.POSHOLD
    endpoint.tick(51.0, last_s + 1.0)  # RC_FS_TIMEOUT 1 s of wall time since the last
    assert vehicle.sticks is None
    assert vehicle.mode == Mode.LAND and vehicle.failsafes == {"radio": "land"}
    texts = [m.text for m in link.take("STATUSTEXT")]
    assert any("Radio failsafe: no sticks for 1 s, LAND" in t for t in texts), texts
    gcs.put(manual_control(0, 0, 500, 0))
    endpoint.tick(60.0, 10.0)
    assert ("clear_failsafe", "radio") in vehicle.calls and vehicle.mode == Mode.LAND
    assert any("Radio failsafe cleared" in m.text for m in link.take("STATUSTEXT"))


def test_rc_override_in_guided_only_expires_and_rtl_is_a_parameter() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    gcs.put(M.MAVLink_param_set_message(1, 1, b"FS_THR_ENABLE", 1.0, M.MAV_PARAM_TYPE_INT8))
    endpoint.tick(0.0, 0.0)
    assert endpoint.params.get("FS_THR_ENABLE") == 1.0
    vehicle.armed, vehicle.mode, vehicle.pos_ned[2] = True, int(Mode.GUIDED), -2.0
    gcs.put(M.MAVLink_rc_channels_override_message(1, 1, 0, 0, 1700, 0, *([KEEP] * 4)))
    endpoint.tick(0.1, 0.1)
    assert vehicle.sticks == Sticks(0.0, 0.0, 0.7, 0.0, time_s=0.1)
    endpoint.tick(0.2, 1.2)
    assert vehicle.sticks is None and vehicle.mode == Mode.GUIDED  # expired, no action
    vehicle.mode = int(Mode.ALT_HOLD)
    gcs.put(M.MAVLink_rc_channels_override_message(1, 1, 0, 0, 1700, 0, *([KEEP] * 4)))
    endpoint.tick(0.3, 2.0)
    endpoint.tick(0.4, 3.0)
    assert vehicle.mode == Mode.RTL and vehicle.failsafes == {"radio": "rtl"}
