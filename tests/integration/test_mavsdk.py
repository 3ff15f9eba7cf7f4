"""MAVSDK (PyPI ``mavsdk``, its bundled native ``mavsdk_server``) flies the vehicle process.

MAVSDK connects on its own UDP port; the vehicle sends to it and to a pymavlink ground
station that only listens, to read what MAVSDK does not show (SIM_STATE, SERVO_OUTPUT_RAW).
Every await is bounded by ``asyncio.wait_for`` with generous limits.
"""

from __future__ import annotations

import asyncio
import math
import socket
import statistics
import warnings
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any, TypeVar

import pytest
from vehicle_harness import Gcs, M, free_port

with warnings.catch_warnings():
    # mavsdk 3.17 (the gRPC API, pinned < 4 in pyproject.toml) announces its rename to
    # mavsdk-grpc when imported
    warnings.simplefilter("ignore", FutureWarning)
    from mavsdk import System
    from mavsdk.failure import FailureError, FailureType, FailureUnit
    from mavsdk.mission_raw import MissionItem

# its bundled mavsdk_server is found through a deprecated importlib.resources call
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

T = TypeVar("T")
STEP_S = 60.0  # s wall, any single MAVSDK step
CMAC = (-35.363261, 149.165230)  # the vehicle's default home, deg


async def bounded(awaitable: Awaitable[T], limit_s: float = STEP_S) -> T:
    return await asyncio.wait_for(awaitable, limit_s)


async def first(stream: AsyncIterator[Any], predicate: Callable[[Any], bool],
                limit_s: float = STEP_S) -> Any:
    """The first item of a MAVSDK stream that satisfies ``predicate``."""
    async def scan() -> Any:
        async for item in stream:
            if predicate(item):
                return item
        raise AssertionError("stream ended")

    return await asyncio.wait_for(scan(), limit_s)


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


@pytest.mark.slow
def test_mavsdk_flies_a_mission_and_injects_failures(start_vehicle, gcs: Gcs) -> None:
    udp_port = free_port()
    grpc_port = free_port(socket.SOCK_STREAM)
    start_vehicle("--speedup", "10", outs=[udp_port, gcs.port])
    gcs.start_reader()
    drone = System(port=grpc_port)

    async def fly() -> None:
        await bounded(drone.connect(system_address=f"udpin://127.0.0.1:{udp_port}"))
        await first(drone.core.connection_state(), lambda s: s.is_connected)
        await first(drone.telemetry.health_all_ok(), bool)
        home = await first(drone.telemetry.home(), lambda h: True)
        assert (home.latitude_deg, home.longitude_deg) == pytest.approx(CMAC, abs=1e-6)
        await bounded(drone.action.set_takeoff_altitude(1.0))
        await bounded(drone.action.arm())
        await bounded(drone.action.takeoff())
        await first(drone.telemetry.in_air(), bool)
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 0.9)
        mode = await first(drone.telemetry.flight_mode(), lambda m: True)
        assert mode.name == "OFFBOARD"  # how MAVSDK names ArduCopter GUIDED

        # mission_raw: seq 0 is home (ArduPilot), one item current, a 1 m triangle at 1 m
        lat, lon = home.latitude_deg, home.longitude_deg
        north_deg, east_deg = 1.0 / 111_000.0, 1.0 / 90_700.0  # ~1 m at 35 deg S
        items = [
            global_item(0, M.MAV_CMD_NAV_WAYPOINT, lat, lon, 0.0),
            global_item(1, M.MAV_CMD_DO_CHANGE_SPEED, 0, 0, 0, current=1,
                        params=(1, 0.5, -1, 0)),
            global_item(2, M.MAV_CMD_NAV_WAYPOINT, lat + north_deg, lon, 1.0),
            global_item(3, M.MAV_CMD_NAV_WAYPOINT, lat + north_deg, lon + east_deg, 1.0),
            global_item(4, M.MAV_CMD_NAV_WAYPOINT, lat, lon, 1.0),
        ]
        await bounded(drone.mission_raw.upload_mission(items))
        since = gcs.mark()
        await bounded(drone.mission_raw.start_mission())

        async def finished() -> None:
            while not await drone.mission_raw.is_mission_finished():
                await asyncio.sleep(0.2)

        await bounded(finished(), 120.0)
        reached = [m.seq for m in gcs.messages("MISSION_ITEM_REACHED", since=since)]
        assert reached == [1, 2, 3, 4]

        # Failure plugin: motor 1 (front) WRONG = 30 % loss of effectiveness, in hover
        await bounded(drone.action.hold())  # LOITER
        before = await window(gcs, 1.0)
        injected_at = gcs.mark()  # the STATUSTEXT may beat MAVSDK's ACK to this client
        await bounded(drone.failure.inject(FailureUnit.SYSTEM_MOTOR, FailureType.WRONG, 1))
        after = await window(gcs, 3.0)
        assert abs(servo_gap(before)) < 40
        assert servo_gap(after) > 100  # motor 1 now needs ~1/0.7 of its hover command
        assert max_pitch_deg(after) > max(1.5, 1.5 * max_pitch_deg(before))  # nose dips
        assert any("injected motor 1: loe 30" in m.text
                   for m in gcs.messages("STATUSTEXT", since=injected_at))
        await bounded(drone.failure.inject(FailureUnit.SYSTEM_MOTOR, FailureType.OK, 1))
        await asyncio.sleep(2.0)
        assert abs(servo_gap(await window(gcs, 1.0))) < 40
        # unsupported combinations say so
        with pytest.raises(FailureError):
            await bounded(drone.failure.inject(FailureUnit.SYSTEM_BATTERY, FailureType.OFF, 0))

        await bounded(drone.action.land())
        await first(drone.telemetry.in_air(), lambda flying: not flying, 120.0)
        await first(drone.telemetry.armed(), lambda armed: not armed, 120.0)

    try:
        asyncio.run(asyncio.wait_for(fly(), 400.0))
    finally:
        server = drone._server_process  # the mavsdk_server this test started  # noqa: SLF001
        drone._stop_mavsdk_server()  # kills it  # noqa: SLF001
        if server is not None:
            server.wait(30)  # and reap it
    sim = gcs.wait("SIM_STATE")
    assert abs(sim.vd) < 0.05  # landed, at rest (truth)
