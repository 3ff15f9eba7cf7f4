"""The legs layer of the navigator: where the vehicle goes in flight, leg after leg.

:class:`FlightLegs` holds what the navigator knows of the vehicle (the latest estimate,
flying or not, home, the speed limits), flies one :class:`~fcu.navigation.legs.Leg` at a
time, detects arrival and landing (:mod:`fcu.navigation.landing`) and collects the events.
What comes after a mission item is left to the layers above it: mission execution
(:class:`fcu.navigation.mission.MissionExecution`) and the mode state machine
(:class:`fcu.navigation.navigator.Navigator`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from fcu.navigation.circle import Circle, circle_entry
from fcu.navigation.events import CommandResult, NavEvent, Severity
from fcu.navigation.guidance import Reference, SpeedLimits
from fcu.navigation.landing import LandedState, LandingDetector, looks_on_ground
from fcu.navigation.legs import (
    Leg,
    LegKind,
    hold_leg,
    landing_leg,
    manual_leg,
    move_leg,
    rtl_leg,
    stopping_point,
    takeoff_leg,
)
from fcu.navigation.settings import TIME_TOL_S, NavigatorConfig
from flightdata.config import finite

_SHAPE3 = (3,)
_isfinite = math.isfinite


class FlightLegs:
    """Legs in flight: planning, arrival, landing detection and events (module docstring).

    Parameters
    ----------
    config : NavigatorConfig
        Settings.

    Notes
    -----
    A subclass supplies the three mission hooks (:meth:`_mission_running`,
    :meth:`_item_reached`, :meth:`_next_item`).
    """

    def __init__(self, config: NavigatorConfig) -> None:
        self.config = config
        self._landing = LandingDetector(config.land_detect_time_s)
        self._reset_flight()

    def _reset_flight(self) -> None:
        """On the ground, nothing known yet; home and speeds from the configuration."""
        cfg = self.config
        self._time_s: float | None = None
        # the latest finite estimate, m and m/s NED, as floats (arrays: _est_pos_ned...)
        self._est_pos_f: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._est_vel_f: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._est_yaw_rad = 0.0
        self._has_estimate = False
        self._estimator_healthy = False
        self._on_ground_hint: bool | None = None
        self._flying = False
        self._landed_after_flight = False
        self._ground_since_s: float | None = None
        self._landing.reset()
        self._leg: Leg | None = None
        # DO_ORBIT's circle (centre m NED, radius m, rate rad/s, entry angle rad), flown
        # once its approach leg is done
        self._orbit_plan: tuple[np.ndarray, float, float, float] | None = None
        self._limits = cfg.speed_limits()
        self._home_pos_ned = np.array(cfg.home_pos_ned, dtype=float)
        self._events: list[NavEvent] = []

    @property
    def landed(self) -> bool:
        """True when not flying."""
        return not self._flying

    @property
    def landed_state(self) -> LandedState:
        """ON_GROUND, TAKEOFF, IN_AIR or LANDING."""
        if not self._flying:
            return LandedState.ON_GROUND
        leg = self._leg
        if leg is None:
            return LandedState.IN_AIR
        kind = leg.kind
        if kind == "takeoff" and leg.reached_s is None:
            return LandedState.TAKEOFF
        if kind == "land":
            return LandedState.LANDING
        return LandedState.IN_AIR

    @property
    def leg_kind(self) -> str:
        """What is being flown: "takeoff", "move", "hold", "manual", "approach",
        "rtl_return", "land", or "" when not flying."""
        return self._leg.kind if self._flying and self._leg is not None else ""

    @property
    def leg_endpoints(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Where the current leg started and where it ends (m, NED), or None when not flying
        or holding the altitude only: a landing ends on the ground below its start, a hold
        at its hold point. NAV_CONTROLLER_OUTPUT's distance and cross-track error."""
        leg = self._leg
        if not self._flying or leg is None or leg.trajectory is None:
            return None
        traj = leg.trajectory
        start = traj.evaluate(traj.start_time_s).pos_ned
        if leg.target_pos_ned is not None:
            end = leg.target_pos_ned
        elif leg.kind == "land":
            end = np.array([start[0], start[1], 0.0])
        else:
            end_s = traj.end_time_s  # a hold never ends: it stays where it started
            end = traj.evaluate(end_s if math.isfinite(end_s) else traj.start_time_s).pos_ned
        return np.array(start, dtype=float), np.array(end, dtype=float)

    @property
    def home_pos_ned(self) -> np.ndarray:
        """Home position, NED, m (a copy)."""
        return self._home_pos_ned.copy()

    @property
    def speed_limits(self) -> SpeedLimits:
        """Limits used for legs planned from now on (DO_CHANGE_SPEED changes them)."""
        return self._limits

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

    def _take_estimate(self, time_s: float, estimate_pos_ned: np.ndarray,
                       estimate_vel_ned: np.ndarray, estimate_yaw_rad: float,
                       estimator_healthy: bool, on_ground_hint: bool | None) -> float:
        """Advance the clock to ``time_s`` (s) and keep the estimate if it is finite (the
        arguments of :meth:`fcu.navigation.navigator.Navigator.step`); returns the time."""
        previous_s = self._time_s
        # (the common tick: a finite float, not earlier than the previous step's)
        if time_s.__class__ is not float or not _isfinite(time_s) or (
                previous_s is not None and time_s < previous_s):
            if not finite(time_s):
                raise ValueError(f"time_s = {time_s!r}: must be a finite time in s")
            if previous_s is not None and time_s < previous_s:
                raise ValueError(f"time_s = {time_s!r}: must not be earlier than the "
                                 f"previous step ({previous_s!r})")
            time_s = float(time_s)
        self._time_s = time_s
        self._on_ground_hint = on_ground_hint
        try:  # an estimator's float64 3-vectors, every tick: their floats, as they are
            x0, x1, x2 = estimate_pos_ned.tolist()
            v0, v1, v2 = estimate_vel_ned.tolist()
            plain = x0.__class__ is x1.__class__ is x2.__class__ is v0.__class__ is \
                v1.__class__ is v2.__class__ is float
        except (AttributeError, TypeError, ValueError):
            plain = False
        if not plain:  # anything else: as float64 3-vectors, if it can be
            pos = np.asarray(estimate_pos_ned, dtype=float).reshape(-1)
            vel = np.asarray(estimate_vel_ned, dtype=float).reshape(-1)
            if pos.shape != _SHAPE3 or vel.shape != _SHAPE3:
                self._estimator_healthy = False
                return time_s
            x0, x1, x2 = pos.tolist()
            v0, v1, v2 = vel.tolist()
        yaw = float(estimate_yaw_rad)
        # a finite sum has finite terms; a sum of finite floats may still overflow
        if _isfinite(x0 + x1 + x2 + v0 + v1 + v2 + yaw) or all(
                map(_isfinite, (x0, x1, x2, v0, v1, v2, yaw))):
            self._est_pos_f, self._est_vel_f = (x0, x1, x2), (v0, v1, v2)
            self._est_yaw_rad = yaw
            self._has_estimate = True
            self._estimator_healthy = bool(estimator_healthy)
        else:
            self._estimator_healthy = False
        return time_s

    @property
    def _est_pos_ned(self) -> np.ndarray:
        """The latest finite position estimate, m, NED (a new array)."""
        return np.array(self._est_pos_f)

    @property
    def _est_vel_ned(self) -> np.ndarray:
        """The latest finite velocity estimate, m/s, NED (a new array)."""
        return np.array(self._est_vel_f)

    # ------------------------------------------------------------------ legs
    def _reference(self, time_s: float) -> Reference:
        leg = self._leg
        if leg is None:  # flying always has a leg; hold the estimate defensively
            return Reference.hold(self._est_pos_ned, self._est_yaw_rad)
        return leg.reference(time_s, self._est_pos_ned, self._est_vel_ned)

    def _near(self, target_pos_ned: np.ndarray | None) -> bool:
        if target_pos_ned is None:
            return True
        return float(np.linalg.norm(self._est_pos_ned - target_pos_ned)) <= \
            self.config.wp_radius_m

    def _looks_on_ground(self) -> bool:
        return looks_on_ground(self._est_pos_ned, self._est_vel_ned, self._on_ground_hint,
                               self.config)

    def _run_flight(self, t: float, max_transitions: int) -> None:
        """Advance the current leg at step time ``t`` (s): reached, done, what follows.

        Transitions can chain within one step (zero-length legs, DO items), at most
        ``max_transitions`` of them.
        """
        leg = self._leg
        if leg is not None and leg.reached_s is None and leg.kind != "land" and \
                t < leg.arrival_s - TIME_TOL_S:
            return  # on the way (what the loop's first pass concludes)
        for _ in range(max_transitions):
            leg = self._leg
            if leg is None or leg.kind in ("manual", "hold"):
                return
            if leg.kind == "land":
                self._detect_landing(t, leg)
                return
            if leg.reached_s is None and t >= leg.arrival_s - TIME_TOL_S:
                first = not leg.checked
                leg.checked = True
                if self._near(leg.target_pos_ned):
                    leg.reached_s = t
                    leg.ready_s = leg.arrival_s if first else t
                    self._on_leg_reached(t, leg)
            if leg.reached_s is None or leg.ready_s is None or leg.done:
                return
            if t < leg.ready_s + leg.hold_s - TIME_TOL_S:
                return
            leg.done = True
            self._on_leg_done(leg)
            if self._leg is leg:
                return

    def _detect_landing(self, t: float, leg: Leg) -> None:
        if self._landing.step(t, self._looks_on_ground()):
            self._on_landed(t, leg)

    # ------------------------------------------------------------------ leg events
    def _on_leg_reached(self, t: float, leg: Leg) -> None:
        """The leg's target was reached at ``t`` (s)."""
        alt_m = -float(leg.target_pos_ned[2]) if leg.target_pos_ned is not None else 0.0
        if leg.kind == "takeoff":
            self._event("takeoff_complete", f"take-off complete at {alt_m:.2f} m")
        if leg.item_index is not None and leg.kind in ("takeoff", "move"):
            self._item_reached(leg.item_index, t)
        elif leg.kind == "move":
            self._event("target_reached", "reached guided target ({:.2f}, {:.2f}, {:.2f})"
                        .format(*leg.target_pos_ned) if leg.target_pos_ned is not None
                        else "reached guided target")

    def _on_leg_done(self, leg: Leg) -> None:
        """The leg's hold after arrival is over: land after a return or an approach, else
        go on with the mission."""
        assert leg.ready_s is not None
        t_next = leg.ready_s + leg.hold_s
        if leg.kind in ("rtl_return", "approach"):
            self._start_land(t_next, leg.item_index)
        elif leg.kind == "circle_approach" and self._orbit_plan is not None:
            centre, radius_m, rate_rad_s, theta0 = self._orbit_plan
            self._start_circle(t_next, centre, radius_m, rate_rad_s, theta0)
        elif leg.item_index is not None and self._mission_running():
            self._next_item(leg.item_index, t_next)

    def _on_landed(self, t: float, leg: Leg) -> None:
        """Landing detected at ``t`` (s): on the ground, armed; a mission goes on."""
        self._flying = False
        self._leg = None
        self._landing.reset()
        self._landed_after_flight = True
        self._ground_since_s = t
        self._event("landed", "landed")
        if leg.item_index is not None and self._mission_running():
            self._item_reached(leg.item_index, t)
            self._next_item(leg.item_index, t)

    # ------------------------------------------------------------------ mission hooks
    def _mission_running(self) -> bool:
        """True when finishing a mission item should start the next one (AUTO)."""
        raise NotImplementedError

    def _item_reached(self, index: int, t: float) -> None:
        """Mission item ``index`` was reached at ``t`` (s)."""
        raise NotImplementedError

    def _next_item(self, index: int, t: float) -> None:
        """Mission item ``index`` is done: start what follows it at ``t`` (s)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ planning
    def _plan_start(self, t: float) -> tuple[np.ndarray, float]:
        """Where a new leg starts: the current reference when flying, else the estimate."""
        if self._flying and self._leg is not None:
            ref = self._reference(t)
            return ref.pos_ned.copy(), ref.yaw_rad
        return self._est_pos_ned.copy(), self._est_yaw_rad

    def _move_leg(self, kind: LegKind, t0: float, target: np.ndarray, yaw_rad: float | None,
                  hold_s: float = 0.0, item_index: int | None = None) -> Leg:
        start, yaw = self._plan_start(t0)
        return move_leg(kind, t0, start, yaw, target, yaw_rad, self._limits, hold_s, item_index)

    def _stopping_point(self) -> np.ndarray:
        return stopping_point(self._est_pos_ned, self._est_vel_ned, self._limits)

    def _enter_hold(self, t: float) -> None:
        _, yaw = self._plan_start(t)
        self._leg = hold_leg(t, self._stopping_point(), yaw)

    def _enter_circle(self, t: float) -> None:
        """CIRCLE entered in flight: the centre CIRCLE_RADIUS ahead, the vehicle on the
        circle, turning at CIRCLE_RATE (as ArduCopter)."""
        start, yaw = self._plan_start(t)
        cfg = self.config
        radius = cfg.circle_radius_m
        centre = start + np.array([radius * math.cos(yaw), radius * math.sin(yaw), 0.0])
        self._start_circle(t, centre, radius, math.radians(cfg.circle_rate_deg_s),
                           yaw + math.pi)

    def _start_circle(self, t: float, centre: np.ndarray, radius_m: float, rate_rad_s: float,
                      theta0_rad: float) -> None:
        circle = Circle(np.array(centre, dtype=float), float(radius_m), float(rate_rad_s),
                        float(theta0_rad), t, self._limits.accel_m_s2)
        self._leg = Leg("circle", None, circle=circle)
        self._event("circle", f"circling ({centre[0]:.2f}, {centre[1]:.2f}) at "
                    f"{-centre[2]:.2f} m, radius {radius_m:.2f} m, "
                    f"{math.degrees(rate_rad_s):.1f} deg/s")

    def _orbit(self, t: float, centre: np.ndarray, radius_m: float, rate_rad_s: float) -> None:
        """Circle ``centre`` (m, NED, its altitude the circle's): straight on when the
        vehicle is on the circle, else after a leg to its nearest point."""
        start, _ = self._plan_start(t)
        entry, theta0 = circle_entry(start, centre, radius_m)
        self._orbit_plan = (np.array(centre, dtype=float), float(radius_m), float(rate_rad_s),
                            theta0)
        if float(np.linalg.norm(entry - start)) <= self.config.wp_radius_m:
            self._start_circle(t, centre, radius_m, rate_rad_s, theta0)
            return
        yaw_in = math.atan2(float(centre[1] - entry[1]), float(centre[0] - entry[0]))
        self._leg = self._move_leg("circle_approach", t, entry,
                                   yaw_in if radius_m > 0.0 else None)
        self._event("circle", "flying to the circle at ({:.2f}, {:.2f}, {:.2f})".format(*entry))

    def _enter_manual(self, t: float) -> None:
        _, yaw = self._plan_start(t)
        self._leg = manual_leg(float(self._stopping_point()[2]), yaw)

    def _start_takeoff(self, t: float, alt_m: float, item_index: int | None) -> None:
        if self._flying:  # already in the air: climb if lower, else reached at once
            start, _ = self._plan_start(t)
            target = np.array([start[0], start[1], min(float(start[2]), -alt_m)])
            self._leg = self._move_leg("takeoff", t, target, None, 0.0, item_index)
            return
        start, yaw = self._est_pos_ned.copy(), self._est_yaw_rad
        self._leg = takeoff_leg(t, start, yaw, alt_m, self._limits, item_index)
        self._flying = True
        self._landed_after_flight = False
        self._landing.reset()
        self._event("takeoff", f"take-off to {alt_m:.2f} m")

    def _start_land(self, t: float, item_index: int | None) -> None:
        start, yaw = self._plan_start(t)
        self._leg = landing_leg(t, start, yaw, self._limits, self.config.land_creep_speed_m_s,
                                item_index)
        self._landing.reset()
        self._event("landing", f"landing from {-start[2]:.2f} m")

    def _start_rtl(self, t: float, item_index: int | None) -> None:
        start, yaw = self._plan_start(t)
        cfg = self.config
        rtl_alt_m = cfg.rtl_alt_m
        if cfg.fence.altitude_on:  # as ArduCopter: the return stays below the fence
            rtl_alt_m = max(min(rtl_alt_m, cfg.fence.alt_max_m - cfg.fence.margin_m),
                            cfg.land_detect_alt_m)
        leg = rtl_leg(t, start, yaw, self._home_pos_ned, rtl_alt_m, cfg.rtl_hold_s,
                      self._limits, item_index)
        self._leg = leg
        assert leg.target_pos_ned is not None
        self._event("mission" if item_index is not None else "landing",
                    f"returning home at {-leg.target_pos_ned[2]:.2f} m")

    def _apply_speed(self, speed_m_s: float, speed_type: str) -> None:
        name = {"ground": "horizontal_m_s", "climb": "up_m_s", "descent": "down_m_s"}
        self._limits = replace(self._limits, **{name[speed_type]: float(speed_m_s)})
        self._event("speed", f"{speed_type} speed {speed_m_s:.3f} m/s")
