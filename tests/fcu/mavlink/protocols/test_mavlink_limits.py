"""Commands at the edges of their ranges: message ids beyond MESSAGE_INTERVAL's field, a home
on the other side of the planet, stream intervals faster than the autopilot ticks.

Driven in memory (:func:`mavlink_testkit.memory_endpoint`): deterministic clocks, every reply
decoded with pymavlink.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from mavlink_testkit import ORIGIN, FakeVehicle, MemoryGcs, MemoryLink, memory_endpoint

from fcu.mavlink.endpoint import MavlinkEndpoint
from fcu.mavlink.endpoint_config import EndpointConfig
from fcu.mavlink.geo import ned_to_geo
from fcu.mavlink.protocols.command_request import CommandLimits
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
ATTITUDE = M.MAVLINK_MSG_ID_ATTITUDE


def command(endpoint: MavlinkEndpoint, link: MemoryLink, gcs: MemoryGcs, cmd: int,
            *params: float) -> tuple[Any, list[Any]]:
    """Send COMMAND_LONG, tick once; returns its single ACK and everything else sent."""
    p = list(params) + [0.0] * (7 - len(params))
    link.take()
    gcs.put(M.MAVLink_command_long_message(1, 1, cmd, 0, *p))
    endpoint.tick(1.0, 1.0)
    sent = link.take()
    acks = [m for m in sent if m.get_type() == "COMMAND_ACK" and m.command == cmd]
    assert len(acks) == 1, sent
    return acks[0], [m for m in sent if m.get_type() != "COMMAND_ACK"]


def texts(sent: list[Any]) -> list[str]:
    """STATUSTEXTs, chunks (same id) put back together."""
    out: dict[int, str] = {}
    for m in sent:
        if m.get_type() == "STATUSTEXT":
            key = m.id if m.id else -len(out) - 1
            out[key] = out.get(key, "") + m.text
    return list(out.values())


@pytest.mark.parametrize("msg_id", [65536, 70000, 0xFFFFFF])
def test_get_message_interval_beyond_the_uint16_field_is_denied(msg_id: int) -> None:
    endpoint, _, link, gcs = memory_endpoint()
    ack, sent = command(endpoint, link, gcs, M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)
    assert ack.result == M.MAV_RESULT_DENIED
    assert [m for m in sent if m.get_type() == "MESSAGE_INTERVAL"] == []
    assert any(str(msg_id) in t and "65535" in t for t in texts(sent))
    assert endpoint.stats.build_errors == 0 and endpoint.stats.handler_errors == 0


def test_get_message_interval_of_an_id_that_is_not_streamed_says_not_available() -> None:
    endpoint, _, link, gcs = memory_endpoint()
    ack, sent = command(endpoint, link, gcs, M.MAV_CMD_GET_MESSAGE_INTERVAL, 65535)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    (interval,) = [m for m in sent if m.get_type() == "MESSAGE_INTERVAL"]
    assert (interval.message_id, interval.interval_us) == (65535, 0)  # 0: not available


def home_at(north_m: float, east_m: float) -> tuple[float, float, float]:
    lat, lon, alt = ned_to_geo(np.array([north_m, east_m, 0.0]), ORIGIN)
    return lat, lon, alt


def test_a_home_farther_than_the_limit_from_the_origin_is_denied() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    limit_m = CommandLimits().max_home_distance_m
    assert limit_m == 50_000.0  # ArduCopter's EKF_ORIGIN_MAX_DIST_M
    # 14,000 km away (the other side of the planet, as latitude allows)
    far = (ORIGIN.lat_deg - 126.0 if ORIGIN.lat_deg > 0 else ORIGIN.lat_deg + 126.0,
           ORIGIN.lon_deg, ORIGIN.alt_m)
    ack, sent = command(endpoint, link, gcs, M.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, *far)
    assert ack.result == M.MAV_RESULT_DENIED
    assert any("km from the origin" in t and "limit 50 km" in t for t in texts(sent)), texts(sent)
    # just beyond and just within the limit, both ways
    ack, _ = command(endpoint, link, gcs, M.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0,
                     *home_at(0.0, limit_m + 500.0))
    assert ack.result == M.MAV_RESULT_DENIED
    assert not [c for c in vehicle.calls if c[0] == "set_home"]
    ack, _ = command(endpoint, link, gcs, M.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0,
                     *home_at(-limit_m * 0.6, limit_m * 0.7))  # 46 km
    assert ack.result == M.MAV_RESULT_ACCEPTED
    assert [c[0] for c in vehicle.calls] == ["set_home"]


def test_set_home_as_command_int_is_judged_the_same() -> None:
    endpoint, vehicle, link, gcs = memory_endpoint()
    lat, lon, alt = home_at(60_000.0, 0.0)
    link.take()
    gcs.put(M.MAVLink_command_int_message(1, 1, M.MAV_FRAME_GLOBAL, M.MAV_CMD_DO_SET_HOME, 0,
                                          0, 0, 0, 0, 0, round(lat * 1e7), round(lon * 1e7),
                                          alt))
    endpoint.tick(1.0, 1.0)
    (ack,) = link.take("COMMAND_ACK")
    assert ack.result == M.MAV_RESULT_DENIED
    assert not vehicle.calls


@pytest.mark.parametrize("interval_us", [1.0, 100.0, 9_999.0])
def test_an_interval_faster_than_the_loop_is_clamped_to_one_message_per_tick(
        interval_us: float) -> None:
    endpoint, _, link, gcs = memory_endpoint()
    assert EndpointConfig().max_stream_rate_hz == 100.0  # the autopilot's default loop rate
    ack, _ = command(endpoint, link, gcs, M.MAV_CMD_SET_MESSAGE_INTERVAL, ATTITUDE,
                     interval_us)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    _, sent = command(endpoint, link, gcs, M.MAV_CMD_GET_MESSAGE_INTERVAL, ATTITUDE)
    (interval,) = [m for m in sent if m.get_type() == "MESSAGE_INTERVAL"]
    assert interval.interval_us == 10_000  # 100 Hz: the effective rate
    assert endpoint.streams.rate_hz(ATTITUDE) == 100.0


def test_the_clamp_follows_the_configured_loop_rate() -> None:
    endpoint, _, link, gcs = memory_endpoint(EndpointConfig(max_stream_rate_hz=400.0))
    command(endpoint, link, gcs, M.MAV_CMD_SET_MESSAGE_INTERVAL, ATTITUDE, 1.0)
    _, sent = command(endpoint, link, gcs, M.MAV_CMD_GET_MESSAGE_INTERVAL, ATTITUDE)
    (interval,) = [m for m in sent if m.get_type() == "MESSAGE_INTERVAL"]
    assert interval.interval_us == 2_500
    # an interval slower than the cap is kept as asked
    command(endpoint, link, gcs, M.MAV_CMD_SET_MESSAGE_INTERVAL, ATTITUDE, 20_000.0)
    _, sent = command(endpoint, link, gcs, M.MAV_CMD_GET_MESSAGE_INTERVAL, ATTITUDE)
    (interval,) = [m for m in sent if m.get_type() == "MESSAGE_INTERVAL"]
    assert interval.interval_us == 20_000



class StepClock:
    """A wall clock that moves ``step_s`` each time it is read."""

    def __init__(self, step_s: float) -> None:
        self.now_s, self.step_s = 0.0, step_s

    def __call__(self) -> float:
        self.now_s += self.step_s
        return self.now_s


def test_a_flood_is_handled_a_budget_at_a_time_in_order_and_nothing_lost() -> None:
    link = MemoryLink()
    endpoint = MavlinkEndpoint(FakeVehicle(), link,
                               config=EndpointConfig(receive_budget_s=0.0025),
                               clock=StepClock(0.001))  # each datagram "takes" 1 ms
    gcs = MemoryGcs(link)
    n_params = len(endpoint.params.names)
    for k in range(100):
        gcs.put(M.MAVLink_param_request_read_message(1, 1, b"", k % n_params))
    handled = [endpoint.poll(1.0) for _ in range(40)]
    assert handled[:33] == [3] * 33 and handled[33] == 1 and sum(handled) == 100
    # every request answered, in the order it came
    values = link.take("PARAM_VALUE")
    assert [v.param_index for v in values] == [k % n_params for k in range(100)]
    assert endpoint.stats.datagrams == 100
