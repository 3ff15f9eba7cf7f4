"""The fault-tolerant autopilot: one control tick from sensor samples to four PWM commands.

Per tick (``loop_rate_hz``, 100 Hz by default)::

    samples --> estimator ("ekf": eq. 3.18 | "tskf"), screened, without excluded sensors
            --> TSKF (eq. 6.10-6.26) --> gamma_hat
    SensorHealth (innovation, frozen, cross-check) --> exclusions, height source, position fix
    MotorFaultDetector (gamma_hat, PWM)  --> per-motor LOE, mass change, declared motors
    navigator (modes, mission, guidance) --> reference pos/vel/acc, yaw
    PositionController (eq. 5.3, 5.4)    --> U1, roll_d, pitch_d
    AttitudeReferenceFilter               --> smooth attitude reference and derivatives
    attitude law ("pd": eq. 5.6 | "lqg": eq. 5.7-5.10) --> torque
    disturbance observer ("none" | "vbdob" | "abdob": eq. 6.27-6.30) --> torque - d_hat
    allocator ("attitude_first": inverse eq. 3.2) --> PWM u1..u4
    CrashCheck (attitude, impact, ground contact in flight; thrust loss) --> disarm
    BatteryMonitor (power-module samples) --> charge used, low/critical failsafe

Detections (:mod:`fcu.monitoring`) are :class:`flightdata.records.DetectionRecord` data, each
carried by an :class:`AutopilotEvent` whose text is derived from the record. A motor declared
faulty blocks arming until it is cleared (in flight) or the autopilot is restarted; a lost
position fix makes the navigator hold attitude and height, then land; a crash disarms.

The configuration (:mod:`fcu.config`) names the estimator, attitude law, disturbance
observer and allocator; the autopilot builds each through its kind's registry
(:mod:`fcu.estimation.registry`, :mod:`fcu.control.registry`). The TSKF always runs: it
supplies the per-motor effectiveness estimates that fault detection and telemetry use,
whichever estimator feeds the controllers (it is that estimator when ``estimator = "tskf"``).
The autopilot knows the world only through the samples (:mod:`fcu.hal`); it never sees
injected faults.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from fcu.config import AutopilotConfig
from fcu.control import chain as control_chain
from fcu.control.attitude_reference import AttitudeReference, AttitudeReferenceFilter
from fcu.control.position import PositionController
from fcu.control.registry import ALLOCATOR_REGISTRY, ATTITUDE_LAW_REGISTRY, DOB_REGISTRY
from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.registry import ESTIMATOR_REGISTRY, StateEstimator
from fcu.estimation.state import StateEstimate, group_samples
from fcu.estimation.tskf import TwoStageKalmanFilter
from fcu.hal import SensorSampleLike
from fcu.monitoring.battery import BatteryMonitor
from fcu.monitoring.crash_check import CrashCheck, contact_counts
from fcu.monitoring.motor_faults import MotorFaultDetector
from fcu.monitoring.rotor_watch import RotorWatch
from fcu.monitoring.sensor_health import SensorHealth
from fcu.monitoring.watched_pair import step_pair_watched
from fcu.navigation.navigator import CommandResult, LandedState, Navigator, NavOutput
from fcu.navigation.reference import Reference
from fcu.rotor_loss import RotorLossResponse
from flightdata.records import DetectionRecord
from flightdata.vocabulary import BATTERY_SENSOR, FTC_MODES, SENSORS

# AutopilotConfig is defined in fcu.config; named here too because it is the configuration
# of this module's Autopilot
__all__ = ["Autopilot", "AutopilotConfig", "AutopilotEvent", "AutopilotStatus"]

_ZERO3 = np.zeros(3)  # the torques of a tick that does not fly (shared: read-only)
_ZERO3.setflags(write=False)
_NOMINAL4 = np.ones(4)  # every motor's effectiveness when no partial loss is known
_NOMINAL4.setflags(write=False)
# the parts of a flying tick's output (fcu.control.chain's OUT_* layout)
_OUT_PWM = slice(control_chain.OUT_PWM, control_chain.OUT_PWM + 4)
_OUT_TORQUE_CMD = slice(control_chain.OUT_TORQUE_CMD, control_chain.OUT_TORQUE_CMD + 3)
_OUT_D_HAT = slice(control_chain.OUT_D_HAT, control_chain.OUT_D_HAT + 3)
_OUT_TORQUE_APPLIED = slice(control_chain.OUT_TORQUE_APPLIED,
                            control_chain.OUT_TORQUE_APPLIED + 3)
_OUT_CRASH_MEASURES = slice(control_chain.OUT_ALT, control_chain.OUT_COLLECTIVE + 1)


# an AutopilotStatus made without its constructor's keywords (_keep_status: once a tick)
_NEW_TUPLE = tuple.__new__


@dataclass(frozen=True)
class AutopilotEvent:
    """Something worth a STATUSTEXT: a mode change, a refusal, a detection..."""

    time_s: float  # s, simulated
    kind: str  # navigator event kind, or "detection" (then ``record`` says what)
    text: str
    severity: str = "info"  # "info" | "notice" | "warning" | "critical"
    seq: int | None = None  # for mission events
    record: DetectionRecord | None = None  # for detections: the data behind the text

    @classmethod
    def of(cls, record: DetectionRecord) -> AutopilotEvent:
        """The event carrying a detection record (severity from its kind and action)."""
        if record.action == "cleared":
            severity = "notice"
        elif record.kind in ("loe", "motor_lost", "motor_hard_over", "motor_stuck", "crash"):
            severity = "critical"
        else:
            severity = "warning"
        return cls(record.time_s, "detection", record.text(), severity, record=record)


class AutopilotStatus(NamedTuple):
    """Everything telemetry and logs need from the last tick (a record made every tick:
    a named tuple, the cheapest to build)."""

    time_s: float
    estimate: StateEstimate
    nav: NavOutput
    reference: Reference | None  # position reference tracked (None: not flying)
    attitude_reference: AttitudeReference | None  # what the attitude loop tracks
    thrust_cmd_n: float  # N, collective thrust commanded
    torque_cmd_nm: np.ndarray  # N*m, after the DOB compensation
    disturbance_nm: np.ndarray  # N*m, DOB estimate (zeros without a DOB)
    pwm: np.ndarray  # PWM commanded for the next interval, (4,)
    loe_estimate: np.ndarray  # per-motor loss of effectiveness (TSKF, mass change removed;
    # after a switch to relaxed hover, as it stood at the switch until the next take-off)
    fault_detected: tuple[bool, bool, bool, bool]  # motors 1..4 declared faulty
    mass_change_kg: float = 0.0  # kg, estimated change of mass (+ heavier)
    excluded_sensors: frozenset[str] = frozenset()  # sensors the estimators do not trust
    motors_lost: tuple[int, ...] = ()  # motors 1..4 declared lost


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
        # it is one, else a TSKF of its own, the thesis's, which leaves the accelerometer to
        # the estimator that flies: in turbulence the accelerometer's model error (vertical
        # drag) reaches the per-motor estimates through the thrust states' correlations
        # (MIL-F-8785C moderate, 30 seeds: motor false alarms in 2 with it, none without)
        self.tskf = (self.estimator if isinstance(self.estimator, TwoStageKalmanFilter)
                     else TwoStageKalmanFilter(model, self.dt_s,
                                               height_source=cfg.height_source))
        self._estimators: tuple[StateEstimator, ...] = (
            (self.tskf,) if self.estimator is self.tskf else (self.tskf, self.estimator))
        self.navigator = Navigator(cfg.navigator)
        self.position = PositionController(model, cfg.position, self.dt_s)
        self._touchdown_below_m = cfg.position.touchdown_below_m  # m (PositionGains)
        self.attitude_filter = AttitudeReferenceFilter(self.dt_s,
                                                       cfg.attitude_ref_bandwidth_rad_s)
        self._sensor_kinds = frozenset().union(*(e.sensor_kinds for e in self._estimators))
        self.sensor_health = SensorHealth(cfg.sensors, cfg.height_source)
        self._gust_accel_sq = cfg.sensors.gust_accel_m_s2 ** 2  # (m/s^2)^2
        noise = self.estimator.noise
        self._sensor_noise = {name: float(getattr(noise, name)) for name in SENSORS}
        self.detector = MotorFaultDetector(model, cfg.detector, self.dt_s)
        self.rotor_watch = RotorWatch(model, cfg.rotor_watch, self.dt_s)
        # the hover regime's bounds (detector settings), read twice a tick
        self._valid_yaw_rate_rad_s = cfg.detector.valid_yaw_rate_rad_s
        self._valid_tilt_rad = cfg.detector.valid_tilt_rad
        self.crash_check = CrashCheck(cfg.crash)
        self._full_thrust_n = 4.0 * model.thrust_gain * model.pwm_max  # N, the collective's scale
        # N, ArduCopter's throttle-at-minimum test: asking for much less than hover thrust
        self._low_thrust_n = 0.75 * model.mass * model.gravity
        self.ftc_active = cfg.ftc == "active"
        # what active FTC does about a lost or runaway rotor (relaxed hover, fcu.rotor_loss)
        self.rotor_loss = RotorLossResponse(cfg, self.dt_s, self.detector, self.rotor_watch,
                                            self.navigator, self._announce_rotor_loss)
        self.battery = BatteryMonitor(cfg.battery)
        self._grouped_kinds = self._sensor_kinds | {BATTERY_SENSOR}
        self.reset()

    def reset(self) -> None:
        """Back to the boot state: estimators, controllers and navigator reset, motors off."""
        self.reset_estimators()
        self.navigator.reset()
        self._reset_controllers()
        self.sensor_health.reset()
        self.detector.reset()
        self.rotor_watch.reset()
        self.crash_check.reset()
        self.battery.reset()
        self._pwm = np.zeros(4)
        self._torque_applied = np.zeros(3)
        self._thrust_n = 0.0  # N, collective commanded at the last tick
        self._events: list[AutopilotEvent] = []
        self._status: AutopilotStatus | None = None  # the latest tick's (_keep_status)
        self._flying = False
        # the declared motors the arming blocker was set for (None: not since the reset)
        self._blocker_motors: tuple[int, ...] | None = None
        self._blocker_watched = False  # the blocker names the wrench residual's motor
        # the latest estimate _hover_regime judged, and its verdict: the estimate of a tick
        # is the next tick's prior, judged again then
        self._regime_of: StateEstimate | None = None
        self._regime = False

    def reset_estimators(self, time_s: float = 0.0) -> None:
        """Restart the estimators at ``time_s`` (s), at rest at the origin."""
        for estimator in self._estimators:
            estimator.reset(time_s)
        self._height_source: str | None = None  # given to the estimators at the next tick

    def _reset_controllers(self) -> None:
        self.position.reset()
        self.position.touchdown(False)  # the flight's tilt limit
        self._touchdown = False
        self.rotor_loss.reset()
        self.attitude.reset()
        self.attitude_filter.reset()
        self.dob.reset()
        # the parts flown with all rotors, stepped together (fcu.control.chain)
        self._chain = control_chain.ControlChain(self.position, self.attitude_filter,
                                                 self.attitude, self.dob, self.allocator,
                                                 self._full_thrust_n, self.crash_check)

    # ------------------------------------------------------------------ the tick
    def step(self, time_s: float, samples: Iterable[SensorSampleLike]) -> np.ndarray:
        """One control tick at ``time_s``; returns PWM u1..u4 to hold until the next tick."""
        # one averaging of the tick's samples, shared by both estimators
        batches = group_samples(samples, self._grouped_kinds)
        gyro, accel = batches.peek_value("gyro"), batches.peek_value("accel")
        self._battery_step(time_s, batches.pop_value(BATTERY_SENSOR))
        health = self.sensor_health
        excluded = health.excluded
        source = health.height_source
        if source != self._height_source:  # (the health monitor changes it rarely)
            self._height_source = source
            for estimator in self._estimators:
                estimator.height_source = source
        # a lone outlier is a sensor's fault only while the model can be trusted: in flight,
        # in the hover regime, with no motor lost (fcu.estimation.estimator), and no gust's
        # drag on the accelerometer's in-plane axes (fcu.monitoring.sensor_health, "Gusts")
        prior = self.estimator.estimate
        reject = (self.navigator.landed_state == LandedState.IN_AIR and prior.alt_m > 0.2
                  and self._hover_regime(prior) and not self.detector.lost
                  and (accel is None or accel[0] * accel[0] + accel[1] * accel[1]
                       < self._gust_accel_sq))
        estimator = self.estimator
        if isinstance(estimator, ExtendedKalmanEstimator):
            # both filters and the sensor watch on the EKF's screening: one compiled call
            estimate, records = step_pair_watched(
                estimator, self.tskf, health, time_s, self._pwm, batches, excluded=excluded,
                reject=reject, noise=self._sensor_noise)
        else:
            if estimator is self.tskf:
                estimate = self.tskf.step_grouped(time_s, self._pwm, batches,
                                                  excluded=excluded, reject=reject)
            else:  # the TSKF's own estimate is built only if read
                self.tskf.advance_grouped(time_s, self._pwm, batches, excluded=excluded,
                                          reject=reject)
                estimate = estimator.step_grouped(time_s, self._pwm, batches,
                                                  excluded=excluded, reject=reject)
            records = health.step(time_s, batches, estimator.screening, reject,
                                  self._sensor_noise)
        low_thrust = self._thrust_n < self._low_thrust_n  # throttle at minimum
        # (the navigator judges a non-finite position, velocity or yaw an unhealthy
        # estimator itself)
        nav = self.navigator.step(time_s, estimate.pos_ned, estimate.vel_ned,
                                  estimate.euler_rad.item(2),
                                  on_ground_hint=True if low_thrust else None,
                                  position_fix=health.position_fix)
        if nav.events:
            for ev in nav.events:
                self._events.append(AutopilotEvent(ev.time_s, ev.kind, ev.text, ev.severity,
                                                   seq=ev.seq))
        flying = nav.reference is not None
        watch = self.rotor_watch
        airborne = (flying and nav.landed_state != LandedState.ON_GROUND
                    and estimate.alt_m > self.config.rotor_watch.min_alt_m)
        watch_records = watch.step(time_s, gyro, accel, self._pwm, airborne,
                                   self._watch_effectiveness())
        if watch_records:
            records += watch_records
        motor_records = self._motor_evidence(time_s, estimate, nav, flying)
        if motor_records:
            records += motor_records
        if not flying:
            if self._flying:
                self._reset_controllers()
            self.rotor_loss.on_ground()
            self._flying = False
            self._pwm = np.zeros(4)
            self._torque_applied = np.zeros(3)
            self._thrust_n = 0.0
            self.crash_check.reset()  # not flying: the checks restart
            if records:
                self._publish(records)
            self._keep_status(time_s, estimate, nav, None, None, 0.0, _ZERO3, _ZERO3)
            return self._pwm
        if not self._flying:  # take-off: start from the current attitude, forget ground contact
            self.rotor_loss.on_take_off()
            self.attitude_filter.reset(estimate.euler_rad)
            self.dob.reset()
        self._flying = True
        ref = nav.reference
        assert ref is not None
        lost = self.rotor_loss.lost_motor(time_s, self.ftc_active)
        if lost is None:
            touchdown = (nav.landed_state == LandedState.LANDING
                         and estimate.alt_m < self._touchdown_below_m)
            if touchdown != self._touchdown:  # the tilt limit of the touchdown, or not
                self._touchdown = touchdown
                self._chain.touchdown(touchdown)
            # position, reference filter, attitude law, DOB, allocation, mix, crash check:
            # one compiled call
            out = self._chain.step(estimate.pos_ned, estimate.vel_ned, estimate.euler_rad,
                                   estimate.rate_frd, ref.pos_ned, ref.vel_ned, ref.acc_ned,
                                   ref.yaw_rad, self._torque_applied,
                                   self._ftc_effectiveness() if self.ftc_active else None,
                                   time_s=time_s, contact_leg=self._contact_counts(ref))
            pwm = out[_OUT_PWM]
            thrust_n = out.item(control_chain.OUT_THRUST)
            torque_cmd = out[_OUT_TORQUE_CMD]
            d_hat = out[_OUT_D_HAT]
            att_ref = control_chain.attitude_reference(out)
            self._torque_applied = out[_OUT_TORQUE_APPLIED]
            found = out.item(control_chain.OUT_CRASH_FOUND)
            if found:
                records += self._crash_records(time_s, int(found), out)
        else:
            # relaxed hover: yaw given up, the primary axis steered along the thrust the
            # position loop asks for (fcu.rotor_loss)
            spin, att_ref = self.rotor_loss.fly(time_s, lost, estimate, ref,
                                                self.attitude_filter, self.position.trim_accel)
            pwm, thrust_n = spin.pwm, spin.collective_n
            torque_cmd = d_hat = np.zeros(3)
            self.allocator.set_effectiveness(None)
            _, self._torque_applied = self.allocator.mix(pwm)
            out = np.zeros(control_chain.OUT_SIZE)
            control_chain.crash_measures(estimate.euler_rad, att_ref.euler_rad,
                                         estimate.pos_ned, estimate.vel_ned, thrust_n,
                                         self._full_thrust_n, out)
            records += self._crash_check(time_s, ref, out)
        self._thrust_n = thrust_n
        if not self.navigator.armed:  # the crash check disarmed
            pwm = np.zeros(4)
        self._pwm = pwm
        if records:
            self._publish(records)
        self._keep_status(time_s, estimate, nav, ref, att_ref, thrust_n, torque_cmd, d_hat)
        return pwm

    # ------------------------------------------------------------------ monitoring
    def _motor_evidence(self, time_s: float, estimate: StateEstimate, nav: NavOutput,
                        flying: bool) -> list[DetectionRecord]:
        """Motor fault detection on the TSKF's gamma (:mod:`fcu.monitoring.motor_faults`):
        evidence only in the air (:meth:`_evidence_leg`), in the hover model's validity,
        with trusted sensors and the TSKF off the ground; blocks arming while a motor is
        declared."""
        landed_state = nav.landed_state
        # (the regime is only asked about in the air: on the ground there is no evidence)
        learn = (flying and landed_state != LandedState.ON_GROUND
                 and self._hover_regime(estimate) and not self.tskf.on_ground
                 and not self.sensor_health.suspect(time_s)
                 and self.rotor_loss.tskf_trusted())
        detector = self.detector
        records = detector.step(time_s, self.tskf.gamma_raw, self._pwm,
                                evidence=learn and self._evidence_leg(landed_state, estimate),
                                learn=learn)
        active = detector.active
        watched = self.rotor_watch.declared
        # (the detector's tuple of declared motors is a new one whenever they change; the
        # watch declares once per boot)
        if active is not self._blocker_motors or (watched is not None
                                                   and not self._blocker_watched):
            self._blocker_motors = active
            self._blocker_watched = watched is not None
            self.navigator.set_arming_blocker(
                "motors", self._motors_blocker if active or watched is not None else None)
        return records

    def _motors_blocker(self) -> str:
        """The arming blocker of the declared motors, naming each one's latest estimated LOE
        in whole per cent, or what the wrench residual found (written when read)."""
        detector = self.detector
        loe = detector.loe
        reasons = [f"motor {m} detected failed (lost about {round(100 * loe.item(m - 1))} "
                   "%): restart the autopilot to clear" for m in detector.active]
        watched = self.rotor_watch.declared
        if watched is not None and watched[0] not in detector.active:
            what = watched[1].removeprefix("motor_").replace("_", "-")
            reasons.append(f"motor {watched[0]} detected failed ({what}): restart the "
                           "autopilot to clear")
        return "; ".join(reasons)

    def _ftc_effectiveness(self) -> np.ndarray | None:
        """Active FTC: per motor, ``1 - LOE`` of the motors the detector has declared or
        suspects now (its estimate, mass change removed, :mod:`fcu.monitoring.motor_faults`),
        1 for the others; None (nominal) while it declares and suspects none.

        Other motors are left nominal: their estimate is noise about zero (turbulence moves
        it by a few per cent), and feeding it to the mixer would shake healthy motors for
        nothing. The suspected one is included so that reconfiguration starts before the
        declaration's persistence has run (40 % step: 4.2 cm of height lost, 5.3 cm with
        declared motors only).
        """
        detector = self.detector
        if not detector.active and detector.suspected is None:
            return None
        e = np.ones(4)
        loe = detector.loe
        motors = set(detector.active)
        if detector.suspected is not None:
            motors.add(detector.suspected)
        for motor in motors:
            e[motor - 1] = 1.0 - min(max(float(loe[motor - 1]), 0.0), 1.0)
        return e

    def _watch_effectiveness(self) -> np.ndarray:
        """Per motor, what the wrench residual is to expect it to deliver of its command: in
        active FTC what the allocator reckons with (:meth:`_ftc_effectiveness`: its
        compensation moves a weakened motor's command, not its thrust), else ``1 - LOE`` of
        the motors the TSKF's detector has declared."""
        if self.ftc_active:
            e = self._ftc_effectiveness()
            if e is None:
                return _NOMINAL4
        else:
            detector = self.detector
            if not detector.active:
                return _NOMINAL4
            e = np.ones(4)
            loe = detector.loe
            for motor in detector.active:
                e[motor - 1] = 1.0 - min(max(float(loe[motor - 1]), 0.0), 1.0)
        # read-only like _NOMINAL4: the watch's kernel is then compiled for one array type
        e.setflags(write=False)
        return e

    @property
    def relaxed_hover_motor(self) -> int | None:
        """The lost motor while the vehicle flies in relaxed hover, else None."""
        return self.rotor_loss.spinning_motor

    def _announce_rotor_loss(self, time_s: float, text: str) -> None:
        self._events.append(AutopilotEvent(time_s, "relaxed_hover", text, "critical"))

    def declare_motor_lost(self, motor: int | None) -> None:
        """Tell the autopilot that ``motor`` (1..4) is lost: from the next tick in flight it
        flies in relaxed hover (yaw given up) whatever the FTC mode; None forgets it (a
        vehicle already spinning stays in relaxed hover until it lands)."""
        self.rotor_loss.declare_motor_lost(motor)

    def set_ftc(self, mode: str) -> None:
        """Switch fault-tolerant control between ``"passive"`` and ``"active"``, in flight too:
        the next tick allocates with (or without) the estimated effectiveness; the
        controllers' states carry over, so the switch is a step in the motor commands only
        as large as the fault being compensated."""
        if mode not in FTC_MODES:
            raise ValueError(f"ftc = {mode!r}: must be one of {', '.join(FTC_MODES)}")
        self.ftc_active = mode == "active"

    def _battery_step(self, time_s: float, value: list[float] | None) -> None:
        """The battery monitor (:mod:`fcu.monitoring.battery`) on the power module's reading
        (the tick's mean voltage and current, or None); a rise of its level is announced and
        triggers the failsafe its action names."""
        volts = amps = None
        if value is not None and len(value) >= 2:
            volts, amps = value[0], value[1]
        event = self.battery.step(time_s, volts, amps)
        if event is None:
            return
        self._events.append(AutopilotEvent(time_s, "battery", event.text, "critical"))
        if event.action is not None:
            self.navigator.trigger_failsafe("battery", event.action)

    def _evidence_leg(self, landed_state: LandedState, estimate: StateEstimate) -> bool:
        """Whether the flight's leg lets the TSKF's detector take evidence: in the air, and
        in a landing above ``detector.landing_evidence_alt_m`` (lower, the touchdown is
        near: a descent from height is flown like the cruise, and a motor that loses
        effectiveness or locks there is found as it would be in the cruise) while the
        wrench residual is not best fitted by an excess (:attr:`RotorWatch.excess_fit`: in
        the descent's turbulence a lock's excess grows under the watch's significance while
        the hover model already reads it as a loss of the opposite motor)."""
        if landed_state == LandedState.IN_AIR:
            return True
        return (landed_state == LandedState.LANDING
                and estimate.alt_m > self.config.detector.landing_evidence_alt_m
                and self.rotor_watch.excess_fit is None)

    def _hover_regime(self, estimate: StateEstimate) -> bool:
        """Yaw rate and tilt within the hover model's validity (``detector`` settings)."""
        if estimate is self._regime_of:  # (an estimate's arrays are never changed)
            return self._regime
        euler = estimate.euler_rad
        regime = (abs(estimate.rate_frd.item(2)) < self._valid_yaw_rate_rad_s
                  and abs(euler.item(0)) < self._valid_tilt_rad
                  and abs(euler.item(1)) < self._valid_tilt_rad)
        self._regime_of, self._regime = estimate, regime
        return regime

    def _contact_counts(self, ref: Reference) -> bool:
        """Whether ground contact is a crash this tick (:func:`contact_counts`): the leg is
        no take-off or landing and the reference ``ref`` is off the ground."""
        return contact_counts(self.navigator.leg_kind, -ref.pos_ned.item(2),
                              self.config.crash.contact_ref_alt_m)

    def _crash_check(self, time_s: float, ref: Reference, measures: np.ndarray
                     ) -> list[DetectionRecord]:
        """ArduCopter's crash and thrust-loss checks (:mod:`fcu.monitoring.crash_check`) on the
        tick's ``measures`` (:func:`fcu.control.chain.crash_measures`), in relaxed hover (the
        control chain runs them otherwise)."""
        nav = self.navigator
        if not (nav.armed and not nav.landed):  # not flying: the checks restart
            self.crash_check.reset()
            return []
        found = self.crash_check.tick(time_s, self._contact_counts(ref),
                                      measures[_OUT_CRASH_MEASURES])
        return self._crash_records(time_s, found, measures) if found else []

    def _crash_records(self, time_s: float, found: int, measures: np.ndarray
                       ) -> list[DetectionRecord]:
        """The records of what the crash checks ``found`` (bits) at ``time_s`` (s) on the
        tick's ``measures``; a crash disarms (``FS_CRASH_CHECK`` = 1)."""
        records = self.crash_check.records(time_s, found, measures[_OUT_CRASH_MEASURES])
        if any(r.kind == "crash" for r in records) and self.config.crash.action == 1:
            self.navigator.crash("crash: disarming")
        return records

    def _publish(self, records: list[DetectionRecord]) -> None:
        for record in records:
            self._events.append(AutopilotEvent.of(record))

    def _keep_status(self, time_s: float, estimate: StateEstimate, nav: NavOutput,
                     ref: Reference | None, att_ref: AttitudeReference | None,
                     thrust_n: float, torque_cmd: np.ndarray, d_hat: np.ndarray) -> None:
        """What the tick computed, as :attr:`status`."""
        detector = self.detector
        spun = self.rotor_loss.loe_at_spin
        loe = detector.loe if spun is None else spun
        # AutopilotStatus(...) without its keyword handling: the fields in their order
        self._status = _NEW_TUPLE(AutopilotStatus, (
            time_s, estimate, nav, ref, att_ref, thrust_n, torque_cmd, d_hat, self._pwm, loe,
            detector.declared_flags, detector.mass_change_kg, self.sensor_health.excluded,
            self.rotor_loss.motors_lost()))

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
