"""What MAVSDK-Python's examples do, done against the vehicle, with both MAVSDK packages.

Each test below is written here and does what one example of the MAVSDK-Python repository
(``examples/*.py``) does, with the same API calls in the same order, against a vehicle
started as the examples expect one (``--home`` at PX4's default home, 47.397742 N,
8.545594 E, 488 m): first with ``mavsdk-grpc`` (import ``mavsdk_grpc``, the API those
examples are written for; its ``mavsdk_server`` is started from the wheel on a free
loopback port), then with ``mavsdk`` 4 (the native binding, same plugins). The examples'
``asyncio.sleep`` pauses, which wait for the vehicle to get somewhere, become waits on its
telemetry; everything else is as the example has it, but for the port (a free loopback
port, not 14540). The README's MAVSDK table lists each example with the test behind it.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import json
import math
import socket
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.calibration import CalibrationAsync
from mavsdk.asyncio.plugins.failure import FailureAsync
from mavsdk.asyncio.plugins.follow_me import FollowMeAsync
from mavsdk.asyncio.plugins.geofence import GeofenceAsync
from mavsdk.asyncio.plugins.manual_control import ManualControlAsync
from mavsdk.asyncio.plugins.mission import MissionAsync
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
from mavsdk.asyncio.plugins.param import ParamAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
from mavsdk_grpc import System
from mavsdk_grpc.server_utility import StatusTextType
from mavsdk_grpc.telemetry import LandedState as GrpcLandedState
from mavsdk_grpc.tune import SongElement, TuneDescription
from test_mavsdk import STEP_S, bounded, first
from vehicle_harness import Gcs, M, free_port

PX4_HOME = "47.397742,8.545594,488"  # PX4 SITL's default home, what the examples assume
HOME_LAT, HOME_LON = 47.397742, 8.545594
SPEEDUP = 10
FLIGHT_S = 400.0  # s wall, a whole example on a loaded machine (pytest-timeout: 600 s)
SERVER_STOP_S = 30.0  # s wall, mavsdk_server exits once killed


# ------------------------------------------------------------------ harness
def start_example_vehicle(start_vehicle: Callable[..., Any], gcs: Gcs,
                          speedup: int = SPEEDUP) -> int:
    """A vehicle at PX4's home sending to a fresh API port (returned) and to ``gcs``."""
    api_port = free_port()
    start_vehicle("--home", PX4_HOME, "--speedup", str(speedup), outs=[api_port, gcs.port])
    gcs.start_reader()
    return api_port


@contextlib.asynccontextmanager
async def grpc_drone(api_port: int) -> AsyncIterator[Any]:
    """``System().connect(...)`` as the examples do, on free ports, then their wait for the
    connection; the server is stopped at the end (mavsdk_grpc only stops it when the object
    is collected)."""
    drone = System(port=free_port(socket.SOCK_STREAM))
    try:
        await bounded(drone.connect(system_address=f"udpin://127.0.0.1:{api_port}"))
        await grpc_connected(drone)
        yield drone
    finally:
        server = drone._server_process
        drone._stop_mavsdk_server()
        if server is not None:
            server.wait(timeout=SERVER_STOP_S)


async def grpc_connected(drone: Any) -> None:
    """The examples' first loop: wait for ``connection_state().is_connected``."""
    await first(drone.core.connection_state(), lambda state: state.is_connected)


class NativeDrone:
    """MAVSDK 4's plugins on the first autopilot, named as ``System`` names them."""

    PLUGINS = {"action": ActionAsync, "telemetry": TelemetryAsync, "param": ParamAsync,
               "mission": MissionAsync, "mission_raw": MissionRawAsync,
               "failure": FailureAsync, "calibration": CalibrationAsync,
               "geofence": GeofenceAsync, "follow_me": FollowMeAsync,
               "manual_control": ManualControlAsync}

    def __init__(self, system: Any) -> None:
        self._plugins = {name: cls(system) for name, cls in self.PLUGINS.items()}

    def __getattr__(self, name: str) -> Any:
        return self._plugins[name]

    def destroy(self) -> None:
        for plugin in self._plugins.values():
            plugin.destroy()


@contextlib.asynccontextmanager
async def native_drone(api_port: int) -> AsyncIterator[NativeDrone]:
    """MAVSDK 4 as a ground station on ``api_port``, once the autopilot is found."""
    mavsdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    drone: NativeDrone | None = None
    try:
        await bounded(mavsdk.add_any_connection(f"udpin://127.0.0.1:{api_port}"))
        system = await bounded(mavsdk.first_autopilot(timeout_s=STEP_S), STEP_S + 10.0)
        assert system is not None, "no autopilot heartbeat"
        drone = NativeDrone(system)
        yield drone
    finally:
        if drone is not None:
            drone.destroy()
        mavsdk.destroy()


def run_example(drone_on: Callable[[int], contextlib.AbstractAsyncContextManager[Any]],
                start_vehicle: Callable[..., Any], gcs: Gcs,
                steps: Callable[[Any], Awaitable[None]], speedup: int = SPEEDUP) -> None:
    """An example's vehicle, then ``steps`` on the drone ``drone_on`` connects to it."""
    api_port = start_example_vehicle(start_vehicle, gcs, speedup)

    async def scenario() -> None:
        async with drone_on(api_port) as drone:
            await steps(drone)

    asyncio.run(asyncio.wait_for(scenario(), FLIGHT_S))


def run_grpc(start_vehicle: Callable[..., Any], gcs: Gcs,
             steps: Callable[[Any], Awaitable[None]], speedup: int = SPEEDUP) -> None:
    run_example(grpc_drone, start_vehicle, gcs, steps, speedup)


def run_native(start_vehicle: Callable[..., Any], gcs: Gcs,
               steps: Callable[[Any], Awaitable[None]], speedup: int = SPEEDUP) -> None:
    run_example(native_drone, start_vehicle, gcs, steps, speedup)


@dataclass(frozen=True)
class Flavour:
    """What differs between the two packages in the examples' calls: the runner, where the
    plugins' classes are, the stream names (``health()`` / ``subscribe_health()``), ``home``
    (a stream / an awaitable) and how a refusal's result is read."""

    name: str  # the test id
    package: str  # the plugins' modules: ``<package>.<plugin>``
    native: bool

    def run(self, start_vehicle: Callable[..., Any], gcs: Gcs,
            steps: Callable[[Any], Awaitable[None]]) -> None:
        (run_native if self.native else run_grpc)(start_vehicle, gcs, steps)

    def plugin(self, name: str) -> ModuleType:
        """Plugin ``name``'s module: its classes, errors and results."""
        return importlib.import_module(f"{self.package}.{name}")

    def stream(self, plugin: Any, name: str) -> AsyncIterator[Any]:
        return getattr(plugin, f"subscribe_{name}" if self.native else name)()

    async def healthy(self, drone: Any) -> None:
        """The examples' wait for ``is_global_position_ok`` and ``is_home_position_ok``."""
        await first(self.stream(drone.telemetry, "health"),
                    lambda h: h.is_global_position_ok and h.is_home_position_ok)

    async def home(self, drone: Any) -> Any:
        if self.native:
            return await bounded(drone.telemetry.home())
        return await first(drone.telemetry.home(), lambda h: True)

    def results(self, result: type) -> Any:
        """The enum of a plugin's results (``MissionResult`` -> ``DENIED``, ...)."""
        return result if self.native else result.Result  # type: ignore[attr-defined]

    def result_of(self, error: BaseException) -> Any:
        """The result a plugin's error was raised with."""
        return error.result if self.native else error._result.result  # type: ignore[attr-defined]


GRPC = Flavour("grpc", "mavsdk_grpc", native=False)
NATIVE = Flavour("native", "mavsdk.asyncio.plugins", native=True)
BOTH = pytest.mark.parametrize("api", [GRPC, NATIVE], ids=lambda flavour: flavour.name)


def horizontal_m(lat_deg: float, lon_deg: float, to_lat: float, to_lon: float) -> float:
    """Distance on the local tangent plane (close enough over a few hundred metres)."""
    north = math.radians(to_lat - lat_deg) * 6_378_137.0
    east = math.radians(to_lon - lon_deg) * 6_378_137.0 * math.cos(math.radians(lat_deg))
    return math.hypot(north, east)


# ------------------------------------------------------------------ goto.py
GOTO_LAT, GOTO_LON = 47.397606, 8.543060  # the example's target, ~190 m west of home
GOTO_START_M = 191.5  # m from home to the target
ABOVE_TAKEOFF_M = 3.5  # m, above MAVSDK's default take-off altitude (2 m)


def on_the_way(pos: Any) -> bool:
    """Climbing towards the 20 m the example asks for (the vehicle used to refuse anything
    above 10 m) and 2 m closer to the target: the go-to was accepted and is being flown
    (the whole 190 m leg takes minutes of simulated time)."""
    return (pos.relative_altitude_m > ABOVE_TAKEOFF_M and horizontal_m(
        pos.latitude_deg, pos.longitude_deg, GOTO_LAT, GOTO_LON) < GOTO_START_M - 2.0)


@BOTH
def test_goto_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Any) -> None:
        await api.healthy(drone)
        home = await api.home(drone)
        await bounded(drone.action.arm())
        await bounded(drone.action.takeoff())
        await first(api.stream(drone.telemetry, "in_air"), bool)  # (the example sleeps 1 s)
        flying_alt = home.absolute_altitude_m + 20.0
        await bounded(drone.action.goto_location(GOTO_LAT, GOTO_LON, flying_alt, 0))
        # (the example then waits forever): on its way up and west
        await first(api.stream(drone.telemetry, "position"), on_the_way, FLIGHT_S)

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ mission_raw.py
RAW_POINTS = ((47.40271757, 8.54285027), (47.40271757, 8.54361892))  # the example's, 30 m


def raw_fields(seq: int, lat: float, lon: float) -> tuple[Any, ...]:
    """The example's item ``seq``: frame 3 (global, relative altitude), NAV_WAYPOINT,
    param2 (acceptance radius) 10, param4 NaN, 30 m."""
    return (seq, 3, 16, 1 if seq == 0 else 0, 1, 0, 10, 0, float("nan"),
            int(lat * 10**7), int(lon * 10**7), 30.0, 0)


def check_raw_download(items: list[Any]) -> None:
    """ArduPilot's convention: seq 0 is home, so the example's first point is taken as home
    (not stored) and its second is item 1, at 30 m above home."""
    assert len(items) == 2
    assert (items[1].command, items[1].x, items[1].y) == (16, *raw_fields(1, *RAW_POINTS[1])[9:11])
    assert items[1].z == pytest.approx(30.0)


@BOTH
def test_mission_raw_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    item = api.plugin("mission_raw").MissionItem

    async def steps(drone: Any) -> None:
        items = [item(*raw_fields(seq, *point)) for seq, point in enumerate(RAW_POINTS)]
        await bounded(drone.mission_raw.upload_mission(items))
        check_raw_download(list(await bounded(drone.mission_raw.download_mission())))

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ mission.py
MISSION_POINTS = ((47.398039859999997, 8.5455725400000002),
                  (47.398036222362471, 8.5450146439425509),
                  (47.397825620791885, 8.5450092830163271))
NAN = float("nan")


def mission_args(lat: float, lon: float, none_camera: Any, none_vehicle: Any) -> tuple[Any, ...]:
    """The example's item: 25 m, 10 m/s, fly-through, everything else NaN / NONE."""
    return (lat, lon, 25, 10, True, NAN, NAN, none_camera, NAN, NAN, NAN, NAN, NAN,
            none_vehicle)


TAKEOFF_REFUSAL = "must be NAV_TAKEOFF"  # ArduCopter: "Auto: Missing Takeoff Cmd"


@BOTH
def test_mission_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    """Upload (with the RTL item MAVSDK adds, param1 NaN) and arming pass; starting is
    refused as ArduCopter refuses it: MAVSDK's Mission plugin puts no NAV_TAKEOFF first,
    and ArduCopter does not take off into a waypoint from the ground."""
    mission = api.plugin("mission")
    item = mission.MissionItem

    async def steps(drone: Any) -> None:
        items = [item(*mission_args(lat, lon, item.CameraAction.NONE, item.VehicleAction.NONE))
                 for lat, lon in MISSION_POINTS]
        await bounded(drone.mission.set_return_to_launch_after_mission(True))
        since = gcs.mark()
        await bounded(drone.mission.upload_mission(mission.MissionPlan(items)))
        gcs.wait_text("mission of", since)
        await api.healthy(drone)
        await bounded(drone.action.arm())
        since = gcs.mark()
        with pytest.raises(mission.MissionError) as refused:
            await bounded(drone.mission.start_mission())
        assert api.result_of(refused.value) == api.results(mission.MissionResult).DENIED
        gcs.wait_text(TAKEOFF_REFUSAL, since)

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ failure_injection.py
@BOTH
def test_failure_injection_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    failure = api.plugin("failure")

    async def steps(drone: Any) -> None:
        await api.healthy(drone)
        await bounded(drone.param.set_param_int("SYS_FAILURE_EN", 1))
        await bounded(drone.action.arm())
        await bounded(drone.action.takeoff())
        await first(api.stream(drone.telemetry, "in_air"), bool)  # (the example sleeps 5 s)
        position = await first(api.stream(drone.telemetry, "position"),
                               lambda p: p.latitude_deg and p.longitude_deg)
        flying_alt = position.absolute_altitude_m + 20.0
        await bounded(drone.action.goto_location(position.latitude_deg,
                                                 position.longitude_deg, flying_alt, 0))
        await first(api.stream(drone.telemetry, "position"),  # (the example sleeps 5 s)
                    lambda p: p.relative_altitude_m > position.relative_altitude_m + 1.0)
        since = gcs.mark()
        await bounded(drone.failure.inject(failure.FailureUnit.SENSOR_GPS,
                                           failure.FailureType.OFF, instance=0))
        gcs.wait_text("injected", since)  # the vehicle says what it injected
        await bounded(drone.param.set_param_int("SYS_FAILURE_EN", 0))

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ highres_imu.py
def check_imu(imu: Any) -> None:
    """At rest on the ground: the accelerometer reads -g along down, the gyro about 0."""
    assert imu.acceleration_frd.down_m_s2 == pytest.approx(-9.81, abs=0.5)  # noise, bias
    assert abs(imu.angular_velocity_frd.down_rad_s) < 0.1  # rad/s: gyro noise and bias
    assert imu.timestamp_us > 0 and math.isfinite(imu.temperature_degc)


@BOTH
def test_highres_imu_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Any) -> None:
        telemetry = drone.telemetry
        await bounded(telemetry.set_rate_imu(200.0))  # (one per autopilot tick at most)
        check_imu(await first(api.stream(telemetry, "imu"), lambda imu: True))

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ calibration.py
# MAVSDK's Calibration plugin answers UNSUPPORTED by itself unless the autopilot is PX4:
# each calibrate_*() and cancel() of cpp/src/mavsdk/plugins/calibration/calibration_impl.cpp
# begins ``if (_system_impl->effective_autopilot() != Autopilot::Px4) { call_callback(
# callback, Calibration::Result::Unsupported, {}); return; }`` (line 50 for calibrate_gyro;
# MAVSDK commit 3c319e198, "calibration: return unsupported unless PX4", January 2026: its
# progress comes from PX4's "[cal]" STATUSTEXTs). The autopilot is what the HEARTBEAT's
# ``autopilot`` field says (system_impl.cpp: MAV_AUTOPILOT_PX4 -> Px4, ARDUPILOTMEGA ->
# ArduPilot); only a client-side CompatibilityMode::Px4 overrides it, which neither package's
# Python API exposes. Nothing reaches the wire (seen with a proxy between the two). A vehicle
# that said MAV_AUTOPILOT_PX4 would have its ArduCopter custom modes decoded as PX4's, so
# this one stays ArduPilot and the example cannot pass. The vehicle answers
# PREFLIGHT_CALIBRATION itself (tests/fcu/mavlink/protocols/test_calibration.py, and below
# through pymavlink), so QGroundControl's calibration screens can be exercised.
@BOTH
def test_calibration_example_is_refused_by_mavsdk(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    calibration = api.plugin("calibration")

    async def steps(drone: Any) -> None:
        with pytest.raises(calibration.CalibrationError) as refused:
            async for _ in drone.calibration.calibrate_gyro():
                pass
        unsupported = api.results(calibration.CalibrationResult).UNSUPPORTED
        assert api.result_of(refused.value) == unsupported
        ack = gcs.command(M.MAV_CMD_PREFLIGHT_CALIBRATION, 1, 0, 0, 0, 0, 0, 0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gcs.wait_text("[cal] calibration done: gyro", 0)

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ do_orbit.py
ORBIT_LAT, ORBIT_LON = 47.398036222362471, 8.5450146439425509  # the example's centre
CIRCLE = 7  # ArduCopter's CIRCLE mode, which flies DO_ORBIT


@BOTH
def test_do_orbit_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    """From the take-off on: orbit 10 m about the example's centre at 2 m/s, 10 m up (its
    60 s pause becomes: until the vehicle circles), then RTL."""
    hold_front = api.plugin("action").OrbitYawBehavior.HOLD_FRONT_TO_CIRCLE_CENTER

    async def steps(drone: Any) -> None:
        await api.healthy(drone)
        position = await first(api.stream(drone.telemetry, "position"), lambda p: True)
        orbit_height = position.absolute_altitude_m + 10
        await bounded(drone.action.arm())
        await bounded(drone.action.takeoff())
        await first(api.stream(drone.telemetry, "in_air"), bool)  # (the example sleeps 10 s)
        since = gcs.mark()
        await bounded(drone.action.do_orbit(
            radius_m=10, velocity_ms=2, yaw_behavior=hold_front, latitude_deg=ORBIT_LAT,
            longitude_deg=ORBIT_LON, absolute_altitude_m=orbit_height))
        gcs.wait("HEARTBEAT", lambda m: m.custom_mode == CIRCLE, since=since)
        gcs.wait_text("circling", since, timeout_s=FLIGHT_S / 2)
        await bounded(drone.action.return_to_launch())
        gcs.wait("HEARTBEAT", lambda m: m.custom_mode == 6, since=since)  # RTL

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ geofence.py
# The example sends its "no circle" placeholder, Circle(Point(0, 0), 0), which MAVSDK 4
# refuses itself (a radius of 0 is invalid input: INVALID_ARGUMENT before anything is sent).
# Without the placeholder the same polygon uploads, and reads back as a fence.
def fence_points(lat: float, lon: float) -> list[tuple[float, float]]:
    """The example's square, 0.0001 deg about home."""
    return [(lat - 0.0001, lon - 0.0001), (lat + 0.0001, lon - 0.0001),
            (lat + 0.0001, lon + 0.0001), (lat - 0.0001, lon + 0.0001)]


def seq_is(seq: int) -> Callable[[Any], bool]:
    return lambda m: bool(m.seq == seq)


def download_fence(gcs: Gcs) -> list[Any]:
    """The fence as the vehicle reports it (MAV_MISSION_TYPE_FENCE download, pymavlink)."""
    fence = M.MAV_MISSION_TYPE_FENCE
    since = gcs.mark()
    gcs.send(M.MAVLink_mission_request_list_message(1, 1, fence))
    count = gcs.wait("MISSION_COUNT", lambda m: m.mission_type == fence, since=since).count
    items = []
    for seq in range(count):
        since = gcs.mark()
        gcs.send(M.MAVLink_mission_request_int_message(1, 1, seq, fence))
        items.append(gcs.wait("MISSION_ITEM_INT", seq_is(seq), since=since))
    gcs.send(M.MAVLink_mission_ack_message(1, 1, M.MAV_MISSION_ACCEPTED, fence))
    return items


def check_fence(items: list[Any], points: list[tuple[float, float]]) -> None:
    assert [m.command for m in items] == [M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION] * 4
    assert [(m.x, m.y) for m in items] == [(round(a * 1e7), round(b * 1e7)) for a, b in points]
    assert all(m.param1 == 4 for m in items)  # the vertex count


@BOTH
def test_geofence_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    geofence = api.plugin("geofence")
    inclusion = geofence.FenceType.INCLUSION

    async def steps(drone: Any) -> None:
        home = await first(api.stream(drone.telemetry, "home"), lambda h: True)
        points = fence_points(home.latitude_deg, home.longitude_deg)
        polygon = geofence.Polygon([geofence.Point(a, b) for a, b in points], inclusion)
        circle = geofence.Circle(geofence.Point(0, 0), 0, inclusion)
        with pytest.raises(geofence.GeofenceError) as refused:
            await bounded(drone.geofence.upload_geofence(geofence.GeofenceData([polygon],
                                                                               [circle])))
        invalid = api.results(geofence.GeofenceResult).INVALID_ARGUMENT
        assert api.result_of(refused.value) == invalid
        await bounded(drone.geofence.upload_geofence(geofence.GeofenceData([polygon], [])))
        check_fence(download_fence(gcs), points)
        await bounded(drone.geofence.clear_geofence())
        assert download_fence(gcs) == []

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ mission_import.py
def write_plan(path: Path) -> Path:
    """A QGroundControl .plan as QGC writes one (our own, in the example's shape): take-off,
    two waypoints and RTL at PX4's home, and two rally points."""
    def item(command: int, frame: int, params: list[float | None]) -> dict[str, Any]:
        return {"type": "SimpleItem", "autoContinue": True, "command": command,
                "frame": frame, "params": params, "doJumpId": 1}

    lat, lon = HOME_LAT, HOME_LON
    plan = {
        "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "rallyPoints": {"points": [[lat - 0.0002, lon - 0.0003, 0],
                                   [lat + 0.0010, lon - 0.0003, 0]], "version": 2},
        "mission": {
            "cruiseSpeed": 15, "hoverSpeed": 5, "firmwareType": 3, "vehicleType": 2,
            "version": 2, "plannedHomePosition": [lat, lon, 488],
            "items": [item(22, 3, [0, 0, 0, None, lat, lon, 10]),
                      item(16, 3, [0, 0, 0, None, lat + 0.0003, lon, 10]),
                      item(16, 3, [0, 0, 0, None, lat + 0.0003, lon - 0.0004, 10]),
                      item(20, 2, [0, 0, 0, 0, 0, 0, 0])]}}
    path.write_text(json.dumps(plan))
    return path


def check_import(mission_items: list[Any], rally_items: list[Any]) -> None:
    assert len(mission_items) == 5 and len(rally_items) == 2  # home + 4; 2 rally points
    assert {m.mission_type for m in rally_items} == {M.MAV_MISSION_TYPE_RALLY}


@BOTH
def test_mission_import_example(api: Flavour, start_vehicle, gcs: Gcs, tmp_path: Path) -> None:
    plan = write_plan(tmp_path / "example-mission.plan")

    async def steps(drone: Any) -> None:
        out = await bounded(drone.mission_raw.import_qgroundcontrol_mission(str(plan)))
        check_import(out.mission_items, out.rally_items)
        await bounded(drone.mission_raw.upload_mission(out.mission_items))
        await bounded(drone.mission_raw.upload_rally_points(out.rally_items))
        assert len(await bounded(drone.mission_raw.download_mission())) == 5

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ follow_me_example.py
# MAVSDK's FollowMe plugin cannot drive an ArduPilot vehicle, for two reasons in its source
# (cpp/src/mavsdk/plugins/follow_me/follow_me_impl.cpp):
# - set_config() writes PX4's parameters FLW_TGT_HT, FLW_TGT_DST, FLW_TGT_FA, FLW_TGT_RS,
#   FLW_TGT_ALT_M, FLW_TGT_MAX_VEL (set_config, each changed value), which ArduCopter does
#   not have (its FOLLOW mode reads FOLL_*): SET_CONFIG_FAILED once they time out;
# - set_target_location() answers NOT_ACTIVE, and nothing sends FOLLOW_TARGET, until a
#   HEARTBEAT shows PX4's custom mode AUTO / FOLLOW_TARGET (process_heartbeat decodes the
#   custom mode as px4_custom_mode whatever the autopilot): ArduCopter's FOLLOW (23), which
#   start() does select (flight_mode_to_ardupilot_copter_mode), never reads as active.
# The test runs the example on past the first refusal to show the second, with two changes
# made through pymavlink: DISARM_DELAY 0 (set_config's retries take ~15 s, 150 s simulated at
# 10x, and the vehicle armed on the ground would disarm after 10) and FOLL_ENABLE 1
# (ArduCopter refuses FOLLOW without it). The vehicle's FOLLOW itself is tested with a
# pymavlink lead in test_follow_lead.py.
FOLLOW = 23  # ArduCopter's FOLLOW, what FollowMe.start() selects on ArduCopter
HOLD = (5, 17)  # what FollowMe.stop() (MAVSDK's Hold) selects on ArduCopter: LOITER from
# mavsdk-grpc 4.0.5's server, BRAKE from mavsdk 4.1's library
FAKE_LOCATIONS = ((47.398039859999997, 8.5455725400000002),  # the example's
                  (47.398036222362471, 8.5450146439425509),
                  (47.397825620791885, 8.5450092830163271))


def follow_me_config(cls: Any) -> Any:
    """The example's Config: height 8 m, distance 2 m, responsiveness 0.02, TARGET_GPS,
    10 m/s, angle 0."""
    return cls(8.0, 2.0, 0.02, cls.FollowAltitudeMode.TARGET_GPS, 10, 0)

@BOTH
def test_follow_me_example_is_refused_by_mavsdk(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    follow_me = api.plugin("follow_me")
    results = api.results(follow_me.FollowMeResult)

    async def steps(drone: Any) -> None:
        await api.healthy(drone)
        assert gcs.param_set("DISARM_DELAY", 0).param_value == 0  # (not in the example)
        await bounded(drone.action.arm())
        with pytest.raises(follow_me.FollowMeError) as refused:
            await bounded(drone.follow_me.set_config(follow_me_config(follow_me.Config)),
                          FLIGHT_S)
        assert api.result_of(refused.value) == results.SET_CONFIG_FAILED
        # the example from its take-off on
        assert gcs.param_set("FOLL_ENABLE", 1).param_value == 1  # (not in the example)
        await bounded(drone.action.takeoff())
        # (the example sleeps 8 s): up at the take-off altitude
        await first(api.stream(drone.telemetry, "position"),
                    lambda p: p.relative_altitude_m > TAKEOFF_UP_M, FLIGHT_S)
        since = gcs.mark()
        await bounded(drone.follow_me.start())
        gcs.wait("HEARTBEAT", lambda m: m.custom_mode == FOLLOW, since=since)
        gcs.wait_text("follow: waiting for the lead's position", since)
        target = follow_me.TargetLocation(0, 0, 0, 0, 0, 0)
        for latitude, longitude in FAKE_LOCATIONS:
            target.latitude_deg, target.longitude_deg = latitude, longitude
            target.absolute_altitude_m = 480.0
            target.velocity_x_m_s = target.velocity_y_m_s = target.velocity_z_m_s = 0
            with pytest.raises(follow_me.FollowMeError) as refused:
                await bounded(drone.follow_me.set_target_location(target))
            assert api.result_of(refused.value) == results.NOT_ACTIVE
        # no FOLLOW_TARGET reached the vehicle: it never heard of a lead
        assert not [t for t in gcs.texts(since) if "follow: lead is system" in t]
        await bounded(drone.follow_me.stop())
        gcs.wait("HEARTBEAT", lambda m: m.custom_mode in HOLD, since=since)
        await bounded(drone.action.land())

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ manual_control.py
# The example's test set, [roll, pitch, throttle, yaw] (it sends pitch as x, roll as y).
MANUAL_INPUTS = ((0, 0, 0.5, 0), (-1, 0, 0.5, 0), (1, 0, 0.5, 0), (0, -1, 0.5, 0),
                 (0, 1, 0.5, 0), (0, 0, 0.5, -1), (0, 0, 0.5, 1), (0, 0, 1, 0), (0, 0, 0, 0))
ROUNDS_PER_INPUT = 20  # the example's 0.1 s loop, this many rounds on each input
MOVED_M = 0.5  # m an input must move the vehicle by: LOIT_SPEED 1 m/s, PILOT_SPEED_UP 0.5 m/s
# and _DN 0.3 m/s for at least 2 wall s (20 simulated s at 10x; longer on a loaded machine)
TURNED_DEG = 10.0  # deg a yaw input must turn it by (PILOT_Y_RATE 45 deg/s)
INPUT_WAIT_S = 60.0  # s wall an input may take to move the vehicle on a loaded machine
RC_FS_TIMEOUT_S = 5.0  # s wall without sticks before the RC failsafe (default 1 s)
POSHOLD, ALT_HOLD, LAND = 16, 2, 9


def unwrapped_yaw_deg(attitudes: list[Any]) -> float:
    """How far the yaw turned over ATTITUDE messages (deg; > 0 clockwise), unwrapped."""
    yaws = [m.yaw for m in attitudes]
    return math.degrees(sum(math.remainder(b - a, math.tau) for a, b in zip(
        yaws, yaws[1:], strict=False)))


def flown(gcs: Gcs, since: int) -> tuple[float, float, float, float]:
    """Since log index ``since``: forward, right (m, in the heading frame at the start), up
    (m) and the yaw turned (deg), from LOCAL_POSITION_NED and ATTITUDE."""
    log = gcs.messages()  # every message so far, in order: index = log index
    start = [m for m in log[:since] if m.get_type() == "LOCAL_POSITION_NED"][-1]
    end = [m for m in log[since:] if m.get_type() == "LOCAL_POSITION_NED"][-1]
    attitudes = [m for m in log[since:] if m.get_type() == "ATTITUDE"]
    heading = attitudes[0].yaw
    dn, de = end.x - start.x, end.y - start.y
    forward = dn * math.cos(heading) + de * math.sin(heading)
    right = -dn * math.sin(heading) + de * math.cos(heading)
    return forward, right, start.z - end.z, unwrapped_yaw_deg(attitudes)


def check_moved(index: int, moved: tuple[float, float, float, float]) -> None:
    """Input ``index`` of MANUAL_INPUTS moved the vehicle its way (POSHOLD, heading frame)."""
    forward, right, up, turned = moved
    roll, pitch, throttle, yaw = MANUAL_INPUTS[index]
    what = f"input {MANUAL_INPUTS[index]}: forward {forward:.2f} m, right {right:.2f} m, " \
           f"up {up:.2f} m, turned {turned:.1f} deg"
    if roll:
        assert roll * right > MOVED_M and abs(forward) < abs(right), what
    elif pitch:  # x = pitch: +1 forward, as a stick pushed forward
        assert pitch * forward > MOVED_M and abs(right) < abs(forward), what
    elif yaw:
        assert yaw * turned > TURNED_DEG, what
    elif throttle != 0.5:
        assert (1 if throttle > 0.5 else -1) * up > MOVED_M, what
    else:  # centred sticks: held where it was
        assert math.hypot(forward, right) < 0.2 and abs(up) < 0.2, what


async def manual_control_loop(drone: Any, gcs: Gcs) -> None:
    """The example from "set the manual control input after arming" on, in the air: input
    centred, start_position_control (POSHOLD, as MAVSDK maps PX4's POSCTL for ArduCopter),
    then its loop of inputs 0.1 s apart, each input of its set in turn (the example draws
    them at random) for ROUNDS_PER_INPUT rounds, each checked to have moved the vehicle its
    way. Beyond the example: start_altitude_control (ALT_HOLD) climbs on full throttle, and
    once the inputs stop the RC failsafe lands the vehicle."""
    # the RC failsafe counts wall time (a joystick's): on a loaded machine this process can
    # stall for more than the default second between two inputs, so the test allows 5 s
    gcs.param_set("RC_FS_TIMEOUT", RC_FS_TIMEOUT_S)
    await drone.manual_control.set_manual_control_input(0.0, 0.0, 0.5, 0.0)
    since = gcs.mark()
    await bounded(drone.manual_control.start_position_control())
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == POSHOLD, since=since)
    for index, (roll, pitch, throttle, yaw) in enumerate(MANUAL_INPUTS):
        since = gcs.mark()
        # ROUNDS_PER_INPUT rounds, then more (up to INPUT_WAIT_S) while the vehicle has not
        # moved its way yet: a loaded machine runs the vehicle slower than 10x
        deadline = asyncio.get_running_loop().time() + INPUT_WAIT_S
        rounds = 0
        while True:
            await drone.manual_control.set_manual_control_input(
                float(pitch), float(roll), float(throttle), float(yaw))
            await asyncio.sleep(0.1)
            rounds += 1
            if rounds < ROUNDS_PER_INPUT:
                continue
            assert not [t for t in gcs.texts(since) if "failsafe" in t.lower()], \
                "; ".join(gcs.texts(since))
            try:
                check_moved(index, flown(gcs, since))
                break
            except AssertionError:
                if asyncio.get_running_loop().time() > deadline:
                    raise
    assert not [t for t in gcs.texts() if "failsafe" in t.lower()]
    since = gcs.mark()
    await bounded(drone.manual_control.start_altitude_control())
    for _ in range(ROUNDS_PER_INPUT):
        await drone.manual_control.set_manual_control_input(0.0, 0.0, 1.0, 0.0)
        await asyncio.sleep(0.1)
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == ALT_HOLD, since=since)
    assert flown(gcs, since)[2] > MOVED_M
    since = gcs.mark()  # the inputs stop: RC_FS_TIMEOUT (wall) later, FS_THR_ENABLE LAND
    assert "LAND" in gcs.wait_text("Radio failsafe: no sticks", since,
                                   timeout_s=RC_FS_TIMEOUT_S + 10.0)
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == LAND, since=since)


@BOTH
def test_manual_control_example(api: Flavour, start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Any) -> None:
        await api.healthy(drone)
        await drone.manual_control.set_manual_control_input(0.0, 0.0, 0.5, 0.0)
        await bounded(drone.action.arm())
        await bounded(drone.action.takeoff())
        await first(api.stream(drone.telemetry, "position"),  # (the example sleeps 5 s)
                    lambda p: p.relative_altitude_m > TAKEOFF_UP_M, FLIGHT_S)
        await manual_control_loop(drone, gcs)

    api.run(start_vehicle, gcs, steps)


# ------------------------------------------------------------------ examples that ran before
TAKEOFF_UP_M = 1.9  # m: at MAVSDK's default take-off altitude (2 m), within the tracking
# firmware_version.py, all_params.py, telemetry_status_text.py, takeoff_and_land.py,
# tune.py, send_status_message.py (gRPC API only; test_mavsdk.py covers parameters, arming,
# take-off and landing with mavsdk 4)
def test_firmware_version_example_grpc(start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Any) -> None:
        info = await bounded(drone.info.get_version())
        assert info.flight_sw_major >= 0 and info.flight_sw_minor >= 0

    run_grpc(start_vehicle, gcs, steps)


def test_all_params_example_grpc(start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Any) -> None:
        all_params = await bounded(drone.param.get_all_params())
        names = {p.name for p in all_params.int_params} | \
            {p.name for p in all_params.float_params}
        assert {"FENCE_ENABLE", "FENCE_ALT_MAX", "CIRCLE_RADIUS", "WPNAV_SPEED"} <= names

    run_grpc(start_vehicle, gcs, steps)


async def grpc_take_off_and_land(drone: Any) -> None:
    """The take-off and landing of takeoff_and_land.py and telemetry_takeoff_and_land.py:
    health, arm, take-off, up at the take-off altitude (the examples sleep 10 s, 5 s), land,
    on the ground."""
    await GRPC.healthy(drone)
    await bounded(drone.action.arm())
    await bounded(drone.action.takeoff())
    await first(drone.telemetry.position(),
                lambda p: p.relative_altitude_m > TAKEOFF_UP_M, FLIGHT_S)
    await bounded(drone.action.land())
    await first(drone.telemetry.landed_state(),
                lambda s: s == GrpcLandedState.ON_GROUND, FLIGHT_S)


def test_takeoff_and_land_example_grpc_with_status_text(start_vehicle, gcs: Gcs) -> None:
    """takeoff_and_land.py (and telemetry_status_text.py: the texts it prints)."""
    async def steps(drone: Any) -> None:
        texts: list[str] = []

        async def print_status_text() -> None:
            async for status_text in drone.telemetry.status_text():
                texts.append(status_text.text)

        status_text_task = asyncio.ensure_future(print_status_text())
        await grpc_take_off_and_land(drone)
        status_text_task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await status_text_task
        assert any(t.startswith("armed") for t in texts)

    run_grpc(start_vehicle, gcs, steps)


def test_tune_example_grpc(start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Any) -> None:
        song = [SongElement.DURATION_4, SongElement.NOTE_G, SongElement.NOTE_A,
                SongElement.OCTAVE_UP, SongElement.NOTE_E]  # (our own short tune)
        await bounded(drone.tune.play_tune(TuneDescription(song, 200)))

    run_grpc(start_vehicle, gcs, steps)


def test_send_status_message_example_grpc(start_vehicle, gcs: Gcs) -> None:
    api_port = start_example_vehicle(start_vehicle, gcs)

    async def scenario() -> None:
        drone = System(sysid=1, port=free_port(socket.SOCK_STREAM))  # as the example
        await bounded(drone.connect(system_address=f"udpin://127.0.0.1:{api_port}"))
        try:
            await grpc_connected(drone)
            await bounded(drone.server_utility.send_status_text(StatusTextType.INFO,
                                                                "Hello world!"))
        finally:
            server = drone._server_process
            drone._stop_mavsdk_server()
            if server is not None:
                server.wait(timeout=SERVER_STOP_S)

    asyncio.run(asyncio.wait_for(scenario(), FLIGHT_S))


def test_telemetry_examples_grpc(start_vehicle, gcs: Gcs) -> None:
    """telemetry_flight_mode.py, telemetry_is_armed_is_in_air.py, and
    telemetry_takeoff_and_land.py's watch over altitude and mode through a take-off and
    landing: every stream reports, and in the order the flight goes."""
    async def steps(drone: Any) -> None:
        seen: dict[str, list[Any]] = {"mode": [], "armed": [], "in_air": [], "alt": []}

        async def watch(name: str, stream: AsyncIterator[Any]) -> None:
            async for value in stream:
                if not seen[name] or seen[name][-1] != value:
                    seen[name].append(value)

        tasks = [asyncio.ensure_future(watch("mode", drone.telemetry.flight_mode())),
                 asyncio.ensure_future(watch("armed", drone.telemetry.armed())),
                 asyncio.ensure_future(watch("in_air", drone.telemetry.in_air())),
                 asyncio.ensure_future(watch("alt", (round(p.relative_altitude_m)
                                                     async for p in drone.telemetry.position())))]
        await grpc_take_off_and_land(drone)
        await first(drone.telemetry.armed(), lambda armed: not armed, FLIGHT_S)  # auto-disarm
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        assert seen["armed"][:3] == [False, True, False]
        assert seen["in_air"][:3] == [False, True, False]
        assert max(seen["alt"]) == 2 and len(seen["mode"]) >= 2  # up to 2 m; modes changed

    run_grpc(start_vehicle, gcs, steps)
