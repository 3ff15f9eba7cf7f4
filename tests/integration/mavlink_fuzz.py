"""Seeded fuzz datagrams for the vehicle's MAVLink endpoint.

:func:`fuzz_datagrams` makes a list of UDP payloads of five kinds:

- random bytes (1-280), a third starting like MAVLink 2 (0xFD), a third like MAVLink 1;
- valid frames cut short (truncated);
- valid frames with one byte flipped (bad CRC);
- valid-CRC frames of the messages a ground station sends, every field at an extreme: NaN,
  +-inf, +-3.4e38 and the smallest denormal in floats, the ends of each integer type,
  out-of-range enum values, unterminated or non-ASCII names;
- datagrams carrying several frames back to back, some cut.

What is *not* sent: requests that are valid and would legitimately stop the telemetry the
test watches (a REQUEST_DATA_STREAM with start_stop 0 for a real group, SIM_PAUSE = 1) and a
SETUP_SIGNING addressed to the vehicle (a key it accepted would lock the test's unsigned
ground station out): those are behaviour, not bad input. Stream ids are out of range and
SETUP_SIGNING goes to other systems.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

__all__ = ["FuzzCounts", "fuzz_datagrams"]

M = mavlink2
FLOATS = (math.nan, math.inf, -math.inf, 3.4e38, -3.4e38, 1.4e-45, -0.0, 1e-30, 65536.0,
          16777215.0, 16777217.0, 2147483648.0, -2147483649.0, 4294967296.0)
PARAM_VALUES = (math.nan, math.inf, -math.inf, 3.4e38, -3.4e38)  # refused by every parameter
INT_RANGES = {
    "uint8_t": (0, 0xFF), "int8_t": (-0x80, 0x7F), "uint16_t": (0, 0xFFFF),
    "int16_t": (-0x8000, 0x7FFF), "uint32_t": (0, 0xFFFFFFFF),
    "int32_t": (-0x80000000, 0x7FFFFFFF), "uint64_t": (0, 0xFFFFFFFFFFFFFFFF),
    "int64_t": (-0x8000000000000000, 0x7FFFFFFFFFFFFFFF),
}
COMMANDS = (20, 21, 22, 176, 178, 179, 192, 224, 246, 300, 400, 410, 420, 510, 511, 512, 520,
            183, 31337, 0, 0xFFFF)  # the ones the vehicle handles, and others
PARAM_NAMES = (b"SIM_PAUSE", b"SYSID_THISMAV", b"ATT_CTRL", b"FS_GCS_ENABLE", b"SIM_MOT1_LOE",
               b"WPNAV_SPEED", b"SIM_SPEEDUP", b"SIM_WIND_SPD", b"\xff\xfe\x80BAD", b"")
MESSAGES: tuple[type[Any], ...] = (
    M.MAVLink_command_long_message, M.MAVLink_command_int_message,
    M.MAVLink_param_set_message, M.MAVLink_param_request_read_message,
    M.MAVLink_param_request_list_message,
    M.MAVLink_mission_count_message, M.MAVLink_mission_item_int_message,
    M.MAVLink_mission_item_message, M.MAVLink_mission_request_int_message,
    M.MAVLink_mission_request_message, M.MAVLink_mission_request_list_message,
    M.MAVLink_mission_clear_all_message, M.MAVLink_mission_set_current_message,
    M.MAVLink_mission_ack_message,
    M.MAVLink_set_position_target_local_ned_message,
    M.MAVLink_set_position_target_global_int_message,
    M.MAVLink_set_mode_message, M.MAVLink_request_data_stream_message,
    M.MAVLink_setup_signing_message, M.MAVLink_timesync_message, M.MAVLink_heartbeat_message,
    M.MAVLink_file_transfer_protocol_message, M.MAVLink_manual_control_message,
    M.MAVLink_rc_channels_override_message, M.MAVLink_ping_message,
)


@dataclass
class FuzzCounts:
    """How many datagrams of each kind were made."""

    random_bytes: int = 0
    truncated: int = 0
    bad_crc: int = 0
    extreme: int = 0
    several: int = 0
    by_message: dict[str, int] = field(default_factory=dict)

    @property
    def malformed(self) -> int:
        """Datagrams that hold no valid frame (random, truncated, bad CRC)."""
        return self.random_bytes + self.truncated + self.bad_crc


def _int(rng: random.Random, ftype: str) -> int:
    lo, hi = INT_RANGES[ftype]
    return rng.choice((lo, hi, lo + 1, hi - 1, rng.randint(lo, hi)))


def _value(rng: random.Random, ftype: str, length: int) -> Any:
    if ftype == "char":
        return rng.randbytes(rng.randint(0, length)).replace(b"\0", b"\x01")
    if length:
        return [_value(rng, ftype, 0) for _ in range(length)]
    if ftype in ("float", "double"):
        return rng.choice(FLOATS)
    return _int(rng, ftype)


def _fields(rng: random.Random, cls: type[Any]) -> dict[str, Any]:
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    values = {name: _value(rng, ftype, lengths[name])
              for name, ftype in zip(cls.fieldnames, cls.fieldtypes, strict=True)}
    if "target_system" in values:  # mostly for us, so the handlers run
        values["target_system"] = rng.choice((1, 1, 1, 1, 0, 2, 255))
    if "target_component" in values:
        values["target_component"] = rng.choice((1, 1, 1, 0, 190, 255))
    return values


_OVERRIDES: dict[str, Callable[[random.Random, dict[str, Any]], None]] = {
    "COMMAND_LONG": lambda r, v: v.update(command=r.choice(COMMANDS)),
    "COMMAND_INT": lambda r, v: v.update(command=r.choice(COMMANDS)),
    "PARAM_SET": lambda r, v: v.update(param_id=r.choice(PARAM_NAMES),
                                       param_value=r.choice(PARAM_VALUES)),
    "PARAM_REQUEST_READ": lambda r, v: v.update(param_id=r.choice(PARAM_NAMES)),
    "REQUEST_DATA_STREAM": lambda r, v: v.update(req_stream_id=r.randint(13, 255)),
    "SETUP_SIGNING": lambda r, v: v.update(target_system=r.randint(2, 254),
                                           secret_key=[0] * 32),
}


def _frame(rng: random.Random, mav: Any, counts: FuzzCounts) -> bytes:
    cls = rng.choice(MESSAGES)
    values = _fields(rng, cls)
    msg = cls(**values)
    name = msg.get_type()
    override = _OVERRIDES.get(name)
    if override is not None:
        override(rng, values)
        msg = cls(**values)
    mav.srcSystem = rng.choice((255, rng.randint(2, 254)))
    mav.srcComponent = rng.choice((190, rng.randint(0, 255)))
    mav.seq = rng.randint(0, 255)
    counts.by_message[name] = counts.by_message.get(name, 0) + 1
    return bytes(msg.pack(mav))


def fuzz_datagrams(n: int, seed: int) -> tuple[list[bytes], FuzzCounts]:
    """``n`` fuzz datagrams (see the module docstring), the same for the same seed."""
    rng = random.Random(seed)
    mav = M.MAVLink(None)
    counts = FuzzCounts()
    out: list[bytes] = []
    while len(out) < n:
        kind = rng.random()
        if kind < 0.30:
            data = bytearray(rng.randbytes(rng.randint(1, 280)))
            data[0] = rng.choice((0xFD, 0xFE, data[0]))
            out.append(bytes(data))
            counts.random_bytes += 1
        elif kind < 0.45:
            frame = _frame(rng, mav, counts)
            out.append(frame[:rng.randint(1, len(frame) - 1)])
            counts.truncated += 1
        elif kind < 0.50:
            frame = bytearray(_frame(rng, mav, counts))
            frame[rng.randint(10, len(frame) - 1)] ^= 0xFF
            out.append(bytes(frame))
            counts.bad_crc += 1
        elif kind < 0.95:
            out.append(_frame(rng, mav, counts))
            counts.extreme += 1
        else:
            frames = [_frame(rng, mav, counts) for _ in range(rng.randint(2, 5))]
            if rng.random() < 0.5:
                frames[-1] = frames[-1][:len(frames[-1]) // 2]
            out.append(b"".join(frames))
            counts.several += 1
    return out, counts
