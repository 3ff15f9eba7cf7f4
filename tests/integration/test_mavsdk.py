"""MAVSDK 4 (PyPI ``mavsdk``, the native binding) drives the vehicle process.

MAVSDK 4 calls its C++ core through the library in its wheel (``mavsdk/lib/libcmavsdk.so``):
no ``mavsdk_server`` process and nothing downloaded at test time. It connects on its own UDP
port; the vehicle sends to it and to a pymavlink ground station that only listens, to read
what MAVSDK does not show (SIM_STATE, SERVO_OUTPUT_RAW, PARAM_VALUE types, STATUSTEXT).
Every await is bounded by ``asyncio.wait_for`` with generous limits; no step is timed.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import statistics
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import pytest
from mavsdk import LogLevel, log_subscribe
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.failure import (
    FailureAsync,
    FailureError,
    FailureResult,
    FailureType,
    FailureUnit,
)
from mavsdk.asyncio.plugins.mission_raw import (
    MissionItem,
    MissionRawAsync,
    MissionRawError,
    MissionRawResult,
)
from mavsdk.asyncio.plugins.param import ParamAsync, ParamError, ParamResult
from mavsdk.asyncio.plugins.telemetry import FlightMode, TelemetryAsync
from vehicle_harness import Gcs, M, free_port

T = TypeVar("T")
STEP_S = 60.0  # s wall, any single MAVSDK step
PARAM_STEP_S = 30.0  # s wall, one parameter call (MAVSDK times out by itself after ~3 s)
CMAC = (-35.363261, 149.165230)  # the vehicle's default home, deg
NORTH_DEG, EAST_DEG = 1.0 / 111_000.0, 1.0 / 90_700.0  # ~1 m at 35 deg S

# MAVSDK's core prints its own log lines; keep warnings and errors on the test's output
log_subscribe(lambda level, message, file, line: level < LogLevel.WARN)


@dataclass
class Drone:
    """One MAVSDK instance connected to the vehicle, with the plugins the tests use."""

    mavsdk: Mavsdk
    action: ActionAsync
    telemetry: TelemetryAsync
    param: ParamAsync
    mission_raw: MissionRawAsync
    failure: FailureAsync


@contextlib.asynccontextmanager
async def connected(udp_port: int) -> AsyncIterator[Drone]:
    """MAVSDK as a ground station listening on ``udp_port``, once the autopilot is found."""
    mavsdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    plugins: list[Any] = []
    try:
        await bounded(mavsdk.add_any_connection(f"udpin://127.0.0.1:{udp_port}"))
        system = await bounded(mavsdk.first_autopilot(timeout_s=STEP_S), STEP_S + 10.0)
        assert system is not None, "no autopilot heartbeat"
        plugins = [ActionAsync(system), TelemetryAsync(system), ParamAsync(system),
                   MissionRawAsync(system), FailureAsync(system)]
        yield Drone(mavsdk, *plugins)
    finally:
        for plugin in plugins:
            plugin.destroy()
        mavsdk.destroy()


async def bounded(awaitable: Awaitable[T], limit_s: float = STEP_S) -> T:
    return await asyncio.wait_for(awaitable, limit_s)


async def first(stream: AsyncIterator[Any], predicate: Callable[[Any], bool],
                limit_s: float = STEP_S) -> Any:
    """The first item of a MAVSDK subscription that satisfies ``predicate`` (then unsubscribe)."""
    async def scan() -> Any:
        async with contextlib.aclosing(stream) as items:  # type: ignore[type-var]
            async for item in items:
                if predicate(item):
                    return item
        raise AssertionError("stream ended")

    return await asyncio.wait_for(scan(), limit_s)


async def ready(drone: Drone) -> None:
    """Connected, and MAVSDK's health says ready to fly (what its examples wait for)."""
    await first(drone.telemetry.subscribe_health_all_ok(), bool)
    health = await bounded(drone.telemetry.health())
    assert (health.is_gyrometer_calibration_ok, health.is_accelerometer_calibration_ok,
            health.is_magnetometer_calibration_ok, health.is_local_position_ok,
            health.is_global_position_ok, health.is_home_position_ok,
            health.is_armable) == (True,) * 7


async def no_idle_disarm(drone: Drone) -> None:
    """DISARM_DELAY 0: armed on the ground, the vehicle waits for MAVSDK's next command
    however long a loaded machine takes to send it (10 s simulated is 1 s wall at 10x)."""
    await bounded(drone.param.set_param_float("DISARM_DELAY", 0.0))


def with_mavsdk(start_vehicle: Callable[..., Any], gcs: Gcs, speedup: int,
                steps: Callable[[Drone], Awaitable[None]], limit_s: float) -> None:
    """Start the vehicle at ``speedup`` sending to a MAVSDK ground station and to ``gcs``
    (which then listens), and run ``steps`` on MAVSDK once it says ready, all within
    ``limit_s`` of wall time."""
    udp_port = free_port()
    start_vehicle("--speedup", str(speedup), outs=[udp_port, gcs.port])
    gcs.start_reader()

    async def scenario() -> None:
        async with connected(udp_port) as drone:
            await ready(drone)
            await steps(drone)

    asyncio.run(asyncio.wait_for(scenario(), limit_s))


async def param_error(call: Awaitable[Any]) -> ParamResult:
    """The result a MAVSDK parameter call fails with (the test fails if it succeeds)."""
    with pytest.raises(ParamError) as raised:
        await bounded(call, PARAM_STEP_S)
    return raised.value.result


def global_item(seq: int, command: int, lat_deg: float, lon_deg: float, rel_alt_m: float,
                current: int = 0, params: tuple[float, ...] = (0, 0, 0, math.nan)
                ) -> MissionItem:
    return MissionItem(seq, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, current, 1, *params,
                       round(lat_deg * 1e7), round(lon_deg * 1e7), rel_alt_m,
                       M.MAV_MISSION_TYPE_MISSION)


def servo_gap(msgs: list) -> float:
    """Mean servo1 - servo2 (motor 1 front minus motor 2 back), microseconds."""
    servos = [m for m in msgs if m.get_type() == "SERVO_OUTPUT_RAW"]
    assert servos
    return statistics.fmean(m.servo1_raw - m.servo2_raw for m in servos)


def max_pitch_deg(msgs: list) -> float:
    states = [m for m in msgs if m.get_type() == "SIM_STATE"]
    assert states
    return max(abs(math.degrees(m.pitch)) for m in states)


async def window(gcs: Gcs, seconds: float) -> list:
    start = gcs.mark()
    await asyncio.sleep(seconds)
    return gcs.messages(since=start)


def test_mavsdk_reads_and_sets_typed_parameters(start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Drone) -> None:
        p = drone.param
        # integers as ints (INT8/INT16 on the wire), floats as floats
        assert await bounded(p.get_param_int("SYSID_THISMAV")) == 1
        assert await bounded(p.get_param_int("FS_GCS_ENABLE")) == 5
        assert await bounded(p.get_param_float("FS_GCS_TIMEOUT")) == 5.0
        await bounded(p.set_param_int("FS_CRASH_CHECK", 0))
        assert await bounded(p.get_param_int("FS_CRASH_CHECK")) == 0
        await bounded(p.set_param_float("WPNAV_SPEED", 75.0))
        assert await bounded(p.get_param_float("WPNAV_SPEED")) == 75.0
        for name, wire in (("FS_CRASH_CHECK", M.MAV_PARAM_TYPE_INT8),
                           ("WPNAV_SPEED", M.MAV_PARAM_TYPE_REAL32)):  # PARAM_SET echoes
            echo = gcs.wait("PARAM_VALUE", lambda m, n=name: m.param_id == n, since=0)
            assert echo.param_type == wire
        everything = await bounded(p.get_all_params())
        ints = {q.name for q in everything.int_params}
        floats = {q.name for q in everything.float_params}
        assert {"SYSID_THISMAV", "FS_GCS_ENABLE", "ATT_CTRL", "AUTO_OPTIONS",
                "SIM_ENGINE_FAIL", "SYS_FAILURE_EN"} <= ints
        assert {"FS_GCS_TIMEOUT", "WPNAV_SPEED", "SIM_FI_LOE"} <= floats
        assert not ints & floats

        # the wrong getter is MAVSDK's own WRONG_TYPE, at once
        assert await param_error(p.get_param_float("FS_GCS_ENABLE")) == \
            ParamResult.WRONG_TYPE
        assert await param_error(p.get_param_int("WPNAV_SPEED")) == ParamResult.WRONG_TYPE
        # a float written to an integer parameter is applied (ArduPilot ignores the type
        # named in PARAM_SET), but MAVSDK sees the echo's INT8 and reports WRONG_TYPE
        since = gcs.mark()
        assert await param_error(p.set_param_float("FS_CRASH_CHECK", 1.0)) == \
            ParamResult.WRONG_TYPE
        echo = gcs.wait("PARAM_VALUE", lambda m: m.param_id == "FS_CRASH_CHECK",
                        since=since)
        assert (echo.param_value, echo.param_type) == (1.0, M.MAV_PARAM_TYPE_INT8)
        assert await bounded(p.get_param_int("FS_CRASH_CHECK")) == 1
        # a refused value: the old value is echoed (MAVSDK: TIMEOUT) and a STATUSTEXT says why
        assert await param_error(p.set_param_int("ATT_CTRL", 5)) == ParamResult.TIMEOUT
        assert await bounded(p.get_param_int("ATT_CTRL")) == 1
        gcs.wait_text("ATT_CTRL: 5 outside 0..1", since=0)
        assert gcs.texts().count("ATT_CTRL: 5 outside 0..1") == 1  # not once per retry

        # an unknown name: no PARAM_VALUE, MAVSDK times out with its own error after its
        # retries, and the pilot sees one line, not one per retry
        since = gcs.mark()
        assert await param_error(p.get_param_float("NO_SUCH_PARAM")) == \
            ParamResult.TIMEOUT
        gcs.wait_text("Unknown parameter NO_SUCH_PARAM", since)
        assert gcs.texts(since).count("Unknown parameter NO_SUCH_PARAM") == 1
        assert not [m for m in gcs.messages("PARAM_VALUE", since=since)
                    if m.param_id == "NO_SUCH_PARAM"]

        # SYS_FAILURE_EN gates the Failure plugin: DENIED while 0
        await bounded(p.set_param_int("SYS_FAILURE_EN", 0))
        with pytest.raises(FailureError) as denied:
            await bounded(drone.failure.inject(FailureUnit.SYSTEM_MOTOR,
                                               FailureType.WRONG, 1))
        assert denied.value.result == FailureResult.DENIED
        await bounded(p.set_param_int("SYS_FAILURE_EN", 1))
        await bounded(drone.failure.inject(FailureUnit.SYSTEM_MOTOR, FailureType.OK, 1))

    with_mavsdk(start_vehicle, gcs, 5, steps, 300.0)


@pytest.mark.slow
def test_mavsdk_takes_off_flies_a_mission_from_the_ground_and_injects_failures(
        start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Drone) -> None:
        home = await first(drone.telemetry.subscribe_home(), lambda h: True)
        assert (home.latitude_deg, home.longitude_deg) == pytest.approx(CMAC, abs=1e-6)
        await no_idle_disarm(drone)

        # flight 1: arm, take off (GUIDED), land
        await bounded(drone.action.set_takeoff_altitude(1.0))
        await bounded(drone.action.arm())
        await bounded(drone.action.takeoff())
        await first(drone.telemetry.subscribe_in_air(), bool)
        await first(drone.telemetry.subscribe_position(),
                    lambda p: p.relative_altitude_m > 0.9)
        mode = await bounded(drone.telemetry.flight_mode())
        assert mode == FlightMode.OFFBOARD  # how MAVSDK names ArduCopter GUIDED
        await bounded(drone.action.land())
        await first(drone.telemetry.subscribe_in_air(), lambda flying: not flying, 120.0)
        await first(drone.telemetry.subscribe_armed(), lambda armed: not armed, 120.0)

        # flight 2, mission_raw from the ground: seq 0 home (ArduPilot), NAV_TAKEOFF first
        # (AUTO from the ground needs it), a 1 m triangle at 1 m; upload, arm, start
        lat, lon = home.latitude_deg, home.longitude_deg
        items = [
            global_item(0, M.MAV_CMD_NAV_WAYPOINT, lat, lon, 0.0),
            global_item(1, M.MAV_CMD_NAV_TAKEOFF, 0, 0, 1.0, current=1),
            global_item(2, M.MAV_CMD_DO_CHANGE_SPEED, 0, 0, 0, params=(1, 0.5, -1, 0)),
            global_item(3, M.MAV_CMD_NAV_WAYPOINT, lat + NORTH_DEG, lon, 1.0),
            global_item(4, M.MAV_CMD_NAV_WAYPOINT, lat + NORTH_DEG, lon + EAST_DEG, 1.0),
            global_item(5, M.MAV_CMD_NAV_WAYPOINT, lat, lon, 1.0),
        ]
        await bounded(drone.mission_raw.upload_mission(items))
        await bounded(drone.action.arm())
        since = gcs.mark()
        progress = drone.mission_raw.subscribe_mission_progress()
        await bounded(drone.mission_raw.start_mission())
        await first(drone.telemetry.subscribe_in_air(), bool)
        end = await first(progress, lambda p: p.total > 0 and p.current == p.total, 120.0)
        assert end.total == len(items)  # current = last reached + 1 = the item count

        async def finished() -> None:  # MAVSDK's verdict also waits for MISSION_CURRENT
            while not await drone.mission_raw.is_mission_finished():
                await asyncio.sleep(0.2)

        await bounded(finished())
        gcs.wait("MISSION_ITEM_REACHED", lambda m: m.seq == 5, since=since)  # logged too
        reached = [m.seq for m in gcs.messages("MISSION_ITEM_REACHED", since=since)]
        assert reached == [1, 2, 3, 4, 5]
        assert any(m.custom_mode == 3 for m in gcs.messages("HEARTBEAT", since=since))

        # Failure plugin: motor 1 (front) WRONG = 30 % loss of effectiveness, in hover
        await bounded(drone.action.hold())  # LOITER
        before = await window(gcs, 1.0)
        injected_at = gcs.mark()  # the STATUSTEXT may beat MAVSDK's ACK to this client
        await bounded(drone.failure.inject(FailureUnit.SYSTEM_MOTOR, FailureType.WRONG, 1))
        after = await window(gcs, 3.0)
        assert abs(servo_gap(before)) < 40
        assert servo_gap(after) > 100  # motor 1 now needs ~1/0.7 of its hover command
        assert max_pitch_deg(after) > max(1.5, 1.5 * max_pitch_deg(before))  # nose dips
        gcs.wait_text("injected motor 1: loe 30", injected_at)
        await bounded(drone.failure.inject(FailureUnit.SYSTEM_MOTOR, FailureType.OK, 1))
        await asyncio.sleep(2.0)
        assert abs(servo_gap(await window(gcs, 1.0))) < 40
        # unsupported combinations say so
        with pytest.raises(FailureError) as unsupported:
            await bounded(drone.failure.inject(FailureUnit.SYSTEM_BATTERY,
                                               FailureType.OFF, 0))
        assert unsupported.value.result == FailureResult.UNSUPPORTED

        await bounded(drone.action.land())
        await first(drone.telemetry.subscribe_in_air(), lambda flying: not flying, 120.0)
        await first(drone.telemetry.subscribe_armed(), lambda armed: not armed, 120.0)

    with_mavsdk(start_vehicle, gcs, 10, steps, 600.0)
    sim = gcs.wait("SIM_STATE")
    assert abs(sim.vd) < 0.05  # landed, at rest (truth)


def test_mavsdk_cannot_start_a_mission_without_take_off_from_the_ground(
        start_vehicle, gcs: Gcs) -> None:
    async def steps(drone: Drone) -> None:
        await no_idle_disarm(drone)
        lat, lon = CMAC
        items = [global_item(0, M.MAV_CMD_NAV_WAYPOINT, lat, lon, 0.0),
                 global_item(1, M.MAV_CMD_NAV_WAYPOINT, lat + NORTH_DEG, lon, 1.0,
                             current=1)]
        await bounded(drone.mission_raw.upload_mission(items))
        await bounded(drone.action.arm())
        since = gcs.mark()
        with pytest.raises(MissionRawError) as refused:
            await bounded(drone.mission_raw.start_mission())
        assert refused.value.result == MissionRawResult.DENIED, refused.value
        gcs.wait_text("must be NAV_TAKEOFF", since)
        assert not await bounded(drone.telemetry.in_air())
        await bounded(drone.action.disarm())

    with_mavsdk(start_vehicle, gcs, 5, steps, 300.0)
