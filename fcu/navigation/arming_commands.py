"""The arming layer of the navigator: the pre-arm check, arming and disarming.

:class:`ArmingCommands` arms (after :func:`fcu.navigation.arming.prearm_check`, or forced),
disarms (refused in flight unless forced), keeps the reasons arming is blocked for (the
health monitor's verdicts), disarms on a crash, and, armed on the ground, takes off by
throttle or disarms automatically when due (:func:`fcu.navigation.arming.auto_disarm_reason`).
"""

from __future__ import annotations

from collections.abc import Callable

from fcu.navigation.arming import PrearmCheck, auto_disarm_reason, prearm_check
from fcu.navigation.events import CommandResult, Severity
from fcu.navigation.mode_changes import ModeChanges
from fcu.navigation.modes import MODE_TABLE, Mode

__all__ = ["ArmingCommands"]


class ArmingCommands(ModeChanges):
    """Arming and disarming (module docstring); a layer of the navigator."""

    _blockers: dict[str, str | Callable[[], str]]  # key -> why arming is forbidden

    @property
    def arming_blockers(self) -> tuple[str, ...]:
        """The reasons arming is forbidden for now (:meth:`set_arming_blocker`), in the order
        they were first set."""
        return tuple(r if isinstance(r, str) else r() for r in self._blockers.values())

    def set_arming_blocker(self, key: str, reason: str | Callable[[], str] | None) -> None:
        """Forbid arming for ``reason`` under ``key`` (None lifts it): the health monitor's
        verdicts (a motor detected failed) enter the pre-arm check this way. A reason that
        changes with time (an estimate it quotes) may be given as a function returning the
        text, called whenever the reasons are read."""
        if reason is None:
            self._blockers.pop(key, None)
        else:
            self._blockers[key] = reason

    def crash(self, text: str) -> None:
        """A crash was detected: disarm now, whatever the state (``text`` says why)."""
        if self._armed:
            self._disarm(text, "critical")

    def _run_ground(self, t: float) -> None:
        """Armed on the ground at ``t`` (s): a take-off by throttle, or auto-disarm when due
        (:mod:`.arming`)."""
        if self._pilot_takeoff(t):
            return
        if self._ground_since_s is None:
            self._ground_since_s = t
        landed_like = self._landed_after_flight or MODE_TABLE[self._mode].lands
        why = auto_disarm_reason(t, self._ground_since_s, landed_like, self.config)
        if why is not None:
            self._disarm(why)

    def prearm_check(self) -> PrearmCheck:
        """Whether :meth:`arm` (not forced) would arm now, else the reason it would refuse.

        The checks of :func:`fcu.navigation.arming.prearm_check`, on the state of the latest
        step. While armed there is nothing left to check: OK.
        """
        if self._armed:
            return PrearmCheck(True)
        return prearm_check(has_estimate=self._has_estimate,
                            failsafe_sources=tuple(self._failsafes),
                            estimator_healthy=self._estimator_healthy,
                            on_ground=self._looks_on_ground(), est_pos_ned=self._est_pos_ned,
                            est_vel_ned=self._est_vel_ned, mode=self._mode, config=self.config,
                            position_fix=self._position_fix,
                            blockers=self.arming_blockers,
                            auto_start_problem=self._ground_start_problem()
                            if self._mode == Mode.AUTO else "")

    def arm(self, force: bool = False) -> CommandResult:
        """Arm (COMPONENT_ARM_DISARM p1=1; ``force`` for p2=21196 skips the checks).

        Refused with the reason of the first failing pre-arm check (:meth:`prearm_check`).
        """
        if self._armed:
            return self._ok("already armed")
        if not force:
            check = self.prearm_check()
            if not check.ok:
                return self._refuse("arming", check.reason)
        t = self._now()
        self._armed = True
        self._landed_after_flight = False
        self._ground_since_s = t
        self._event("arm", "armed (forced)" if force else "armed")
        if force and self._has_estimate and not self._looks_on_ground():
            # Force-armed in the air: fly the current mode from where the vehicle is.
            self._flying = True
            self._start_mode_behaviour(t)
        else:
            self._auto_takeoff_without_start(t)
        return self._ok()

    def disarm(self, force: bool = False) -> CommandResult:
        """Disarm (COMPONENT_ARM_DISARM p1=0); refused in flight unless ``force``."""
        if not self._armed:
            return self._ok("already disarmed")
        if self._flying and not force:
            return self._refuse("disarming", "flying: land first (or force)")
        self._disarm("disarmed (forced)" if force else "disarmed")
        return self._ok()

    def _disarm(self, text: str, severity: Severity = "info") -> None:
        self._armed = False
        self._flying = False
        self._leg = None
        self._landing.reset()
        self._ground_since_s = None
        self._mission.active = False
        self._event("disarm", text, severity)

