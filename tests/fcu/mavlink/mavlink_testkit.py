"""Test kit for the MAVLink endpoint: a plausible fake vehicle, a threaded vehicle on loopback
UDP, and a pymavlink ground station.

Every socket is bound on 127.0.0.1 to a free port chosen by the OS, so tests run in parallel.
All waits are bounded by generous wall-clock timeouts; no test asserts on tight timing.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pymavlink import mavutil

from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.endpoint_config import EndpointConfig
from fcu.mavlink.enums import MavState, Severity
from fcu.mavlink.port_records import (
    AttitudeTarget,
    CommandResult,
    GeoPoint,
    LandedState,
    MissionItem,
    MissionItemReached,
    MissionState,
    ParamSpec,
    PositionTarget,
    SimTruth,
    StatusText,
    VehicleEvent,
    VehicleSnapshot,
)
from fcu.mavlink.protocols.follow_target import LeadReport
from fcu.mavlink.transport.codec import mavlink2
from fcu.mavlink.transport.udp import UdpLink
from fcu.navigation.modes import Mode

M = mavlink2
ORIGIN = GeoPoint(40.8908, 29.3788, 100.0)  # deg, deg, m AMSL (an arbitrary lab site)
WAIT_S = 5.0  # s, generous bound for any single answer over loopback
SUPPORTED_MODES = {Mode.STABILIZE, Mode.ALT_HOLD, Mode.AUTO,
                   Mode.GUIDED, Mode.LOITER, Mode.RTL, Mode.LAND,
                   Mode.POSHOLD, Mode.BRAKE}
ARMABLE_MODES = {Mode.STABILIZE, Mode.ALT_HOLD, Mode.GUIDED,
                 Mode.LOITER, Mode.POSHOLD}
MISSION_COMMANDS = {M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_LAND,
                    M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_DO_CHANGE_SPEED}


class FakeVehicle:
    """A kinematic vehicle with ArduCopter-like rules; records every port call.

    It flies straight to its target at ``speed_m_s``, climbs for take-off, descends in LAND,
    flies missions item by item (reporting MISSION_ITEM_REACHED), and refuses what ArduCopter
    refuses (arming in AUTO/RTL/LAND, take-off outside GUIDED, go-to when disarmed, ...).
    """

    def __init__(self, origin: GeoPoint = ORIGIN) -> None:
        self.origin = origin
        self.time_s = 0.0
        self.armed = False
        self.mode = int(Mode.STABILIZE)
        self.pos_ned = np.zeros(3)
        self.vel_ned = np.zeros(3)
        self.yaw_rad = 0.0
        self.target: np.ndarray | None = None
        self.speed_m_s = 2.0
        self.home_pos_ned: np.ndarray | None = np.zeros(3)
        self.mission: list[MissionItem] = []
        self.mission_seq = 0
        self.mission_state = MissionState.NO_MISSION
        self.failsafes: dict[str, str] = {}
        self.prearm_ok = True
        self.reboots = 0
        self.sticks: Any = None
        self.calls: list[tuple[Any, ...]] = []
        self._events: list[VehicleEvent] = []
        self.param_values: dict[str, float] = {"WPNAV_SPEED": 5.0, "PSC_POSXY_P": 1.0,
                                               "ATC_RAT_RLL_P": 0.135}

    # ----------------------------------------------------------------- simulation
    @property
    def in_air(self) -> bool:
        return self.pos_ned[2] < -0.05

    def step(self, dt_s: float) -> None:
        """Advance simulated time by ``dt_s``."""
        self.time_s += dt_s
        if not self.armed or self.target is None:
            self.vel_ned = np.zeros(3)
            return
        delta = self.target - self.pos_ned
        dist = float(np.linalg.norm(delta))
        step = self.speed_m_s * dt_s
        if dist <= step:
            self.pos_ned = self.target.copy()
            self.vel_ned = np.zeros(3)
            self._arrived()
        else:
            self.vel_ned = delta / dist * self.speed_m_s
            self.pos_ned = self.pos_ned + self.vel_ned * dt_s

    def _arrived(self) -> None:
        if self.mode == Mode.LAND and not self.in_air:
            self.armed = False
            self.target = None
            self._events.append(StatusText(Severity.INFO, "Landed, disarmed"))
        elif self.mode == Mode.AUTO and self.mission_state == MissionState.ACTIVE:
            self._events.append(MissionItemReached(self.mission_seq))
            if self.mission_seq >= len(self.mission):
                self.mission_state = MissionState.COMPLETE
            else:
                self.mission_seq += 1
                self._fly_item()

    def _fly_item(self) -> None:
        item = self.mission[self.mission_seq - 1]
        north, east = item.north_east_m if item.north_east_m else self.pos_ned[:2]
        down = item.down_m if item.down_m is not None else self.pos_ned[2]
        if item.command == M.MAV_CMD_NAV_TAKEOFF and item.alt_m is not None:
            north, east, down = self.pos_ned[0], self.pos_ned[1], -item.alt_m
        self.target = np.array([north, east, down], dtype=float)

    def snapshot(self) -> VehicleSnapshot:
        landed = LandedState.IN_AIR if self.in_air else LandedState.ON_GROUND
        if self.in_air and self.mode == Mode.LAND:
            landed = LandedState.LANDING
        ref = None if self.target is None else PositionTarget(pos_ned=self.target.copy(),
                                                               yaw_rad=self.yaw_rad)
        euler = np.array([0.0, 0.0, self.yaw_rad])
        return VehicleSnapshot(
            time_s=self.time_s, armed=self.armed, custom_mode=self.mode,
            pos_ned=self.pos_ned.copy(), vel_ned=self.vel_ned.copy(), euler_rad=euler,
            rate_frd=np.zeros(3), origin=self.origin,
            home_pos_ned=None if self.home_pos_ned is None else self.home_pos_ned.copy(),
            system_status=MavState.ACTIVE if self.in_air else MavState.STANDBY,
            landed_state=landed, position_target=ref,
            attitude_target=AttitudeTarget(euler_rad=euler, thrust=0.5 if self.armed else 0.0),
            pwm=np.full(4, 0.02 if self.armed else 0.0),
            truth=SimTruth(pos_ned=self.pos_ned.copy(), vel_ned=self.vel_ned.copy(),
                           quat_wxyz=np.array([math.cos(self.yaw_rad / 2), 0.0, 0.0,
                                               math.sin(self.yaw_rad / 2)]),
                           rate_frd=np.zeros(3), accel_frd=np.array([0.0, 0.0, -9.81])),
            loe=np.array([0.0, 0.25, 0.0, 0.0]), mission_seq=self.mission_seq,
            mission_state=self.mission_state, failsafe_active=bool(self.failsafes))

    def say(self, severity: int, text: str) -> None:
        """Queue a STATUSTEXT event, as the navigator would."""
        self._events.append(StatusText(severity, text))

    def drain_events(self) -> list[VehicleEvent]:
        events, self._events = self._events, []
        return events

    # ----------------------------------------------------------------- commands
    def _call(self, *call: Any) -> None:
        self.calls.append(call)

    def arm(self, *, force: bool) -> CommandResult:
        self._call("arm", force)
        if self.armed:
            return CommandResult.ok()
        if not force and self.mode not in ARMABLE_MODES:
            return CommandResult.denied(f"Arm: mode {self.mode} not armable")
        if not force and (not self.prearm_ok or self.failsafes):
            return CommandResult.denied("Arm: pre-arm checks failed")
        self.armed = True
        return CommandResult.ok()

    def prearm_check(self) -> CommandResult:
        self._call("prearm_check")
        if not self.armed and self.mode not in ARMABLE_MODES:
            return CommandResult.denied(f"Arm: mode {self.mode} not armable")
        if not self.armed and (not self.prearm_ok or self.failsafes):
            return CommandResult.denied("Arm: pre-arm checks failed")
        return CommandResult.ok()

    def disarm(self, *, force: bool) -> CommandResult:
        self._call("disarm", force)
        if self.in_air and not force:
            return CommandResult.denied("Disarm: in flight")
        self.armed = False
        self.target = None
        return CommandResult.ok()

    def set_mode(self, custom_mode: int) -> CommandResult:
        self._call("set_mode", custom_mode)
        if custom_mode not in SUPPORTED_MODES:
            return CommandResult.denied(f"Mode {custom_mode} not supported")
        if custom_mode == Mode.AUTO and not self.mission:
            return CommandResult.denied("AUTO: no mission")
        self.mode = custom_mode
        if custom_mode == Mode.LAND:
            self.target = np.array([self.pos_ned[0], self.pos_ned[1], 0.0])
        elif custom_mode == Mode.RTL and self.home_pos_ned is not None:
            self.target = self.home_pos_ned.copy()
        return CommandResult.ok()

    def takeoff(self, alt_m: float) -> CommandResult:
        self._call("takeoff", alt_m)
        if self.mode != Mode.GUIDED or not self.armed:
            return CommandResult.denied("Takeoff: needs GUIDED and armed")
        self.target = np.array([self.pos_ned[0], self.pos_ned[1], -alt_m])
        return CommandResult.ok()

    def land(self) -> CommandResult:
        self._call("land")
        return self.set_mode(Mode.LAND)

    def return_to_launch(self) -> CommandResult:
        self._call("rtl")
        if self.home_pos_ned is None:
            return CommandResult.denied("RTL: no home")
        return self.set_mode(Mode.RTL)

    def goto(self, pos_ned: np.ndarray, yaw_rad: float | None) -> CommandResult:
        self._call("goto", np.asarray(pos_ned, dtype=float).copy(), yaw_rad)
        if self.mode != Mode.GUIDED or not self.armed:
            return CommandResult.denied("Goto: needs GUIDED and armed")
        self.target = np.asarray(pos_ned, dtype=float).copy()
        if yaw_rad is not None:
            self.yaw_rad = yaw_rad
        return CommandResult.ok()

    def set_velocity(self, vel_ned: np.ndarray, yaw_rad: float | None,
                     yaw_rate_rad_s: float | None, heading_frame: bool) -> CommandResult:
        self._call("set_velocity", np.asarray(vel_ned, dtype=float).copy(), yaw_rad,
                   yaw_rate_rad_s, heading_frame)
        return CommandResult.ok()

    def set_attitude(self, roll_rad: float, pitch_rad: float, yaw_rad: float | None,
                     thrust: float) -> CommandResult:
        self._call("set_attitude", roll_rad, pitch_rad, yaw_rad, thrust)
        return CommandResult.ok()

    def change_speed(self, speed_m_s: float, speed_type: str) -> CommandResult:
        self._call("change_speed", speed_m_s, speed_type)
        if speed_type == "ground":
            self.speed_m_s = speed_m_s
        return CommandResult.ok()

    def set_home(self, pos_ned: np.ndarray | None) -> CommandResult:
        self._call("set_home", None if pos_ned is None else np.asarray(pos_ned).copy())
        self.home_pos_ned = self.pos_ned.copy() if pos_ned is None else np.asarray(
            pos_ned, dtype=float).copy()
        return CommandResult.ok()

    def fence_set(self, areas: Any) -> CommandResult:
        self._call("fence_set", areas)
        self.fence = areas
        return CommandResult.ok()

    def mission_set(self, items: Sequence[MissionItem]) -> CommandResult:
        self._call("mission_set", list(items))
        for item in items:
            if item.command not in MISSION_COMMANDS:
                return CommandResult.not_supported(f"item {item.seq}: command "
                                                   f"{item.command} not supported")
        self.mission = list(items)
        self.mission_seq = 1 if items else 0
        self.mission_state = MissionState.NOT_STARTED if items else MissionState.NO_MISSION
        return CommandResult.ok()

    def mission_start(self) -> CommandResult:
        self._call("mission_start")
        if not self.mission:
            return CommandResult.denied("no mission")
        if not self.armed:
            return CommandResult.denied("Mission start: not armed")
        self.mode = int(Mode.AUTO)
        self.mission_state = MissionState.ACTIVE
        self._fly_item()
        return CommandResult.ok()

    def mission_set_current(self, seq: int) -> CommandResult:
        self._call("mission_set_current", seq)
        if not 1 <= seq <= len(self.mission):
            return CommandResult.denied(f"seq {seq} outside 1..{len(self.mission)}")
        self.mission_seq = seq
        return CommandResult.ok()

    def reboot(self) -> CommandResult:
        self._call("reboot")
        if self.armed:
            return CommandResult.denied("Reboot: disarm first")
        self.reboots += 1
        return CommandResult.ok()

    def trigger_failsafe(self, source: str, action: str) -> CommandResult:
        self._call("trigger_failsafe", source, action)
        self.failsafes[source] = action
        if self.armed and self.in_air:
            return self.set_mode(Mode.RTL if action == "rtl" else Mode.LAND)
        self.armed = False
        return CommandResult.ok()

    def set_sticks(self, sticks: Any) -> CommandResult:
        self._call("set_sticks", sticks)
        self.sticks = sticks
        return CommandResult.ok()

    def clear_failsafe(self, source: str) -> CommandResult:
        self._call("clear_failsafe", source)
        self.failsafes.pop(source, None)
        return CommandResult.ok()

    def orbit(self, centre_ned: np.ndarray | None, radius_m: float | None,
              speed_m_s: float | None) -> CommandResult:
        self._call("orbit", centre_ned, radius_m, speed_m_s)
        return CommandResult.ok()

    def follow_target(self, report: LeadReport) -> None:
        self._call("follow_target", report)

    # ----------------------------------------------------------------- parameters
    def param_specs(self) -> list[ParamSpec]:
        v = self.param_values
        return [
            ParamSpec(name="WPNAV_SPEED", value=v["WPNAV_SPEED"], min_value=0.1,
                      max_value=20.0, description="Horizontal cruise speed, m/s"),
            ParamSpec(name="PSC_POSXY_P", value=v["PSC_POSXY_P"], min_value=0.0,
                      max_value=10.0, description="Position P gain, 1/s"),
            ParamSpec(name="ATC_RAT_RLL_P", value=v["ATC_RAT_RLL_P"], min_value=0.0,
                      max_value=1.0, description="Roll rate P gain"),
        ]

    def set_param(self, name: str, value: float) -> CommandResult:
        self._call("set_param", name, value)
        if name == "WPNAV_SPEED" and value > 15.0 and self.armed:
            return CommandResult.denied("above 15 m/s only when disarmed")
        self.param_values[name] = value
        return CommandResult.ok()


@dataclass
class FakeInjector:
    """Supports motor OFF/WRONG/OK and gyro STUCK; everything else UNSUPPORTED."""

    calls: list[tuple[int, int, int]] = field(default_factory=list)
    times: list[float | None] = field(default_factory=list)

    def inject_failure(self, unit: int, failure_type: int, instance: int,
                       at_s: float | None = None) -> CommandResult:
        self.calls.append((unit, failure_type, instance))
        self.times.append(at_s)
        if unit == M.FAILURE_UNIT_SYSTEM_MOTOR and failure_type in (0, 1, 4):
            if instance > 4:
                return CommandResult.denied(f"motor {instance} does not exist")
            return CommandResult.ok()
        if unit == M.FAILURE_UNIT_SENSOR_GYRO and failure_type in (0, 2):
            return CommandResult.ok()
        return CommandResult.not_supported(f"failure {unit}/{failure_type} not simulated")


class VehicleThread:
    """A fake vehicle and its endpoint on loopback UDP, stepped in a background thread.

    Simulated time advances ``speedup`` times faster than the wall clock. The loop holds
    ``lock`` while stepping; hold it to read or change the vehicle from a test.
    """

    def __init__(self, gcs_ports: Sequence[int], *, speedup: float = 1.0,
                 config: EndpointConfig | None = None, injector: bool = True,
                 period_s: float = 0.002) -> None:
        self.vehicle = FakeVehicle()
        self.injector = FakeInjector() if injector else None
        self.link = UdpLink("127.0.0.1", 0, default_peers=[("127.0.0.1", p) for p in gcs_ports])
        self.endpoint = MavlinkEndpoint(self.vehicle, self.link, config=config,
                                        injector=self.injector)
        self.speedup = speedup
        self.lock = threading.Lock()
        self._period_s = period_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self.error: BaseException | None = None

    @property
    def port(self) -> int:
        return self.link.local_address[1]

    def _run(self) -> None:
        last = time.monotonic()
        try:
            while not self._stop.is_set():
                with self.lock:
                    now = time.monotonic()
                    self.vehicle.step((now - last) * self.speedup)
                    last = now
                    self.endpoint.tick(self.vehicle.time_s, now)
                time.sleep(self._period_s)
        except BaseException as err:  # surfaced by stop()
            self.error = err

    def start(self) -> VehicleThread:
        self.link.open()
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10.0)
        self.link.close()
        if self.error is not None:
            raise self.error

    def __enter__(self) -> VehicleThread:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


class Gcs:
    """A pymavlink ground station listening on a free loopback port (``udpin``).

    The connection speaks MAVLink 2 with the ardupilotmega dialect from the first byte: the
    dialect module is chosen explicitly instead of through mavutil's environment variables.
    """

    def __init__(self, sysid: int = 255, compid: int = 190) -> None:
        self.conn = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=sysid,
                                               source_component=compid)
        self.conn.WIRE_PROTOCOL_VERSION = "2.0"
        self.conn.first_byte = False
        self.conn.mav = mavlink2.MAVLink(self.conn, srcSystem=sysid, srcComponent=compid)
        self.conn.mav.robust_parsing = True
        self.mav = self.conn.mav
        self.port = int(self.conn.port.getsockname()[1])
        self.sysid, self.compid = sysid, compid

    def close(self) -> None:
        self.conn.close()

    def __enter__(self) -> Gcs:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def recv(self, kind: str | Sequence[str] | None = None, timeout_s: float = WAIT_S,
             condition: Callable[[Any], bool] | None = None) -> Any:
        """The next message of ``kind`` satisfying ``condition``, or None after the timeout."""
        kinds = None if kind is None else [kind] if isinstance(kind, str) else list(kind)
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            msg = self.conn.recv_match(type=kinds, blocking=True, timeout=min(left, 0.2))
            if msg is None or msg.get_type() == "BAD_DATA":
                continue
            if condition is None or condition(msg):
                return msg

    def collect(self, kind: str | Sequence[str], duration_s: float,
                condition: Callable[[Any], bool] | None = None) -> list[Any]:
        """Every message of ``kind`` (satisfying ``condition``) received for ``duration_s``."""
        kinds = [kind] if isinstance(kind, str) else list(kind)
        out: list[Any] = []
        deadline = time.monotonic() + duration_s
        while (left := deadline - time.monotonic()) > 0:
            msg = self.conn.recv_match(type=kinds, blocking=True, timeout=min(left, 0.2))
            if msg is not None and (condition is None or condition(msg)):
                out.append(msg)
        return out

    def gather(self, wanted: dict[str, Callable[[Any], bool]],
               timeout_s: float = WAIT_S) -> dict[str, Any]:
        """The first message of each kind in ``wanted`` that satisfies its condition, in any
        order; kinds not seen before the timeout are missing from the result."""
        found: dict[str, Any] = {}
        deadline = time.monotonic() + timeout_s
        while len(found) < len(wanted) and (left := deadline - time.monotonic()) > 0:
            msg = self.conn.recv_match(type=[k for k in wanted if k not in found],
                                       blocking=True, timeout=min(left, 0.2))
            if msg is not None and wanted[msg.get_type()](msg):
                found[msg.get_type()] = msg
        return found

    def text(self, predicate: Callable[[str], bool], timeout_s: float = WAIT_S) -> str | None:
        """The first STATUSTEXT whose text (chunks reassembled) satisfies ``predicate``."""
        partial: dict[int, list[str]] = {}
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            msg = self.conn.recv_match(type="STATUSTEXT", blocking=True, timeout=min(left, 0.2))
            if msg is None:
                continue
            if msg.id == 0:
                whole = msg.text
            else:
                chunks = partial.setdefault(msg.id, [])
                chunks.append(msg.text)
                if len(msg.text) == 50:
                    continue
                whole = "".join(partial.pop(msg.id))
            if predicate(whole):
                return str(whole)
        return None

    def wait_vehicle(self) -> Any:
        """The first HEARTBEAT of the autopilot; afterwards writes go to the vehicle."""
        hb = self.recv("HEARTBEAT", condition=lambda m: m.get_srcComponent() == 1)
        assert hb is not None, "no HEARTBEAT from the vehicle"
        return hb

    def heartbeat(self) -> None:
        self.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def command_long(self, command: int, *params: float, target_system: int = 1,
                     target_component: int = 1) -> None:
        p = list(params) + [0.0] * (7 - len(params))
        self.mav.command_long_send(target_system, target_component, command, 0, *p)

    def command_int(self, command: int, frame: int, params: Sequence[float], x: int, y: int,
                    z: float) -> None:
        p = list(params) + [0.0] * (4 - len(params))
        self.mav.command_int_send(1, 1, frame, command, 0, 0, *p, x, y, z)

    def acks(self, command: int, grace_s: float = 0.5, timeout_s: float = WAIT_S) -> list[Any]:
        """All COMMAND_ACKs for ``command``: waits for the first, then ``grace_s`` more."""
        first = self.recv("COMMAND_ACK", timeout_s, lambda m: m.command == command)
        if first is None:
            return []
        return [first] + self.collect("COMMAND_ACK", grace_s, lambda m: m.command == command)

    def ack(self, command: int, *params: float) -> Any:
        """Send COMMAND_LONG and return its single ACK (asserting there is exactly one)."""
        self.command_long(command, *params)
        acks = self.acks(command)
        assert len(acks) == 1, f"command {command}: {len(acks)} ACKs"
        return acks[0]

    def statustexts(self, duration_s: float = 1.0) -> list[str]:
        return [m.text for m in self.collect("STATUSTEXT", duration_s)]


def started(gcs: Gcs, **kwargs: Any) -> VehicleThread:
    """A running vehicle that sends to ``gcs``; waits for its first heartbeat."""
    vehicle = VehicleThread([gcs.port], **kwargs).start()
    try:
        gcs.wait_vehicle()
    except BaseException:
        vehicle.stop()
        raise
    return vehicle


@contextmanager
def linked(**kwargs: Any) -> Iterator[tuple[Gcs, VehicleThread]]:
    """A ground station and a vehicle sending to it (:func:`started` with ``kwargs``); the
    vehicle is stopped and the station closed on the way out. Whatever the test sent, the
    endpoint must have answered it without an error in a handler or in building a message."""
    with Gcs() as gcs:
        vehicle = started(gcs, **kwargs)
        try:
            yield gcs, vehicle
        finally:
            vehicle.stop()
        stats = vehicle.endpoint.stats
        assert (stats.handler_errors, stats.build_errors) == (0, 0), stats


GCS_ADDR = ("127.0.0.1", 50000)  # a made-up peer address for in-memory tests


class MemoryLink:
    """An in-memory Link: tests put datagrams in ``inbox`` and read what was sent."""

    def __init__(self) -> None:
        self.inbox: list[tuple[bytes, tuple[str, int]]] = []
        self.sent: list[tuple[bytes, tuple[str, int] | None]] = []
        self.peers: list[tuple[str, int]] = []
        self._parser = mavlink2.MAVLink(None)
        self._parser.robust_parsing = True

    def send(self, data: bytes, to: tuple[str, int] | None = None) -> None:
        self.sent.append((data, to))

    def receive(self) -> list[tuple[bytes, tuple[str, int]]]:
        out, self.inbox = self.inbox, []
        return out

    def add_peer(self, peer: tuple[str, int]) -> None:
        if peer not in self.peers:
            self.peers.append(peer)

    def take(self, kind: str | None = None) -> list[Any]:
        """Decode and forget everything sent so far; keep only ``kind`` when given."""
        out = []
        for data, _ in self.sent:
            for msg in self._parser.parse_buffer(data) or []:
                if kind is None or msg.get_type() == kind:
                    out.append(msg)
        self.sent = []
        return out


class MemoryGcs:
    """Packs messages as a ground station (sysid 255, compid 190) into a MemoryLink."""

    def __init__(self, link: MemoryLink, sysid: int = 255, compid: int = 190) -> None:
        self.link = link
        self.mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)

    def put(self, msg: Any) -> None:
        data = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        self.link.inbox.append((data, GCS_ADDR))


def memory_endpoint(config: EndpointConfig | None = None, injector: bool = True
                    ) -> tuple[MavlinkEndpoint, FakeVehicle, MemoryLink, MemoryGcs]:
    """An endpoint on a MemoryLink, stepped by the test (deterministic clocks: the receive
    budget's wall clock stands still, so a loaded machine cannot leave datagrams unread)."""
    vehicle = FakeVehicle()
    link = MemoryLink()
    endpoint = MavlinkEndpoint(vehicle, link, config=config,
                               injector=FakeInjector() if injector else None,
                               clock=lambda: 0.0)
    return endpoint, vehicle, link, MemoryGcs(link)


@dataclass(frozen=True)
class Item:
    """A mission item as a test writes it (x, y in degrees or metres, z in metres)."""

    command: int
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    frame: int = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    current: int = 0

    def message(self, seq: int, legacy: bool) -> Any:
        """MISSION_ITEM (floats) or MISSION_ITEM_INT (degE7 / metres * 1e4)."""
        if legacy:
            return M.MAVLink_mission_item_message(
                1, 1, seq, self.frame, self.command, self.current, 1, *self.params, self.x,
                self.y, self.z, M.MAV_MISSION_TYPE_MISSION)
        scale = 1e4 if self.frame == M.MAV_FRAME_LOCAL_NED else 1e7
        return M.MAVLink_mission_item_int_message(
            1, 1, seq, self.frame, self.command, self.current, 1, *self.params,
            _scaled(self.x, scale), _scaled(self.y, scale), self.z, M.MAV_MISSION_TYPE_MISSION)


def _scaled(value: float, scale: float) -> int:
    return 0 if not math.isfinite(value) else round(value * scale)


@dataclass
class Upload:
    """How an upload went: the final MISSION_ACK (None if none) and every request seen."""

    ack: Any
    requests: list[tuple[str, int]]


def upload(gcs: Gcs, items: Sequence[Item], *, legacy: bool = False,
           drop_first: Sequence[int] = (), answer_until: int | None = None,
           timeout_s: float = 3 * WAIT_S) -> Upload:
    """Upload ``items`` (seq 0 = home first) the way a ground station does.

    ``drop_first``: seqs whose first transmission is lost. ``answer_until``: stop answering
    requests for seq >= this (a stalled ground station).
    """
    gcs.mav.mission_count_send(1, 1, len(items), M.MAV_MISSION_TYPE_MISSION)
    dropped: set[int] = set()
    requests: list[tuple[str, int]] = []
    deadline = time.monotonic() + timeout_s
    while (left := deadline - time.monotonic()) > 0:
        msg = gcs.conn.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"],
                                  blocking=True, timeout=min(left, 0.2))
        if msg is None:
            continue
        if msg.get_type() == "MISSION_ACK":
            return Upload(msg, requests)
        requests.append((msg.get_type(), msg.seq))
        if answer_until is not None and msg.seq >= answer_until:
            continue
        if msg.seq in drop_first and msg.seq not in dropped:
            dropped.add(msg.seq)
            continue
        gcs.mav.send(items[msg.seq].message(msg.seq, legacy))
    return Upload(None, requests)


def _seq_is(seq: int) -> Callable[[Any], bool]:
    return lambda m: bool(m.seq == seq)


def download(gcs: Gcs, *, legacy: bool = False) -> list[Any]:
    """Download the mission (home included) with MISSION_REQUEST_INT or MISSION_REQUEST."""
    gcs.mav.mission_request_list_send(1, 1, M.MAV_MISSION_TYPE_MISSION)
    count = gcs.recv("MISSION_COUNT")
    assert count is not None, "no MISSION_COUNT"
    kind = "MISSION_ITEM" if legacy else "MISSION_ITEM_INT"
    out = []
    for seq in range(count.count):
        if legacy:
            gcs.mav.mission_request_send(1, 1, seq, M.MAV_MISSION_TYPE_MISSION)
        else:
            gcs.mav.mission_request_int_send(1, 1, seq, M.MAV_MISSION_TYPE_MISSION)
        item = gcs.recv(kind, condition=_seq_is(seq))
        assert item is not None, f"no {kind} {seq}"
        out.append(item)
    gcs.mav.mission_ack_send(1, 1, M.MAV_MISSION_ACCEPTED, M.MAV_MISSION_TYPE_MISSION)
    return out
