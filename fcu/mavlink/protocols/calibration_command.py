"""PREFLIGHT_CALIBRATION on simulated sensors: accepted, and PX4's ``[cal]`` progress texts.

The sensors are simulated: gyro, compass, barometer, accelerometer and level calibrations are
accepted and reported started, in progress and done at once, in the STATUSTEXTs of PX4's
calibration protocol that MAVSDK and QGroundControl parse; all parameters 0 cancels.
"""

from __future__ import annotations

import math

from fcu.mavlink.enums import Severity
from fcu.mavlink.port import VehiclePort
from fcu.mavlink.protocols.command_request import (
    CommandOutcome,
    CommandRequest,
    accepted,
    denied,
    unsupported,
    whole_number,
)
from fcu.mavlink.transport.codec import MAVLinkMessage, mavlink2

__all__ = ["CalibrationCommand"]

_M = mavlink2


def _cal_texts(*texts: str) -> list[MAVLinkMessage]:
    """Calibration progress as STATUSTEXTs (each under 50 characters: one packet)."""
    return [_M.MAVLink_statustext_message(Severity.INFO, text.encode("ascii"), 0, 0)
            for text in texts]


class CalibrationCommand:
    """PREFLIGHT_CALIBRATION (module docstring); a part of
    :class:`fcu.mavlink.protocols.commands.CommandDispatcher`, whose port it reads."""

    _port: VehiclePort

    def _calibrate(self, r: CommandRequest) -> CommandOutcome:
        """PREFLIGHT_CALIBRATION on simulated sensors: accepted, then the progress texts
        ground stations parse (PX4's ``[cal]`` protocol, version 2: started, progress,
        done), at once; all parameters 0 cancels (nothing runs long enough to cancel)."""
        values = (r.params[0], r.params[1], r.params[2], r.params[3], r.x, r.y, r.z)
        codes = [whole_number(v, 0, 255) if math.isfinite(v) else 0 for v in values]
        if any(c is None for c in codes):
            return denied(f"Calibration: parameters {values} must be whole numbers")
        if not any(codes):
            return accepted(follow_up=_cal_texts("[cal] calibration cancelled"))
        which = [name for name, on in (
            ("gyro", codes[0] == 1), ("mag", codes[1] == 1), ("baro", codes[2] == 1),
            ("accel", codes[4] in (1, 4)), ("level", codes[4] == 2)) if on]
        others = [i + 1 for i, c in enumerate(codes) if c and i not in (0, 1, 2, 4)]
        if others or not which or codes[4] not in (0, 1, 2, 4):
            return unsupported(f"Calibration {values}: only gyro (p1), compass (p2), "
                                "barometer (p3), accelerometer and level (p5 1, 2, 4)")
        if self._port.snapshot().armed:
            return denied("Calibration refused: disarm first")
        texts: list[str] = []
        for name in which:
            texts += [f"[cal] calibration started: 2 {name}", "[cal] progress <50>",
                      "[cal] progress <100>", f"[cal] calibration done: {name}"]
        return accepted(follow_up=_cal_texts(*texts))
