"""Tell when the vehicle's MAVLink 2 signing cannot match the ground station's.

With a signing key, a :class:`gcs.link.Link` handles only packets that verify with it; one
without a key handles unsigned packets only. Either way a mismatch shows as silence, so
:class:`SigningCheck` watches what the link drops and hears and says why (the text of a
:class:`gcs.errors.SigningMismatch`): the vehicle signs and we have no key, or three of its
HEARTBEATs failed the signature check (it does not sign, or signs with another key).
"""

from __future__ import annotations

from gcs.mavlink import MAVLinkMessage, decode_packet, is_signed, mavlink2

__all__ = ["SigningCheck"]

_M = mavlink2
_UNVERIFIED_HEARTBEATS = 3  # autopilot HEARTBEATs failing the signature check: a mismatch


class SigningCheck:
    """What a link has seen of the vehicle's signing (module docstring).

    Parameters
    ----------
    url : str
        The link's connection string (for messages).
    signing : bool
        The link signs its packets and checks the vehicle's (it has a key).

    Attributes
    ----------
    unverified : int
        Packets dropped by the signature check.
    """

    def __init__(self, url: str, signing: bool) -> None:
        self.url = url
        self.signing = signing
        self.unverified = 0
        self._unverified_heartbeats: list[bytes] = []  # raw autopilot HEARTBEATs dropped
        self._vehicle_signs = False  # a signed autopilot HEARTBEAT was seen

    def note_unverified(self, bad: MAVLinkMessage) -> None:
        """Count a packet the signature check dropped (a BAD_DATA); keep the autopilot
        HEARTBEATs."""
        if getattr(bad, "reason", "") != "Invalid signature":
            return
        self.unverified += 1
        packet = bytes(bad.data)
        msg = decode_packet(packet)
        if (msg is not None and msg.get_type() == "HEARTBEAT"
                and int(msg.autopilot) != _M.MAV_AUTOPILOT_INVALID
                and len(self._unverified_heartbeats) < _UNVERIFIED_HEARTBEATS):
            self._unverified_heartbeats.append(packet)

    def note_received(self, msg: MAVLinkMessage) -> None:
        """A packet the link handles: without a key, note an autopilot HEARTBEAT that is
        signed."""
        if (not self.signing and not self._vehicle_signs and msg.get_type() == "HEARTBEAT"
                and int(msg.autopilot) != _M.MAV_AUTOPILOT_INVALID
                and is_signed(msg.get_msgbuf())):
            self._vehicle_signs = True

    def mismatch(self) -> str | None:
        """Why the vehicle's signing cannot match ours (None: no sign of a mismatch yet)."""
        if not self.signing and self._vehicle_signs:
            return (f"the autopilot on {self.url} signs its packets (MAVLink 2 signing) and "
                    "drops unsigned ones: give its key with --signing-key")
        if len(self._unverified_heartbeats) < _UNVERIFIED_HEARTBEATS:
            return None
        if not any(is_signed(p) for p in self._unverified_heartbeats):
            return (f"the autopilot on {self.url} does not sign its packets (no signing key "
                    "on the vehicle?), so none verifies with --signing-key")
        return (f"the autopilot on {self.url} signs with another key than --signing-key "
                f"({self.unverified} of its packets failed the signature check)")
