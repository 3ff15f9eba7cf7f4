"""MAVSDK-Python's five offboard examples, done against the vehicle with both MAVSDK packages.

As in :mod:`test_mavsdk_examples`: each test makes the calls its example makes, in the same
order, against a vehicle at PX4's default home. MAVSDK's ``offboard.start()`` puts an
ArduPilot autopilot in GUIDED, and its setpoints arrive as SET_POSITION_TARGET_LOCAL_NED
(position, velocity, both) and SET_ATTITUDE_TARGET. The examples' ``asyncio.sleep`` pauses
become waits on telemetry showing the vehicle does what the setpoint asks (climbing, moving
north, rolling right...), so a setpoint that is accepted but not flown fails the test, and
then the rest of the pause in simulated time, so each set-point is flown as long as the
example flies it.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any

import pytest
from mavsdk.asyncio.plugins import offboard as native_offboard
from mavsdk.asyncio.plugins.offboard import OffboardAsync
from mavsdk_grpc import offboard as grpc_offboard
from test_mavsdk import bounded, first
from test_mavsdk_examples import FLIGHT_S, NativeDrone, run_grpc, run_native
from vehicle_harness import Gcs

NativeDrone.PLUGINS.setdefault("offboard", OffboardAsync)

MOVING_M_S = 0.3  # m/s: clearly moving the way asked (the velocity estimate's noise is ~cm/s)
SINKING_M_S = 0.1  # m/s: clearly descending (WPNAV_SPEED_DN is 0.2 m/s)
ROLLED_DEG = 15.0  # deg: leaning the way a 30 deg roll setpoint asks


class Api:
    """What differs between the two packages: the setpoint classes and the stream names."""

    def __init__(self, drone: Any, native: bool, gcs: Gcs) -> None:
        self.drone, self.native, self.gcs = drone, native, gcs
        self.sp = native_offboard if native else grpc_offboard

    async def sleep(self, seconds: float) -> None:
        """The example's ``asyncio.sleep(seconds)``, in simulated time (the vehicle's clock,
        LOCAL_POSITION_NED's), so the set-point is flown as long as the example flies it."""
        def now_ms() -> int:
            return int(self.gcs.messages("LOCAL_POSITION_NED")[-1].time_boot_ms)

        end_ms = now_ms() + 1000.0 * seconds
        deadline = asyncio.get_running_loop().time() + FLIGHT_S / 4
        while now_ms() < end_ms:
            assert asyncio.get_running_loop().time() < deadline, "the vehicle's clock stalls"
            await asyncio.sleep(0.05)

    def stream(self, name: str) -> AsyncIterator[Any]:
        telemetry = self.drone.telemetry
        return getattr(telemetry, f"subscribe_{name}" if self.native else name)()

    async def until(self, name: str, predicate: Callable[[Any], bool]) -> Any:
        return await first(self.stream(name), predicate, FLIGHT_S / 4)

    async def velocity(self, predicate: Callable[[Any], bool]) -> Any:
        """The first NED velocity (m/s) satisfying ``predicate``."""
        pv = await self.until("position_velocity_ned", lambda pv: predicate(pv.velocity))
        return pv.velocity

    async def ready(self) -> None:
        """The examples' health wait, then arm."""
        await self.until("health", lambda h: h.is_global_position_ok
                         and h.is_home_position_ok)
        await bounded(self.drone.action.arm())


def run(native: bool, start_vehicle: Any, gcs: Gcs,
        steps: Callable[[Api], Awaitable[None]]) -> None:
    async def with_api(drone: Any) -> None:
        await steps(Api(drone, native, gcs))

    (run_native if native else run_grpc)(start_vehicle, gcs, with_api)
    # where the set-points took it was meant: no fly-away or crash judged (a landing may be,
    # when the auto-disarm comes before the link closes)
    judged = [t for t in gcs.texts() if "outcome:" in t]
    assert all("outcome: landed" in t for t in judged), "; ".join(gcs.texts())


BOTH = pytest.mark.parametrize("native", [False, True], ids=["grpc", "native"])


# ------------------------------------------------------------------ offboard_position_ned.py
@BOTH
def test_offboard_position_ned_example(native: bool, start_vehicle, gcs: Gcs) -> None:
    async def steps(api: Api) -> None:
        sp, offboard = api.sp, api.drone.offboard
        await api.ready()
        await bounded(offboard.set_position_ned(sp.PositionNedYaw(0.0, 0.0, 0.0, 0.0)))
        await bounded(offboard.start())
        await bounded(offboard.set_position_ned(sp.PositionNedYaw(0.0, 0.0, -5.0, 0.0)))
        await api.until("position_velocity_ned", lambda pv: pv.position.down_m < -1.0)
        await bounded(offboard.set_position_ned(sp.PositionNedYaw(5.0, 0.0, -5.0, 90.0)))
        await api.until("position_velocity_ned", lambda pv: pv.position.north_m > 1.0)
        await api.until("heading", lambda h: abs(h.heading_deg - 90.0) < 20.0)
        await bounded(offboard.set_position_ned(sp.PositionNedYaw(5.0, 10.0, -5.0, 90.0)))
        await api.until("position_velocity_ned", lambda pv: pv.position.east_m > 1.0)
        await bounded(offboard.set_position_ned(sp.PositionNedYaw(0.0, 10.0, 0.0, 180.0)))
        await api.velocity(lambda v: v.down_m_s > SINKING_M_S)  # on its way down
        await bounded(offboard.stop())

    run(native, start_vehicle, gcs, steps)


# ------------------------------------------------------------------ offboard_velocity_ned.py
@BOTH
def test_offboard_velocity_ned_example(native: bool, start_vehicle, gcs: Gcs) -> None:
    async def steps(api: Api) -> None:
        sp, offboard = api.sp, api.drone.offboard
        await api.ready()
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(0.0, 0.0, 0.0, 0.0)))
        await bounded(offboard.start())
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(0.0, 0.0, -2.0, 0.0)))
        await api.velocity(lambda v: v.down_m_s < -MOVING_M_S)  # "Go up 2 m/s"
        await api.until("position_velocity_ned", lambda pv: pv.position.down_m < -2.0)
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(2.0, 0.0, 0.0, 90.0)))
        await api.velocity(lambda v: v.north_m_s > MOVING_M_S)
        await api.sleep(4.0)
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(-2.0, 0.0, 0.0, 270.0)))
        await api.velocity(lambda v: v.north_m_s < -MOVING_M_S)
        await api.sleep(4.0)
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(0.0, -2.0, 0.0, 90.0)))
        await api.velocity(lambda v: v.east_m_s < -MOVING_M_S)
        await api.sleep(4.0)
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(0.0, 2.0, 0.0, 90.0)))
        await api.velocity(lambda v: v.east_m_s > MOVING_M_S)
        await api.sleep(4.0)
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(0.0, 0.0, 0.0, 180.0)))
        await api.until("heading", lambda h: abs(h.heading_deg - 180.0) < 20.0)
        await bounded(offboard.set_velocity_ned(sp.VelocityNedYaw(0.0, 0.0, 1.0, 0.0)))
        await api.velocity(lambda v: v.down_m_s > MOVING_M_S)
        await bounded(offboard.stop())

    run(native, start_vehicle, gcs, steps)


# ------------------------------------------------------------------ offboard_velocity_body.py
@BOTH
def test_offboard_velocity_body_example(native: bool, start_vehicle, gcs: Gcs) -> None:
    async def steps(api: Api) -> None:
        sp, offboard = api.sp, api.drone.offboard
        await api.ready()
        await bounded(offboard.set_velocity_body(sp.VelocityBodyYawspeed(0.0, 0.0, 0.0, 0.0)))
        await bounded(offboard.start())
        start = await api.until("heading", lambda h: True)
        # "Turn clock-wise and climb"
        await bounded(offboard.set_velocity_body(
            sp.VelocityBodyYawspeed(0.0, 0.0, -1.0, 60.0)))
        await api.velocity(lambda v: v.down_m_s < -MOVING_M_S)
        await api.until("heading", lambda h: turned_deg(start.heading_deg, h.heading_deg) > 20)
        turned = await api.until("heading", lambda h: True)
        # "Turn back anti-clockwise"
        await bounded(offboard.set_velocity_body(
            sp.VelocityBodyYawspeed(0.0, 0.0, 0.0, -60.0)))
        await api.until("heading",
                        lambda h: turned_deg(turned.heading_deg, h.heading_deg) < -20)
        await bounded(offboard.set_velocity_body(sp.VelocityBodyYawspeed(0.0, 0.0, 0.0, 0.0)))
        # "Fly a circle": forward 5 m/s while turning
        await bounded(offboard.set_velocity_body(
            sp.VelocityBodyYawspeed(5.0, 0.0, 0.0, 30.0)))
        await api.velocity(lambda v: math.hypot(v.north_m_s, v.east_m_s) > 1.0)
        await api.sleep(15.0)
        await bounded(offboard.set_velocity_body(sp.VelocityBodyYawspeed(0.0, 0.0, 0.0, 0.0)))
        await api.velocity(lambda v: math.hypot(v.north_m_s, v.east_m_s) < MOVING_M_S)
        # "Fly a circle sideways"
        await bounded(offboard.set_velocity_body(
            sp.VelocityBodyYawspeed(0.0, -5.0, 0.0, 30.0)))
        await api.velocity(lambda v: math.hypot(v.north_m_s, v.east_m_s) > 1.0)
        await api.sleep(15.0)
        await bounded(offboard.set_velocity_body(sp.VelocityBodyYawspeed(0.0, 0.0, 0.0, 0.0)))
        await bounded(offboard.stop())

    run(native, start_vehicle, gcs, steps)


def turned_deg(from_deg: float, to_deg: float) -> float:
    """Heading change, deg in (-180, 180], > 0 clockwise."""
    return (to_deg - from_deg + 180.0) % 360.0 - 180.0


# ------------------------------------------------------- offboard_position_velocity_ned.py
@BOTH
def test_offboard_position_velocity_ned_example(native: bool, start_vehicle,
                                                gcs: Gcs) -> None:
    async def steps(api: Api) -> None:
        sp, offboard, action = api.sp, api.drone.offboard, api.drone.action
        await api.ready()
        await bounded(offboard.set_position_ned(sp.PositionNedYaw(0.0, 0.0, 0.0, 0.0)))
        await bounded(offboard.start())
        await bounded(offboard.set_position_velocity_ned(
            sp.PositionNedYaw(0.0, 0.0, -10.0, 0.0), sp.VelocityNedYaw(0.0, 0.0, -1.0, 0.0)))
        await api.until("position_velocity_ned", lambda pv: pv.position.down_m < -2.0)
        await bounded(offboard.set_position_velocity_ned(
            sp.PositionNedYaw(50.0, 0.0, -10.0, 0.0), sp.VelocityNedYaw(1.0, 0.0, 0.0, 0.0)))
        await api.until("position_velocity_ned", lambda pv: pv.position.north_m > 2.0)
        await bounded(action.land())
        await api.velocity(lambda v: v.down_m_s > SINKING_M_S)  # landing
        # (the example then stops offboard: LAND is no longer offboard, MAVSDK says so or not)
        try:
            await bounded(offboard.stop())
        except (native_offboard.OffboardError, grpc_offboard.OffboardError):
            pass

    run(native, start_vehicle, gcs, steps)


# ------------------------------------------------------------------ offboard_attitude.py
@BOTH
def test_offboard_attitude_example(native: bool, start_vehicle, gcs: Gcs) -> None:
    async def steps(api: Api) -> None:
        sp, offboard, action = api.sp, api.drone.offboard, api.drone.action
        await api.ready()
        await bounded(offboard.set_attitude(sp.Attitude(0.0, 0.0, 0.0, 0.0)))
        await bounded(offboard.start())
        # "Go up at 70% thrust": as ArduCopter reads it, a climb at 0.4 WPNAV_SPEED_UP
        await bounded(offboard.set_attitude(sp.Attitude(0.0, 0.0, 0.0, 0.7)))
        await api.until("position_velocity_ned", lambda pv: pv.position.down_m < -0.3)
        await api.sleep(2.0)
        await bounded(offboard.set_attitude(sp.Attitude(30.0, 0.0, 0.0, 0.6)))
        await api.until("attitude_euler", lambda a: a.roll_deg > ROLLED_DEG)
        await api.sleep(2.0)
        await bounded(offboard.set_attitude(sp.Attitude(-30.0, 0.0, 0.0, 0.6)))
        await api.until("attitude_euler", lambda a: a.roll_deg < -ROLLED_DEG)
        await api.sleep(2.0)
        await bounded(offboard.set_attitude(sp.Attitude(0.0, 0.0, 0.0, 0.6)))  # "Hover"
        await api.until("attitude_euler", lambda a: abs(a.roll_deg) < 5.0)
        await api.sleep(2.0)
        await bounded(offboard.stop())
        await bounded(action.land())
        await api.until("landed_state", lambda s: s.name == "ON_GROUND")

    run(native, start_vehicle, gcs, steps)
