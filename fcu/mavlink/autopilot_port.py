"""The MAVLink endpoint's view of an autopilot: telemetry snapshots, commands, parameters.

:class:`AutopilotPort` implements :class:`fcu.mavlink.port.VehiclePort` over one
:class:`fcu.autopilot.Autopilot`, held by a host (the composition root's tick loop, which
may have the autopilot replaced: a parameter change rebuilds it). What only the simulator
knows (truth for SIM_STATE, its own STATUSTEXTs, fault injection, ``SIM_*`` parameters) is
plugged in by the composition root: a truth callable, :meth:`AutopilotPort.post` for its
events, and the endpoint's ``injector`` and ``extra_params``.

Parameters (:mod:`fcu.mavlink.autopilot_params`): a change rebuilds the autopilot with the
new configuration (keeping the loaded mission, home and mode), so it is accepted only
disarmed on the ground; in flight it is refused with the reason, except ``WPNAV_SPEED``,
``WPNAV_SPEED_UP`` and ``WPNAV_SPEED_DN``, which also act at once like DO_CHANGE_SPEED.
``SCHED_LOOP_RATE`` (the autopilot rate) is read-only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace

import numpy as np

from fcu.autopilot import Autopilot, AutopilotConfig, AutopilotEvent
from fcu.hal import SensorSampleLike
from fcu.mavlink.autopilot_params import AUTOPILOT_PARAMS, find_param
from fcu.mavlink.enums import MavState, Severity
from fcu.mavlink.port_records import (
    CommandResult,
    GeoPoint,
    MissionItem,
    MissionItemReached,
    ParamSpec,
    RecordEvent,
    SensorHealth,
    SimTruth,
    StatusText,
    VehicleEvent,
    VehicleSnapshot,
)
from fcu.mavlink.protocols.follow_target import LeadReport
from fcu.mavlink.telemetry.autopilot_snapshot import LazySnapshot
from fcu.mavlink.telemetry.autopilot_telemetry import AutopilotHost, AutopilotTelemetry
from fcu.navigation.fence import FenceAreas
from fcu.navigation.navigator import CommandResult as NavResult
from fcu.navigation.navigator import Mode, mode_name
from fcu.navigation.sticks import Sticks
from flightdata.mission import MAV_CMD_BY_COMMAND, SPEED_TYPE_BY_MAV_PARAM
from flightdata.mission import MissionItem as NavItem
from flightdata.records import Record

__all__ = ["BRAKE_ARMABLE", "AutopilotPort", "vehicle_autopilot_config"]

BRAKE_ARMABLE = int(Mode.BRAKE)
"""MAVSDK switches to BRAKE before arming when the vehicle sits in AUTO, RTL or LAND."""

_SEVERITY = {"info": Severity.INFO, "notice": Severity.NOTICE, "warning": Severity.WARNING,
             "critical": Severity.CRITICAL}


def vehicle_autopilot_config(config: AutopilotConfig) -> AutopilotConfig:
    """``config`` with BRAKE added to the armable modes (what MAVSDK's arm needs)."""
    nav = config.navigator
    if BRAKE_ARMABLE in nav.armable_modes:
        return config
    return replace(config, navigator=replace(
        nav, armable_modes=(*nav.armable_modes, BRAKE_ARMABLE)))


class AutopilotPort:
    """:class:`fcu.mavlink.port.VehiclePort` over the autopilot a host holds.

    Parameters
    ----------
    host : AutopilotHost
        Holds the autopilot (and its PWM) between ticks.
    origin : GeoPoint
        Geodetic position of the NED origin (home at boot).
    truth : callable, optional
        Simulator truth for SIM_STATE (None outside simulation, or no callable).
    on_target : callable, optional
        Called with each position (m, NED) the vehicle is sent to by a go-to command
        (the simulator's outcome judge learns where the vehicle is meant to be).

    Notes
    -----
    Call :meth:`collect` after every tick with the autopilot's events; call the endpoint
    between ticks. Not thread-safe: everything runs on the vehicle loop's thread.
    """

    def __init__(self, host: AutopilotHost, origin: GeoPoint, *,
                 truth: Callable[[], SimTruth | None] | None = None,
                 on_target: Callable[[np.ndarray], None] | None = None) -> None:
        self.host = host
        self.origin = origin
        self._truth = truth if truth is not None else (lambda: None)
        self._on_target = on_target if on_target is not None else (lambda pos_ned: None)
        self._config = host.autopilot.config
        self._events: list[VehicleEvent] = []
        self._snap: VehicleSnapshot | None = None
        self.telemetry = AutopilotTelemetry(host, origin)
        self._fence_areas = FenceAreas()  # the uploaded fence (the navigator's, kept here
        # for a rebuild)

    @property
    def autopilot(self) -> Autopilot:
        """The autopilot in force."""
        return self.host.autopilot

    # ------------------------------------------------------------------ events
    def collect(self, events: Sequence[AutopilotEvent]) -> None:
        """After a tick: the autopilot's events become STATUSTEXT / MISSION_ITEM_REACHED."""
        self._expire()
        for ev in events:
            if ev.kind == "refused":
                continue  # the endpoint reports refusals with the command's ACK
            if ev.kind == "item_reached" and ev.seq is not None:
                self._events.append(MissionItemReached(int(ev.seq)))
            if ev.record is not None:
                self.post_record(ev.record)
            self.post(_SEVERITY.get(ev.severity, Severity.INFO), ev.text)

    def observe(self, samples: Iterable[SensorSampleLike]) -> None:
        """After a tick: the samples the autopilot received (the extended telemetry's IMU,
        barometer and vibration; kept unprocessed until a message needs them)."""
        self.telemetry.observe(samples)

    def post(self, severity: int, text: str) -> None:
        """Queue a STATUSTEXT (the composition root's own messages go here too)."""
        self._events.append(StatusText(int(severity), text))

    def post_record(self, record: Record) -> None:
        """Queue a fault, detection or outcome record (DEBUG_FLOAT_ARRAY ``FTC_REC``)."""
        self._events.append(RecordEvent(record))

    def invalidate(self) -> None:
        """Forget the cached snapshot (something outside the autopilot changed)."""
        self._expire()

    def drain_events(self) -> list[VehicleEvent]:
        """STATUSTEXT and MISSION_ITEM_REACHED since the previous call, oldest first."""
        events, self._events = self._events, []
        return events

    # ------------------------------------------------------------------ VehiclePort: telemetry
    def snapshot(self) -> VehicleSnapshot:
        """Telemetry state after the last tick (cached until the next tick or command)."""
        if self._snap is None:
            self._snap = self._build_snapshot()
        return self._snap

    def _build_snapshot(self) -> VehicleSnapshot:
        ap = self.host.autopilot
        nav = ap.navigator
        status = ap.status
        t = self.host.time_s
        if status is None:
            return VehicleSnapshot(time_s=t, armed=False, custom_mode=int(nav.mode),
                                   pos_ned=np.zeros(3), vel_ned=np.zeros(3),
                                   euler_rad=np.zeros(3), rate_frd=np.zeros(3),
                                   origin=self.origin, home_pos_ned=nav.home_pos_ned,
                                   system_status=MavState.BOOT,
                                   health=SensorHealth(ahrs=False, prearm=False),
                                   extended=self.telemetry)
        return LazySnapshot(self, ap, status, t)

    def _expire(self) -> None:
        """The vehicle moves on (a tick, a command): the snapshot taken so far is done."""
        if self._snap is not None:
            if isinstance(self._snap, LazySnapshot):
                self._snap.expire()
            self._snap = None

    # ------------------------------------------------------------------ VehiclePort: commands
    def _nav(self, what: str, result: NavResult) -> CommandResult:
        self._expire()  # the command may have changed mode, arming, targets...
        if result.accepted:
            return CommandResult.ok()
        return CommandResult.denied(f"{what} refused: {result.reason}")

    def arm(self, *, force: bool) -> CommandResult:
        """COMPONENT_ARM_DISARM p1 = 1 (the navigator's pre-arm checks unless forced)."""
        return self._nav("Arm", self.host.autopilot.navigator.arm(force))

    def disarm(self, *, force: bool) -> CommandResult:
        """COMPONENT_ARM_DISARM p1 = 0 (refused in flight unless forced)."""
        return self._nav("Disarm", self.host.autopilot.navigator.disarm(force))

    def set_mode(self, custom_mode: int) -> CommandResult:
        """DO_SET_MODE / SET_MODE: the navigator's modes; others refused with the reason."""
        return self._nav(f"Mode {mode_name(custom_mode)}",
                         self.host.autopilot.navigator.set_mode(int(custom_mode)))

    def takeoff(self, alt_m: float) -> CommandResult:
        """NAV_TAKEOFF in GUIDED, ``alt_m`` above home."""
        return self._nav("Takeoff", self.host.autopilot.navigator.takeoff(float(alt_m)))

    def land(self) -> CommandResult:
        """NAV_LAND: switch to LAND."""
        return self._nav("Land", self.host.autopilot.navigator.land())

    def return_to_launch(self) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH: switch to RTL."""
        return self._nav("RTL", self.host.autopilot.navigator.return_to_launch())

    def goto(self, pos_ned: np.ndarray, yaw_rad: float | None) -> CommandResult:
        """SET_POSITION_TARGET_* / DO_REPOSITION: a cubic leg to ``pos_ned`` (GUIDED only)."""
        result = self._nav("Go-to", self.host.autopilot.navigator.go_to(pos_ned, yaw_rad))
        if result.accepted:
            self._on_target(np.asarray(pos_ned, dtype=float))
        return result

    def orbit(self, centre_ned: np.ndarray | None, radius_m: float | None,
              speed_m_s: float | None) -> CommandResult:
        """DO_ORBIT: the navigator's circle, in CIRCLE mode (the outcome judge learns the
        circle's extent, as it learns go-to targets)."""
        result = self._nav("Orbit", self.host.autopilot.navigator.orbit(centre_ned, radius_m,
                                                                        speed_m_s))
        if result.accepted and centre_ned is not None:
            r = self.host.autopilot.navigator.config.circle_radius_m if radius_m is None \
                else float(radius_m)
            for dn, de in ((r, 0.0), (-r, 0.0), (0.0, r), (0.0, -r)):
                self._on_target(np.asarray(centre_ned, dtype=float) + np.array([dn, de, 0.0]))
        return result

    def set_velocity(self, vel_ned: np.ndarray, yaw_rad: float | None,
                     yaw_rate_rad_s: float | None, heading_frame: bool) -> CommandResult:
        """SET_POSITION_TARGET_* velocity: the navigator's GUIDED velocity set-point."""
        return self._nav("Velocity target", self.host.autopilot.navigator.set_velocity(
            vel_ned, yaw_rad, yaw_rate_rad_s, heading_frame))

    def set_attitude(self, roll_rad: float, pitch_rad: float, yaw_rad: float | None,
                     thrust: float) -> CommandResult:
        """SET_ATTITUDE_TARGET: the navigator's GUIDED attitude set-point."""
        return self._nav("Attitude target", self.host.autopilot.navigator.set_attitude(
            roll_rad, pitch_rad, yaw_rad, thrust))

    def change_speed(self, speed_m_s: float, speed_type: str) -> CommandResult:
        """DO_CHANGE_SPEED for legs planned from now on."""
        return self._nav("Change speed",
                         self.host.autopilot.navigator.change_speed(float(speed_m_s), speed_type))

    def set_home(self, pos_ned: np.ndarray | None) -> CommandResult:
        """DO_SET_HOME; None = the current estimated position."""
        if pos_ned is None:
            status = self.host.autopilot.status
            if status is None:
                return CommandResult.denied("Set home refused: no position estimate yet")
            pos_ned = np.array(status.estimate.pos_ned)
        return self._nav("Set home", self.host.autopilot.navigator.set_home(pos_ned))

    def fence_set(self, areas: FenceAreas) -> CommandResult:
        """The uploaded fence, to the navigator (kept across a rebuild)."""
        self._fence_areas = areas
        return self._nav("Fence", self.host.autopilot.navigator.set_fence_areas(areas))

    def mission_set(self, items: Sequence[MissionItem]) -> CommandResult:
        """Replace the mission (converted to navigator items; unsupported commands refused)."""
        converted: list[NavItem] = []
        for item in items:
            nav_item = _to_nav_item(item)
            if isinstance(nav_item, CommandResult):
                return nav_item
            converted.append(nav_item)
        nav = self.host.autopilot.navigator
        result = nav.load_mission(converted) if converted else nav.clear_mission()
        return self._nav("Mission", result)

    def mission_start(self) -> CommandResult:
        """MISSION_START: AUTO from the current item."""
        return self._nav("Mission start", self.host.autopilot.navigator.start_mission())

    def mission_set_current(self, seq: int) -> CommandResult:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT."""
        return self._nav("Set mission current",
                         self.host.autopilot.navigator.set_current_item(int(seq)))

    def reboot(self) -> CommandResult:
        """PREFLIGHT_REBOOT_SHUTDOWN: restart the autopilot (the simulated world goes on)."""
        nav = self.host.autopilot.navigator
        if nav.armed:
            return CommandResult.denied("Reboot refused: disarm first")
        error = self._rebuild(self._config, keep_mode=False)
        if error:
            return CommandResult.denied(f"Reboot failed: {error}")
        self.post(Severity.NOTICE, "Autopilot rebooted")
        return CommandResult.ok()

    def prearm_check(self) -> CommandResult:
        """RUN_PREARM_CHECKS: the verdict arming would give now (armed: nothing to check)."""
        check = self.host.autopilot.navigator.prearm_check()
        return CommandResult.ok() if check.ok else CommandResult.denied(check.reason)

    def set_sticks(self, sticks: Sticks | None) -> CommandResult:
        """The pilot's sticks, to the navigator (flown in the pilot modes from its next step:
        the snapshot stays valid)."""
        result = self.host.autopilot.navigator.set_sticks(sticks)
        return CommandResult.ok() if result.accepted else CommandResult.denied(result.reason)

    def trigger_failsafe(self, source: str, action: str) -> CommandResult:
        """GCS-loss or RC failsafe from the endpoint: LAND/RTL in flight, disarm on the
        ground."""
        return self._nav("Failsafe", self.host.autopilot.navigator.trigger_failsafe(source, action))

    def clear_failsafe(self, source: str) -> CommandResult:
        """The failsafe source is over (the mode stays)."""
        return self._nav("Failsafe clear", self.host.autopilot.navigator.clear_failsafe(source))

    def follow_target(self, report: LeadReport) -> None:
        """A possible lead's report, to FOLLOW (:mod:`fcu.mavlink.protocols.follow_target`)."""
        nav = self.host.autopilot.navigator
        pos = report.pos_ned(self.origin, nav.home_pos_ned, nav.config.follow.alt_type)
        vel = None if report.vel_ned_m_s is None else np.array(report.vel_ned_m_s)
        nav.follow_report(report.sysid, pos, vel, report.heading_rad)

    # ------------------------------------------------------------------ autopilot parameters
    @property
    def config(self) -> AutopilotConfig:
        """The autopilot configuration in force."""
        return self._config

    def param_specs(self) -> Sequence[ParamSpec]:
        """The autopilot configuration as parameters (see the module docstring)."""
        return [ParamSpec(name=p.name, value=p.get(self._config), min_value=p.min_value,
                          max_value=p.max_value, allowed=p.allowed, integer=p.integer,
                          description=p.description) for p in AUTOPILOT_PARAMS]

    def set_param(self, name: str, value: float) -> CommandResult:
        """Apply a validated autopilot parameter: rebuild on the ground, refuse in flight."""
        spec = find_param(name)
        if spec is None:
            return CommandResult.denied(f"unknown parameter {name}")
        if spec.read_only:
            return CommandResult.denied("read-only")  # the value in force is echoed back
        try:
            new = spec.set(self._config, float(value))
        except (ValueError, TypeError) as err:
            return CommandResult.denied(str(err))
        if spec.live_ftc:
            self.host.autopilot.set_ftc(new.ftc)
            self._config = new
            self._expire()
            self.post(Severity.INFO, f"FTC: {new.ftc}")
            return CommandResult.ok()
        nav = self.host.autopilot.navigator
        if spec.live_fence:
            nav.set_fence(new.navigator.fence)
            self._config = replace(self._config, navigator=replace(
                self._config.navigator, fence=new.navigator.fence))
            self._expire()
            self.post(Severity.INFO, f"{name} = {value:g}")
            return CommandResult.ok()
        if spec.live_follow:
            nav.set_follow(new.navigator.follow)
            self._config = replace(self._config, navigator=replace(
                self._config.navigator, follow=new.navigator.follow))
            self._expire()
            self.post(Severity.INFO, f"{name} = {value:g}")
            return CommandResult.ok()
        if nav.armed or not nav.landed:
            if spec.live_speed is None:
                return CommandResult.denied("change it disarmed on the ground (the "
                                            "autopilot is rebuilt with it)")
            speed_m_s = spec.get(new) / 100.0
            result = nav.change_speed(speed_m_s, spec.live_speed)
            if not result.accepted:
                return CommandResult.denied(result.reason)
            self._config = new
            self._expire()
            return CommandResult.ok()
        error = self._rebuild(new, keep_mode=True)
        if error:
            return CommandResult.denied(error)
        self.post(Severity.INFO, f"{name} = {value:g}: autopilot rebuilt")
        return CommandResult.ok()

    def _rebuild(self, config: AutopilotConfig, *, keep_mode: bool) -> str:
        """Replace the autopilot by one built from ``config`` at the current time.

        Keeps the loaded mission, home and (``keep_mode``) the flight mode. Returns "" or
        why the configuration could not be built (the old autopilot then stays).
        """
        t = self.host.time_s
        old_nav = self.host.autopilot.navigator
        try:
            ap = Autopilot(config)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
            return f"cannot build the autopilot: {err}"
        ap.reset_estimators(t)
        ap.step(t, [])
        nav = ap.navigator
        home = old_nav.home_pos_ned
        if not np.array_equal(home, nav.home_pos_ned):
            nav.set_home(home)
        if old_nav.mission_items:
            loaded = nav.load_mission(old_nav.mission_items)
            if not loaded.accepted:  # (the new configuration's fence refuses it)
                return f"the loaded mission does not fit it: {loaded.reason}"
        nav.set_fence_areas(self._fence_areas)
        if keep_mode and old_nav.mode != nav.mode:
            nav.set_mode(int(old_nav.mode))
        ap.step(t, [])
        if keep_mode:  # a parameter change, not a restart: the charge used still counts
            ap.battery.take_over(self.host.autopilot.battery)
        ap.drain_events()  # the rebuild's own mode/mission lines: not news to the pilot
        self.host.autopilot = ap
        self._config = config
        self.host.pwm = np.array(ap.pwm)
        self._expire()
        return ""


def _to_nav_item(item: MissionItem) -> NavItem | CommandResult:
    """A MAVLink mission item (SI, NED) as a navigator item, or why it cannot be flown."""
    where = f"item {item.seq}"
    cmd = item.command
    try:
        if cmd == MAV_CMD_BY_COMMAND["waypoint"]:
            hold_s = item.params[0]
            if not (math.isfinite(hold_s) and hold_s >= 0.0):
                return CommandResult.denied(f"{where}: hold time {hold_s} s must be >= 0")
            if item.north_east_m is None:
                if item.down_m is not None:
                    return CommandResult.denied(f"{where}: a waypoint needs a latitude and "
                                                "longitude (0, 0 = here is not supported)")
                pos = None
            else:
                assert item.down_m is not None
                pos = (item.north_east_m[0], item.north_east_m[1], item.down_m)
            return NavItem(command="waypoint", pos_ned=pos, hold_s=float(hold_s),
                           yaw_rad=item.yaw_rad)
        if cmd == MAV_CMD_BY_COMMAND["takeoff"]:
            if item.alt_m is None:
                return CommandResult.denied(f"{where}: NAV_TAKEOFF needs an altitude")
            return NavItem(command="takeoff", alt_m=float(item.alt_m))
        if cmd == MAV_CMD_BY_COMMAND["land"]:
            land_pos = None if item.north_east_m is None else (
                item.north_east_m[0], item.north_east_m[1], 0.0)
            return NavItem(command="land", pos_ned=land_pos)
        if cmd == MAV_CMD_BY_COMMAND["rtl"]:
            return NavItem(command="rtl")
        if cmd == MAV_CMD_BY_COMMAND["change_speed"]:
            kind = item.params[0]
            speed = item.params[1]
            if kind not in SPEED_TYPE_BY_MAV_PARAM:
                return CommandResult.denied(f"{where}: DO_CHANGE_SPEED speed type {kind} "
                                            "not in 0..3")
            if speed == -1.0:
                return CommandResult.denied(f"{where}: DO_CHANGE_SPEED -1 (no change) is "
                                            "not supported in missions")
            return NavItem(command="change_speed", speed_m_s=float(speed),
                           speed_type=SPEED_TYPE_BY_MAV_PARAM[int(kind)])  # type: ignore[arg-type]
    except ValueError as err:
        return CommandResult.denied(f"{where}: {err}")
    return CommandResult.not_supported(
        f"{where}: MAV_CMD {cmd} not supported (NAV_WAYPOINT 16, NAV_RETURN_TO_LAUNCH 20, "
        "NAV_LAND 21, NAV_TAKEOFF 22, DO_CHANGE_SPEED 178 are)")
