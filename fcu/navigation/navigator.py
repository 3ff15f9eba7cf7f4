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

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from fcu.navigation.arming import PrearmCheck, auto_disarm_reason, prearm_check
from fcu.navigation.events import CommandResult, NavEvent, Severity
from fcu.navigation.fence import FenceAreas, target_problem
from fcu.navigation.fence_watch import FenceWatch
from fcu.navigation.follow_mode import FollowLegs
from fcu.navigation.guidance import Reference, wrap_pi
from fcu.navigation.guided_setpoints import GuidedSetpoints
from fcu.navigation.landing import LandedState
from fcu.navigation.legs import Leg
from fcu.navigation.mission import (
    MissionExecution,
    MissionProgress,
    MissionState,
    upload_problem,
)
from fcu.navigation.modes import (
    ARDUCOPTER_MODE_NAMES,
    MODE_TABLE,
    SUPPORTED_MODE_NUMBERS,
    Mode,
    mode_name,
)
from fcu.navigation.settings import AUTO_TAKEOFF_WITHOUT_START, TIME_TOL_S, NavigatorConfig
from flightdata.config import finite
from flightdata.mission import MissionItem

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


class Navigator(FollowLegs, GuidedSetpoints, FenceWatch, MissionExecution):
    """Flight-mode state machine, arming, take-off/landing and mission execution.

    The mode state machine and the commands live here; the layers below follow a lead
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

    # ------------------------------------------------------------------ commands
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

    def takeoff(self, alt_m: float) -> CommandResult:
        """NAV_TAKEOFF in GUIDED: climb vertically to ``alt_m`` (m above home), then hold."""
        cfg = self.config
        if not finite(alt_m) or not cfg.land_detect_alt_m < alt_m:
            return self._refuse("take-off", f"altitude {alt_m!r} m not above "
                                f"{cfg.land_detect_alt_m} m")
        home = self._home_pos_ned
        problem = target_problem((home[0], home[1], home[2] - alt_m), home, cfg.fence)
        if problem is not None:
            return self._refuse("take-off", problem)
        if self._mode != Mode.GUIDED:
            return self._refuse("take-off", f"needs GUIDED (mode is {self._mode.name})")
        if not self._armed:
            return self._refuse("take-off", "not armed")
        if self._flying:
            return self._refuse("take-off", "already flying")
        self._start_takeoff(self._now(), float(alt_m), None)
        return self._ok()

    def _check_target(self, what: str, pos_ned: Sequence[float] | np.ndarray
                      ) -> np.ndarray | CommandResult:
        target = np.asarray(pos_ned, dtype=float).reshape(-1)
        if target.shape != (3,) or not np.all(np.isfinite(target)):
            return self._refuse(what, f"target {pos_ned!r} is not three finite numbers")
        if -target[2] < 0.0:
            return self._refuse(what, f"target altitude {-target[2]:.2f} m outside the air "
                                "(below home)")
        problem = target_problem(target, self._home_pos_ned, self.config.fence)
        if problem is not None:
            return self._refuse(what, f"target {problem}")
        return target

    def go_to(self, pos_ned: Sequence[float] | np.ndarray, yaw_rad: float | None = None
              ) -> CommandResult:
        """Fly to ``pos_ned`` (m, NED) along a cubic (SET_POSITION_TARGET_LOCAL_NED).

        Needs GUIDED and armed; on the ground it takes off along the leg
        (:mod:`fcu.navigation.guided_setpoints`). ``yaw_rad`` (rad) None keeps the current
        yaw. A new
        target replans from the current reference point, at rest (the velocity reference
        steps to zero); repeating the current target (a GCS streaming its setpoint) changes
        nothing.
        """
        target = self._check_target("go-to", pos_ned)
        if isinstance(target, CommandResult):
            return target
        if yaw_rad is not None and not finite(yaw_rad):
            return self._refuse("go-to", f"yaw {yaw_rad!r} is not finite")
        if self._mode != Mode.GUIDED:
            return self._refuse("go-to", f"needs GUIDED (mode is {self._mode.name})")
        if not self._armed:
            return self._refuse("go-to", "not armed")
        t = self._now()
        if not self._flying:  # a position set-point from the ground takes off (as PX4's)
            return self._goto_from_ground(t, target, yaw_rad)
        leg = self._leg
        if leg is not None and leg.kind in ("move", "takeoff") and leg.item_index is None and \
                leg.target_pos_ned is not None and leg.trajectory is not None and \
                float(np.max(np.abs(leg.target_pos_ned - target))) < 1e-6 and (
                    yaw_rad is None or abs(wrap_pi(
                        yaw_rad - leg.trajectory.evaluate(math.inf).yaw_rad)) < 1e-6):
            return self._ok("already going there")
        self._leg = self._move_leg("move", t, target, yaw_rad)
        self._event("mission", "going to ({:.2f}, {:.2f}, {:.2f})".format(*target))
        return self._ok()

    def reposition(self, pos_ned: Sequence[float] | np.ndarray, yaw_rad: float | None = None
                   ) -> CommandResult:
        """DO_REPOSITION: switch to GUIDED if needed, then :meth:`go_to`."""
        target = self._check_target("reposition", pos_ned)
        if isinstance(target, CommandResult):
            return target
        if not (self._armed and self._flying):
            return self._refuse("reposition", "not flying")
        if self._mode != Mode.GUIDED:
            result = self.set_mode(Mode.GUIDED)
            if not result.accepted:
                return result
        return self.go_to(target, yaw_rad)

    def orbit(self, centre_ned: Sequence[float] | np.ndarray | None, radius_m: float | None,
              speed_m_s: float | None) -> CommandResult:
        """DO_ORBIT: circle ``centre_ned`` (m, NED; None = the current position, at the
        current altitude) at ``radius_m`` (None: CIRCLE_RADIUS) and ``speed_m_s`` along the
        circle (> 0 clockwise seen from above; None: CIRCLE_RATE), in CIRCLE mode."""
        cfg = self.config
        if not (self._armed and self._flying):
            return self._refuse("orbit", "not flying")
        radius = cfg.circle_radius_m if radius_m is None else float(radius_m)
        if not finite(radius) or radius < 0.0:
            return self._refuse("orbit", f"radius {radius_m!r} m is not >= 0")
        if speed_m_s is None:
            rate = math.radians(cfg.circle_rate_deg_s)
        elif not finite(speed_m_s) or abs(speed_m_s) > cfg.max_speed_m_s:
            return self._refuse("orbit", f"speed {speed_m_s!r} m/s outside "
                                f"[-{cfg.max_speed_m_s}, {cfg.max_speed_m_s}] m/s")
        else:
            rate = float(speed_m_s) / radius if radius > 0.0 else 0.0
        start, _ = self._plan_start(self._now())
        checked = self._check_target(
            "orbit", start.copy() if centre_ned is None else np.asarray(centre_ned, dtype=float))
        if isinstance(checked, CommandResult):
            return checked
        centre = checked
        for point in ((centre[0] + radius, centre[1], centre[2]),
                      (centre[0], centre[1] + radius, centre[2]),
                      (centre[0] - radius, centre[1], centre[2]),
                      (centre[0], centre[1] - radius, centre[2])):
            problem = target_problem(point, self._home_pos_ned, cfg.fence)
            if problem is not None:
                return self._refuse("orbit", f"circle {problem}")
        if self._mode != Mode.CIRCLE:
            self._mode, old = Mode.CIRCLE, self._mode
            self._event("mode", f"mode {old.name} -> CIRCLE (orbit)")
            if old == Mode.AUTO:
                self._mission.active = False
        self._orbit(self._now(), centre, radius, rate)
        return self._ok()

    def change_speed(self, speed_m_s: float, speed_type: str = "ground") -> CommandResult:
        """DO_CHANGE_SPEED: set the ground, climb or descent speed of later legs (m/s)."""
        if speed_type not in ("ground", "climb", "descent"):
            return self._refuse("speed change", f"speed type {speed_type!r} is not ground, "
                                "climb or descent")
        if not finite(speed_m_s) or not 0.0 < speed_m_s <= self.config.max_speed_m_s:
            return self._refuse("speed change", f"speed {speed_m_s!r} m/s outside "
                                f"(0, {self.config.max_speed_m_s}] m/s")
        self._apply_speed(float(speed_m_s), speed_type)
        return self._ok()

    def set_home(self, pos_ned: Sequence[float] | np.ndarray) -> CommandResult:
        """DO_SET_HOME in local NED (m); RTL returns above it."""
        home = np.asarray(pos_ned, dtype=float).reshape(-1)
        if home.shape != (3,) or not np.all(np.isfinite(home)):
            return self._refuse("set home", f"position {pos_ned!r} is not three finite numbers")
        self._home_pos_ned = home.copy()
        self._event("home", "home set to ({:.2f}, {:.2f}, {:.2f})".format(*home))
        return self._ok()

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

