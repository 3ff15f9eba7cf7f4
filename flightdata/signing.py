"""MAVLink 2 signing words the vehicle and the ground station share: the key format, the
clock of signatures and the messages a radio may send unsigned.

A signing key is 32 bytes (https://mavlink.io/en/guide/message_signing.html). People write
it in one of two forms, both accepted by ``ftc-vehicle --signing-key``, ``ftc-gcs fly
--signing-key`` and the ``vehicle(signing_key=...)`` test marker:

- a passphrase (printable ASCII without spaces): the key is the SHA-256
  digest of its ASCII bytes, as MAVProxy's ``signing setup PASSPHRASE`` and ``signing key
  PASSPHRASE`` make it, so the same word works in MAVProxy and here;
- ``hex:`` followed by 64 hexadecimal digits: the 32 bytes themselves.

The all-zero key means "no signing" on the wire (SETUP_SIGNING with it disables signing), so
it is refused as a key.

Signature timestamps count 10 microseconds since 2015-01-01 00:00:00 UTC in 48 bits.
"""

from __future__ import annotations

import hashlib
import string

__all__ = [
    "EPOCH_UNIX_S",
    "KEY_BYTES",
    "MAX_TIMESTAMP",
    "UNSIGNED_ALLOWED_IDS",
    "key_from_text",
    "timestamp_from_unix",
]

KEY_BYTES = 32
"""Length of a MAVLink 2 signing key, bytes."""
EPOCH_UNIX_S = 1_420_070_400
"""2015-01-01 00:00:00 UTC in UNIX seconds: the origin of signature timestamps."""
MAX_TIMESTAMP = (1 << 48) - 1
"""Largest signature timestamp (48 bits), in 10 us units."""
UNSIGNED_ALLOWED_IDS: frozenset[int] = frozenset({109, 166})
"""Message ids accepted unsigned while signing is on: RADIO_STATUS (109) and RADIO (166),
which telemetry radios inject without the key (ArduPilot's ``accept_unsigned_callback`` and
MAVProxy's ``allow_unsigned`` accept exactly these)."""

_HEX_PREFIX = "hex:"
_PASSPHRASE_CHARS = frozenset(string.ascii_letters + string.digits + string.punctuation)


def key_from_text(text: str) -> bytes:
    """The 32-byte signing key a command-line KEY stands for (see the module docstring).

    Parameters
    ----------
    text : str
        A passphrase, or ``hex:`` and 64 hexadecimal digits.

    Returns
    -------
    bytes
        32 bytes, never all zero.

    Raises
    ------
    ValueError
        One line saying what is wrong (the text itself is never repeated: it is a secret).
    """
    if text.lower().startswith(_HEX_PREFIX):
        digits = text[len(_HEX_PREFIX):]
        if len(digits) != 2 * KEY_BYTES or not all(c in string.hexdigits for c in digits):
            raise ValueError(f"signing key: after 'hex:' give exactly {2 * KEY_BYTES} "
                             f"hexadecimal digits (got {len(digits)} characters)")
        key = bytes.fromhex(digits)
    else:
        if not text:
            raise ValueError("signing key: empty passphrase")
        if not set(text) <= _PASSPHRASE_CHARS:
            raise ValueError("signing key: a passphrase is printable ASCII without spaces "
                             "(as MAVProxy's 'signing setup' takes it)")
        key = hashlib.sha256(text.encode("ascii")).digest()
    if not any(key):
        raise ValueError("signing key: the all-zero key means no signing; omit the option "
                         "instead")
    return key


def timestamp_from_unix(unix_s: float) -> int:
    """Signature timestamp (10 us units since 2015, 48 bits) of a UNIX time in seconds."""
    return min(max(int((unix_s - EPOCH_UNIX_S) * 100_000), 0), MAX_TIMESTAMP)
