"""The signing-key format shared by ftc-vehicle, ftc-gcs and the test marker."""

from __future__ import annotations

import hashlib

import pytest

from flightdata.signing import (
    EPOCH_UNIX_S,
    MAX_TIMESTAMP,
    key_from_text,
    timestamp_from_unix,
)


def test_a_passphrase_gives_mavproxys_key() -> None:
    from MAVProxy.modules.mavproxy_signing import SigningModule

    # MAVProxy's own conversion (``signing setup`` / ``signing key``), called unbound
    mavproxy_key = SigningModule.passphrase_to_key(None, "quadftc-2024!")  # type: ignore[arg-type]
    assert key_from_text("quadftc-2024!") == mavproxy_key
    assert key_from_text("quadftc-2024!") == hashlib.sha256(b"quadftc-2024!").digest()


def test_hex_gives_the_bytes_themselves() -> None:
    key = bytes(range(1, 33))
    assert key_from_text("hex:" + key.hex()) == key
    assert key_from_text("HEX:" + key.hex().upper()) == key


@pytest.mark.parametrize(("text", "words"), [
    ("", "empty passphrase"),
    ("two words", "printable ASCII without spaces"),
    ("caf\u00e9", "printable ASCII without spaces"),
    ("hex:abc", "exactly 64 hexadecimal digits (got 3 characters)"),
    ("hex:" + "g" * 64, "exactly 64 hexadecimal digits"),
    ("hex:" + "0" * 64, "all-zero key means no signing"),
])
def test_bad_keys_are_one_line_errors_that_never_repeat_the_secret(text: str,
                                                                   words: str) -> None:
    with pytest.raises(ValueError) as err:
        key_from_text(text)
    message = str(err.value)
    assert words in message and "\n" not in message
    assert message.startswith("signing key: ")
    if len(text) > 4:
        assert text not in message


def test_timestamps_count_ten_microseconds_since_2015_in_48_bits() -> None:
    assert timestamp_from_unix(EPOCH_UNIX_S) == 0
    assert timestamp_from_unix(EPOCH_UNIX_S + 1.5) == 150_000
    assert timestamp_from_unix(0.0) == 0  # a clock before 2015 never goes negative
    assert timestamp_from_unix(1e12) == MAX_TIMESTAMP
