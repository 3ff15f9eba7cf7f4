"""The geofence's layer of the navigator: FENCE_* changes and breaches in flight.

:class:`FenceWatch` keeps the uploaded fence areas and, every step in flight with the fence
enabled, checks the estimate against the parameters' fence and the areas
(:func:`fcu.navigation.fence.breach`): a breach triggers FENCE_ACTION once, announced; back
inside by FENCE_MARGIN the fence re-arms and its failsafe clears.
"""

from __future__ import annotations

from dataclasses import replace

from fcu.navigation.events import CommandResult
from fcu.navigation.fence import FENCE_ACTIONS, FenceAreas, FenceConfig, breach
from fcu.navigation.flight import FlightLegs
from fcu.navigation.modes import Mode

__all__ = ["FenceWatch"]


class FenceWatch(FlightLegs):
    """Geofence changes and breaches (module docstring); a layer of the navigator, whose
    mode, failsafes and mode changes it uses."""

    _mode: Mode
    _failsafes: dict[str, str]
    _fence_areas: FenceAreas  # the uploaded fence (set by the navigator, kept across a reset)
    _fence_breach: str | None  # the breach the fence acted on, until back inside

    def trigger_failsafe(self, source: str, action: str = "land") -> CommandResult:
        """The navigator's (:meth:`fcu.navigation.navigator.Navigator.trigger_failsafe`)."""
        raise NotImplementedError

    def clear_failsafe(self, source: str) -> CommandResult:
        """The navigator's (:meth:`fcu.navigation.navigator.Navigator.clear_failsafe`)."""
        raise NotImplementedError

    def _enter_mode(self, mode: Mode, why: str) -> None:
        """The navigator's mode change."""
        raise NotImplementedError

    def set_fence(self, fence: FenceConfig) -> CommandResult:
        """FENCE_* changed, in flight or not: in force at once (a fence enabled with the
        vehicle outside it is breached at the next step); disabled, its breach and failsafe
        are over."""
        self.config = replace(self.config, fence=fence)
        if not fence.enable and self._fence_breach is not None:
            self._fence_breach = None
            if "fence" in self._failsafes:
                self.clear_failsafe("fence")
        return self._ok()

    def set_fence_areas(self, areas: FenceAreas) -> CommandResult:
        """The uploaded fence (polygons, circles; local NED), enforced with the parameters'
        fence while FENCE_ENABLE is 1 and FENCE_TYPE has bit 2."""
        self._fence_areas = areas
        return self._ok()

    def _watch_fence(self, t: float) -> None:
        """A breach of the enabled fence triggers FENCE_ACTION once (announced); back
        inside by FENCE_MARGIN the fence re-arms and its failsafe clears."""
        fence = self.config.fence
        pos = self._est_pos_ned
        if self._fence_breach is not None:
            if breach(pos, self._home_pos_ned, fence, margin_m=fence.margin_m,
                      areas=self._fence_areas) is None:
                self._fence_breach = None
                self._event("fence", "back inside the fence", "notice")
                if "fence" in self._failsafes:
                    self.clear_failsafe("fence")
            return
        why = breach(pos, self._home_pos_ned, fence, areas=self._fence_areas)
        if why is None:
            return
        self._fence_breach = why
        action = FENCE_ACTIONS[fence.action]
        self._event("fence", f"fence breach: {why}" + (
            f", FENCE_ACTION {fence.action}: {action.upper()}" if action else
            " (FENCE_ACTION 0: report only)"), "critical")
        if action in ("rtl", "land"):
            self.trigger_failsafe("fence", action)
        elif action == "brake" and self._mode != Mode.BRAKE:
            self._enter_mode(Mode.BRAKE, " (fence breach)")
