"""Telemetry scheduling in simulated time with a wall-clock heartbeat floor."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from mavlink_testkit import memory_endpoint

from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ, STREAM_GROUPS, StreamScheduler
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
HB = M.MAVLINK_MSG_ID_HEARTBEAT
ATT = M.MAVLINK_MSG_ID_ATTITUDE
DT_S = 0.01  # s, the autopilot's 100 Hz tick


def run(scheduler: StreamScheduler, sim_s: float, *, speedup: float = 1.0,
        t0_s: float = 0.0) -> Counter[int]:
    """Messages due over ``sim_s`` of simulated time ticked every 10 ms (simulated)."""
    counts: Counter[int] = Counter()
    for k in range(round(sim_s / DT_S)):
        t = t0_s + k * DT_S
        counts.update(scheduler.due(t, t / speedup))
    return counts


def test_default_rates_in_simulated_time() -> None:
    counts = run(StreamScheduler(), 10.0)
    for msg_id, rate in DEFAULT_RATES_HZ.items():
        # +1: every stream also fires at t = 0; rates are divisors of the 100 Hz tick.
        assert counts[msg_id] == pytest.approx(rate * 10.0 + 1, abs=1), msg_id


def test_rates_scale_with_a_speed_up_except_nothing_is_lost() -> None:
    # At 10x the same simulated 10 s pass in 1 wall second: the same messages are sent.
    assert run(StreamScheduler(), 10.0, speedup=10.0) == run(StreamScheduler(), 10.0)


def test_heartbeat_keeps_a_wall_clock_floor_while_the_simulation_is_paused() -> None:
    scheduler = StreamScheduler()
    scheduler.due(5.0, 0.0)  # first tick: everything is due
    beats = 0
    for k in range(1, 1001):  # 10 wall seconds of ticks, simulated time frozen at 5 s
        due = scheduler.due(5.0, k * 0.01)
        assert due in ([], [HB])  # nothing else: the other streams wait for simulated time
        beats += len(due)
    assert beats == 10  # one per wall second


def test_heartbeat_floor_in_a_slow_motion_simulation() -> None:
    scheduler = StreamScheduler()
    wall_beats = []
    for k in range(2000):  # 20 wall s at 0.1x: 2 simulated seconds
        wall = k * 0.01
        if HB in scheduler.due(wall * 0.1, wall):
            wall_beats.append(wall)
    gaps = [b - a for a, b in zip(wall_beats, wall_beats[1:], strict=False)]
    assert max(gaps) <= 1.0 + 1e-9  # never more than a wall second apart


def test_set_rate_stop_and_default() -> None:
    scheduler = StreamScheduler()
    scheduler.set_rate(ATT, 5.0)
    assert run(scheduler, 10.0)[ATT] == pytest.approx(51, abs=1)
    scheduler.set_rate(ATT, 0.0)
    assert run(scheduler, 10.0, t0_s=10.0)[ATT] == 0
    scheduler.set_rate(ATT, None)
    assert scheduler.rate_hz(ATT) == DEFAULT_RATES_HZ[ATT]


def test_heartbeat_cannot_be_stopped_and_rates_are_validated() -> None:
    scheduler = StreamScheduler()
    with pytest.raises(ValueError, match="HEARTBEAT"):
        scheduler.set_rate(HB, 0.0)
    with pytest.raises(ValueError):
        scheduler.set_rate(ATT, float("nan"))
    with pytest.raises(ValueError):
        scheduler.set_rate(ATT, -1.0)
    with pytest.raises(KeyError):
        scheduler.set_rate(12345, 1.0)


def test_group_rates_follow_ardupilot_groups() -> None:
    scheduler = StreamScheduler()
    assert scheduler.set_group_rate(M.MAV_DATA_STREAM_POSITION, 0.0)
    assert scheduler.rate_hz(M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT) == 0.0
    assert scheduler.rate_hz(M.MAVLINK_MSG_ID_LOCAL_POSITION_NED) == 0.0
    assert scheduler.rate_hz(ATT) == DEFAULT_RATES_HZ[ATT]  # other groups untouched
    assert scheduler.set_group_rate(M.MAV_DATA_STREAM_ALL, 3.0)
    for group in STREAM_GROUPS.values():
        for msg_id in group:
            assert scheduler.rate_hz(msg_id) == 3.0
    assert scheduler.rate_hz(HB) == 1.0  # in no group
    assert not scheduler.set_group_rate(99, 1.0)


def test_time_going_backwards_restarts_the_schedule() -> None:
    scheduler = StreamScheduler()
    run(scheduler, 5.0, t0_s=100.0)
    assert ATT in scheduler.due(0.0, 1000.0)  # after a reboot the streams start again


def test_endpoint_streams_start_by_themselves_in_simulated_time() -> None:
    endpoint, vehicle, link, _ = memory_endpoint()
    vehicle.target = np.zeros(3)  # a position reference exists (POSITION_TARGET_LOCAL_NED)
    for k in range(500):  # 5 simulated seconds, wall clock standing still
        vehicle.time_s = k * DT_S
        endpoint.tick(vehicle.time_s, 0.0)
    counts = Counter(m.get_type() for m in link.take())
    assert counts["ATTITUDE"] == pytest.approx(100, abs=1)
    assert counts["HEARTBEAT"] == pytest.approx(5, abs=1)
    assert counts["NAMED_VALUE_FLOAT"] == pytest.approx(4 * 10, abs=4)  # LOE1..4 at 2 Hz
    for kind in ("SYS_STATUS", "GPS_RAW_INT", "ATTITUDE_QUATERNION", "LOCAL_POSITION_NED",
                 "GLOBAL_POSITION_INT", "VFR_HUD", "SERVO_OUTPUT_RAW", "BATTERY_STATUS",
                 "HOME_POSITION", "EXTENDED_SYS_STATE", "MISSION_CURRENT", "SYSTEM_TIME",
                 "POSITION_TARGET_LOCAL_NED", "ATTITUDE_TARGET", "SIM_STATE"):
        assert counts[kind] >= 1, kind


class _EveryStreamEveryTick:
    """The schedule's rules checked stream by stream at every call (the scheduler skips the
    calls before its earliest due time): the reference the scheduler must match."""

    def __init__(self, rates_hz: dict[int, float], heartbeat_wall_period_s: float) -> None:
        self.rates_hz = dict(rates_hz)
        self.period_s = heartbeat_wall_period_s
        self.next_s = {m: -np.inf for m in rates_hz}
        self.last_time_s = -np.inf
        self.last_heartbeat_wall_s = -np.inf

    def due(self, time_s: float, wall_time_s: float) -> list[int]:
        if time_s < self.last_time_s:
            self.next_s = {m: -np.inf for m in self.rates_hz}
        self.last_time_s = time_s
        out = []
        for msg_id, rate in self.rates_hz.items():
            wall_due = (msg_id == HB and wall_time_s - self.last_heartbeat_wall_s
                        >= self.period_s)
            if rate <= 0.0 and not wall_due:
                continue
            next_s = self.next_s[msg_id]
            if time_s >= next_s or wall_due:
                period = 1.0 / rate
                self.next_s[msg_id] = (next_s + period if time_s < next_s + period
                                       else time_s + period)
                if msg_id == HB:
                    self.last_heartbeat_wall_s = wall_time_s
                    if wall_due and time_s < next_s:
                        self.next_s[msg_id] = time_s + period
                out.append(msg_id)
        out.sort(key=lambda m: m != HB)
        return out


def test_the_schedule_is_the_stream_by_stream_rule_at_every_tick() -> None:
    """Random rate changes, stalls, pauses, time steps back and heartbeat requests: every
    call answers what checking every stream at every call answers."""
    rng = np.random.default_rng(7)
    rates = {m: r for m, r in reversed(DEFAULT_RATES_HZ.items())}  # HEARTBEAT not first
    scheduler = StreamScheduler(rates, heartbeat_wall_period_s=1.0)
    reference = _EveryStreamEveryTick(rates, 1.0)
    ids = list(rates)
    t, wall = 0.0, 0.0
    sent = 0
    for _ in range(30_000):
        roll = rng.random()
        if roll < 0.002:
            msg_id = ids[int(rng.integers(len(ids)))]
            rate = None if rng.random() < 0.3 else float(rng.choice([0.0, 0.7, 5.0, 50.0, 400.0]))
            if msg_id == HB and rate == 0.0:
                rate = 2.0
            scheduler.set_rate(msg_id, rate)
            reference.rates_hz[msg_id] = min(rates[msg_id] if rate is None else rate, 100.0)
            reference.next_s[msg_id] = -np.inf
        elif roll < 0.003:
            scheduler.request_heartbeat()
            reference.next_s[HB] = -np.inf
        elif roll < 0.004:
            t -= 0.5  # a reboot's clock going back
        elif roll < 0.01:
            wall += 1.5  # paused (simulated time holds) or slow motion: the wall clock goes on
            t += float(rng.choice([0.0, DT_S, 0.5]))
        else:
            t += DT_S * (1 + int(rng.random() < 0.01) * 40)  # now and then a stall
            wall += DT_S / 20.0
        expected = reference.due(t, wall)
        assert scheduler.due(t, wall) == expected
        sent += len(expected)
    assert sent > 20_000  # the calls that sent something are not a handful
