"""GCS heartbeat-loss failsafe (ArduCopter FS_GCS_*), judged on the wall clock.

Which heartbeats count ("the GCS")
----------------------------------
A HEARTBEAT counts when it does not come from this vehicle and any of these holds: its
sysid is SYSID_MYGCS (default 255: MAVProxy, QGroundControl, Mission Planner), its sysid is
245 (MAVSDK's default), or its type is MAV_TYPE_GCS (6). Heartbeats of other vehicles or
companion computers with other ids do not keep the failsafe at bay.

When it fires
-------------
Only when FS_GCS_ENABLE != 0, the vehicle is armed, a GCS heartbeat has been seen since
boot, and no GCS heartbeat arrived for FS_GCS_TIMEOUT seconds of **wall-clock** time (the
endpoint passes ``time.monotonic()``): a ground station sends heartbeats in wall time, so a
simulation speed-up never fires it spuriously, and a slow-down never delays it. It fires
once per loss; a returning heartbeat clears it (the mode is not changed back, as in
ArduPilot), and so does disarming.

Action (FS_GCS_ENABLE, ArduCopter numbering)
--------------------------------------------
0 disabled; 1 RTL; 2 RTL, or continue the mission when in AUTO; 5 LAND (the default here).
If RTL is refused (e.g. no home) the vehicle is told to land instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

from fcu.mavlink.transport.codec import mavlink2

__all__ = ["GCS_SYSID_MAVSDK", "FailsafeAction", "GcsFailsafe", "GcsFailsafeConfig"]

GCS_SYSID_MAVSDK = 245  # MAVSDK's default own system id


class FailsafeAction(IntEnum):
    """FS_GCS_ENABLE values (ArduCopter numbering; 3, 4 and 6 need SmartRTL/DO_LAND_START)."""

    DISABLED = 0
    RTL = 1
    RTL_OR_CONTINUE_MISSION = 2
    LAND = 5


@dataclass(frozen=True, slots=True)
class GcsFailsafeConfig:
    """Current FS_GCS_* / SYSID_MYGCS settings (read from the parameter table each check)."""

    action: FailsafeAction = FailsafeAction.LAND
    timeout_s: float = 5.0  # s of wall-clock time
    gcs_sysid: int = 255


class GcsFailsafe:
    """Tracks GCS heartbeats and decides when the loss failsafe triggers.

    Parameters
    ----------
    own_sysid : int
        This vehicle's system id (its own heartbeats never count).
    """

    def __init__(self, own_sysid: int) -> None:
        self.own_sysid = own_sysid
        self._last_heartbeat_s = -math.inf
        self._seen = False
        self._active = False

    def reset(self) -> None:
        """Forget everything (reboot)."""
        self._last_heartbeat_s = -math.inf
        self._seen = False
        self._active = False

    @property
    def active(self) -> bool:
        """The failsafe has fired and no GCS heartbeat has come back since."""
        return self._active

    @property
    def gcs_seen(self) -> bool:
        """A GCS heartbeat has been received since boot."""
        return self._seen

    def is_gcs(self, sysid: int, mav_type: int, config: GcsFailsafeConfig) -> bool:
        """Whether a HEARTBEAT from ``sysid`` of ``mav_type`` counts as the GCS."""
        if sysid == self.own_sysid:
            return False
        return (sysid == config.gcs_sysid or sysid == GCS_SYSID_MAVSDK
                or mav_type == mavlink2.MAV_TYPE_GCS)

    def on_heartbeat(self, sysid: int, mav_type: int, wall_time_s: float,
                     config: GcsFailsafeConfig) -> bool:
        """Record a HEARTBEAT received at ``wall_time_s``.

        Returns
        -------
        bool
            True when it cleared an active failsafe.
        """
        if not self.is_gcs(sysid, mav_type, config):
            return False
        self._seen = True
        self._last_heartbeat_s = max(self._last_heartbeat_s, wall_time_s)
        cleared = self._active
        self._active = False
        return cleared

    def overdue(self, wall_time_s: float, config: GcsFailsafeConfig) -> bool:
        """Enabled, a GCS was seen, and its heartbeat is ``timeout_s`` old or older.

        Needs nothing from the vehicle: a caller can skip :meth:`check` (and reading the
        vehicle's armed state) while this is False and the failsafe is not active.
        """
        return (self._seen and config.action != FailsafeAction.DISABLED
                and wall_time_s - self._last_heartbeat_s >= config.timeout_s)

    def check(self, armed: bool, wall_time_s: float,
              config: GcsFailsafeConfig) -> FailsafeAction | None:
        """The action to take now, once per loss; None otherwise.

        Parameters
        ----------
        armed : bool
            The vehicle is armed (disarming clears the failsafe).
        wall_time_s : float
            Monotonic wall-clock time, s.
        config : GcsFailsafeConfig
        """
        if not armed:
            self._active = False
            return None
        if (self._active or config.action == FailsafeAction.DISABLED or not self._seen
                or wall_time_s - self._last_heartbeat_s < config.timeout_s):
            return None
        self._active = True
        return config.action
