"""The compiled control chain (fcu.control.chain) is the parts stepped one after the other,
to the bit: the position loop, the reference filter, the attitude law with its lead, the DOB
on the previous tick's mixed torque, the allocation with the FTC effectiveness and the mix."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fcu.config import AutopilotConfig
from fcu.control import chain as control_chain
from fcu.control.attitude_reference import AttitudeReferenceFilter
from fcu.control.position import PositionController
from fcu.control.registry import ALLOCATOR_REGISTRY, ATTITUDE_LAW_REGISTRY, DOB_REGISTRY
from fcu.monitoring import crash_check

CONFIG = AutopilotConfig()
DT = 1.0 / CONFIG.loop_rate_hz  # s
FULL_THRUST_N = 4.0 * CONFIG.model.thrust_gain * CONFIG.model.pwm_max


def _chain(law: str, dob: str) -> control_chain.ControlChain:
    return control_chain.ControlChain(
        PositionController(CONFIG.model, CONFIG.position, DT),
        AttitudeReferenceFilter(DT, CONFIG.attitude_ref_bandwidth_rad_s),
        ATTITUDE_LAW_REGISTRY.factory(law)(CONFIG, DT), DOB_REGISTRY.factory(dob)(CONFIG, DT),
        ALLOCATOR_REGISTRY.factory("attitude_first")(CONFIG, DT), FULL_THRUST_N)


def _inputs(seed: int, n: int) -> list[tuple[np.ndarray, ...]]:
    """A wandering estimate around a hover 1 m up, a moving reference, a yaw past +-pi."""
    rng = np.random.default_rng(seed)
    ticks: list[tuple[np.ndarray, ...]] = []
    for k in range(n):
        t = k * DT
        pos = np.array([0.3 * np.sin(t), 0.2 * np.cos(0.7 * t), -1.0]) + rng.normal(0, 0.05, 3)
        vel = rng.normal(0, 0.3, 3)
        euler = np.array([*rng.normal(0, 0.1, 2), 3.1 + 0.1 * np.sin(3.0 * t)])
        euler[2] = (euler[2] + np.pi) % (2 * np.pi) - np.pi
        rate = rng.normal(0, 0.5, 3)
        ref = np.array([0.5 * t, 0.0, -1.0]), np.array([0.5, 0.0, 0.0]), rng.normal(0, 1, 3)
        ticks.append((pos, vel, euler, rate, *ref, np.array([3.1 - 0.01 * k])))
    return ticks


# the motor 3 effectiveness of active FTC from tick 60 on, 1 elsewhere
_EFFECTIVENESS = np.array([1.0, 1.0, 0.6, 1.0])


@pytest.mark.parametrize(("law", "dob"),
                         list(itertools.product(("pd", "lqg"), ("none", "vbdob", "abdob"))))
def test_the_compiled_chain_is_the_parts_stepped_in_turn(law: str, dob: str) -> None:
    compiled, parts = _chain(law, dob), _chain(law, dob)
    parts.compiled = False  # the same chain through the parts' own step methods
    applied_c = applied_p = np.zeros(3)
    saturated = 0
    for k, (pos, vel, euler, rate, rpos, rvel, racc, yaw) in enumerate(_inputs(7, 200)):
        eff = _EFFECTIVENESS if k >= 60 else None
        out_c = compiled.step(pos, vel, euler, rate, rpos, rvel, racc, float(yaw[0]), applied_c,
                              eff)
        out_p = parts.step(pos, vel, euler, rate, rpos, rvel, racc, float(yaw[0]), applied_p,
                           eff)
        # bit for bit: the same operations in the same order
        np.testing.assert_array_equal(out_c, out_p)
        applied_c = out_c[control_chain.OUT_TORQUE_APPLIED:control_chain.OUT_TORQUE_APPLIED + 3]
        applied_p = out_p[control_chain.OUT_TORQUE_APPLIED:control_chain.OUT_TORQUE_APPLIED + 3]
        pwm = out_c[control_chain.OUT_PWM:control_chain.OUT_PWM + 4]
        saturated += bool(np.any(pwm >= CONFIG.model.pwm_max * 0.999))
    # the inputs are rough enough to reach the allocator's saturation branches too
    assert saturated > 0
    # the states the two chains advanced agree as well
    np.testing.assert_array_equal(compiled.position.integral, parts.position.integral)
    if dob != "none":
        np.testing.assert_array_equal(compiled.dob.kernel_states()[0],  # type: ignore
                                      parts.dob.kernel_states()[0])  # type: ignore


@pytest.mark.parametrize("law", ["pd", "lqg"])
def test_the_touchdown_tilt_reaches_the_compiled_call(law: str) -> None:
    """The chain's workspace keeps its own copy of the position loop's parameters: the
    touchdown's tilt limit set through the chain is the one the compiled call flies, as the
    parts stepped in turn do, to the bit; and it is lifted again."""
    compiled, parts = _chain(law, "abdob"), _chain(law, "abdob")
    parts.compiled = False
    applied_c = applied_p = np.zeros(3)
    tilts = []
    for k, (pos, vel, euler, rate, rpos, rvel, _, yaw) in enumerate(_inputs(3, 120)):
        for chain in (compiled, parts):
            chain.touchdown(40 <= k < 80)
        far = rpos + np.array([30.0, 0.0, 0.0])  # 30 m off: the tilt limit binds
        racc = np.zeros(3)
        out_c = compiled.step(pos, vel, euler, rate, far, rvel, racc, float(yaw[0]), applied_c,
                              None)
        out_p = parts.step(pos, vel, euler, rate, far, rvel, racc, float(yaw[0]), applied_p,
                           None)
        assert np.array_equal(out_c, out_p), k
        applied_c = out_c[control_chain.OUT_TORQUE_APPLIED:control_chain.OUT_TORQUE_APPLIED + 3]
        applied_p = out_p[control_chain.OUT_TORQUE_APPLIED:control_chain.OUT_TORQUE_APPLIED + 3]
        mu = out_c[control_chain.OUT_ACCEL:control_chain.OUT_ACCEL + 3]
        tilts.append(np.degrees(np.arctan2(np.hypot(mu[0], mu[1]),
                                           CONFIG.model.gravity - mu[2])))
    assert max(tilts[45:80]) == pytest.approx(20.0, abs=0.05)
    assert max(tilts[85:]) == pytest.approx(30.0, abs=0.05)


def _run(chain: control_chain.ControlChain, ticks: list[tuple[np.ndarray, ...]]
         ) -> list[np.ndarray]:
    applied, outs = np.zeros(3), []
    for pos, vel, euler, rate, rpos, rvel, racc, yaw in ticks:
        out = chain.step(pos, vel, euler, rate, rpos, rvel, racc, float(yaw[0]), applied, None)
        applied = out[control_chain.OUT_TORQUE_APPLIED:control_chain.OUT_TORQUE_APPLIED + 3]
        outs.append(out)
    return outs


@pytest.mark.parametrize("law", ["pd", "lqg"])
def test_the_parts_and_the_compiled_call_share_their_states(law: str) -> None:
    """A reset through a part's own method (as the autopilot resets its controllers)
    restarts what the compiled call works on: the chain afterwards flies as a fresh one."""
    ticks = _inputs(3, 100)
    used, fresh = _chain(law, "abdob"), _chain(law, "abdob")
    _run(used, ticks[:50])
    assert np.any(used.position.integral != 0.0)
    for part in (used.position, used.reference_filter, used.law, used.dob):
        part.reset()
    np.testing.assert_array_equal(np.array(_run(used, ticks[50:])),
                                  np.array(_run(fresh, ticks[50:])))


def test_the_chain_reports_what_the_crash_check_reads() -> None:
    chain = _chain("pd", "none")
    pos, vel = np.array([0.0, 0.0, -2.0]), np.array([3.0, 0.0, 4.0])
    euler = np.array([0.3, -0.4, 0.0])
    out = chain.step(pos, vel, euler, np.zeros(3), pos, np.zeros(3), np.zeros(3), 0.0,
                     np.zeros(3), None)
    assert out[control_chain.OUT_ALT] == 2.0  # up positive
    assert out[control_chain.OUT_VEL_DOWN] == 4.0
    assert out[control_chain.OUT_SPEED] == pytest.approx(5.0, rel=1e-15)  # 3-4-5
    # lean: acos(cos(phi) cos(theta)) (exact formula; rounding only)
    assert out[control_chain.OUT_LEAN] == pytest.approx(np.arccos(np.cos(0.3) * np.cos(0.4)),
                                                        rel=1e-14)
    # the larger of the roll and pitch errors against the reference the tick computed
    ref = control_chain.attitude_reference(out)
    assert out[control_chain.OUT_ATT_ERROR] == pytest.approx(
        max(abs(ref.euler_rad[0] - 0.3), abs(ref.euler_rad[1] + 0.4)), rel=1e-15)
    assert out[control_chain.OUT_COLLECTIVE] == pytest.approx(
        out[control_chain.OUT_THRUST] / FULL_THRUST_N, rel=1e-15)


def test_the_measures_are_laid_out_as_the_crash_check_reads_them() -> None:
    offsets = [control_chain.OUT_ALT, control_chain.OUT_VEL_DOWN, control_chain.OUT_SPEED,
               control_chain.OUT_LEAN, control_chain.OUT_ATT_ERROR, control_chain.OUT_COLLECTIVE]
    named = [crash_check.ALT, crash_check.VEL_DOWN, crash_check.SPEED, crash_check.LEAN,
             crash_check.ATTITUDE_ERROR, crash_check.COLLECTIVE]
    assert [o - control_chain.OUT_ALT for o in offsets] == named
    assert len(offsets) == crash_check.MEASURES_SIZE


@pytest.mark.parametrize("compiled", [True, False])
def test_the_chain_runs_the_crash_check_as_the_check_alone_does(compiled: bool) -> None:
    """A vehicle on its side (lean and attitude error past 30 deg) for more than 2 s: the
    chain's own crash check fires at the tick the check fed the same measures fires, and a
    flight without a bound check reports nothing."""
    config = crash_check.CrashCheckConfig()
    bound = crash_check.CrashCheck(config)
    chain = _chain("pd", "none")
    chain = control_chain.ControlChain(chain.position, chain.reference_filter, chain.law,
                                       chain.dob, chain.allocator, FULL_THRUST_N, bound)
    chain.compiled = compiled and chain.compiled
    alone, unbound = crash_check.CrashCheck(config), _chain("pd", "none")
    pos, euler = np.array([0.0, 0.0, -1.0]), np.array([1.2, 0.0, 0.0])  # rolled 69 deg
    found_at = []
    for k in range(300):
        t = k * DT
        args = (pos, np.zeros(3), euler, np.zeros(3), pos, np.zeros(3), np.zeros(3), 0.0,
                np.zeros(3), None)
        out = chain.step(*args, time_s=t, contact_leg=True)
        measures = out[control_chain.OUT_ALT:control_chain.OUT_ALT + crash_check.MEASURES_SIZE]
        assert out[control_chain.OUT_CRASH_FOUND] == alone.tick(t, True, measures.copy())
        assert unbound.step(*args, time_s=t)[control_chain.OUT_CRASH_FOUND] == 0.0
        if out[control_chain.OUT_CRASH_FOUND]:
            found_at.append(t)
    assert found_at == [pytest.approx(config.angle_time_s, abs=1e-9)]  # once, after 2 s
    assert bound.crashed  # the check's own state is the one the chain advanced
