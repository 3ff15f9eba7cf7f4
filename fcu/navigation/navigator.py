"""Flight modes, arming and missions of an ArduCopter-style vehicle.

The navigator decides *what* the vehicle should do: it owns the flight mode, the armed and
landed states, the mission and its progress, and turns them into a guidance
:class:`~fcu.navigation.guidance.Reference` for the position and yaw controllers. It knows
nothing of
MAVLink (the endpoint converts messages to the calls below and builds COMMAND_ACK,
STATUSTEXT, MISSION_CURRENT and MISSION_ITEM_REACHED from the results and events) nor of the
controllers (a ``None`` reference means "motors idle or stopped").

Usage, once per autopilot tick::

    out = nav.step(time_s, est_pos_ned, est_vel_ned, est_yaw_rad, estimator_healthy=ok)
    # out.reference -> position controller; out.events -> STATUSTEXT / mission messages

and commands between ticks (each returns a :class:`CommandResult`)::

    nav.set_mode(Mode.GUIDED); nav.arm(); nav.takeoff(0.6); nav.go_to((1, 0, -0.6))
    nav.load_mission(thesis_mission()); nav.start_mission()

Commands take effect at the time of the latest ``step`` (simulated time is only known from
``step``); a trajectory they start begins at that time.

Modes (ArduCopter numbers, :class:`Mode`)
-----------------------------------------
=========  ==  ==========================================================================
STABILIZE   0  no pilot sticks exist here: hold the altitude captured on entry, leave the
               horizontal position free (reference = estimate), i.e. level attitude
ALT_HOLD    2  same as STABILIZE (there is no throttle stick either)
AUTO        3  fly the mission (items below); holds the last point once complete
GUIDED      4  take-off command, go-to (SET_POSITION_TARGET_LOCAL_NED, DO_REPOSITION)
LOITER      5  hold the stopping point (estimate + v|v| / 2a)
RTL         6  climb to ``rtl_alt_m`` if lower, fly home, hold ``rtl_hold_s``, land
LAND        9  descend along a cubic to the ground, then creep down until landed
BRAKE      17  as LOITER
=========  ==  ==========================================================================

Other ArduCopter modes are refused with a reason. Position modes (all but STABILIZE,
ALT_HOLD, LAND) are refused while the caller reports the estimator unhealthy.

Landing detection (only while landing): altitude below ``land_detect_alt_m``, vertical speed
below ``land_detect_speed_m_s``, and ``on_ground_hint`` not False, continuously for
``land_detect_time_s``. Auto-disarm follows ``landed_disarm_delay_s`` after landing (or
after arming in LAND/RTL on the ground), and ``idle_disarm_delay_s`` after arming without a
take-off (0 disables it).

Missions
--------
A mission is a sequence of :class:`MissionItem` in local NED (the MAVLink layer converts
latitude/longitude). As in ArduPilot, seq 0 is home: ``items[k]`` has seq ``k + 1`` and
:meth:`Navigator.mission_progress` reports ``total = len(items) + 1``. A NAV item is reached
when the reference has arrived and the estimate is within ``wp_radius_m`` of the target (a
take-off at its altitude, a landing when landed); the next item starts ``hold_s`` after the
reference arrived, so a vehicle that tracks well flies the planned timeline exactly and a
vehicle that lags is waited for. DO_CHANGE_SPEED items execute (and are reached) at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import IntEnum
from typing import Literal

import numpy as np

from fcu.navigation.guidance import (
    Reference,
    SpeedLimits,
    Trajectory,
    Waypoint,
    hold_trajectory,
    landing_trajectory,
    takeoff_trajectory,
    wrap_pi,
)
from flightdata.config import finite, require
from flightdata.mission import MissionItem

_TIME_TOL_S = 1e-6  # s, slack when comparing step times with planned times (float sums)


class Mode(IntEnum):
    """Supported flight modes, numbered as ArduCopter's custom_mode."""

    STABILIZE = 0
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    LAND = 9
    BRAKE = 17


#: All ArduCopter mode numbers and names (pymavlink ``mode_mapping_acm``), for messages.
ARDUCOPTER_MODE_NAMES: dict[int, str] = {
    0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL",
    7: "CIRCLE", 8: "POSITION", 9: "LAND", 10: "OF_LOITER", 11: "DRIFT", 13: "SPORT",
    14: "FLIP", 15: "AUTOTUNE", 16: "POSHOLD", 17: "BRAKE", 18: "THROW", 19: "AVOID_ADSB",
    20: "GUIDED_NOGPS", 21: "SMART_RTL", 22: "FLOWHOLD", 23: "FOLLOW", 24: "ZIGZAG",
    25: "SYSTEMID", 26: "AUTOROTATE", 27: "AUTO_RTL", 28: "TURTLE", 29: "RATE_ACRO",
}

_POSITION_MODES = frozenset({Mode.AUTO, Mode.GUIDED, Mode.LOITER, Mode.RTL, Mode.BRAKE})


def mode_name(number: int) -> str:
    """ArduCopter name of mode ``number`` (``"MODE_<n>"`` when unknown)."""
    return ARDUCOPTER_MODE_NAMES.get(int(number), f"MODE_{int(number)}")


class LandedState(IntEnum):
    """MAV_LANDED_STATE values (EXTENDED_SYS_STATE.landed_state)."""

    UNDEFINED = 0
    ON_GROUND = 1
    IN_AIR = 2
    TAKEOFF = 3
    LANDING = 4


class MissionState(IntEnum):
    """MISSION_STATE values (MISSION_CURRENT.mission_state)."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


@dataclass(frozen=True)
class CommandResult:
    """Outcome of a command: ACCEPTED or DENIED, with a reason for STATUSTEXT."""

    accepted: bool
    reason: str = ""


Severity = Literal["info", "notice", "warning", "critical"]


@dataclass(frozen=True)
class NavEvent:
    """A human-readable record of something the navigator did or refused.

    Attributes
    ----------
    time_s : float
        Simulated time, s (a command's event carries the latest step time).
    kind : str
        ``mode``, ``arm``, ``disarm``, ``takeoff``, ``takeoff_complete``, ``target_reached``,
        ``mission``, ``item_reached``, ``mission_complete``, ``landing``, ``landed``,
        ``speed``, ``home``, ``failsafe`` or ``refused``.
    text : str
        Message suitable for STATUSTEXT (at most ~50 characters is not guaranteed).
    severity : {"info", "notice", "warning", "critical"}
        MAV_SEVERITY to use.
    seq : int or None
        Mission seq for ``item_reached`` (and ``mission``) events.
    """

    time_s: float
    kind: str
    text: str
    severity: Severity = "info"
    seq: int | None = None

    def __str__(self) -> str:
        return f"[{self.time_s:8.2f} s] {self.text}"


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


@dataclass(frozen=True, kw_only=True)
class NavigatorConfig:
    """Navigator settings (ArduPilot parameter in brackets where one exists)."""

    initial_mode: int = 0  # ArduCopter mode number at boot (supported, see Mode)
    speed_horizontal_m_s: float = 0.5  # m/s, peak horizontal leg speed [WPNAV_SPEED]
    speed_up_m_s: float = 0.3  # m/s, peak climb speed [WPNAV_SPEED_UP]
    speed_down_m_s: float = 0.2  # m/s, peak descent speed, also landing [WPNAV_SPEED_DN]
    accel_m_s2: float = 0.5  # m/s^2, peak leg acceleration 6 d / T^2 [WPNAV_ACCEL]
    yaw_rate_rad_s: float = 0.5  # rad/s, peak yaw rate along a leg
    min_leg_s: float = 0.5  # s, shortest leg that moves
    max_speed_m_s: float = 5.0  # m/s, largest speed DO_CHANGE_SPEED accepts
    wp_radius_m: float = 0.1  # m, distance at which a target counts as reached [WPNAV_RADIUS]
    max_alt_m: float = 10.0  # m, highest take-off / target altitude accepted
    rtl_alt_m: float = 1.0  # m, RTL return altitude [RTL_ALT]
    rtl_hold_s: float = 1.0  # s, hold above home before landing [RTL_LOIT_TIME]
    land_creep_speed_m_s: float = 0.1  # m/s, descent after the cubic reached the ground
    land_detect_alt_m: float = 0.1  # m, below this altitude the vehicle may be landed
    land_detect_speed_m_s: float = 0.05  # m/s, |vertical speed| below this when landed
    land_detect_time_s: float = 1.0  # s, both conditions held this long = landed
    landed_disarm_delay_s: float = 2.0  # s, auto-disarm after landing
    idle_disarm_delay_s: float = 10.0  # s, auto-disarm armed without take-off; 0 = never
    home_pos_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m, NED
    armable_modes: tuple[int, ...] = (0, 2, 4, 5)  # STABILIZE, ALT_HOLD, GUIDED, LOITER

    def __post_init__(self) -> None:
        supported = {int(m) for m in Mode}
        require(isinstance(self.initial_mode, int) and self.initial_mode in supported,
                "initial_mode", self.initial_mode, f"must be one of {sorted(supported)}")
        positive = ("speed_horizontal_m_s", "speed_up_m_s", "speed_down_m_s", "accel_m_s2",
                    "yaw_rate_rad_s", "max_speed_m_s", "wp_radius_m", "max_alt_m",
                    "rtl_alt_m", "land_creep_speed_m_s", "land_detect_alt_m",
                    "land_detect_speed_m_s")
        for name in positive:
            value = getattr(self, name)
            require(finite(value) and value > 0, name, value, "must be a finite number > 0")
        for name in ("min_leg_s", "rtl_hold_s", "land_detect_time_s", "landed_disarm_delay_s",
                     "idle_disarm_delay_s"):
            value = getattr(self, name)
            require(finite(value) and value >= 0, name, value,
                    "must be a finite number >= 0")
        require(len(self.home_pos_ned) == 3 and all(finite(v) for v in self.home_pos_ned),
                "home_pos_ned", self.home_pos_ned, "must be three finite numbers (m, NED)")
        require(all(m in supported for m in self.armable_modes), "armable_modes",
                self.armable_modes, f"must be mode numbers among {sorted(supported)}")
        require(self.rtl_alt_m <= self.max_alt_m, "rtl_alt_m", self.rtl_alt_m,
                f"must be <= max_alt_m ({self.max_alt_m})")

    def speed_limits(self) -> SpeedLimits:
        """The guidance limits these settings describe."""
        return SpeedLimits(horizontal_m_s=self.speed_horizontal_m_s, up_m_s=self.speed_up_m_s,
                           down_m_s=self.speed_down_m_s, accel_m_s2=self.accel_m_s2,
                           yaw_rate_rad_s=self.yaw_rate_rad_s, min_duration_s=self.min_leg_s)


_LegKind = Literal["takeoff", "move", "hold", "manual", "approach", "rtl_return", "land"]


@dataclass
class _Leg:
    """What the vehicle is doing in flight: a trajectory and how it completes."""

    kind: _LegKind
    trajectory: Trajectory | None  # None for "manual"
    target_pos_ned: np.ndarray | None = None
    arrival_s: float = math.inf  # s, reference arrives at the target
    hold_s: float = 0.0  # s, rest at the target before the leg is done
    item_index: int | None = None  # mission item this leg flies (AUTO)
    manual_z_ned: float = 0.0  # m, held altitude of a "manual" leg
    manual_yaw_rad: float = 0.0  # rad, held yaw of a "manual" leg
    checked: bool = False  # the reached test ran at least once after arrival
    reached_s: float | None = None  # s, step time the target was reached
    ready_s: float | None = None  # s, time counted as arrival when scheduling what follows
    done: bool = False


class Navigator:
    """Flight-mode state machine, arming, take-off/landing and mission execution.

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
        self.config = config if config is not None else NavigatorConfig()
        self._items: tuple[MissionItem, ...] = ()
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Boot state: disarmed on the ground in ``initial_mode``; mission kept, not started."""
        cfg = self.config
        self._time_s: float | None = None
        self._est_pos_ned = np.zeros(3)
        self._est_vel_ned = np.zeros(3)
        self._est_yaw_rad = 0.0
        self._has_estimate = False
        self._estimator_healthy = False
        self._on_ground_hint: bool | None = None
        self._mode = Mode(cfg.initial_mode)
        self._armed = False
        self._flying = False
        self._landed_after_flight = False
        self._ground_since_s: float | None = None
        self._land_since_s: float | None = None
        self._leg: _Leg | None = None
        self._limits = cfg.speed_limits()
        self._home_pos_ned = np.array(cfg.home_pos_ned, dtype=float)
        self._failsafes: dict[str, str] = {}
        self._events: list[NavEvent] = []
        self._reset_mission_progress()

    def _reset_mission_progress(self) -> None:
        self._current_index = 0
        self._mission_started = False
        self._mission_active = False
        self._mission_complete = False
        self._reached: list[ItemReached] = []

    @property
    def mode(self) -> Mode:
        """Current flight mode."""
        return self._mode

    @property
    def armed(self) -> bool:
        """True while armed."""
        return self._armed

    @property
    def landed(self) -> bool:
        """True when not flying."""
        return not self._flying

    @property
    def landed_state(self) -> LandedState:
        """ON_GROUND, TAKEOFF, IN_AIR or LANDING."""
        if not self._flying:
            return LandedState.ON_GROUND
        kind = self._leg.kind if self._leg is not None else ""
        if kind == "takeoff" and self._leg is not None and self._leg.reached_s is None:
            return LandedState.TAKEOFF
        if kind == "land":
            return LandedState.LANDING
        return LandedState.IN_AIR

    @property
    def home_pos_ned(self) -> np.ndarray:
        """Home position, NED, m (a copy)."""
        return self._home_pos_ned.copy()

    @property
    def speed_limits(self) -> SpeedLimits:
        """Limits used for legs planned from now on (DO_CHANGE_SPEED changes them)."""
        return self._limits

    @property
    def failsafe_sources(self) -> tuple[str, ...]:
        """Active failsafe sources, in the order they were triggered."""
        return tuple(self._failsafes)

    @property
    def mission_items(self) -> tuple[MissionItem, ...]:
        """Loaded mission items; ``mission_items[k]`` is seq ``k + 1``."""
        return self._items

    def _now(self) -> float:
        return 0.0 if self._time_s is None else self._time_s

    def _event(self, kind: str, text: str, severity: Severity = "info",
               seq: int | None = None) -> None:
        self._events.append(NavEvent(self._now(), kind, text, severity, seq))

    def _ok(self, reason: str = "") -> CommandResult:
        return CommandResult(True, reason)

    def _refuse(self, what: str, reason: str) -> CommandResult:
        self._event("refused", f"{what} refused: {reason}", "warning")
        return CommandResult(False, reason)

    # ------------------------------------------------------------------ step
    def step(self, time_s: float, estimate_pos_ned: np.ndarray, estimate_vel_ned: np.ndarray,
             estimate_yaw_rad: float, *, estimator_healthy: bool = True,
             on_ground_hint: bool | None = None) -> NavOutput:
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

        Returns
        -------
        NavOutput
        """
        if not finite(time_s):
            raise ValueError(f"time_s = {time_s!r}: must be a finite time in s")
        if self._time_s is not None and time_s < self._time_s:
            raise ValueError(f"time_s = {time_s!r}: must not be earlier than the previous "
                             f"step ({self._time_s!r})")
        self._time_s = float(time_s)
        pos = np.asarray(estimate_pos_ned, dtype=float).reshape(-1)
        vel = np.asarray(estimate_vel_ned, dtype=float).reshape(-1)
        good = pos.shape == (3,) and vel.shape == (3,) and all(
            map(math.isfinite, pos.tolist() + vel.tolist())) and finite(
            float(estimate_yaw_rad))
        if good:
            self._est_pos_ned, self._est_vel_ned = pos.copy(), vel.copy()
            self._est_yaw_rad = float(estimate_yaw_rad)
            self._has_estimate = True
        self._estimator_healthy = bool(estimator_healthy) and good
        self._on_ground_hint = on_ground_hint

        if self._armed and self._flying:
            self._run_flight(self._time_s)
        elif self._armed:
            self._run_ground(self._time_s)
        reference = self._reference(self._time_s) if self._armed and self._flying else None
        events = tuple(self._events)
        self._events.clear()
        return NavOutput(reference=reference, armed=self._armed, mode=self._mode,
                         landed=not self._flying, landed_state=self.landed_state,
                         failsafe=bool(self._failsafes), events=events)

    def _reference(self, time_s: float) -> Reference:
        leg = self._leg
        if leg is None:  # flying always has a leg; hold the estimate defensively
            return Reference.hold(self._est_pos_ned, self._est_yaw_rad)
        if leg.kind == "manual":
            pos = np.array([self._est_pos_ned[0], self._est_pos_ned[1], leg.manual_z_ned])
            vel = np.array([self._est_vel_ned[0], self._est_vel_ned[1], 0.0])
            return Reference(pos_ned=pos, vel_ned=vel, acc_ned=np.zeros(3),
                             yaw_rad=leg.manual_yaw_rad)
        assert leg.trajectory is not None
        return leg.trajectory.evaluate(time_s)

    def _near(self, target_pos_ned: np.ndarray | None) -> bool:
        if target_pos_ned is None:
            return True
        return float(np.linalg.norm(self._est_pos_ned - target_pos_ned)) <= \
            self.config.wp_radius_m

    def _looks_on_ground(self) -> bool:
        cfg = self.config
        return (-self._est_pos_ned[2] < cfg.land_detect_alt_m
                and abs(self._est_vel_ned[2]) < cfg.land_detect_speed_m_s
                and self._on_ground_hint is not False)

    def _run_flight(self, t: float) -> None:
        # Transitions can chain within one step (zero-length legs, DO items).
        for _ in range(len(self._items) + 8):
            leg = self._leg
            if leg is None or leg.kind in ("manual", "hold"):
                return
            if leg.kind == "land":
                self._detect_landing(t, leg)
                return
            if leg.reached_s is None and t >= leg.arrival_s - _TIME_TOL_S:
                first = not leg.checked
                leg.checked = True
                if self._near(leg.target_pos_ned):
                    leg.reached_s = t
                    leg.ready_s = leg.arrival_s if first else t
                    self._on_leg_reached(t, leg)
            if leg.reached_s is None or leg.ready_s is None or leg.done:
                return
            if t < leg.ready_s + leg.hold_s - _TIME_TOL_S:
                return
            leg.done = True
            self._on_leg_done(leg)
            if self._leg is leg:
                return

    def _run_ground(self, t: float) -> None:
        cfg = self.config
        if self._ground_since_s is None:
            self._ground_since_s = t
        landed_like = self._landed_after_flight or self._mode in (Mode.LAND, Mode.RTL)
        delay = cfg.landed_disarm_delay_s if landed_like else cfg.idle_disarm_delay_s
        if not landed_like and delay == 0.0:
            return
        if t - self._ground_since_s >= delay - _TIME_TOL_S:
            why = "after landing" if landed_like else "no take-off"
            self._disarm(f"auto-disarm {why} ({delay:g} s on the ground)")

    def _detect_landing(self, t: float, leg: _Leg) -> None:
        if not self._looks_on_ground():
            self._land_since_s = None
            return
        if self._land_since_s is None:
            self._land_since_s = t
        if t - self._land_since_s >= self.config.land_detect_time_s - _TIME_TOL_S:
            self._on_landed(t, leg)

    # ------------------------------------------------------------------ leg events
    def _on_leg_reached(self, t: float, leg: _Leg) -> None:
        alt_m = -float(leg.target_pos_ned[2]) if leg.target_pos_ned is not None else 0.0
        if leg.kind == "takeoff":
            self._event("takeoff_complete", f"take-off complete at {alt_m:.2f} m")
        if leg.item_index is not None and leg.kind in ("takeoff", "move"):
            self._item_reached(leg.item_index, t)
        elif leg.kind == "move":
            self._event("target_reached", "reached guided target ({:.2f}, {:.2f}, {:.2f})"
                        .format(*leg.target_pos_ned) if leg.target_pos_ned is not None
                        else "reached guided target")

    def _on_leg_done(self, leg: _Leg) -> None:
        assert leg.ready_s is not None
        t_next = leg.ready_s + leg.hold_s
        if leg.kind in ("rtl_return", "approach"):
            self._start_land(t_next, leg.item_index)
        elif leg.item_index is not None and self._mode == Mode.AUTO:
            self._start_item(leg.item_index + 1, t_next)

    def _on_landed(self, t: float, leg: _Leg) -> None:
        self._flying = False
        self._leg = None
        self._land_since_s = None
        self._landed_after_flight = True
        self._ground_since_s = t
        self._event("landed", "landed")
        if leg.item_index is not None and self._mode == Mode.AUTO:
            self._item_reached(leg.item_index, t)
            self._start_item(leg.item_index + 1, t)

    # ------------------------------------------------------------------ planning
    def _plan_start(self, t: float) -> tuple[np.ndarray, float]:
        """Where a new leg starts: the current reference when flying, else the estimate."""
        if self._flying and self._leg is not None:
            ref = self._reference(t)
            return ref.pos_ned.copy(), ref.yaw_rad
        return self._est_pos_ned.copy(), self._est_yaw_rad

    def _move_leg(self, kind: _LegKind, t0: float, target: np.ndarray, yaw_rad: float | None,
                  hold_s: float = 0.0, item_index: int | None = None) -> _Leg:
        start, yaw = self._plan_start(t0)
        traj = Trajectory.from_waypoints(
            t0, start, [Waypoint(pos_ned=tuple(target), yaw_rad=yaw_rad)], self._limits, yaw)
        return _Leg(kind, traj, np.array(target, dtype=float), traj.arrival_times_s[-1],
                    hold_s, item_index)

    def _stopping_point(self) -> np.ndarray:
        """Estimate plus the distance to stop at the acceleration limit, v|v| / (2 a)."""
        vel = self._est_vel_ned
        return self._est_pos_ned + vel * np.abs(vel) / (2.0 * self._limits.accel_m_s2)

    def _enter_hold(self, t: float) -> None:
        _, yaw = self._plan_start(t)
        self._leg = _Leg("hold", hold_trajectory(t, self._stopping_point(), yaw))

    def _enter_manual(self, t: float) -> None:
        _, yaw = self._plan_start(t)
        self._leg = _Leg("manual", None, manual_z_ned=float(self._stopping_point()[2]),
                         manual_yaw_rad=yaw)

    def _start_takeoff(self, t: float, alt_m: float, item_index: int | None) -> None:
        if self._flying:  # already in the air: climb if lower, else reached at once
            start, _ = self._plan_start(t)
            target = np.array([start[0], start[1], min(float(start[2]), -alt_m)])
            self._leg = self._move_leg("takeoff", t, target, None, 0.0, item_index)
            return
        start, yaw = self._est_pos_ned.copy(), self._est_yaw_rad
        traj = takeoff_trajectory(t, start, alt_m, self._limits, yaw)
        self._flying = True
        self._landed_after_flight = False
        self._land_since_s = None
        self._leg = _Leg("takeoff", traj, np.array([start[0], start[1], -alt_m]),
                         traj.arrival_times_s[-1], 0.0, item_index)
        self._event("takeoff", f"take-off to {alt_m:.2f} m")

    def _start_land(self, t: float, item_index: int | None) -> None:
        start, yaw = self._plan_start(t)
        traj = landing_trajectory(t, start, self._limits, self.config.land_creep_speed_m_s, yaw)
        self._leg = _Leg("land", traj, None, traj.arrival_times_s[-1], 0.0, item_index)
        self._land_since_s = None
        self._event("landing", f"landing from {-start[2]:.2f} m")

    def _start_rtl(self, t: float, item_index: int | None) -> None:
        start, yaw = self._plan_start(t)
        z_return = min(float(start[2]), -self.config.rtl_alt_m)
        home = self._home_pos_ned
        wps = []
        if z_return < float(start[2]) - 1e-9:
            wps.append(Waypoint(pos_ned=(float(start[0]), float(start[1]), z_return)))
        wps.append(Waypoint(pos_ned=(float(home[0]), float(home[1]), z_return)))
        traj = Trajectory.from_waypoints(t, start, wps, self._limits, yaw)
        self._leg = _Leg("rtl_return", traj, np.array(wps[-1].pos_ned),
                         traj.arrival_times_s[-1], self.config.rtl_hold_s, item_index)
        self._event("mission" if item_index is not None else "landing",
                    f"returning home at {-z_return:.2f} m")

    # ------------------------------------------------------------------ mission engine
    def _item_reached(self, index: int, t: float) -> None:
        seq = index + 1
        self._reached.append(ItemReached(seq, t))
        self._event("item_reached", f"reached item {seq}: {self._items[index].describe()}",
                    seq=seq)

    def _apply_speed(self, speed_m_s: float, speed_type: str) -> None:
        name = {"ground": "horizontal_m_s", "climb": "up_m_s", "descent": "down_m_s"}
        self._limits = replace(self._limits, **{name[speed_type]: float(speed_m_s)})
        self._event("speed", f"{speed_type} speed {speed_m_s:.3f} m/s")

    def _start_item(self, index: int, t0: float) -> None:
        """Execute items from ``index``: DO items at once, then start the next NAV item."""
        now = self._now()
        while index < len(self._items):
            item = self._items[index]
            self._current_index = index
            if item.command == "change_speed":
                self._apply_speed(item.speed_m_s, item.speed_type)
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
        self._mission_complete = True
        self._mission_active = False
        self._event("mission_complete", "mission complete")
        if self._flying:
            start, yaw = self._plan_start(t)
            self._leg = _Leg("hold", hold_trajectory(t, start, yaw))

    def _resume_mission(self, t: float) -> None:
        if self._mission_complete:
            self._reset_mission_progress()
        self._mission_started = True
        self._mission_active = True
        self._event("mission", f"mission running from item {self._current_index + 1}",
                    seq=self._current_index + 1)
        self._start_item(self._current_index, t)

    def _first_nav_index(self, index: int) -> int | None:
        for i in range(index, len(self._items)):
            if self._items[i].is_nav:
                return i
        return None

    def mission_progress(self) -> MissionProgress:
        """Current seq, total, state and items reached (for MISSION_CURRENT/ITEM_REACHED)."""
        if not self._items:
            return MissionProgress(0, 0, MissionState.NO_MISSION, ())
        if self._mission_complete:
            state = MissionState.COMPLETE
        elif self._mission_active and self._mode == Mode.AUTO:
            state = MissionState.ACTIVE
        elif self._mission_started:
            state = MissionState.PAUSED
        else:
            state = MissionState.NOT_STARTED
        return MissionProgress(len(self._items) + 1, self._current_index + 1, state,
                               tuple(self._reached))

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
        if number not in {int(m) for m in Mode}:
            if number in ARDUCOPTER_MODE_NAMES:
                return self._refuse(what, f"{mode_name(number)} ({number}) is not supported")
            return self._refuse(what, f"unknown mode number {number}")
        mode = Mode(number)
        if mode == self._mode:
            return self._ok(f"already in {mode.name}")
        if mode in _POSITION_MODES and not self._estimator_healthy:
            return self._refuse(what, "position estimate not healthy")
        if mode == Mode.AUTO and not self._items:
            return self._refuse(what, "no mission loaded")
        self._enter_mode(mode, "")
        return self._ok()

    def _enter_mode(self, mode: Mode, why: str) -> None:
        old = self._mode
        self._mode = mode
        t = self._now()
        self._event("mode", f"mode {old.name} -> {mode.name}{why}",
                    "warning" if why else "info")
        if old == Mode.AUTO and mode != Mode.AUTO:
            self._mission_active = False
        if not (self._armed and self._flying):
            if self._armed and mode in (Mode.LAND, Mode.RTL):
                self._ground_since_s = t
            return
        self._start_mode_behaviour(t)

    def _start_mode_behaviour(self, t: float) -> None:
        """Start what the current mode does in flight, from the current reference."""
        mode = self._mode
        if mode in (Mode.GUIDED, Mode.LOITER, Mode.BRAKE):
            self._enter_hold(t)
        elif mode in (Mode.STABILIZE, Mode.ALT_HOLD):
            self._enter_manual(t)
        elif mode == Mode.AUTO:
            self._resume_mission(t)
        elif mode == Mode.RTL:
            self._start_rtl(t, None)
        else:
            self._start_land(t, None)

    def land(self) -> CommandResult:
        """NAV_LAND as a command: switch to LAND."""
        return self.set_mode(Mode.LAND)

    def return_to_launch(self) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH as a command: switch to RTL."""
        return self.set_mode(Mode.RTL)

    def arm(self, force: bool = False) -> CommandResult:
        """Arm (COMPONENT_ARM_DISARM p1=1; ``force`` for p2=21196 skips the checks).

        Pre-arm checks, in order: a state estimate exists, no failsafe is active, the
        estimator is healthy, the vehicle is on the ground, the mode allows arming.
        """
        if self._armed:
            return self._ok("already armed")
        if not force:
            cfg = self.config
            if not self._has_estimate:
                return self._refuse("arming", "no state estimate yet")
            if self._failsafes:
                return self._refuse("arming", "failsafe active: " + ", ".join(self._failsafes))
            if not self._estimator_healthy:
                return self._refuse("arming", "estimator not healthy")
            if not self._looks_on_ground():
                return self._refuse(
                    "arming", f"not on the ground (altitude {-self._est_pos_ned[2]:.2f} m, "
                    f"vertical speed {self._est_vel_ned[2]:.2f} m/s)")
            if int(self._mode) not in cfg.armable_modes:
                allowed = ", ".join(mode_name(m) for m in cfg.armable_modes)
                return self._refuse("arming", f"mode {self._mode.name} does not allow arming "
                                    f"(use {allowed})")
        t = self._now()
        self._armed = True
        self._landed_after_flight = False
        self._ground_since_s = t
        self._event("arm", "armed (forced)" if force else "armed")
        if force and self._has_estimate and not self._looks_on_ground():
            # Force-armed in the air: fly the current mode from where the vehicle is.
            self._flying = True
            self._start_mode_behaviour(t)
        return self._ok()

    def disarm(self, force: bool = False) -> CommandResult:
        """Disarm (COMPONENT_ARM_DISARM p1=0); refused in flight unless ``force``."""
        if not self._armed:
            return self._ok("already disarmed")
        if self._flying and not force:
            return self._refuse("disarming", "flying: land first (or force)")
        self._disarm("disarmed (forced)" if force else "disarmed")
        return self._ok()

    def _disarm(self, text: str) -> None:
        self._armed = False
        self._flying = False
        self._leg = None
        self._land_since_s = None
        self._ground_since_s = None
        self._mission_active = False
        self._event("disarm", text)

    def takeoff(self, alt_m: float) -> CommandResult:
        """NAV_TAKEOFF in GUIDED: climb vertically to ``alt_m`` (m above home), then hold."""
        cfg = self.config
        if not finite(alt_m) or not cfg.land_detect_alt_m < alt_m <= cfg.max_alt_m:
            return self._refuse("take-off", f"altitude {alt_m!r} m outside "
                                f"({cfg.land_detect_alt_m}, {cfg.max_alt_m}] m")
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
        if not 0.0 <= -target[2] <= self.config.max_alt_m:
            return self._refuse(what, f"target altitude {-target[2]:.2f} m outside "
                                f"[0, {self.config.max_alt_m}] m")
        return target

    def go_to(self, pos_ned: Sequence[float] | np.ndarray, yaw_rad: float | None = None
              ) -> CommandResult:
        """Fly to ``pos_ned`` (m, NED) along a cubic (SET_POSITION_TARGET_LOCAL_NED).

        Needs GUIDED, armed and flying. ``yaw_rad`` (rad) None keeps the current yaw. A new
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
        if not self._flying:
            return self._refuse("go-to", "not flying: take off first")
        t = self._now()
        leg = self._leg
        if leg is not None and leg.kind == "move" and leg.item_index is None and \
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

        Refused while flying it in AUTO, and for targets outside [0, max_alt_m] altitude.
        """
        if self._mode == Mode.AUTO and self._flying:
            return self._refuse("mission upload", "flying the current mission in AUTO")
        for k, item in enumerate(items):
            seq = k + 1
            if not isinstance(item, MissionItem):
                return self._refuse("mission upload", f"item {seq} is not a MissionItem")
            if item.pos_ned is not None and not 0.0 <= -item.pos_ned[2] <= self.config.max_alt_m:
                return self._refuse("mission upload", f"item {seq}: altitude "
                                    f"{-item.pos_ned[2]:.2f} m outside [0, "
                                    f"{self.config.max_alt_m}] m")
            if item.command == "takeoff" and item.alt_m > self.config.max_alt_m:
                return self._refuse("mission upload", f"item {seq}: take-off altitude "
                                    f"{item.alt_m} m above {self.config.max_alt_m} m")
            if item.command == "change_speed" and item.speed_m_s > self.config.max_speed_m_s:
                return self._refuse("mission upload", f"item {seq}: speed {item.speed_m_s} "
                                    f"m/s above {self.config.max_speed_m_s} m/s")
        self._items = tuple(items)
        self._reset_mission_progress()
        self._event("mission", f"mission of {len(self._items)} items loaded")
        return self._ok()

    def clear_mission(self) -> CommandResult:
        """MISSION_CLEAR_ALL; refused while flying the mission in AUTO."""
        return self.load_mission(())

    def start_mission(self) -> CommandResult:
        """MISSION_START: switch to AUTO (if needed) and run from the current item.

        Refused without a mission, when disarmed, and on the ground unless the next NAV
        item is a take-off. A complete mission restarts from item 1.
        """
        if not self._items:
            return self._refuse("mission start", "no mission loaded")
        if not self._armed:
            return self._refuse("mission start", "not armed")
        if self._mission_complete:
            self._reset_mission_progress()
        if not self._flying:
            nav = self._first_nav_index(self._current_index)
            if nav is None or self._items[nav].command != "takeoff":
                what = "none" if nav is None else \
                    f"item {nav + 1} is {self._items[nav].describe()}"
                return self._refuse("mission start", "on the ground the next NAV item must "
                                    f"be NAV_TAKEOFF ({what})")
        if self._mode != Mode.AUTO:
            result = self.set_mode(Mode.AUTO)
            if not result.accepted:
                return result
        if not self._mission_active:
            self._resume_mission(self._now())
        return self._ok()

    def set_current_item(self, seq: int) -> CommandResult:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT: continue from ``seq``.

        ``seq`` 0 (home) means item 1. In AUTO in flight the vehicle heads there at once.
        """
        if not self._items:
            return self._refuse("set current", "no mission loaded")
        if isinstance(seq, bool) or not isinstance(seq, (int, np.integer)):
            return self._refuse("set current", f"seq {seq!r} is not an integer")
        seq = int(seq) or 1
        if not 1 <= seq <= len(self._items):
            return self._refuse("set current", f"seq {seq} outside 1..{len(self._items)}")
        self._mission_complete = False
        self._current_index = seq - 1
        self._event("mission", f"current item set to {seq}", seq=seq)
        if self._mission_active and self._flying and self._mode == Mode.AUTO:
            self._start_item(self._current_index, self._now())
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

