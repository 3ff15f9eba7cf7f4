"""The fault-tolerant autopilot: one control tick from sensor samples to four PWM commands.

Per tick (``loop_rate_hz``, 100 Hz by default)::

    samples --> estimator ("ekf": eq. 3.18 | "tskf") --> estimate
            --> TSKF (eq. 6.10-6.26) --> gamma_hat --> LoeFaultDetector --> events
    navigator (modes, mission, guidance) --> reference pos/vel/acc, yaw
    PositionController (eq. 5.3, 5.4)    --> U1, roll_d, pitch_d
    AttitudeReferenceFilter               --> smooth attitude reference and derivatives
    attitude law ("pd": eq. 5.6 | "lqg": eq. 5.7-5.10) --> torque
    disturbance observer ("none" | "vbdob" | "abdob": eq. 6.27-6.30) --> torque - d_hat
    allocator ("attitude_first": inverse eq. 3.2) --> PWM u1..u4

The configuration (:mod:`fcu.config`) names the estimator, attitude law, disturbance
observer and allocator; the autopilot builds each through its kind's registry
(:mod:`fcu.estimation.registry`, :mod:`fcu.control.registry`). The TSKF always runs: it
supplies the per-motor effectiveness estimates that fault detection and telemetry use,
whichever estimator feeds the controllers (it is that estimator when ``estimator = "tskf"``).
The autopilot knows the world only through the samples (:mod:`fcu.hal`); it never sees
injected faults.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from fcu.config import AutopilotConfig, DetectorConfig
from fcu.control.attitude_reference import AttitudeReference, AttitudeReferenceFilter
from fcu.control.position import PositionCommand, PositionController
from fcu.control.registry import ALLOCATOR_REGISTRY, ATTITUDE_LAW_REGISTRY, DOB_REGISTRY
from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.registry import ESTIMATOR_REGISTRY, StateEstimator
from fcu.estimation.state import StateEstimate, group_samples
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.hal import SensorSampleLike
from fcu.monitoring.loe_detector import LoeFaultDetector
from fcu.navigation.guidance import Reference
from fcu.navigation.navigator import CommandResult, LandedState, Navigator, NavOutput

# AutopilotConfig and DetectorConfig are defined in fcu.config; named here too because they
# are the configuration of this module's Autopilot
__all__ = ["Autopilot", "AutopilotConfig", "AutopilotEvent", "AutopilotStatus",
           "DetectorConfig"]

_NO_EVIDENCE = np.full(4, np.nan)  # what the fault detector gets outside free flight
_NO_EVIDENCE.setflags(write=False)


@dataclass(frozen=True)
class AutopilotEvent:
    """Something worth a STATUSTEXT: a mode change, a refusal, a fault detection..."""

    time_s: float  # s, simulated
    kind: str  # navigator event kind, or "fault_detected" / "fault_cleared"
    text: str
    severity: str = "info"  # "info" | "notice" | "warning" | "critical"
    motor: int | None = None  # for fault events, thesis numbering 1..4
    seq: int | None = None  # for mission events


@dataclass(frozen=True)
class AutopilotStatus:
    """Everything telemetry and logs need from the last tick."""

    time_s: float
    estimate: StateEstimate
    nav: NavOutput
    reference: Reference | None  # position reference tracked (None: not flying)
    attitude_reference: AttitudeReference | None  # what the attitude loop tracks
    thrust_cmd_n: float  # N, collective thrust commanded
    torque_cmd_nm: np.ndarray  # N*m, after the DOB compensation
    disturbance_nm: np.ndarray  # N*m, DOB estimate (zeros without a DOB)
    pwm: np.ndarray  # PWM commanded for the next interval, (4,)
    loe_estimate: np.ndarray  # TSKF gamma_hat per motor, clipped to [0, 1]
    fault_detected: tuple[bool, bool, bool, bool]


class Autopilot:
    """Estimators, navigator, controllers and allocation run at ``loop_rate_hz``.

    Construct it complete (gains are designed here, LQR via python-control), call
    :meth:`step` every tick with the samples since the previous tick, send the returned PWM to
    the motors. Commands (arm, take-off, missions...) go through :attr:`navigator`'s methods,
    re-exported below for the MAVLink endpoint and the scenario runner.
    """

    def __init__(self, config: AutopilotConfig | None = None) -> None:
        self.config = config if config is not None else AutopilotConfig()
        cfg = self.config
        self.dt_s = 1.0 / cfg.loop_rate_hz
        model = cfg.model
        self.model = model
        # the parts the configuration names, each built by its kind's registry
        self.estimator: StateEstimator = ESTIMATOR_REGISTRY.factory(cfg.estimator)(
            cfg, self.dt_s)
        self.attitude = ATTITUDE_LAW_REGISTRY.factory(cfg.attitude)(cfg, self.dt_s)
        self.dob = DOB_REGISTRY.factory(cfg.dob)(cfg, self.dt_s)
        self.allocator = ALLOCATOR_REGISTRY.factory(cfg.allocator)(cfg, self.dt_s)
        # the per-motor effectiveness always comes from a TSKF: the selected estimator when
        # it is one, else a TSKF of its own
        self.tskf = (self.estimator if isinstance(self.estimator, TwoStageKalmanFilter)
                     else TwoStageKalmanFilter(model, self.dt_s,
                                               height_source=cfg.height_source))
        self._estimators: tuple[StateEstimator, ...] = (
            (self.tskf,) if self.estimator is self.tskf else (self.tskf, self.estimator))
        self.navigator = Navigator(cfg.navigator)
        self.position = PositionController(model, cfg.position, self.dt_s)
        self.attitude_filter = AttitudeReferenceFilter(self.dt_s,
                                                       cfg.attitude_ref_bandwidth_rad_s)
        self._sensor_kinds = frozenset().union(*(e.sensor_kinds for e in self._estimators))
        det = cfg.detector
        self.detector = LoeFaultDetector(det.threshold, det.persistence_s,
                                         recovery_threshold=det.recovery_threshold,
                                         recovery_persistence_s=det.recovery_persistence_s)
        self.reset()

    def reset(self) -> None:
        """Back to the boot state: estimators, controllers and navigator reset, motors off."""
        self.reset_estimators()
        self.navigator.reset()
        self._reset_controllers()
        self.detector.reset()
        self._pwm = np.zeros(4)
        self._torque_applied = np.zeros(3)
        self._events: list[AutopilotEvent] = []
        self._status: AutopilotStatus | None = None
        self._flying = False

    def reset_estimators(self, time_s: float = 0.0) -> None:
        """Restart the estimators at ``time_s`` (s), at rest at the origin."""
        for estimator in self._estimators:
            estimator.reset(time_s)

    def _reset_controllers(self) -> None:
        self.position.reset()
        self.attitude.reset()
        self.attitude_filter.reset()
        self.dob.reset()

    # ------------------------------------------------------------------ the tick
    def step(self, time_s: float, samples: Iterable[SensorSampleLike]) -> np.ndarray:
        """One control tick at ``time_s``; returns PWM u1..u4 to hold until the next tick."""
        # one averaging of the tick's samples, shared by both estimators
        batches = group_samples(samples, self._sensor_kinds)
        estimate = self.tskf.step_grouped(time_s, self._pwm, batches)
        if self.estimator is not self.tskf:
            estimate = self.estimator.step_grouped(time_s, self._pwm, batches)
        loe = self.tskf.loe_estimate  # a fresh array, clipped to [0, 1]
        healthy = all(map(math.isfinite, estimate.pos_ned.tolist()))
        nav = self.navigator.step(time_s, estimate.pos_ned, estimate.vel_ned,
                                  float(estimate.euler_rad[2]), estimator_healthy=healthy)
        for ev in nav.events:
            self._events.append(AutopilotEvent(ev.time_s, ev.kind, ev.text, ev.severity,
                                               seq=ev.seq))
        flying = nav.reference is not None
        # Effectiveness is only observable in free flight: on the ground, and while taking
        # off or landing (ground contact, the landing creep), commanded thrust without the
        # motion it should cause is not evidence of a fault. Outside free flight the
        # detector gets no evidence either way.
        in_free_flight = flying and nav.landed_state == LandedState.IN_AIR
        for det in self.detector.step(time_s, loe if in_free_flight else _NO_EVIDENCE):
            self._events.append(AutopilotEvent(
                det.time_s, "fault_detected" if det.kind == "fault" else "fault_cleared",
                det.message, "critical" if det.kind == "fault" else "notice",
                motor=det.motor))
        if not flying:
            if self._flying:
                self._reset_controllers()
            self._flying = False
            self._pwm = np.zeros(4)
            self._torque_applied = np.zeros(3)
            self._status = AutopilotStatus(time_s, estimate, nav, None, None, 0.0, np.zeros(3),
                                           np.zeros(3), self._pwm, loe,
                                           self._detected())
            return self._pwm
        if not self._flying:  # take-off: start from the current attitude, forget ground contact
            self.attitude_filter.reset(estimate.euler_rad)
            self.dob.reset()
        self._flying = True
        ref = nav.reference
        assert ref is not None
        cmd: PositionCommand = self.position.step(estimate.pos_ned, estimate.vel_ned,
                                                  ref.pos_ned, ref.vel_ned, ref.acc_ned,
                                                  ref.yaw_rad)
        att_ref = self.attitude_filter.step((cmd.roll_ref_rad, cmd.pitch_ref_rad, ref.yaw_rad))
        torque = self.attitude.step(estimate.euler_rad, estimate.rate_frd, att_ref.euler_rad,
                                    att_ref.rate, att_ref.acc)
        d_hat = self.dob.step(estimate.euler_rad, estimate.rate_frd, self._torque_applied)
        torque_cmd = torque - d_hat
        pwm = self.allocator.allocate(cmd.thrust_n, torque_cmd)
        _, self._torque_applied = self.allocator.mix(pwm)
        self._pwm = pwm
        self._status = AutopilotStatus(time_s, estimate, nav, ref, att_ref, cmd.thrust_n,
                                       torque_cmd, d_hat, pwm, loe, self._detected())
        return pwm

    def _detected(self) -> tuple[bool, bool, bool, bool]:
        active = self.detector.active
        return (1 in active, 2 in active, 3 in active, 4 in active)

    # ------------------------------------------------------------------ observation
    @property
    def status(self) -> AutopilotStatus | None:
        """What the last tick computed (None before the first tick)."""
        return self._status

    @property
    def ekf(self) -> ExtendedKalmanEstimator | None:
        """The EKF when it is the estimator feeding the controllers, else None."""
        return self.estimator if isinstance(self.estimator, ExtendedKalmanEstimator) else None

    @property
    def pwm(self) -> np.ndarray:
        """The PWM commanded at the last tick, (4,)."""
        return self._pwm

    def drain_events(self) -> list[AutopilotEvent]:
        """Events since the previous call (navigator events and fault detections)."""
        events, self._events = self._events, []
        return events

    # ------------------------------------------------------------------ commands
    def arm(self, force: bool = False) -> CommandResult:
        """Arm (pre-arm checks unless ``force``)."""
        return self.navigator.arm(force)

    def disarm(self, force: bool = False) -> CommandResult:
        """Disarm (refused in flight unless ``force``)."""
        return self.navigator.disarm(force)
