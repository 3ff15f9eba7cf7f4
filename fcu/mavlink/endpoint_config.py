"""The endpoint's configuration (identity, clocks, limits) and its counters."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from fcu.mavlink.protocols.command_request import CommandLimits
from fcu.mavlink.protocols.failsafe import FailsafeAction
from fcu.mavlink.protocols.mission_items import MissionConfig
from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ
from fcu.mavlink.transport.signing import check_key

__all__ = ["EndpointConfig", "EndpointStats"]


@dataclass(frozen=True, kw_only=True)
class EndpointConfig:
    """Identity, clocks and limits of the endpoint."""

    sysid: int = 1  # MAVLink system id (SYSID_THISMAV at boot)
    compid: int = 1  # MAV_COMP_ID_AUTOPILOT1: the only id QGC and MAVSDK treat as autopilot
    pwm_max: float = 0.05  # motor command at full power (VehicleModel.pwm_max)
    heartbeat_wall_period_s: float = 1.0  # s, longest wall-clock gap between HEARTBEATs
    stream_rates_hz: Mapping[int, float] = field(default_factory=lambda: dict(DEFAULT_RATES_HZ))
    max_stream_rate_hz: float = 100.0  # Hz simulated, the autopilot's loop rate (one per tick)
    mission: MissionConfig = field(default_factory=MissionConfig)
    limits: CommandLimits = field(default_factory=CommandLimits)
    flight_sw_version: tuple[int, int, int] = (4, 5, 0)  # ArduCopter protocol generation
    boot_unix_time_s: float | None = None  # UNIX time at boot, for SYSTEM_TIME
    gcs_failsafe_action: int = int(FailsafeAction.LAND)  # FS_GCS_ENABLE default
    gcs_failsafe_timeout_s: float = 5.0  # FS_GCS_TIMEOUT default, s (2..120)
    gcs_sysid: int = 255  # SYSID_MYGCS default
    signing_key: bytes | None = field(default=None, repr=False)  # MAVLink 2 signing key
    # at start (32 bytes; None: off); never shown in a repr
    receive_budget_s: float = 0.003  # s wall, longest handling of received data per tick

    def __post_init__(self) -> None:
        if not 1 <= self.sysid <= 255:
            raise ValueError(f"sysid = {self.sysid!r}: must be in 1..255")
        if not 1 <= self.compid <= 255:
            raise ValueError(f"compid = {self.compid!r}: must be in 1..255")
        if not self.pwm_max > 0:
            raise ValueError(f"pwm_max = {self.pwm_max!r}: must be > 0")
        if not (math.isfinite(self.max_stream_rate_hz) and self.max_stream_rate_hz > 0):
            raise ValueError(f"max_stream_rate_hz = {self.max_stream_rate_hz!r}: must be > 0")
        if self.gcs_failsafe_action not in {int(a) for a in FailsafeAction}:
            raise ValueError(f"gcs_failsafe_action = {self.gcs_failsafe_action!r}: must be one "
                             f"of {[int(a) for a in FailsafeAction]}")
        if not 2.0 <= self.gcs_failsafe_timeout_s <= 120.0:
            raise ValueError(f"gcs_failsafe_timeout_s = {self.gcs_failsafe_timeout_s!r}: "
                             "must be in 2..120")
        if not 1 <= self.gcs_sysid <= 255:
            raise ValueError(f"gcs_sysid = {self.gcs_sysid!r}: must be in 1..255")
        if self.signing_key is not None:
            check_key(self.signing_key)
        if not (math.isfinite(self.receive_budget_s) and self.receive_budget_s > 0):
            raise ValueError(f"receive_budget_s = {self.receive_budget_s!r}: must be > 0 s")


@dataclass
class EndpointStats:
    """Counters (never reset except by a new endpoint)."""

    datagrams: int = 0
    messages: int = 0
    malformed: int = 0  # bad CRC/length/prefix, truncated
    unknown_ids: int = 0  # well-formed packets of ids the dialect lacks
    not_for_us: int = 0  # addressed to another system/component
    handler_errors: int = 0  # exceptions caught around a message handler
    build_errors: int = 0  # telemetry that could not be built or packed
    commands: int = 0
    gcs_failsafes: int = 0
