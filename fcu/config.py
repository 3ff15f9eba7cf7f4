"""The autopilot's configuration: which parts it runs and their settings (TOML ``[autopilot]``).

The parts are chosen by name; the names, and the MAVLink parameter values that select them,
are those of :data:`flightdata.vocabulary.CONFIG_CHOICES`, and each name has a factory in
its kind's registry (:mod:`fcu.estimation.registry`, :mod:`fcu.control.registry`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from fcu.control.attitude_lqr import LqrWeights
from fcu.control.attitude_pd import AttitudePdGains
from fcu.control.position import PositionGains
from fcu.model import VehicleModel
from fcu.navigation.settings import NavigatorConfig
from flightdata.config import finite, require
from flightdata.vocabulary import CONFIG_CHOICES


@dataclass(frozen=True, kw_only=True)
class DetectorConfig:
    """Settings of the LOE fault detector (:mod:`fcu.monitoring.loe_detector`)."""

    threshold: float = 0.1  # LOE fraction above which a motor is suspected
    persistence_s: float = 0.5  # s above the threshold before a fault is declared
    recovery_threshold: float = 0.05  # LOE fraction below which a faulty motor may recover
    recovery_persistence_s: float = 1.0  # s below it before recovery is declared

    def __post_init__(self) -> None:
        require(finite(self.threshold) and 0.0 < self.threshold < 1.0, "threshold",
                self.threshold, "must lie in (0, 1)")
        require(finite(self.recovery_threshold)
                and 0.0 <= self.recovery_threshold < self.threshold, "recovery_threshold",
                self.recovery_threshold, f"must lie in [0, threshold = {self.threshold})")
        for name in ("persistence_s", "recovery_persistence_s"):
            value = getattr(self, name)
            require(finite(value) and value >= 0.0, name, value, "must be >= 0 s")


@dataclass(frozen=True, kw_only=True)
class AutopilotConfig:
    """The autopilot's whole configuration (frozen; TOML table ``[autopilot]``).

    ``attitude``, ``estimator``, ``dob``, ``height_source`` and ``allocator`` each take one
    of the names :data:`flightdata.vocabulary.CONFIG_CHOICES` lists for them.
    """

    attitude: str = "lqg"  # attitude law: "pd" (eq. 5.6) or "lqg" (LQR + integral, eq. 5.10)
    estimator: str = "ekf"  # which estimate feeds the controllers: "ekf" or "tskf"
    dob: str = "none"  # disturbance observer on roll, pitch and yaw: "none", "vbdob", "abdob"
    height_source: str = "mocap"  # height from motion capture ("mocap") or "baro"
    allocator: str = "attitude_first"  # control allocation (inverse of eq. 3.2)
    loop_rate_hz: float = 100.0  # Hz, control and estimation tick
    dob_cutoff_rad_s: float = 5.0  # rad/s, w of the DOB Q filters (section 6.2)
    attitude_ref_bandwidth_rad_s: float = 15.0  # rad/s, attitude reference filter
    model: VehicleModel = field(default_factory=VehicleModel)
    position: PositionGains = field(default_factory=PositionGains)
    pd: AttitudePdGains = field(default_factory=AttitudePdGains)
    lqr: LqrWeights = field(default_factory=LqrWeights)
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)
    detector: DetectorConfig = field(default_factory=DetectorConfig)

    def __post_init__(self) -> None:
        for key, choices in CONFIG_CHOICES.items():
            value = getattr(self, key)
            require(value in choices, key, value,
                    f"must be one of {', '.join(map(repr, choices))}")
        require(finite(self.loop_rate_hz) and 20.0 <= self.loop_rate_hz <= 1000.0,
                "loop_rate_hz", self.loop_rate_hz, "must be within [20, 1000] Hz")
        require(finite(self.dob_cutoff_rad_s) and self.dob_cutoff_rad_s > 0,
                "dob_cutoff_rad_s", self.dob_cutoff_rad_s, "must be > 0 rad/s")
        require(finite(self.attitude_ref_bandwidth_rad_s)
                and self.attitude_ref_bandwidth_rad_s > 0, "attitude_ref_bandwidth_rad_s",
                self.attitude_ref_bandwidth_rad_s, "must be > 0 rad/s")
