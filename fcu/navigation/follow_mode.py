"""The navigator's FOLLOW mode: the lead's reports in, a "follow" leg out.

:class:`FollowLegs` is a layer of the navigator (beside the mission layer,
:class:`fcu.navigation.mission.MissionExecution`, over :class:`~fcu.navigation.flight.FlightLegs`)
that keeps the lead (:class:`fcu.navigation.follow.FollowTarget`), takes its reports
(:meth:`FollowLegs.follow_report`), applies FOLL_* changes at once (:meth:`FollowLegs.set_follow`)
and flies the chase when the mode is entered in flight (:meth:`FollowLegs._enter_follow`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from fcu.navigation.events import CommandResult
from fcu.navigation.flight import FlightLegs
from fcu.navigation.follow import FollowChase, FollowConfig, FollowTarget
from fcu.navigation.legs import Leg
from fcu.navigation.reference import Reference

__all__ = ["FollowLegs"]


class FollowLegs(FlightLegs):
    """FOLLOW's part of the navigator (module docstring)."""

    def _reset_flight(self) -> None:
        super()._reset_flight()
        self._follow_target = FollowTarget(self.config.follow)
        self._follow_lead: int | None = None  # the lead last announced

    def follow_report(self, sysid: int, pos_ned: np.ndarray, vel_ned: np.ndarray | None,
                      heading_rad: float | None) -> bool:
        """A position report of system ``sysid`` (m, m/s NED; heading rad from north, None
        unknown), at the time of the latest step. True when it is the lead's."""
        taken = self._follow_target.report(self._now(), int(sysid), pos_ned, vel_ned,
                                           heading_rad)
        lead = self._follow_target.sysid
        if taken and lead != self._follow_lead:
            self._follow_lead = lead
            self._event("follow", f"follow: lead is system {lead}", "notice")
        return taken

    def set_follow(self, config: FollowConfig) -> CommandResult:
        """FOLL_* changed: in force at once, in flight too."""
        self.config = replace(self.config, follow=config)
        self._follow_target.configure(config)
        return CommandResult(True, "")

    def _follow_refusal(self) -> str:
        """Why FOLLOW cannot be entered now ("" when it can), as ArduCopter says it."""
        return "" if self.config.follow.enable else "Set FOLL_ENABLE = 1"

    def _enter_follow(self, t: float) -> None:
        """FOLLOW entered in flight: chase the lead from the current reference."""
        if self._flying and self._leg is not None:
            start = self._reference(t)
        else:
            start = Reference.hold(*self._plan_start(t))
        chase = FollowChase(self._follow_target, start, t, self._limits, self._est_pos_ned)
        self._leg = Leg("follow", None, follow=chase)
        lead = self._follow_target.estimate(t)
        self._event("follow", f"following system {lead.sysid}" if lead is not None else
                    "follow: waiting for the lead's position (FOLLOW_TARGET or "
                    "GLOBAL_POSITION_INT)")
