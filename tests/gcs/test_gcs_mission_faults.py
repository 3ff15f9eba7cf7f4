"""Missions and fault schedules as the ground station reads and sends them."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gcs.faults import (
    TABLE_7_3,
    FaultScheduleError,
    FaultSpec,
    load_schedule,
    parse_fault_flag,
)
from gcs.mavlink import decode_packet, mavlink2
from gcs.mission import MissionFileError, load_mission, thesis_mission

M = mavlink2
ROOT = Path(__file__).resolve().parents[2]


def test_thesis_mission_is_the_chapter_7_flight() -> None:
    items = thesis_mission()
    assert [i.command for i in items] == [178, 22, 16, 178, 16, 16, 16, 16, 178, 21]
    assert items[0].params[:2] == (2.0, pytest.approx(0.18))  # climb 1.5 * 0.6 / 5
    assert items[1].z == 0.6 and items[1].frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    corners = [(i.x, i.y, i.z) for i in items[4:8]]
    assert corners == [(1.0, 0.0, -0.6), (1.0, 1.0, -0.6), (0.0, 1.0, -0.6), (0.0, 0.0, -0.6)]
    assert [i.params[0] for i in items[4:8]] == [1.0, 1.0, 1.0, 2.0]  # holds, s
    assert items[3].params[:2] == (1.0, pytest.approx(0.15))  # ground 1.5 * 1 / 10
    assert items[8].params[:2] == (3.0, pytest.approx(0.225))  # descent 1.5 * 0.6 / 4


def test_local_items_travel_in_1e4_metres_and_nan_yaw_survives() -> None:
    wp = thesis_mission()[5]  # (1, 1, -0.6)
    msg = wp.to_message(6, 1, 1)
    decoded = decode_packet(msg.pack(M.MAVLink(None, 255, 190)))
    assert decoded is not None
    assert (decoded.x, decoded.y, decoded.z) == (10000, 10000, pytest.approx(-0.6))
    assert math.isnan(decoded.param4)


def test_waypoint_file_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "m.waypoints"
    path.write_text("QGC WPL 110\n"
                    "0\t1\t0\t16\t0\t0\t0\t0\t-35.36\t149.16\t584\t1\n"
                    "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t0.6\t1\n"
                    "2\t0\t1\t16\t1\t0\t0\t0\t1.0\t0\t-0.6\t1\n")
    items = load_mission(path)
    assert [(i.command, i.frame) for i in items] == [(22, 3), (16, 1)]


def test_toml_mission_with_named_and_raw_items(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text('[[items]]\ncommand = "takeoff"\nalt_m = 0.5\n'
                    '[[items]]\ncommand = "waypoint"\npos_ned = [0.5, 0, -0.5]\nhold_s = 1\n'
                    '[[items]]\nmav_cmd = 21\nframe = 6\n')
    items = load_mission(path)
    assert [i.command for i in items] == [22, 16, 21]
    assert items[1].params[0] == 1.0


@pytest.mark.parametrize("body, words", [
    ('[[items]]\ncommand = "jump"\n', r"items\[0\]\.command"),
    ('[[items]]\ncommand = "waypoint"\n', "needs pos_ned"),
    ('[[items]]\ncommand = "takeoff"\nalt = 1\n', "unknown key alt"),
    ('items = 3\n', "non-empty array"),
])
def test_bad_toml_mission_names_the_key(tmp_path: Path, body: str, words: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(body)
    with pytest.raises(MissionFileError, match=words):
        load_mission(path)


def test_table_7_3() -> None:
    assert [(f.motor, f.loe, f.at_s) for f in TABLE_7_3] == [(3, 0.2, 22.0), (1, 0.3, 38.0),
                                                             (4, 0.15, 48.0)]


def test_fault_flags() -> None:
    assert parse_fault_flag("3:0.20@22") == FaultSpec(motor=3, loe=0.2, at_s=22.0)
    assert parse_fault_flag("sim_baro_glitch=0.1@30") == FaultSpec(
        param="SIM_BARO_GLITCH", value=0.1, at_s=30.0)
    for bad in ("5:0.2@22", "3:1.5@22", "3:0.2", "nonsense"):
        with pytest.raises(FaultScheduleError):
            parse_fault_flag(bad)


def test_scenario_files_load_as_schedules() -> None:
    faults = load_schedule(ROOT / "sim" / "scenarios" / "lqg_loe.toml")
    assert faults == list(TABLE_7_3)


def test_schedule_file_errors_name_the_key(tmp_path: Path) -> None:
    path = tmp_path / "f.toml"
    path.write_text('[[faults]]\ntype = "sensor"\nsensor = "baro"\nstart_s = 1.0\n')
    with pytest.raises(FaultScheduleError, match=r"faults\[0\].type"):
        load_schedule(path)
    path.write_text('[[faults]]\nmotor = 2\nloe = 0.1\n')
    with pytest.raises(FaultScheduleError, match="needs at_s"):
        load_schedule(path)
    path.write_text('[[faults]]\nparam = "SIM_MASS_DROP"\nvalue = 0.3\nat_s = 22\n'
                    '[[faults]]\nmotor = 2\nloe = 0.1\nat_s = 5\n')
    assert [f.at_s for f in load_schedule(path)] == [5.0, 22.0]
