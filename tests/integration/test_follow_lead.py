"""FOLLOW (ArduCopter mode 23) over MAVLink: a second system leads, the vehicle follows.

A pymavlink "lead" (system 2) walks north at 0.2 m/s from 3 m north of home and reports its
position, as a phone or a rover would: GLOBAL_POSITION_INT in one test, FOLLOW_TARGET in the
other. Its position is a function of the vehicle's simulated time (read from the vehicle's
own telemetry), so the lead walks in the vehicle's time at any speed-up. With FOLL_OFS_X -3,
FOLL_OFS_Z -2 the vehicle should stay 3 m behind (south of) the lead, 2 m above it, facing it;
when the lead falls silent the vehicle stops and holds, still in FOLLOW.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import pytest
from vehicle_harness import Gcs, M

from fcu.mavlink.geo import ned_to_geo
from sim.vehicle import DEFAULT_HOME

ACCEPTED = M.MAV_RESULT_ACCEPTED
GUIDED, FOLLOW = 4, 23
SPEEDUP = "10"
LEAD_SYSID = 2
LEAD_START_NED = np.array([3.0, 0.0, 0.0])  # m: on the ground, 3 m north of home
LEAD_VEL_NED = np.array([0.2, 0.0, 0.0])  # m/s: walking north
OFFSET_NED = np.array([-3.0, 0.0, -2.0])  # m: FOLL_OFS_X, FOLL_OFS_Y, FOLL_OFS_Z
REPORT_S = 0.1  # s of simulated time between the lead's reports (10 Hz)
TRACK_M = 0.1  # m: the bound on the distance from the goal once following (measured
# 0.025 m: the chase's reference tracks the goal to a few mm at constant speed, the rest is
# the position loop's lag at 0.2 m/s and the estimate's noise; 4x margin)
REPORT_LAG_S = 5.0  # s simulated: how late a report may reach the vehicle (the lead reports
# at the vehicle's clock as its telemetry shows it; on a loaded machine the telemetry and the
# report each take wall time, 0.5 s wall at 10x in all): along the walk the vehicle may be
# behind the goal by the lead's speed times this


def lead_message(kind: str, t_s: float) -> Any:
    """The lead's report at simulated time ``t_s`` (s since the start of its walk)."""
    vel = LEAD_VEL_NED
    pos = LEAD_START_NED + vel * t_s
    lat, lon, alt = ned_to_geo(pos, DEFAULT_HOME)
    lat_e7, lon_e7 = round(lat * 1e7), round(lon * 1e7)
    if kind == "GLOBAL_POSITION_INT":
        return M.MAVLink_global_position_int_message(
            int(t_s * 1e3), lat_e7, lon_e7, round(alt * 1e3), round(-pos[2] * 1e3),
            *(round(v * 100) for v in vel), 0)  # heading north
    return M.MAVLink_follow_target_message(  # MAVSDK's FollowMe fields, velocity added
        int(t_s * 1e3), 1 | 2, lat_e7, lon_e7, alt, [float(v) for v in vel], [math.nan] * 3,
        [1.0, math.nan, math.nan, math.nan], [math.nan] * 3, [math.nan] * 3, 0)


class Lead:
    """System 2, reporting to the vehicle in the vehicle's simulated time."""

    def __init__(self, gcs: Gcs, kind: str) -> None:
        self.gcs = gcs
        self.kind = kind
        self.radio = Gcs(sysid=LEAD_SYSID, compid=1)
        self.radio.vehicle = gcs.vehicle
        self.start_ms: int | None = None
        self.next_ms = 0

    def run(self, seconds: float, report: bool = True) -> list[Any]:
        """Report (or not) at each of the vehicle's ATTITUDE messages (10 Hz) for ``seconds``
        of simulated time; returns what the vehicle sent meanwhile."""
        since = cursor = self.gcs.mark()
        now_ms: int | None = None
        end_ms = math.inf
        deadline = time.monotonic() + 60.0 + 10.0 * seconds  # s wall, a loaded machine
        while now_ms is None or now_ms < end_ms:
            assert time.monotonic() < deadline, "the vehicle's clock stopped"
            mark = self.gcs.mark()
            attitudes = self.gcs.messages("ATTITUDE", since=cursor)
            cursor = mark
            if not attitudes:
                time.sleep(0.005)
                continue
            now_ms = int(attitudes[-1].time_boot_ms)
            if self.start_ms is None:
                self.start_ms = self.next_ms = now_ms
            if end_ms == math.inf:
                end_ms = now_ms + seconds * 1e3
            if report and now_ms >= self.next_ms:
                self.radio.send(lead_message(self.kind, (now_ms - self.start_ms) / 1e3))
                self.next_ms = now_ms + int(REPORT_S * 1e3)
        return self.gcs.messages(since=since)

    def goal_ned(self, time_boot_ms: int) -> np.ndarray:
        """Where the vehicle should be at ``time_boot_ms``."""
        assert self.start_ms is not None
        return LEAD_START_NED + LEAD_VEL_NED * (time_boot_ms - self.start_ms) / 1e3 + OFFSET_NED

    def close(self) -> None:
        self.radio.close()


@pytest.mark.parametrize("kind", ["GLOBAL_POSITION_INT", "FOLLOW_TARGET"])
def test_the_vehicle_follows_a_second_system_at_the_offset(start_vehicle, gcs: Gcs,
                                                           kind: str) -> None:
    start_vehicle("--speedup", SPEEDUP, outs=[gcs.port])
    gcs.wait_heartbeat()
    gcs.start_reader()
    assert gcs.param_set("DISARM_DELAY", 0.0).param_value == 0.0
    assert gcs.set_mode(FOLLOW).result == M.MAV_RESULT_DENIED  # FOLL_ENABLE 0
    gcs.wait_text("Set FOLL_ENABLE = 1", 0)
    for name, value in (("FOLL_ENABLE", 1), ("FOLL_OFS_X", OFFSET_NED[0]),
                        ("FOLL_OFS_Y", OFFSET_NED[1]), ("FOLL_OFS_Z", OFFSET_NED[2])):
        assert gcs.param_set(name, value).param_value == pytest.approx(value)
    assert gcs.set_mode(GUIDED).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert gcs.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 2.0).result == ACCEPTED
    gcs.wait_text("take-off complete", 0, timeout_s=120.0)

    lead = Lead(gcs, kind)
    try:
        lead.run(0.5)  # heard before the mode is entered
        since = gcs.mark()
        assert gcs.set_mode(FOLLOW).result == ACCEPTED
        gcs.wait_mode(FOLLOW)
        gcs.wait_text("following system 2", since)
        lead.run(20.0)  # settle: the lead walks 4 m
        flown = lead.run(30.0)
        positions = [m for m in flown if m.get_type() == "LOCAL_POSITION_NED"]
        assert len(positions) > 30 * 3  # a few Hz over 30 s
        errors = np.array([[m.x, m.y, m.z] - lead.goal_ned(m.time_boot_ms)
                           for m in positions])
        across = np.abs(errors[:, 1:]).max()  # east and down: no lag shows there
        assert across < TRACK_M, f"largest distance across the walk {across:.3f} m"
        along = errors[:, 0]  # north, along the walk: late reports leave it behind
        behind_m = TRACK_M + float(LEAD_VEL_NED[0]) * REPORT_LAG_S
        assert along.max() < TRACK_M and along.min() > -behind_m, \
            f"along the walk {along.min():.3f} .. {along.max():.3f} m from the goal"
        travelled = positions[-1].x - positions[0].x
        assert travelled == pytest.approx(0.2 * 30.0, abs=0.5)  # kept up with the lead
        yaws = [m.yaw for m in flown if m.get_type() == "ATTITUDE"]
        assert max(abs(y) for y in yaws[-50:]) < 0.1  # FOLL_YAW_BEHAVE 1: facing north

        # the lead falls silent: after FOLLOW's 3 s timeout the vehicle stops and holds
        quiet = lead.run(10.0, report=False)
        held = [m for m in quiet if m.get_type() == "LOCAL_POSITION_NED"][-10:]
        assert all(math.hypot(m.vx, m.vy) < 0.05 for m in held)
        assert gcs.messages("HEARTBEAT")[-1].custom_mode == FOLLOW
    finally:
        lead.close()
