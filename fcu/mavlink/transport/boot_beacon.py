"""The vehicle's HEARTBEAT while it boots: alive at once, ``MAV_STATE_BOOT`` until ready.

A real autopilot answers a ground station within a second of power-up and says it is booting
(``HEARTBEAT.system_status = MAV_STATE_BOOT``) until its estimators and controllers are up.
The simulated vehicle needs one to two seconds to load numpy, numba's compiled kernels and the
autopilot; :class:`BootBeacon` binds the vehicle's socket first and sends a boot HEARTBEAT at
once and then every ``period_s`` from a background thread, with only the light MAVLink
modules imported. :meth:`BootBeacon.handover` stops the thread and leaves the bound link and
the packer to the endpoint (:class:`fcu.mavlink.endpoint.MavlinkEndpoint`), whose HEARTBEATs
carry on with the next sequence number and signature timestamps after the beacon's.

While the vehicle prepares its compiled code (minutes on a fresh machine, a second once it is
cached), the composition root sets :attr:`BootBeacon.progress_line` now and then; the next
boot HEARTBEAT is followed by that line as a STATUSTEXT (``preparing: 37 of 131 kernels
compiled, 41 s``), so that a ground station can tell a vehicle that is getting on with it from
one that hangs, and show how far it has got.

Nothing is read from the socket while booting: datagrams a ground station sends meanwhile
wait in the socket's buffer for the endpoint. A careful ground station waits for a
HEARTBEAT that is no longer ``MAV_STATE_BOOT`` before it talks (``gcs.link`` does).
"""

from __future__ import annotations

import threading

from fcu.mavlink.enums import MavState, Severity
from fcu.mavlink.transport.codec import Codec, heartbeat_message, mavlink2
from fcu.mavlink.transport.signing import start_signing
from fcu.mavlink.transport.udp import UdpLink

__all__ = ["BootBeacon"]

_M = mavlink2


class BootBeacon:
    """Bind ``link`` and send boot HEARTBEATs from a thread until :meth:`handover`.

    Parameters
    ----------
    link : UdpLink
        The vehicle's link (bound by :meth:`start`; boot HEARTBEATs go to its default peers).
    codec : Codec
        The vehicle's packer (its system and component ids).
    signing_key : bytes or None
        MAVLink 2 signing key (32 bytes): the boot HEARTBEATs are signed with it.
    period_s : float
        Wall seconds between boot HEARTBEATs (1 Hz, as the vehicle's own).
    """

    def __init__(self, link: UdpLink, codec: Codec, *, signing_key: bytes | None = None,
                 period_s: float = 1.0) -> None:
        if not period_s > 0:
            raise ValueError(f"period_s = {period_s!r}: must be > 0 s")
        self.link = link
        self.codec = codec
        self._period_s = period_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.sent = 0  # boot HEARTBEATs sent
        self.progress_line = ""  # the newest progress line, sent after the next HEARTBEAT
        self._progress_sent = ""
        self._lock = threading.Lock()  # the packer's sequence numbers: one sender at a time
        if signing_key is not None:
            start_signing(codec.signing, signing_key)

    def start(self) -> None:
        """Bind the socket, send the first boot HEARTBEAT and start the thread.

        Raises
        ------
        OSError
            The address cannot be bound.
        """
        self.link.open()
        self._send()
        self._thread = threading.Thread(target=self._beat, name="boot-heartbeat", daemon=True)
        self._thread.start()

    def handover(self) -> None:
        """Stop the boot HEARTBEATs (the link and the packer are the endpoint's from now)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def _beat(self) -> None:
        while not self._stop.wait(self._period_s):
            self._send()

    def _send(self) -> None:
        # STABILIZE (custom mode 0), disarmed, booting
        msg = heartbeat_message(_M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0, int(MavState.BOOT))
        with self._lock:
            self.link.send(self.codec.pack(msg))
            self.sent += 1
            line = self.progress_line
            if line and line != self._progress_sent:
                self._progress_sent = line
                text = line.encode("ascii", "replace")[:50]
                self.link.send(self.codec.pack(
                    _M.MAVLink_statustext_message(int(Severity.INFO), text, 0, 0)))
