"""Missions: what an upload may hold, the progress of a run, and its execution.

A mission is a sequence of :class:`~flightdata.mission.MissionItem` in local NED (the MAVLink
layer converts latitude/longitude). As in ArduPilot, seq 0 is home: ``items[k]`` has seq
``k + 1`` and :meth:`MissionRun.progress` reports ``total = len(items) + 1``.
:class:`MissionExecution` flies it in AUTO: a NAV item is reached when the
reference has arrived and the estimate is within ``wp_radius_m`` of the target (a take-off
at its altitude, a landing when landed); the next item starts ``hold_s`` after the reference
arrived, so a vehicle that tracks well flies the planned timeline exactly and a vehicle that
lags is waited for. DO_CHANGE_SPEED items execute (and are reached) at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from fcu.navigation.fence import Vec3, target_problem
from fcu.navigation.flight import FlightLegs
from fcu.navigation.legs import hold_leg
from fcu.navigation.settings import NavigatorConfig
from flightdata.mission import MissionItem


class MissionState(IntEnum):
    """MISSION_STATE values (MISSION_CURRENT.mission_state)."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


@dataclass(frozen=True)
class ItemReached:
    """Mission item ``seq`` reached at ``time_s`` (s, step time)."""

    seq: int
    time_s: float


@dataclass(frozen=True)
class MissionProgress:
    """What MISSION_CURRENT and MISSION_ITEM_REACHED need.

    Attributes
    ----------
    total : int
        Number of seqs including home (``len(items) + 1``; 0 without a mission).
    current_seq : int
        Current item (1..total-1; 0 without a mission).
    state : MissionState
        NO_MISSION, NOT_STARTED, ACTIVE, PAUSED or COMPLETE.
    reached : tuple of ItemReached
        Items reached in this run of the mission, in order.
    """

    total: int
    current_seq: int
    state: MissionState
    reached: tuple[ItemReached, ...]


def upload_problem(items: Sequence[MissionItem], config: NavigatorConfig,
                   home_ned: Vec3 = (0.0, 0.0, 0.0)) -> str | None:
    """Why ``items`` (seq 1..n) cannot be loaded, or None: each must be a MissionItem with
    targets not below ground and, with the fence enabled, inside it (about ``home_ned``,
    m NED); speeds above ``max_speed_m_s`` are flown at that speed (as ArduCopter limits
    them to what it can fly)."""
    for k, item in enumerate(items):
        seq = k + 1
        if not isinstance(item, MissionItem):
            return f"item {seq} is not a MissionItem"
        if item.pos_ned is not None:
            if -item.pos_ned[2] < 0.0:
                return f"item {seq}: altitude {-item.pos_ned[2]:.2f} m below ground"
            problem = target_problem(item.pos_ned, home_ned, config.fence)
            if problem is not None:
                return f"item {seq}: {problem}"
        if item.command == "takeoff":
            problem = target_problem((home_ned[0], home_ned[1], home_ned[2] - item.alt_m),
                                     home_ned, config.fence)
            if problem is not None:
                return f"item {seq}: take-off {problem}"
    return None


class MissionRun:
    """The loaded mission and the progress of its current run.

    Attributes
    ----------
    items : tuple of MissionItem
        Loaded items; ``items[k]`` is seq ``k + 1``.
    current_index : int
        Index of the current item (seq - 1).
    started : bool
        The run was started (AUTO entered with this mission) at least once.
    active : bool
        The run is being flown (AUTO, not interrupted by another mode).
    complete : bool
        The run went past its last item.
    reached : list of ItemReached
        Items reached in this run, in order.
    """

    def __init__(self) -> None:
        self.items: tuple[MissionItem, ...] = ()
        self.reset_progress()

    def reset_progress(self) -> None:
        """Back to item 1, not started; the items stay."""
        self.current_index = 0
        self.started = False
        self.active = False
        self.complete = False
        self.reached: list[ItemReached] = []

    def load(self, items: Sequence[MissionItem]) -> None:
        """Replace the items (checked with :func:`upload_problem` first) and the progress."""
        self.items = tuple(items)
        self.reset_progress()

    def record_reached(self, index: int, time_s: float) -> str:
        """Record item ``index`` reached at ``time_s`` (s); returns the event text."""
        seq = index + 1
        self.reached.append(ItemReached(seq, time_s))
        return f"reached item {seq}: {self.items[index].describe()}"

    def first_nav_index(self, index: int) -> int | None:
        """The first NAV item at or after ``index``, or None."""
        for i in range(index, len(self.items)):
            if self.items[i].is_nav:
                return i
        return None

    def progress(self, in_auto: bool) -> MissionProgress:
        """Current seq, total, state and items reached; ``in_auto``: the vehicle is in AUTO."""
        if not self.items:
            return MissionProgress(0, 0, MissionState.NO_MISSION, ())
        if self.complete:
            state = MissionState.COMPLETE
        elif self.active and in_auto:
            state = MissionState.ACTIVE
        elif self.started:
            state = MissionState.PAUSED
        else:
            state = MissionState.NOT_STARTED
        return MissionProgress(len(self.items) + 1, self.current_index + 1, state,
                               tuple(self.reached))


class MissionExecution(FlightLegs):
    """Mission execution on top of the legs layer: items become legs, one after the other.

    DO items execute (and are reached) at once; a NAV item starts its leg (take-off,
    waypoint, an approach then a landing, or a return to launch); when its leg is done
    (:class:`~fcu.navigation.flight.FlightLegs`) the next item starts while
    :meth:`_mission_running` (the subclass's: the vehicle is in AUTO).

    Parameters
    ----------
    config : NavigatorConfig
        Settings.
    """

    def __init__(self, config: NavigatorConfig) -> None:
        self._mission = MissionRun()
        super().__init__(config)

    def _item_reached(self, index: int, t: float) -> None:
        self._event("item_reached", self._mission.record_reached(index, t), seq=index + 1)

    def _next_item(self, index: int, t: float) -> None:
        self._start_item(index + 1, t)

    def _start_item(self, index: int, t0: float) -> None:
        """Execute items from ``index``: DO items at once, then start the next NAV item."""
        now = self._now()
        mission = self._mission
        while index < len(mission.items):
            item = mission.items[index]
            mission.current_index = index
            if item.command == "change_speed":  # as ArduCopter, at most what it flies
                self._apply_speed(min(item.speed_m_s, self.config.max_speed_m_s),
                                  item.speed_type)
                self._item_reached(index, now)
                index += 1
                continue
            if not self._flying and item.command != "takeoff":
                self._event("mission", f"mission ended: item {index + 1} "
                            f"({item.describe()}) needs the vehicle in the air", "warning")
                self._complete_mission(now)
                return
            if item.command == "takeoff":
                self._start_takeoff(t0, item.alt_m, index)
            elif item.command == "waypoint":
                start, _ = self._plan_start(t0)
                target = start if item.pos_ned is None else np.array(item.pos_ned)
                self._leg = self._move_leg("move", t0, target, item.yaw_rad, item.hold_s, index)
            elif item.command == "land":
                start, _ = self._plan_start(t0)
                if item.pos_ned is not None and math.hypot(
                        item.pos_ned[0] - start[0], item.pos_ned[1] - start[1]) > \
                        self.config.wp_radius_m:
                    target = np.array([item.pos_ned[0], item.pos_ned[1], start[2]])
                    self._leg = self._move_leg("approach", t0, target, None, 0.0, index)
                else:
                    self._start_land(t0, index)
            else:  # rtl
                self._start_rtl(t0, index)
            return
        self._complete_mission(now)

    def _complete_mission(self, t: float) -> None:
        """Past the last item (or stopped early): hold where the reference is."""
        self._mission.complete = True
        self._mission.active = False
        self._event("mission_complete", "mission complete")
        if self._flying:
            start, yaw = self._plan_start(t)
            self._leg = hold_leg(t, start, yaw)

    def _resume_mission(self, t: float) -> None:
        """Run the mission from its current item (from item 1 once complete)."""
        mission = self._mission
        if mission.complete:
            mission.reset_progress()
        mission.started = True
        mission.active = True
        self._event("mission", f"mission running from item {mission.current_index + 1}",
                    seq=mission.current_index + 1)
        self._start_item(mission.current_index, t)

    def _ground_start_problem(self) -> str:
        """Why the mission cannot start from the ground now ("" when it can): as ArduCopter
        ("Auto: Missing Takeoff Cmd"), the next NAV item must be a take-off."""
        mission = self._mission
        if not mission.items:
            return "no mission loaded"
        index = 0 if mission.complete else mission.current_index
        nav = mission.first_nav_index(index)
        if nav is not None and mission.items[nav].command == "takeoff":
            return ""
        what = "none" if nav is None else f"item {nav + 1} is {mission.items[nav].describe()}"
        return f"on the ground the next NAV item must be NAV_TAKEOFF ({what})"

    def mission_progress(self) -> MissionProgress:
        """Current seq, total, state and items reached (for MISSION_CURRENT/ITEM_REACHED)."""
        return self._mission.progress(self._mission_running())

    @property
    def mission_items(self) -> tuple[MissionItem, ...]:
        """Loaded mission items; ``mission_items[k]`` is seq ``k + 1``."""
        return self._mission.items
