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
from fcu.monitoring.battery import BatteryMonitorConfig
from fcu.monitoring.crash_check import CrashCheckConfig
from fcu.monitoring.motor_faults import DetectorConfig
from fcu.monitoring.rotor_watch import RotorWatchConfig
from fcu.monitoring.sensor_health import SensorHealthConfig
from fcu.navigation.settings import NavigatorConfig
from flightdata.config import finite, require
from flightdata.vocabulary import (
    CONFIG_CHOICES,
    AllocatorName,
    AttitudeLawName,
    DobName,
    EstimatorName,
    FtcMode,
    HeightSource,
)


@dataclass(frozen=True, kw_only=True)
class AutopilotConfig:
    """The autopilot's whole configuration (frozen; TOML table ``[autopilot]``).

    ``attitude``, ``estimator``, ``dob``, ``height_source``, ``allocator`` and ``ftc`` each take one
    of the names :data:`flightdata.vocabulary.CONFIG_CHOICES` lists for them.
    """

    attitude: AttitudeLawName = "lqg"  # "pd" (eq. 5.6) or "lqg" (LQR + integral, eq. 5.10)
    estimator: EstimatorName = "ekf"  # which estimate feeds the controllers: "ekf" or "tskf"
    dob: DobName = "none"  # disturbance observer on roll, pitch and yaw: "none", "vbdob", "abdob"
    height_source: HeightSource = "mocap"  # height from motion capture ("mocap") or "baro"
    allocator: AllocatorName = "attitude_first"  # control allocation (inverse of eq. 3.2)
    ftc: FtcMode = "passive"  # "passive" (the thesis) or "active": allocation uses the estimates
    loop_rate_hz: float = 100.0  # Hz, control and estimation tick
    dob_cutoff_rad_s: float = 5.0  # rad/s, w of the DOB Q filters (section 6.2)
    attitude_ref_bandwidth_rad_s: float = 15.0  # rad/s, attitude reference filter
    # s: after the loss of a rotor (relaxed hover, fcu.control.reduced_attitude) the vehicle
    # brakes and holds where it is while the spin builds up (to 90 % in about 3 s at full
    # yaw torque) and the position settles, then lands
    rotor_loss_hold_s: float = 10.0
    model: VehicleModel = field(default_factory=VehicleModel)
    position: PositionGains = field(default_factory=PositionGains)
    pd: AttitudePdGains = field(default_factory=AttitudePdGains)
    lqr: LqrWeights = field(default_factory=LqrWeights)
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)
    detector: DetectorConfig = field(default_factory=DetectorConfig)
    rotor_watch: RotorWatchConfig = field(default_factory=RotorWatchConfig)
    sensors: SensorHealthConfig = field(default_factory=SensorHealthConfig)
    crash: CrashCheckConfig = field(default_factory=CrashCheckConfig)
    battery: BatteryMonitorConfig = field(default_factory=BatteryMonitorConfig)

    def __post_init__(self) -> None:
        for key, choices in CONFIG_CHOICES.items():
            value = getattr(self, key)
            require(value in choices, key, value,
                    f"must be one of {', '.join(map(repr, choices))}")
        require(finite(self.rotor_loss_hold_s) and 0.0 <= self.rotor_loss_hold_s <= 600.0,
                "rotor_loss_hold_s", self.rotor_loss_hold_s, "must be within [0, 600] s")
        require(finite(self.loop_rate_hz) and 20.0 <= self.loop_rate_hz <= 1000.0,
                "loop_rate_hz", self.loop_rate_hz, "must be within [20, 1000] Hz")
        require(finite(self.dob_cutoff_rad_s) and self.dob_cutoff_rad_s > 0,
                "dob_cutoff_rad_s", self.dob_cutoff_rad_s, "must be > 0 rad/s")
        require(finite(self.attitude_ref_bandwidth_rad_s)
                and self.attitude_ref_bandwidth_rad_s > 0, "attitude_ref_bandwidth_rad_s",
                self.attitude_ref_bandwidth_rad_s, "must be > 0 rad/s")
