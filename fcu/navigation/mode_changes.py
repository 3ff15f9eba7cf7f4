"""The mode changes of the navigator: DO_SET_MODE, the failsafes, and what each mode starts.

:class:`ModeChanges` checks a requested mode (supported, a position estimate and fix for the
position modes, a mission for AUTO, a lead for FOLLOW), switches to it and starts what the
mode does in flight (:data:`fcu.navigation.modes.MODE_TABLE`'s behaviour: hold, the sticks,
the mission, RTL, CIRCLE, FOLLOW or LAND). A failsafe switches to LAND or RTL in flight and
disarms on the ground. It sits on every layer whose behaviour a mode starts.
"""

from __future__ import annotations

import numpy as np

from fcu.navigation.events import CommandResult, Severity
from fcu.navigation.fence_watch import FenceWatch
from fcu.navigation.follow_mode import FollowLegs
from fcu.navigation.guided_setpoints import GuidedSetpoints
from fcu.navigation.mission import MissionExecution
from fcu.navigation.modes import (
    ARDUCOPTER_MODE_NAMES,
    MODE_TABLE,
    SUPPORTED_MODE_NUMBERS,
    Mode,
    mode_name,
)
from fcu.navigation.settings import AUTO_TAKEOFF_WITHOUT_START

__all__ = ["ModeChanges"]


class ModeChanges(FollowLegs, GuidedSetpoints, FenceWatch, MissionExecution):
    """Mode changes and failsafes (module docstring); a layer of the navigator, which owns
    the mode, arming and failsafe state set here."""

    _mode: Mode  # the flight mode
    _armed: bool  # armed (the arming layer's, :mod:`fcu.navigation.arming_commands`)
    _failsafes: dict[str, str]  # active failsafe sources -> their action
    _position_fix: bool  # position measurements trusted

    def _disarm(self, text: str, severity: Severity = "info") -> None:
        """The arming layer's (:meth:`fcu.navigation.arming_commands.ArmingCommands._disarm`)."""
        raise NotImplementedError

    def set_mode(self, mode_number: int) -> CommandResult:
        """Change flight mode (DO_SET_MODE / SET_MODE custom_mode).

        Refused: unsupported or unknown numbers; position modes while the estimator is
        unhealthy; AUTO without a mission.
        """
        if isinstance(mode_number, bool) or not isinstance(mode_number, (int, np.integer)):
            return self._refuse("mode change", f"mode {mode_number!r} is not a mode number")
        number = int(mode_number)
        what = f"mode {mode_name(number)}"
        if number not in SUPPORTED_MODE_NUMBERS:
            if number in ARDUCOPTER_MODE_NAMES:
                return self._refuse(what, f"{mode_name(number)} ({number}) is not supported")
            return self._refuse(what, f"unknown mode number {number}")
        mode = Mode(number)
        if mode == self._mode:
            return self._ok(f"already in {mode.name}")
        if MODE_TABLE[mode].needs_position and not self._estimator_healthy:
            return self._refuse(what, "position estimate not healthy")
        if MODE_TABLE[mode].needs_position and not self._position_fix:
            return self._refuse(what, "no position fix")
        if mode == Mode.AUTO and not self._mission.items:
            return self._refuse(what, "no mission loaded")
        if mode == Mode.FOLLOW and self._follow_refusal():
            return self._refuse(what, self._follow_refusal())
        if mode == Mode.AUTO and self._armed and not self._flying:
            problem = self._ground_start_problem()
            if problem:
                return self._refuse(what, problem)
        self._enter_mode(mode, "")
        return self._ok()

    def _enter_mode(self, mode: Mode, why: str) -> None:
        old = self._mode
        self._mode = mode
        t = self._now()
        self._event("mode", f"mode {old.name} -> {mode.name}{why}",
                    "warning" if why else "info")
        if old == Mode.AUTO and mode != Mode.AUTO:
            self._mission.active = False
        if not (self._armed and self._flying):
            if self._armed and MODE_TABLE[mode].lands:
                self._ground_since_s = t
            self._auto_takeoff_without_start(t)
            return
        self._start_mode_behaviour(t)

    def _auto_takeoff_without_start(self, t: float) -> None:
        """Armed on the ground in AUTO: with AUTO_OPTIONS bit 1 the mission (its take-off)
        starts at once; without it, MISSION_START starts it (ArduCopter's throttle raise)."""
        if self._mode == Mode.AUTO and self._armed and not self._flying and \
                not self._mission.active and \
                self.config.auto_options & AUTO_TAKEOFF_WITHOUT_START and \
                not self._ground_start_problem():
            self._resume_mission(t)

    def _start_mode_behaviour(self, t: float) -> None:
        """Start what the current mode does in flight, from the current reference."""
        behaviour = MODE_TABLE[self._mode].behaviour
        if behaviour == "hold":
            self._enter_hold(t)
        elif behaviour == "manual":
            self._enter_manual(t)
        elif behaviour == "mission":
            self._resume_mission(t)
        elif behaviour == "rtl":
            self._start_rtl(t, None)
        elif behaviour == "circle":
            self._enter_circle(t)
        elif behaviour == "follow":
            self._enter_follow(t)
        else:  # land
            self._start_land(t, None)

    def land(self) -> CommandResult:
        """NAV_LAND as a command: switch to LAND."""
        return self.set_mode(Mode.LAND)

    def return_to_launch(self) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH as a command: switch to RTL."""
        return self.set_mode(Mode.RTL)

    def trigger_failsafe(self, source: str, action: str = "land") -> CommandResult:
        """Enter a failsafe from ``source`` (e.g. ``"gcs"``, ``"battery"``, ``"ekf"``).

        In flight the vehicle switches to LAND (``action="land"``) or RTL (``"rtl"``; LAND
        when the estimator is unhealthy or already landing); armed on the ground it disarms.
        Arming is refused while any failsafe is active.
        """
        if action not in ("land", "rtl"):
            return self._refuse("failsafe", f"action {action!r} is not land or rtl")
        self._failsafes[str(source)] = action
        self._event("failsafe", f"failsafe {source}: {action.upper()}", "critical")
        if self._armed and self._flying:
            target = Mode.RTL if action == "rtl" and self._estimator_healthy else Mode.LAND
            if self._mode == Mode.LAND:
                target = Mode.LAND
            if target != self._mode:
                self._enter_mode(target, f" (failsafe {source})")
        elif self._armed:
            self._disarm(f"disarmed (failsafe {source} on the ground)")
        return self._ok()

    def clear_failsafe(self, source: str) -> CommandResult:
        """Clear failsafe ``source``; the mode stays as it is (as in ArduPilot)."""
        if source not in self._failsafes:
            return self._ok(f"no failsafe {source} active")
        del self._failsafes[source]
        self._event("failsafe", f"failsafe {source} cleared", "notice")
        return self._ok()

