"""The vehicle's packer writes what pymavlink writes, byte for byte, for every message type of
the dialect, unsigned and signed, with the same sequence numbers and signing timestamps."""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np
import pytest

from fcu.mavlink.transport.codec import Codec, mavlink2

M = mavlink2
KEY = bytes(range(7, 39))  # 32 bytes
_INT_RANGES = {"int8_t": (-128, 127), "uint8_t": (0, 255), "int16_t": (-32768, 32767),
               "uint16_t": (0, 65535), "int32_t": (-2**31, 2**31 - 1),
               "uint32_t": (0, 2**32 - 1), "int64_t": (-2**63, 2**63 - 1),
               "uint64_t": (0, 2**64 - 1)}


def _value(kind: str, length: int, rng: np.random.Generator, zero: bool) -> Any:
    """A field value of pymavlink type ``kind`` (an array when ``length``), or all zeros."""
    def one() -> Any:
        if kind in ("float", "double"):
            return 0.0 if zero else float(rng.normal(0.0, 100.0))
        lo, hi = _INT_RANGES[kind]
        return 0 if zero else lo + int(rng.random() * (hi - lo))  # Python ints: uint64 too

    if kind == "char":
        n = max(length, 1)
        if zero:
            return b""
        return bytes(rng.integers(65, 91, size=int(rng.integers(1, n + 1))).tolist())
    if length:
        return [one() for _ in range(length)]
    return one()


def _fields(cls: type, rng: np.random.Generator, zero: bool) -> list[Any]:
    """Constructor arguments of ``cls``: random values, or all zeros."""
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    kinds = dict(zip(cls.fieldnames, cls.fieldtypes, strict=True))
    params = list(inspect.signature(cls.__init__).parameters)[1:]
    return [_value(kinds[name], lengths[name], rng, zero) for name in params]


def _message(cls: type, rng: np.random.Generator, zero: bool) -> Any:
    return cls(*_fields(cls, rng, zero))


def _reference(sysid: int, compid: int) -> Any:
    return M.MAVLink(None, srcSystem=sysid, srcComponent=compid)


def _sign(state: Any, timestamp: int, link_id: int) -> None:
    state.secret_key = KEY
    state.sign_outgoing = True
    state.link_id = link_id
    state.timestamp = timestamp


def _codec_and_reference(sysid: int, signed: bool, timestamp: int,
                         link_id: int) -> tuple[Codec, Any]:
    """Our codec and pymavlink's packer as (sysid, 1), both signing from ``timestamp`` on
    link ``link_id`` when ``signed``."""
    codec = Codec(sysid, 1)
    ref = _reference(sysid, 1)
    if signed:
        _sign(codec.signing, timestamp, link_id)
        _sign(ref.signing, timestamp, link_id)
    return codec, ref


MESSAGE_TYPES = sorted(M.mavlink_map.values(), key=lambda c: c.id)


@pytest.mark.parametrize("signed", [False, True], ids=["unsigned", "signed"])
def test_every_message_type_packs_as_pymavlink_packs_it(signed: bool) -> None:
    rng = np.random.default_rng(20261124)
    codec, ref = _codec_and_reference(7, signed, 123_456_789, 0)
    packed = 0
    for cls in MESSAGE_TYPES:
        for zero in (False, True, False):  # random values, all zero (trailing bytes dropped)
            msg = _message(cls, rng, zero)
            expected = msg.pack(ref)
            ref.seq = (ref.seq + 1) % 256
            assert codec.pack(msg) == expected, cls.msgname
            packed += 1
    assert packed == 3 * len(MESSAGE_TYPES) > 300  # the whole dialect, seq wrapping around
    if signed:
        assert codec.signing.timestamp == ref.signing.timestamp == 123_456_789 + packed


@pytest.mark.parametrize("signed", [False, True], ids=["unsigned", "signed"])
def test_packing_from_the_constructor_arguments_is_packing_the_message(signed: bool) -> None:
    """``pack_fields(cls, fields)`` (the telemetry streams' path) writes what pymavlink's
    ``cls(*fields).pack`` writes, for every message type, field for field: each field in
    turn is given a random value while the others are zero."""
    rng = np.random.default_rng(20261125)
    codec, ref = _codec_and_reference(3, signed, 987_654, 2)
    packed = 0
    for cls in MESSAGE_TYPES:
        zeros = _fields(cls, rng, zero=True)
        full = _fields(cls, rng, zero=False)
        cases = [full, zeros] + [zeros[:k] + [full[k]] + zeros[k + 1:]
                                 for k in range(len(full))]
        for fields in cases:
            expected = cls(*fields).pack(ref)
            ref.seq = (ref.seq + 1) % 256
            assert codec.pack_fields(cls, tuple(fields)) == expected, cls.msgname
            packed += 1
    assert packed > 2000
    if signed:
        assert codec.signing.timestamp == ref.signing.timestamp == 987_654 + packed


def test_sequence_numbers_and_ids_follow_the_codec() -> None:
    codec = Codec(42, 1)
    hb = M.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3)
    seqs = []
    for _ in range(300):
        parsed = codec.parse_datagram(codec.pack(hb))
        msg = parsed.messages[0]
        assert (msg.get_srcSystem(), msg.get_srcComponent()) == (42, 1)
        seqs.append(msg.get_seq())
    assert seqs == [k % 256 for k in range(300)]
    codec.sysid = 9
    assert codec.parse_datagram(codec.pack(hb)).messages[0].get_srcSystem() == 9


def test_a_value_out_of_its_wire_range_raises_as_pymavlink_does() -> None:
    codec = Codec(1, 1)
    bad = M.MAVLink_heartbeat_message(300, 3, 0, 0, 4, 3)  # type is uint8
    with pytest.raises(Exception) as ours:
        codec.pack(bad)
    with pytest.raises(Exception) as theirs:
        bad.pack(_reference(1, 1))
    assert type(ours.value) is type(theirs.value)


def test_without_the_compiled_crc_the_packets_are_the_same(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """pymavlink's own CRC (its Python loop when fastcrc is missing) gives the same packets."""
    import fcu.mavlink.transport.codec as codec_module

    msgs = [M.MAVLink_attitude_message(123, 0.1, -0.2, 3.0, 0.0, 0.5, -0.5),
            M.MAVLink_statustext_message(4, b"hello", 0, 0),
            M.MAVLink_servo_output_raw_message(7, 0, *([1500] * 4 + [0] * 12))]
    fast = [Codec(1, 1).pack(m) for m in msgs[:1]]
    monkeypatch.setattr(codec_module, "_crc", lambda data: int(M._x25crc_slow(data).crc))
    codec, ref = Codec(1, 1), _reference(1, 1)
    for msg in msgs:
        expected = msg.pack(ref)
        ref.seq += 1
        assert codec.pack(msg) == expected
    assert Codec(1, 1).pack(msgs[0]) == fast[0]
