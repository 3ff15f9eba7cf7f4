"""Crash and thrust-loss checks, after ArduCopter's (``crash_check.cpp``), on the estimate.

An autopilot that does not notice it has crashed keeps its motors running on the ground,
hops, and flies again with a dead motor. Three crash checks run while armed and flying (the
navigator's view: not on the ground); the first to fire disarms the motors
(``FS_CRASH_CHECK`` = 1; 0 only reports):

- **attitude** (ArduCopter's check): lean angle above ``angle_deg`` (30 deg) *and* attitude
  error (reference against estimate, the larger of roll and pitch) above ``angle_deg``,
  continuously for ``angle_time_s`` (2 s). A vehicle tumbling or lying on its side.
- **impact**: the estimate reaches the ground (altitude below ``ground_alt_m``) after
  descending faster than ``impact_speed_m_s`` (1.5 m/s) within the last ``impact_window_s``
  (0.3 s), in any leg (a landing descends at a few tenths of a m/s). A fall.
- **ground contact in flight**: the estimate sits on the ground (altitude below
  ``ground_alt_m``, speed below 0.1 m/s) for ``contact_time_s`` (1 s) while the navigator
  flies a leg that is not a take-off or a landing *and* its reference is at least
  ``contact_ref_alt_m`` (0.2 m) up: the vehicle is asked to fly and stays down. A vehicle
  that came down without a hard impact (a slow loss of thrust) and cannot get up. (A go-to
  sent at lift-off starts its reference on the ground: the vehicle is where it is asked to
  be, not crashed; see :func:`contact_counts`.)

ArduCopter's *thrust-loss* check warns only: collective command above ``thrust_loss_throttle``
(90 % of full thrust) with the attitude error below 15 deg while descending faster than
``thrust_loss_descent_m_s``, for ``thrust_loss_time_s`` (1 s): the motors give all they have
and the vehicle still sinks. Reported once per flight (``thrust_loss``, magnitude: the
collective command, 0..1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from flightdata.config import finite, require
from flightdata.records import DetectionRecord
from jitsupport.layout import OneStatePart


@dataclass(frozen=True, kw_only=True)
class CrashCheckConfig:
    """Settings of the crash and thrust-loss checks (module docstring)."""

    action: int = 1  # FS_CRASH_CHECK: 0 report only, 1 disarm
    angle_deg: float = 30.0  # deg, lean and attitude error of the attitude check
    angle_time_s: float = 2.0  # s the attitude check must hold
    impact_speed_m_s: float = 1.5  # m/s, descent speed before reaching the ground: a fall
    impact_window_s: float = 0.3  # s, how recent that speed must be
    contact_time_s: float = 1.0  # s on the ground in a flying leg
    ground_alt_m: float = 0.05  # m, altitude below which the estimate is on the ground
    contact_ref_alt_m: float = 0.2  # m, reference altitude from which ground contact counts
    thrust_loss_throttle: float = 0.9  # collective command, fraction of full thrust
    thrust_loss_descent_m_s: float = 0.5  # m/s, descent speed of the thrust-loss check
    thrust_loss_time_s: float = 1.0  # s the thrust-loss check must hold

    def __post_init__(self) -> None:
        require(self.action in (0, 1), "action", self.action, "must be 0 or 1")
        for name in ("angle_deg", "angle_time_s", "impact_speed_m_s", "impact_window_s",
                     "contact_time_s", "ground_alt_m", "contact_ref_alt_m",
                     "thrust_loss_throttle",
                     "thrust_loss_descent_m_s", "thrust_loss_time_s"):
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a number > 0")


# CrashCheck's state vector (times in s; NaN: not running)
_ANGLE_SINCE, _CONTACT_SINCE, _FAST_DESCENT, _THRUST_SINCE, _THRUST_WARNED, _CRASHED = range(6)
STATE_SIZE = 6
# its parameter vector
(_P_ANGLE, _P_ANGLE_TIME, _P_IMPACT_SPEED, _P_IMPACT_WINDOW, _P_CONTACT_TIME, _P_GROUND_ALT,
 _P_THROTTLE, _P_DESCENT, _P_THRUST_TIME, _P_THRUST_ERROR) = range(10)
PAR_SIZE = 10
# what crash_tick found: bits of its return value
THRUST_LOSS, CRASH = 1, 2


# the measures a tick is checked on, in this order (CrashCheck.check)
ALT, VEL_DOWN, SPEED, LEAN, ATTITUDE_ERROR, COLLECTIVE = range(6)
MEASURES_SIZE = 6


# inlined: a call of its own was compiled once for each constant ``since`` it is given
@njit(cache=True, error_model="numpy", inline="always")
def _held(state: np.ndarray, since: int, condition: bool, time_s: float, hold_s: float) -> bool:
    """Whether ``condition`` has held for ``hold_s`` (s) up to ``time_s``; ``state[since]`` keeps
    when it began (NaN while it does not hold)."""
    if not condition:
        state[since] = np.nan
        return False
    if math.isnan(state[since]):
        state[since] = time_s
    return time_s - state[since] >= hold_s - 1e-9


@njit(cache=True, error_model="numpy")
def crash_tick(par: np.ndarray, state: np.ndarray, time_s: float, contact_leg: bool,
               measures: np.ndarray) -> int:
    """One flying tick of the checks of the module docstring on ``measures`` (``ALT``...
    ``COLLECTIVE``, as :meth:`CrashCheck.step`'s arguments; ``contact_leg``: the leg is
    neither a take-off nor a landing); advances ``state`` and returns ``THRUST_LOSS | CRASH``
    bits for what fired."""
    alt_m, vel_down_m_s, speed_m_s = measures[ALT], measures[VEL_DOWN], measures[SPEED]
    lean_rad, attitude_error_rad = measures[LEAN], measures[ATTITUDE_ERROR]
    collective = measures[COLLECTIVE]
    if vel_down_m_s > par[_P_IMPACT_SPEED]:
        state[_FAST_DESCENT] = time_s
    found = 0
    if state[_THRUST_WARNED] == 0.0:
        # thrust loss: collective high, descending, attitude fine, for thrust_loss_time_s
        if (collective > par[_P_THROTTLE] and vel_down_m_s > par[_P_DESCENT]
                and attitude_error_rad < par[_P_THRUST_ERROR]):
            if math.isnan(state[_THRUST_SINCE]):
                state[_THRUST_SINCE] = time_s
            if time_s - state[_THRUST_SINCE] >= par[_P_THRUST_TIME] - 1e-9:
                state[_THRUST_WARNED] = 1.0
                found |= THRUST_LOSS
        else:
            state[_THRUST_SINCE] = np.nan
    if state[_CRASHED] != 0.0:
        return found
    angle = par[_P_ANGLE]
    # attitude: lean and attitude error both above angle_deg for angle_time_s
    if _held(state, _ANGLE_SINCE, lean_rad > angle and attitude_error_rad > angle, time_s,
             par[_P_ANGLE_TIME]):
        state[_CRASHED] = 1.0
        return found | CRASH
    on_ground = alt_m < par[_P_GROUND_ALT]
    # impact: on the ground within impact_window_s of a fast descent
    if on_ground and time_s - state[_FAST_DESCENT] <= par[_P_IMPACT_WINDOW] + 1e-9:
        state[_CRASHED] = 1.0
        return found | CRASH
    # ground contact in a flying leg for contact_time_s
    if _held(state, _CONTACT_SINCE, on_ground and speed_m_s < 0.1 and contact_leg, time_s,
             par[_P_CONTACT_TIME]):
        state[_CRASHED] = 1.0
        return found | CRASH
    return found


def contact_counts(leg: str, ref_alt_m: float, contact_ref_alt_m: float) -> bool:
    """Whether ground contact would be a crash now: the navigator flies a leg that is not a
    take-off or a landing (``leg``) and its reference altitude ``ref_alt_m`` (m, up) is at
    least ``contact_ref_alt_m`` (m) above the ground."""
    return leg not in ("takeoff", "land") and ref_alt_m >= contact_ref_alt_m


class CrashCheck(OneStatePart):
    """The checks of the module docstring, fed once per tick."""

    def __init__(self, config: CrashCheckConfig) -> None:
        self.config = config
        self._angle_rad = math.radians(config.angle_deg)
        self._thrust_loss_error_rad = math.radians(15.0)
        cfg = config
        self.par = np.array([self._angle_rad, cfg.angle_time_s, cfg.impact_speed_m_s,
                             cfg.impact_window_s, cfg.contact_time_s, cfg.ground_alt_m,
                             cfg.thrust_loss_throttle, cfg.thrust_loss_descent_m_s,
                             cfg.thrust_loss_time_s, self._thrust_loss_error_rad])
        self.state = np.empty(STATE_SIZE)
        self.reset()

    def reset(self) -> None:
        """A new flight: timers and the once-per-flight warning restart."""
        self.state[:] = (math.nan, math.nan, -math.inf, math.nan, 0.0, 0.0)

    @property
    def crashed(self) -> bool:
        """A crash was detected in this flight."""
        return bool(self.state[_CRASHED])

    def step(self, time_s: float, *, flying: bool, leg: str, ref_alt_m: float, alt_m: float,
             vel_down_m_s: float, speed_m_s: float, lean_rad: float,
             attitude_error_rad: float, collective: float) -> list[DetectionRecord]:
        """One tick.

        Parameters
        ----------
        time_s : float
            Tick time, s.
        flying : bool
            Armed and not on the ground (the navigator's view).
        leg : str
            What the navigator flies: "takeoff", "land" or anything else.
        ref_alt_m : float
            Altitude of the position reference, m (up).
        alt_m, vel_down_m_s, speed_m_s : float
            Estimated altitude (m), vertical speed (m/s, + down) and speed (m/s).
        lean_rad, attitude_error_rad : float
            Estimated lean (angle of the body z axis from the vertical) and the attitude
            error against the reference (the larger of roll and pitch), rad.
        collective : float
            Commanded collective thrust as a fraction of full thrust.
        """
        if not flying:
            self.reset()
            return []
        contact_leg = contact_counts(leg, ref_alt_m, self.config.contact_ref_alt_m)
        return self.check(time_s, contact_leg, np.array(
            [alt_m, vel_down_m_s, speed_m_s, lean_rad, attitude_error_rad, collective],
            dtype=float))

    def check(self, time_s: float, contact_leg: bool, measures: np.ndarray
              ) -> list[DetectionRecord]:
        """One tick in flight (:meth:`step` with ``flying`` true) on ``measures`` (shape (6,):
        ``alt_m``, ``vel_down_m_s``, ``speed_m_s``, ``lean_rad``, ``attitude_error_rad``,
        ``collective`` in that order); ``contact_leg``: the ground-contact check applies
        (:func:`contact_counts`)."""
        return self.records(time_s, self.tick(time_s, contact_leg, measures), measures)

    def tick(self, time_s: float, contact_leg: bool, measures: np.ndarray) -> int:
        """:func:`crash_tick` on this check's parameters and timers (:meth:`check`'s
        arguments); returns its bits."""
        return crash_tick(self.par, self.state, time_s, contact_leg, measures)

    def records(self, time_s: float, found: int, measures: np.ndarray
                ) -> list[DetectionRecord]:
        """The records of what :func:`crash_tick` ``found`` (its bits) at ``time_s`` (s) on
        ``measures`` (:meth:`check`'s)."""
        if not found:
            return []
        out = []
        if found & THRUST_LOSS:
            out.append(DetectionRecord(time_s=time_s, action="detected", kind="thrust_loss",
                                       magnitude=float(measures[COLLECTIVE])))
        if found & CRASH:
            out.append(DetectionRecord(time_s=time_s, action="detected", kind="crash",
                                       magnitude=float(measures[ATTITUDE_ERROR])))
        return out
