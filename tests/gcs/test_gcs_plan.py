"""QGroundControl ``.plan`` files: the items QGC would upload, and one-line errors for bad ones."""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from gcs.mavlink import mavlink2
from gcs.mission import MissionFileError, load_mission, load_plan

M = mavlink2
ROOT = Path(__file__).resolve().parents[2]
WALL_LIMIT_S = 60.0  # s: start-up of a Python process on a loaded two-core machine

# A plan as QGroundControl 4 saves it (keys, order and nulls as in QGC's own test plans):
# take-off, a waypoint, a speed change (MAV_FRAME_MISSION), a return to launch; a fence of
# one inclusion polygon and one exclusion circle; one rally point.
PLAN: dict[str, Any] = {
    "fileType": "Plan",
    "geoFence": {
        "circles": [{"circle": {"center": [-35.3631, 149.1653], "radius": 12.5},
                     "inclusion": False, "version": 1}],
        "polygons": [{"inclusion": True, "polygon": [[-35.3630, 149.1650],
                                                     [-35.3630, 149.1655],
                                                     [-35.3635, 149.1655]],
                      "version": 1}],
        "version": 2},
    "groundStation": "QGroundControl",
    "mission": {
        "cruiseSpeed": 15, "firmwareType": 3, "globalPlanAltitudeMode": 1, "hoverSpeed": 5,
        "items": [
            {"AMSLAltAboveTerrain": None, "Altitude": 2, "AltitudeMode": 1, "autoContinue": True,
             "command": 22, "doJumpId": 1, "frame": 3,
             "params": [0, 0, 0, None, -35.363261, 149.16523, 2], "type": "SimpleItem"},
            {"AMSLAltAboveTerrain": None, "Altitude": 2, "AltitudeMode": 1, "autoContinue": True,
             "command": 16, "doJumpId": 2, "frame": 3,
             "params": [1.5, 0, 0, None, -35.36325, 149.16524, 2], "type": "SimpleItem"},
            {"autoContinue": True, "command": 178, "doJumpId": 3, "frame": 2,
             "params": [1, 0.5, -1, 0, 0, 0, 0], "type": "SimpleItem"},
            {"autoContinue": True, "command": 20, "doJumpId": 4, "frame": 2,
             "params": [0, 0, 0, 0, 0, 0, 0], "type": "SimpleItem"},
        ],
        "plannedHomePosition": [-35.363261, 149.16523, 584],
        "vehicleType": 2,
        "version": 2},
    "rallyPoints": {"points": [[-35.3632, 149.1651, 5]], "version": 2},
    "version": 1,
}


def write(tmp_path: Path, plan: Any, name: str = "m.plan") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(plan, indent=4) if not isinstance(plan, str) else plan)
    return path


def test_a_qgc_plan_gives_the_items_qgc_uploads(tmp_path: Path) -> None:
    sections = load_plan(write(tmp_path, PLAN))
    takeoff, waypoint, speed, rtl = sections.mission
    assert takeoff.command == M.MAV_CMD_NAV_TAKEOFF
    assert takeoff.frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT
    assert (takeoff.x, takeoff.y, takeoff.z) == (-35.363261, 149.16523, 2.0)
    assert math.isnan(takeoff.params[3])  # null yaw: NaN, "keep the heading"
    assert waypoint.params[0] == 1.5  # hold, s
    assert speed.command == M.MAV_CMD_DO_CHANGE_SPEED and speed.frame == M.MAV_FRAME_MISSION
    assert speed.params[:3] == (1.0, 0.5, -1.0)
    assert rtl.command == M.MAV_CMD_NAV_RETURN_TO_LAUNCH
    # on the wire: degE7, NaN yaw kept
    msg = takeoff.to_message(1, 1, 1)
    assert (msg.x, msg.y) == (-353632610, 1491652300) and math.isnan(msg.param4)
    # the fence as QGC uploads it: each vertex with the vertex count, circles with a radius
    vertices, circle = sections.fence[:3], sections.fence[3]
    assert [v.command for v in vertices] == [M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION] * 3
    assert all(v.params[0] == 3.0 for v in vertices)
    assert circle.command == M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
    assert circle.params[0] == 12.5 and (circle.x, circle.y) == (-35.3631, 149.1653)
    fence_msg = circle.to_message(3, 1, 1, mission_type=M.MAV_MISSION_TYPE_FENCE)
    assert fence_msg.mission_type == M.MAV_MISSION_TYPE_FENCE
    (rally,) = sections.rally
    assert rally.command == M.MAV_CMD_NAV_RALLY_POINT and rally.z == 5.0
    assert load_mission(write(tmp_path, PLAN)) == sections.mission  # --mission FILE.plan


def _with(change: dict[str, Any]) -> dict[str, Any]:
    """PLAN with ``change`` applied: keys are paths like ``mission.items.1.params``."""
    plan = copy.deepcopy(PLAN)
    for where, value in change.items():
        *parents, last = where.split(".")
        node: Any = plan
        for key in parents:
            node = node[int(key)] if isinstance(node, list) else node[key]
        if isinstance(node, list):
            node[int(last)] = value
        elif value is _DELETE:
            del node[last]
        else:
            node[last] = value
    return plan


_DELETE = object()


@pytest.mark.parametrize("plan, words", [
    ("{ not json", "not valid JSON: Expecting property name"),
    ({"fileType": "Mission"}, 'fileType: not a QGroundControl plan (no "fileType": "Plan")'),
    (_with({"mission.version": 1}), "mission.version: 1: only version 2"),
    (_with({"mission.items": []}), "mission.items: no mission items"),
    (_with({"mission.items.1.params": [1, 0, 0, None, 1, 2]}),
     "mission.items[1].params: 6 values: expected 7 (param1..4, latitude, longitude, "
     "altitude; null for none)"),
    (_with({"mission.items.1.params": [1, 0, 0, None, "north", 2, 3]}),
     'mission.items[1].params[4]: "north" is not a number (or null)'),
    (_with({"mission.items.0.command": _DELETE}), "mission.items[0]: no 'command'"),
    (_with({"mission.items.2.type": "ComplexItem",
            "mission.items.2.complexItemType": "survey"}),
     "mission.items[2]: complex item 'survey': not supported (only SimpleItem"),
    (_with({"mission.items.0.frame": 3.5}), "mission.items[0].frame: 3.5 is not a MAV_FRAME"),
    (_with({"mission.items.0.autoContinue": "yes"}),
     'mission.items[0].autoContinue: "yes" must be true or false'),
    (_with({"geoFence.polygons.0.polygon": [[-35.36, 149.16]]}),
     "geoFence.polygons[0].polygon: must be at least 3 [latitude, longitude]"),
    (_with({"geoFence.circles.0.circle": {"center": [-35.36, 149.16], "radius": 0}}),
     "geoFence.circles[0].circle.radius: 0 m must be > 0"),
    (_with({"rallyPoints.points": [[95.0, 149.16, 5]]}),
     "rallyPoints.points[0]: latitude 95, longitude 149.16 out of range"),
])
def test_a_bad_plan_is_one_line_naming_what_is_wrong(tmp_path: Path, plan: Any,
                                                      words: str) -> None:
    path = write(tmp_path, plan)
    with pytest.raises(MissionFileError) as err:
        load_plan(path)
    text = str(err.value)
    assert "\n" not in text and text.startswith(f"{path}: ")
    assert words in text, text


def test_a_bad_plan_stops_ftc_gcs_before_it_connects(tmp_path: Path) -> None:
    path = write(tmp_path, _with({"mission.items.1.params": [1, 0, 0]}))
    proc = subprocess.run([sys.executable, "-m", "gcs", "fly", "--mission", str(path),
                           "--out-dir", str(tmp_path / "out")], cwd=ROOT, capture_output=True,
                          text=True, timeout=WALL_LIMIT_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        f"ftc-gcs: error: {path}: mission.items[1].params: 3 values: expected 7 (param1..4, "
        "latitude, longitude, altitude; null for none)"]
    assert not (tmp_path / "out").exists()  # nothing started, nothing written
