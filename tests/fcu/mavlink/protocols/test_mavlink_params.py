"""Parameter table and protocol: complete contiguous lists, validated sets, echoes."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from mavlink_testkit import Gcs, VehicleThread, linked

from fcu.mavlink.port_records import CommandResult, ParamSpec
from fcu.mavlink.protocols.params import ParamEntry, ParamTable, wire_type
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
Link = tuple[Gcs, VehicleThread]


@pytest.fixture
def link() -> Iterator[Link]:
    """A ground station and a vehicle with the default parameters, sending to it."""
    with linked() as pair:
        yield pair


def table() -> ParamTable:
    def refuse_big(value: float) -> CommandResult:
        return CommandResult.denied("too big for now") if value > 5 else CommandResult.ok()

    return ParamTable([
        ParamEntry(ParamSpec(name="B_GAIN", value=1.0, min_value=0.0, max_value=10.0)),
        ParamEntry(ParamSpec(name="A_MODE", value=5, allowed=(0, 1, 5), integer=True)),
        ParamEntry(ParamSpec(name="C_LIMITED", value=1.0, min_value=0, max_value=10),
                   refuse_big),
    ])


def test_table_is_sorted_and_indexed() -> None:
    t = table()
    assert t.names == ["A_MODE", "B_GAIN", "C_LIMITED"]
    assert [t.index_of(n) for n in t.names] == [0, 1, 2]
    assert t.index_of("NOPE") is None


@pytest.mark.parametrize("name, value, why", [
    ("B_GAIN", math.nan, "finite"), ("B_GAIN", math.inf, "finite"), ("B_GAIN", 10.5, "outside"),
    ("A_MODE", 2.0, "not one of"), ("A_MODE", 1.5, "whole"), ("C_LIMITED", 6.0, "too big"),
])
def test_table_refuses_and_keeps_the_value(name: str, value: float, why: str) -> None:
    t = table()
    before = t.get(name)
    outcome = t.set(name, value)
    assert not outcome.accepted and why in outcome.reason
    assert outcome.value == before == t.get(name)


def test_table_stores_float32() -> None:
    t = table()
    outcome = t.set("B_GAIN", 0.1)
    assert outcome.accepted and outcome.value == float(np.float32(0.1))


@pytest.mark.parametrize("spec, wire", [
    (ParamSpec(name="F", value=0.5), M.MAV_PARAM_TYPE_REAL32),
    (ParamSpec(name="B", value=1, min_value=-128, max_value=127, integer=True),
     M.MAV_PARAM_TYPE_INT8),
    (ParamSpec(name="S", value=1, min_value=0, max_value=255, integer=True),
     M.MAV_PARAM_TYPE_INT16),
    (ParamSpec(name="E", value=1, allowed=(0, 40000), integer=True), M.MAV_PARAM_TYPE_INT32),
    (ParamSpec(name="U", value=1, integer=True), M.MAV_PARAM_TYPE_INT32),
])
def test_wire_type_is_the_smallest_integer_type_holding_the_range(spec: ParamSpec,
                                                                   wire: int) -> None:
    assert wire_type(spec) == wire


def test_an_unbounded_integer_is_kept_within_int32() -> None:
    t = ParamTable([ParamEntry(ParamSpec(name="U", value=1, integer=True))])
    assert "INT32" in t.set("U", 2.0**31).reason
    assert t.set("U", -(2.0**31)).accepted


def test_duplicate_names_and_long_names_are_refused() -> None:
    spec = ParamSpec(name="X", value=0.0)
    with pytest.raises(ValueError, match="twice"):
        ParamTable([ParamEntry(spec), ParamEntry(spec)])
    with pytest.raises(ValueError, match="16"):
        ParamSpec(name="A" * 17, value=0.0)


def test_param_list_is_complete_and_contiguous(link: Link) -> None:
    gcs, vehicle = link
    gcs.mav.param_request_list_send(1, 0)
    values = gcs.collect("PARAM_VALUE", 1.5)
    expected = vehicle.endpoint.params.names
    assert sorted(v.param_index for v in values) == list(range(len(expected)))
    assert {v.param_count for v in values} == {len(expected)}
    assert {v.param_id: v.param_index for v in values} == \
        {name: i for i, name in enumerate(expected)}
    specs = {name: vehicle.endpoint.params.spec_at(i) for i, name in enumerate(expected)}
    types = {v.param_id: v.param_type for v in values}
    # typed as ArduPilot types them: integers INT8/16/32 (C_CAST value), floats REAL32
    assert {name for name, t in types.items() if t == M.MAV_PARAM_TYPE_REAL32} == \
        {name for name, spec in specs.items() if not spec.integer}
    assert types["FS_GCS_ENABLE"] == M.MAV_PARAM_TYPE_INT8  # 0..5
    assert types["SYSID_MYGCS"] == M.MAV_PARAM_TYPE_INT16  # 1..255: beyond INT8
    names = {v.param_id for v in values}
    assert {"SYSID_THISMAV", "SYSID_MYGCS", "FS_GCS_ENABLE", "FS_GCS_TIMEOUT",
            "WPNAV_SPEED"} <= names
    by_name = {v.param_id: v.param_value for v in values}
    assert by_name["FS_GCS_TIMEOUT"] == 5.0 and by_name["SYSID_MYGCS"] == 255


def test_param_read_by_name_and_index(link: Link) -> None:
    gcs, vehicle = link
    gcs.mav.param_request_read_send(1, 1, b"FS_GCS_TIMEOUT", -1)
    by_name = gcs.recv("PARAM_VALUE", condition=lambda m: m.param_id == "FS_GCS_TIMEOUT")
    index = vehicle.endpoint.params.index_of("WPNAV_SPEED")
    gcs.mav.param_request_read_send(1, 1, b"", index)
    by_index = gcs.recv("PARAM_VALUE", condition=lambda m: m.param_index == index)
    gcs.mav.param_request_read_send(1, 1, b"NO_SUCH_PARAM", -1)
    text = gcs.recv("STATUSTEXT", condition=lambda m: "NO_SUCH_PARAM" in m.text)
    assert by_name is not None and by_name.param_value == 5.0
    assert by_index is not None and by_index.param_id == "WPNAV_SPEED"
    assert text is not None


def test_param_set_accepted_is_applied_and_echoed(link: Link) -> None:
    gcs, vehicle = link
    gcs.mav.param_set_send(1, 1, b"WPNAV_SPEED", 7.5, M.MAV_PARAM_TYPE_REAL32)
    echo = gcs.recv("PARAM_VALUE", condition=lambda m: m.param_id == "WPNAV_SPEED")
    assert echo is not None and echo.param_value == 7.5
    assert vehicle.vehicle.param_values["WPNAV_SPEED"] == 7.5


@pytest.mark.parametrize("value, why", [(math.nan, "finite"), (math.inf, "finite"),
                                        (1000.0, "outside")])
def test_param_set_invalid_echoes_the_old_value_with_a_reason(value: float, why: str,
                                                             link: Link) -> None:
    gcs, _ = link
    gcs.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", value, M.MAV_PARAM_TYPE_REAL32)
    got = gcs.gather({"PARAM_VALUE": lambda m: m.param_id == "FS_GCS_TIMEOUT",
                      "STATUSTEXT": lambda m: "FS_GCS_TIMEOUT" in m.text})
    assert got["PARAM_VALUE"].param_value == 5.0  # the unchanged value is echoed
    assert why in got["STATUSTEXT"].text


def test_param_set_refused_by_the_vehicle(link: Link) -> None:
    gcs, vehicle = link
    with vehicle.lock:
        vehicle.vehicle.armed = True
    gcs.mav.param_set_send(1, 1, b"WPNAV_SPEED", 18.0, M.MAV_PARAM_TYPE_REAL32)
    got = gcs.gather({"PARAM_VALUE": lambda m: m.param_id == "WPNAV_SPEED",
                      "STATUSTEXT": lambda m: "WPNAV_SPEED" in m.text})
    assert got["PARAM_VALUE"].param_value == 5.0
    assert "disarmed" in got["STATUSTEXT"].text


def test_param_set_unknown_name_gets_a_statustext(link: Link) -> None:
    gcs, _ = link
    gcs.mav.param_set_send(1, 1, b"NOT_A_PARAM", 1.0, M.MAV_PARAM_TYPE_REAL32)
    text = gcs.recv("STATUSTEXT", condition=lambda m: "NOT_A_PARAM" in m.text)
    echoes = gcs.collect("PARAM_VALUE", 0.5)
    assert text is not None and "Unknown parameter" in text.text
    assert echoes == []


def test_repeated_unknown_reads_get_one_statustext_and_no_value(link: Link) -> None:
    # MAVSDK retries a read six times before its own time-out: one line for the pilot
    log: list = []

    def until(done: Callable[[Any], bool]) -> Callable[[Any], bool]:
        def record(msg: Any) -> bool:
            log.append(msg)
            return done(msg)
        return record

    gcs, _ = link
    for _ in range(6):
        gcs.mav.param_request_read_send(1, 1, b"NO_SUCH_PARAM", -1)
    gcs.mav.param_request_read_send(1, 1, b"FS_GCS_TIMEOUT", -1)  # answered after them
    known = gcs.recv(["PARAM_VALUE", "STATUSTEXT"], condition=until(
        lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == "FS_GCS_TIMEOUT"))
    gcs.mav.param_request_read_send(1, 1, b"OTHER_UNKNOWN", -1)
    other = gcs.recv(["PARAM_VALUE", "STATUSTEXT"], condition=until(
        lambda m: m.get_type() == "STATUSTEXT" and "OTHER_UNKNOWN" in m.text))
    log += gcs.collect(["STATUSTEXT", "PARAM_VALUE"], 0.5)
    assert known is not None and other is not None  # another unknown name is still reported
    texts = [m.text for m in log if m.get_type() == "STATUSTEXT"]
    assert texts.count("Unknown parameter NO_SUCH_PARAM") == 1
    assert not [m for m in log if m.get_type() == "PARAM_VALUE"
                and m.param_id in ("NO_SUCH_PARAM", "OTHER_UNKNOWN")]


def test_param_set_ignores_the_type_field_and_echoes_the_parameter_type(link: Link) -> None:
    # ArduPilot ignores PARAM_SET.param_type: REAL32 sent for an INT8 parameter is applied
    gcs, _ = link
    gcs.mav.param_set_send(1, 1, b"FS_GCS_ENABLE", 1.0, M.MAV_PARAM_TYPE_REAL32)
    echo = gcs.recv("PARAM_VALUE", condition=lambda m: m.param_id == "FS_GCS_ENABLE")
    gcs.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", 7.0, M.MAV_PARAM_TYPE_INT8)
    echo_float = gcs.recv("PARAM_VALUE",
                          condition=lambda m: m.param_id == "FS_GCS_TIMEOUT")
    assert echo is not None and (echo.param_value, echo.param_type) == (1.0,
                                                                        M.MAV_PARAM_TYPE_INT8)
    assert echo_float is not None and (echo_float.param_value, echo_float.param_type) == \
        (7.0, M.MAV_PARAM_TYPE_REAL32)


def test_param_set_int_type_is_c_cast(link: Link) -> None:
    # A GCS that believes SYSID_MYGCS is INT32 still sends the value as a float (C_CAST).
    gcs, vehicle = link
    gcs.mav.param_set_send(1, 1, b"SYSID_MYGCS", 200.0, M.MAV_PARAM_TYPE_INT32)
    echo = gcs.recv("PARAM_VALUE", condition=lambda m: m.param_id == "SYSID_MYGCS")
    assert echo is not None and echo.param_value == 200.0
    assert vehicle.endpoint.params.get("SYSID_MYGCS") == 200.0
