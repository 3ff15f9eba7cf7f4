"""PREFLIGHT_CALIBRATION on simulated sensors, as ArduPilot SITL answers it: accepted, then
PX4's ``[cal]`` progress texts (started, progress, done) that ground stations parse."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from fcu.mavlink.protocols.command_request import CommandLimits, CommandRequest
from fcu.mavlink.protocols.commands import CommandDispatcher
from fcu.mavlink.transport.codec import mavlink2

M = mavlink2
NAN = float("nan")


@dataclass
class Snapshot:
    armed: bool


class Port:
    def __init__(self, armed: bool = False) -> None:
        self.armed = armed

    def snapshot(self) -> Snapshot:
        return Snapshot(self.armed)


def calibrate(*params: float, armed: bool = False) -> tuple[int, list[str]]:
    p = list(params) + [0.0] * (7 - len(params))
    dispatcher = CommandDispatcher(Port(armed), None, None, lambda msg_id: None,  # type: ignore[arg-type]
                                   lambda: 0, CommandLimits())
    out = dispatcher.dispatch(CommandRequest(command=M.MAV_CMD_PREFLIGHT_CALIBRATION,
                                             params=(p[0], p[1], p[2], p[3]), x=p[4], y=p[5],
                                             z=p[6]))
    return out.result, [m.text for m in out.follow_up]


@pytest.mark.parametrize("params, name", [((1,), "gyro"), ((0, 1), "mag"), ((0, 0, 1), "baro"),
                                          ((0, 0, 0, 0, 1), "accel"),
                                          ((0, 0, 0, 0, 2), "level"),
                                          ((0, 0, 0, 0, 4), "accel")])
def test_each_sensor_is_started_progressed_and_done(params: tuple[float, ...],
                                                     name: str) -> None:
    result, texts = calibrate(*params)
    assert result == M.MAV_RESULT_ACCEPTED
    assert texts == [f"[cal] calibration started: 2 {name}", "[cal] progress <50>",
                     "[cal] progress <100>", f"[cal] calibration done: {name}"]
    assert all(len(t) <= 50 for t in texts)  # one STATUSTEXT each


def test_two_at_once_and_nan_as_zero() -> None:
    result, texts = calibrate(1, NAN, NAN, NAN, 1, NAN, NAN)
    assert result == M.MAV_RESULT_ACCEPTED
    assert texts[3] == "[cal] calibration done: gyro" and texts[-1].endswith("accel")


def test_cancel_refusals_and_unsupported() -> None:
    assert calibrate() == (M.MAV_RESULT_ACCEPTED, ["[cal] calibration cancelled"])
    assert calibrate(1, armed=True)[0] == M.MAV_RESULT_DENIED
    assert calibrate(0.5)[0] == M.MAV_RESULT_DENIED  # not a whole number
    assert calibrate(0, 0, 0, 1)[0] == M.MAV_RESULT_UNSUPPORTED  # radio trim
    assert calibrate(0, 0, 0, 0, 0, 0, 1)[0] == M.MAV_RESULT_UNSUPPORTED  # ESC
