"""Arming: the one pre-arm check, and when an armed vehicle on the ground disarms by itself.

Pre-arm checks, in order (:func:`prearm_check`): a state estimate exists, no failsafe is
active, the estimator is healthy, there is a position fix, nothing the autopilot's health
monitor reported blocks it (a motor detected failed), the vehicle looks on the ground
(:func:`fcu.navigation.landing.looks_on_ground`), the mode allows arming
(``armable_modes``; AUTO when AUTO_OPTIONS bit 0 is set, and then only with a mission whose
next NAV item is a take-off, as ArduCopter's "Auto mode not armable").
:meth:`fcu.navigation.navigator.Navigator.arm` refuses with the first failing check's reason
unless forced; telemetry reports the same verdict (SYS_STATUS
pre-arm bit) through :meth:`~fcu.navigation.navigator.Navigator.prearm_check`.

Auto-disarm (:func:`auto_disarm_reason`) follows ``landed_disarm_delay_s`` after landing (or
after arming on the ground in a mode that lands: LAND, RTL), and ``idle_disarm_delay_s``
after arming without a take-off (0 disables it). As in ArduCopter, the parameter
``DISARM_DELAY`` (default 10 s) is the second one; the first is fixed (ArduCopter disarms as
soon as its land detector has declared the landing, about a second after touchdown; here
2 s) and its STATUSTEXT does not name the parameter.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

from fcu.navigation.modes import Mode, mode_name
from fcu.navigation.settings import TIME_TOL_S, NavigatorConfig


@dataclass(frozen=True)
class PrearmCheck:
    """The pre-arm verdict: ``ok``, or the reason arming would be refused."""

    ok: bool
    reason: str = ""  # why arming would be refused (empty when ok)

    def __bool__(self) -> bool:
        return self.ok


def prearm_check(*, has_estimate: bool, failsafe_sources: Collection[str],
                 estimator_healthy: bool, on_ground: bool, est_pos_ned: np.ndarray,
                 est_vel_ned: np.ndarray, mode: Mode, config: NavigatorConfig,
                 position_fix: bool = True, blockers: Collection[str] = (),
                 auto_start_problem: str = "") -> PrearmCheck:
    """The pre-arm checks of the module docstring, first failure first.

    Parameters
    ----------
    has_estimate : bool
        A finite state estimate has been received.
    failsafe_sources : collection of str
        Active failsafe sources, in the order they were triggered.
    estimator_healthy : bool
        The estimator's health at the latest step.
    on_ground : bool
        The vehicle looks on the ground (:func:`~fcu.navigation.landing.looks_on_ground`).
    est_pos_ned, est_vel_ned : numpy.ndarray, shape (3,)
        Latest estimate, m and m/s, NED (for the message).
    mode : Mode
        Current flight mode.
    config : NavigatorConfig
        Supplies ``armable_modes``.
    position_fix : bool
        Position measurements are trusted.
    blockers : collection of str
        Reasons from the autopilot's health monitor that forbid arming.
    auto_start_problem : str
        Why the loaded mission cannot start from the ground ("" when it can; read in AUTO).
    """
    if not has_estimate:
        return PrearmCheck(False, "no state estimate yet")
    if failsafe_sources:
        return PrearmCheck(False, "failsafe active: " + ", ".join(failsafe_sources))
    if not estimator_healthy:
        return PrearmCheck(False, "estimator not healthy")
    if not position_fix:
        return PrearmCheck(False, "no position fix")
    if blockers:
        return PrearmCheck(False, "; ".join(blockers))
    if not on_ground:
        return PrearmCheck(False, f"not on the ground (altitude {-est_pos_ned[2]:.2f} m, "
                           f"vertical speed {est_vel_ned[2]:.2f} m/s)")
    if not config.allows_arming_in(mode):
        allowed = ", ".join(mode_name(m) for m in config.armable_modes)
        hint = "; AUTO_OPTIONS bit 0 allows AUTO" if mode == Mode.AUTO else ""
        return PrearmCheck(False, f"mode {mode.name} does not allow arming (use {allowed}"
                           f"{hint})")
    if mode == Mode.AUTO and auto_start_problem:
        return PrearmCheck(False, f"AUTO: {auto_start_problem}")
    return PrearmCheck(True)


def auto_disarm_reason(time_s: float, ground_since_s: float, landed_like: bool,
                       config: NavigatorConfig) -> str | None:
    """The auto-disarm message when an armed vehicle on the ground is due to disarm, else None.

    Parameters
    ----------
    time_s : float
        Step time, s.
    ground_since_s : float
        When the vehicle was last armed or landed, s.
    landed_like : bool
        It landed after a flight, or its mode lands: ``landed_disarm_delay_s`` applies, else
        ``idle_disarm_delay_s`` (0 = never).
    config : NavigatorConfig
        Supplies the delays.
    """
    delay = config.landed_disarm_delay_s if landed_like else config.idle_disarm_delay_s
    if not landed_like and delay == 0.0:
        return None
    if time_s - ground_since_s >= delay - TIME_TOL_S:
        if landed_like:
            return f"auto-disarm {delay:g} s after landing"
        return f"auto-disarm: no take-off {delay:g} s after arming (DISARM_DELAY)"
    return None
