"""The navigator: the flight-mode state machine of an ArduCopter-style vehicle.

The navigator decides *what* the vehicle should do: it owns the flight mode
(:mod:`fcu.navigation.modes`), the armed and landed states (:mod:`fcu.navigation.arming`,
:mod:`fcu.navigation.landing`), the mission and its progress (:mod:`fcu.navigation.mission`),
and turns them into a guidance :class:`~fcu.navigation.guidance.Reference` for the position
and yaw controllers by flying one leg at a time (:mod:`fcu.navigation.legs`). It knows
nothing of MAVLink (the endpoint converts messages to the calls below and builds
COMMAND_ACK, STATUSTEXT, MISSION_CURRENT and MISSION_ITEM_REACHED from the results and
events) nor of the controllers (a ``None`` reference means "motors idle or stopped").

Usage, once per autopilot tick::

    out = nav.step(time_s, est_pos_ned, est_vel_ned, est_yaw_rad, estimator_healthy=ok)
    # out.reference -> position controller; out.events -> STATUSTEXT / mission messages

and commands between ticks (each returns a :class:`CommandResult`)::

    nav.set_mode(Mode.GUIDED); nav.arm(); nav.takeoff(0.6); nav.go_to((1, 0, -0.6))
    nav.load_mission(thesis_mission()); nav.start_mission()
    nav.set_sticks(Sticks(roll, pitch, throttle, yaw))  # flies STABILIZE ... POSHOLD

Commands take effect at the time of the latest ``step`` (simulated time is only known from
``step``); a trajectory they start begins at that time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from fcu.navigation.arming import PrearmCheck
from fcu.navigation.arming_commands import ArmingCommands
from fcu.navigation.events import CommandResult, NavEvent
from fcu.navigation.fence import FenceAreas
from fcu.navigation.guidance import Reference
from fcu.navigation.guided_commands import GuidedCommands
from fcu.navigation.landing import LandedState
from fcu.navigation.legs import Leg, hold_leg
from fcu.navigation.mission import MissionProgress, MissionState
from fcu.navigation.mission_commands import MissionCommands
from fcu.navigation.modes import ARDUCOPTER_MODE_NAMES, MODE_TABLE, Mode, mode_name
from fcu.navigation.settings import TIME_TOL_S, NavigatorConfig

_new_object = object.__new__

# the navigator's public face: the types its methods take and return
__all__ = [
    "ARDUCOPTER_MODE_NAMES",
    "CommandResult",
    "LandedState",
    "MissionProgress",
    "MissionState",
    "Mode",
    "NavEvent",
    "NavOutput",
    "Navigator",
    "NavigatorConfig",
    "PrearmCheck",
    "mode_name",
]


@dataclass(frozen=True, eq=False)
class NavOutput:
    """Result of one navigator step.

    Attributes
    ----------
    reference : Reference or None
        What the controllers track; None = motors idle (armed on the ground) or stopped.
    armed : bool
    mode : Mode
    landed : bool
        True when not flying (on the ground, or disarmed).
    landed_state : LandedState
        ON_GROUND, TAKEOFF, IN_AIR or LANDING (EXTENDED_SYS_STATE).
    failsafe : bool
        True while any failsafe source is active.
    events : tuple of NavEvent
        Everything that happened since the previous step, commands included.
    """

    reference: Reference | None
    armed: bool
    mode: Mode
    landed: bool
    landed_state: LandedState
    failsafe: bool
    events: tuple[NavEvent, ...]


class _Cruise(NamedTuple):
    """A leg on the way along a moving guidance segment, before its arrival.

    Until ``until_s`` (s), a tick with a position fix and no event (every command that
    changes the state leaves one) changes nothing but the reference: the legs layer has
    nothing to run before the arrival (:meth:`FlightLegs._run_flight`'s first test), the
    output's other fields stay those of ``fields``, and the reference is ``evaluate(t)``,
    what :meth:`Navigator._reference` returns then (:meth:`Trajectory.moving_span`).
    """

    leg: Leg
    until_s: float  # s
    evaluate: Callable[[float], Reference]
    fields: dict[str, object]  # the output's fields, reference included (replaced)


class Navigator(ArmingCommands, GuidedCommands, MissionCommands):
    """Flight-mode state machine, arming, take-off/landing and mission execution.

    The step and the position-fix watch live here; the layers below arm and disarm
    (:class:`~fcu.navigation.arming_commands.ArmingCommands`), take the guided and the
    mission commands (:class:`~fcu.navigation.guided_commands.GuidedCommands`,
    :class:`~fcu.navigation.mission_commands.MissionCommands`), change modes and enter
    failsafes (:class:`~fcu.navigation.mode_changes.ModeChanges`), follow a lead
    (:class:`~fcu.navigation.follow_mode.FollowLegs`), fly GUIDED's velocity and attitude
    set-points (:class:`~fcu.navigation.guided_setpoints.GuidedSetpoints`) and the sticks
    (:class:`~fcu.navigation.pilot_modes.PilotModes`), watch the geofence
    (:class:`~fcu.navigation.fence_watch.FenceWatch`), fly the mission
    (:class:`~fcu.navigation.mission.MissionExecution`) and the legs
    (:class:`~fcu.navigation.flight.FlightLegs`).

    Parameters
    ----------
    config : NavigatorConfig, optional
        Settings; defaults suit the thesis's small indoor quadrotor.

    Notes
    -----
    ``reset()`` returns to the boot state (disarmed, ``initial_mode``, home and speeds from
    the configuration, no failsafe) but keeps the loaded mission, as an autopilot keeps it
    in storage across a reboot; its progress restarts.
    """

    def __init__(self, config: NavigatorConfig | None = None) -> None:
        super().__init__(config if config is not None else NavigatorConfig())
        self._fence_areas = FenceAreas()  # the uploaded fence, kept across a reset
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Boot state: disarmed on the ground in ``initial_mode``; mission kept, not started."""
        self._reset_flight()
        self._mode = Mode(self.config.initial_mode)
        self._armed = False
        self._failsafes: dict[str, str] = {}
        self._blockers: dict[str, str | Callable[[], str]] = {}
        self._position_fix = True
        self._fix_lost_s: float | None = None
        self._output: NavOutput | None = None  # the latest step's, while it had no events
        self._cruise: _Cruise | None = None
        self._fence_breach: str | None = None  # the breach the fence acted on, until back
        self._mission.reset_progress()

    @property
    def mode(self) -> Mode:
        """Current flight mode."""
        return self._mode

    @property
    def armed(self) -> bool:
        """True while armed."""
        return self._armed

    @property
    def failsafe_sources(self) -> tuple[str, ...]:
        """Active failsafe sources, in the order they were triggered."""
        return tuple(self._failsafes)

    # ------------------------------------------------------------------ step
    def step(self, time_s: float, estimate_pos_ned: np.ndarray, estimate_vel_ned: np.ndarray,
             estimate_yaw_rad: float, *, estimator_healthy: bool = True,
             on_ground_hint: bool | None = None, position_fix: bool = True) -> NavOutput:
        """Advance to ``time_s`` with the latest state estimate.

        Parameters
        ----------
        time_s : float
            Simulated time, s; never decreases.
        estimate_pos_ned, estimate_vel_ned : numpy.ndarray, shape (3,)
            Estimated position (m) and velocity (m/s), NED. Non-finite values are ignored
            (the previous estimate is kept) and count as an unhealthy estimator.
        estimate_yaw_rad : float
            Estimated yaw, rad.
        estimator_healthy : bool
            The caller's verdict on the estimator (pre-arm check, position modes).
        on_ground_hint : bool or None
            Optional extra evidence from the caller (e.g. thrust at its minimum, contact
            switch). When given, landing is only detected while it is True and arming only
            allowed while it is True; None leaves the decision to the estimate.
        position_fix : bool
            Position measurements are trusted. Without a fix the vehicle holds attitude and
            height (the horizontal references follow the estimate: no horizontal feedback),
            lands after ``position_timeout_s``, and refuses position modes and arming.

        Returns
        -------
        NavOutput
        """
        t = self._take_estimate(time_s, estimate_pos_ned, estimate_vel_ned, estimate_yaw_rad,
                                estimator_healthy, on_ground_hint)
        if position_fix is not self._position_fix or not position_fix:
            self._watch_position_fix(t, position_fix)
        if self.config.fence.enable and self._armed and self._flying:
            self._watch_fence(t)
        cruise = self._cruise
        if cruise is not None and t < cruise.until_s and cruise.leg is self._leg and \
                not self._events and self._position_fix and self._armed and self._flying:
            # the common tick in flight (see _Cruise): only the reference moves
            out = _new_object(NavOutput)  # NavOutput(...) without its frozen __setattr__s
            fields = out.__dict__
            fields.update(cruise.fields)
            fields["reference"] = cruise.evaluate(t)
            self._output = out
            return out
        if self._armed and self._flying:
            self._run_flight(t, len(self._mission.items) + 8)
        elif self._armed:
            self._run_ground(t)
        reference = self._reference(t) if self._armed and self._flying else None
        landed_state = self.landed_state
        last = self._output
        if self._events:
            events = tuple(self._events)
            self._events.clear()
        elif (last is not None and last.reference is reference and last.armed is self._armed
              and last.mode is self._mode and last.landed_state is landed_state
              and last.failsafe is bool(self._failsafes)):
            return last  # nothing happened and the reference is the same object: reuse
        else:
            events = ()
        out = object.__new__(NavOutput)  # NavOutput(...) without its frozen __setattr__s
        object.__setattr__(out, "__dict__", {
            "reference": reference, "armed": self._armed, "mode": self._mode,
            "landed": not self._flying, "landed_state": landed_state,
            "failsafe": bool(self._failsafes), "events": events})
        self._output = out if not events else None
        self._cruise = self._cruise_from(t, out) if reference is not None and not events \
            else None
        return out

    def hold_at(self, time_s: float, pos_ned: np.ndarray) -> None:
        """In a hold mode (BRAKE, LOITER, GUIDED without a target), hold ``pos_ned`` (m,
        NED) from ``time_s`` instead of the stopping point the mode chose: a vehicle that
        cannot brake as the limits assume (relaxed hover after a rotor loss) goes back to
        where it was. Does nothing in other modes."""
        if MODE_TABLE[self._mode].behaviour != "hold" or not self._flying:
            return
        _, yaw = self._plan_start(time_s)
        self._leg = hold_leg(time_s, np.array(pos_ned, dtype=float), yaw)

    def _cruise_from(self, t: float, out: NavOutput) -> _Cruise | None:
        """What the ticks after ``t`` (s) may skip while nothing happens (:class:`_Cruise`),
        or None when they may not: the leg is on the way along a moving segment, before
        its arrival, with a position fix."""
        leg = self._leg
        if leg is None or leg.trajectory is None or leg.kind in ("manual", "land") or \
                leg.reached_s is not None or not self._position_fix:
            return None
        moving = leg.trajectory.moving_span(t)
        if moving is None:
            return None
        inside, until_s = moving
        return _Cruise(leg, min(until_s, leg.arrival_s - TIME_TOL_S), inside,
                       dict(out.__dict__))

    def _mission_running(self) -> bool:
        return self._mode == Mode.AUTO

    def _watch_position_fix(self, t: float, fix: bool) -> None:
        """Position fix lost: hold attitude and height, land after the timeout; regained
        before it: carry on (the mode's references resume)."""
        if fix and not self._position_fix:
            self._position_fix = True
            self._fix_lost_s = None
            self._event("failsafe", "position fix recovered", "notice")
            if "position" in self._failsafes:
                self.clear_failsafe("position")
        elif not fix and self._position_fix:
            self._position_fix = False
            self._fix_lost_s = t
            if self._armed and self._flying:
                self._event("failsafe", "position fix lost: holding attitude and height, "
                            f"landing in {self.config.position_timeout_s:g} s", "critical")
        if not fix and self._armed and self._flying and self._fix_lost_s is not None and \
                "position" not in self._failsafes and \
                t - self._fix_lost_s >= self.config.position_timeout_s - TIME_TOL_S:
            self.trigger_failsafe("position", "land")

    def _reference(self, time_s: float) -> Reference:
        leg = self._leg
        if leg is not None and leg.trajectory is not None and leg.kind != "manual":
            ref = leg.trajectory.evaluate(time_s)  # Leg.reference() of a trajectory leg
        else:
            ref = super()._reference(time_s)
        if self._position_fix:
            return ref
        # no position fix: the horizontal references follow the estimate (no horizontal
        # feedback: the attitude holds the trim the position loop's integrator last found)
        est_p, est_v = self._est_pos_ned, self._est_vel_ned
        return Reference(pos_ned=np.array([est_p[0], est_p[1], ref.pos_ned[2]]),
                         vel_ned=np.array([est_v[0], est_v[1], ref.vel_ned[2]]),
                         acc_ned=np.array([0.0, 0.0, ref.acc_ned[2]]), yaw_rad=ref.yaw_rad,
                         yaw_rate_rad_s=ref.yaw_rate_rad_s)
