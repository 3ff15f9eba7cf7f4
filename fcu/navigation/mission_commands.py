"""The mission commands of the navigator: upload, clear, start, set the current item.

:class:`MissionCommands` checks an uploaded mission (:func:`fcu.navigation.mission.upload_problem`)
and starts or redirects its execution (:class:`fcu.navigation.mission.MissionExecution`):
MISSION_START switches to AUTO, MISSION_SET_CURRENT continues from an item.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fcu.navigation.events import CommandResult
from fcu.navigation.mission import upload_problem
from fcu.navigation.mode_changes import ModeChanges
from fcu.navigation.modes import Mode
from flightdata.mission import MissionItem

__all__ = ["MissionCommands"]


class MissionCommands(ModeChanges):
    """Mission upload, start and current item (module docstring); a layer of the
    navigator."""

    def load_mission(self, items: Sequence[MissionItem]) -> CommandResult:
        """Replace the mission with ``items`` (seq 1..n; home is seq 0 and not included).

        Refused while flying it in AUTO, for targets below ground, and with the fence
        enabled for targets outside it.
        """
        if self._mode == Mode.AUTO and self._flying:
            return self._refuse("mission upload", "flying the current mission in AUTO")
        problem = upload_problem(items, self.config, self._home_pos_ned)
        if problem is not None:
            return self._refuse("mission upload", problem)
        self._mission.load(items)
        self._event("mission", f"mission of {len(self._mission.items)} items loaded")
        return self._ok()

    def clear_mission(self) -> CommandResult:
        """MISSION_CLEAR_ALL; refused while flying the mission in AUTO."""
        return self.load_mission(())

    def start_mission(self) -> CommandResult:
        """MISSION_START: switch to AUTO (if needed) and run from the current item.

        Refused without a mission, when disarmed, and on the ground unless the next NAV
        item is a take-off. A complete mission restarts from item 1. On the ground it is
        what starts the take-off of an AUTO mission (ArduCopter's MISSION_START sets
        "auto-armed", the throttle raise a pilot would give; AUTO_OPTIONS bit 1 makes AUTO
        take off without it).
        """
        mission = self._mission
        if not mission.items:
            return self._refuse("mission start", "no mission loaded")
        if not self._armed:
            return self._refuse("mission start", "not armed")
        if not self._flying:
            problem = self._ground_start_problem()
            if problem:
                return self._refuse("mission start", problem)
        if mission.complete:
            mission.reset_progress()
        if self._mode != Mode.AUTO:
            result = self.set_mode(Mode.AUTO)
            if not result.accepted:
                return result
        if not mission.active:
            self._resume_mission(self._now())
        return self._ok()

    def set_current_item(self, seq: int) -> CommandResult:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT: continue from ``seq``.

        ``seq`` 0 (home) means item 1. In AUTO in flight the vehicle heads there at once.
        """
        mission = self._mission
        if not mission.items:
            return self._refuse("set current", "no mission loaded")
        if isinstance(seq, bool) or not isinstance(seq, (int, np.integer)):
            return self._refuse("set current", f"seq {seq!r} is not an integer")
        seq = int(seq) or 1
        if not 1 <= seq <= len(mission.items):
            return self._refuse("set current", f"seq {seq} outside 1..{len(mission.items)}")
        mission.complete = False
        mission.current_index = seq - 1
        self._event("mission", f"current item set to {seq}", seq=seq)
        if mission.active and self._flying and self._mode == Mode.AUTO:
            self._start_item(mission.current_index, self._now())
        return self._ok()
