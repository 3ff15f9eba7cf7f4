"""Active FTC's answer to a rotor that no longer does what it is told.

Two monitors find such a rotor: the wrench residual (:mod:`fcu.monitoring.rotor_watch`, from
the IMU, in every phase of flight) and the TSKF's detector (:mod:`fcu.monitoring.motor_faults`,
from the hover model). This module decides what the vehicle does about it:

- a motor *lost* (no thrust, or more lost than yaw authority allows) is flown around in
  relaxed hover (:mod:`fcu.control.reduced_attitude`): yaw is given up, the vehicle brakes
  and holds where the fault struck for ``rotor_loss_hold_s`` while the spin builds up, then
  lands (failsafe LAND) unless the pilot chose a mode since;
- a motor *stuck* (its thrust no longer follows its command) is flown around the same way,
  as a motor of fixed thrust (:func:`fcu.control.relaxed_hover.failed_motor_equilibrium`:
  near a quarter of the weight the opposite motor matches it and the vehicle hardly spins),
  as long as the other three can still steer: up to :attr:`RotorLossResponse.
  max_flyable_stuck_n` (a side motor keeps 1 N);
- a motor *hard-over* at full power, or stuck above that, makes 63 % of the weight by
  itself: holding altitude would leave the other three 5 N together and no margin to steer
  the spinning axis (tried: the vehicle held its place but climbed at 10 m/s), so the flight
  is terminated, announced, motors off; the vehicle comes down where the fault struck
  rather than climbing away (a crash, reported as one);
- two opposite motors lost (together, or the second while the first is flown around): the
  vehicle flies on the other pair, spinning at 32 rad/s (the two-propeller relaxed hover,
  rho = 0 with no fixed thrust); two adjacent motors or three: no equilibrium, the flight
  is terminated (motors off: it falls without turning), announced;
- a vehicle that cannot hover on three rotors: announced once, and a level descent under
  the ordinary controller (failsafe LAND).

The TSKF's finding of a lost motor counts only when the wrench residual bears it out (a
deficit of at least a third of hover thrust on that motor), and the TSKF takes no evidence
while the residual suspects a motor of more than a partial loss or of an excess (more
thrust than its command asks), or has found one that does not merely lose
effectiveness: a motor running away at full thrust reads to the TSKF's hover model as a loss
of the opposite motor.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fcu.config import AutopilotConfig
from fcu.control.attitude_reference import AttitudeReference, AttitudeReferenceFilter
from fcu.control.position import PositionController
from fcu.control.reduced_attitude import (
    MIN_SCHEDULE_SPIN_RAD_S,
    SPINNING_POSITION_GAINS,
    ReducedAttitudeCommand,
    ReducedAttitudeController,
)
from fcu.estimation.state import StateEstimate
from fcu.monitoring.motor_faults import MotorFaultDetector
from fcu.monitoring.rotor_watch import RotorWatch
from fcu.navigation.modes import MODE_TABLE, Mode
from fcu.navigation.navigator import Navigator
from fcu.navigation.reference import Reference
from flightdata.vocabulary import OPPOSITE_MOTOR

Announce = Callable[[float, str], None]  # (time_s, critical text)
OPPOSITE_PAIRS = ((1, 2), (3, 4))  # the motors on one arm pair (eq. 3.2)

# of the weight, the most a spinning vehicle lands with below the landing detector's height:
# under the autopilot's throttle-at-minimum test (0.75), so the landing is detected and the
# motors stop instead of lifting the vehicle off again once the ground has stopped its spin
TOUCHDOWN_THRUST_FRACTION = 0.7
# of the relaxed hover's spin: below it, low over the ground while landing, the vehicle sits
# on the ground (its friction stops the spin within a tenth of a second)
TOUCHDOWN_SPIN_FRACTION = 0.3
LANDING_SPEED_M_S = 0.5  # m/s, the least descent speed of the landing after the hold
# of the horizontal force the position loop asks for, what the axis is steered by before
# the spin has built up (all of it once it has)
SPIN_UP_STEER = 0.3
# of the relaxed hover's spin: below it the vehicle is spinning up (the lost pair's axis has
# torque one way only, and the lean the loss started grows until the spin turns it onto the
# other pair's axis)
SPIN_UP_FRACTION = 0.3
# m, below it a spinning-up vehicle is not asked for less lift than its weight: the lean of
# the spin-up takes up to 3 m of height with the position loop braking a climb (the outdoor
# mission's climb at 3 m in 4 m/s of wind), twice that is kept as the margin; higher up the
# braking is kept, as extra thrust in the lean pushes the vehicle sideways (larger excursion)
SPIN_UP_LIFT_BELOW_M = 6.0
# s after the switch to relaxed hover, the longest that floor holds (a total loss reaches
# SPIN_UP_FRACTION in about 0.9 s; a spin that does not build must not keep the vehicle up)
SPIN_UP_LIFT_S = 1.5


class RotorLossResponse:
    """Which motor to fly around in relaxed hover, and the relaxed hover's flight
    (module docstring).

    Parameters
    ----------
    config : AutopilotConfig
        The model, the detector's ``lost_threshold`` and ``rotor_loss_hold_s``.
    dt_s : float
        Control period, s.
    detector, watch, navigator
        The autopilot's TSKF detector, wrench-residual watch and navigator.
    announce : callable
        ``announce(time_s, text)`` publishes a critical event.
    """

    def __init__(self, config: AutopilotConfig, dt_s: float, detector: MotorFaultDetector,
                 watch: RotorWatch, navigator: Navigator, announce: Announce) -> None:
        self.config = config
        self.model = config.model
        self.dt_s = dt_s
        self.detector = detector
        self.watch = watch
        self.navigator = navigator
        self._announce = announce
        # designed when first needed, one per lost motor
        # (motor, the thrust it makes (N), its opposite lost too) -> its controller
        self._reduced: dict[tuple[int, float, bool], ReducedAttitudeController] = {}
        self.position = PositionController(self.model, SPINNING_POSITION_GAINS, dt_s)
        self.reset()

    def reset(self) -> None:
        """Back to the boot state: no motor told lost, not spinning."""
        self.position.reset()
        self._motor_told: int | None = None  # a motor the operator declared lost
        self._spinning: int | None = None  # the failed motor while in relaxed hover
        self._fixed_n = 0.0  # N, what the failed motor makes whatever it is told
        self._pair_lost = False  # the motor opposite it is lost too
        self._spinning_since_s = 0.0  # s, when relaxed hover began
        self.loe_at_spin: np.ndarray | None = None  # LOE published since a spin began
        self._landing = False  # the LAND failsafe of this loss was triggered
        self._terminated = False  # the motors were stopped (terminate)

    @property
    def spinning_motor(self) -> int | None:
        """The lost motor while the vehicle flies in relaxed hover, else None."""
        return self._spinning

    def declare_motor_lost(self, motor: int | None) -> None:
        """The operator says ``motor`` (1..4) is lost (None forgets it)."""
        if motor is not None and motor not in (1, 2, 3, 4):
            raise ValueError(f"motor = {motor!r}: must be 1, 2, 3 or 4 (or None)")
        self._motor_told = motor

    def on_ground(self) -> None:
        """The vehicle is not flying: relaxed hover ends."""
        self._spinning = None
        self._landing = False

    def on_take_off(self) -> None:
        """A new flight: the per-motor estimates are published live again."""
        self.loe_at_spin = None

    # ------------------------------------------------------------------ deciding
    def tskf_trusted(self) -> bool:
        """Whether the TSKF's detector may take evidence and its findings count (module
        docstring)."""
        watch = self.watch
        declared = watch.declared
        # (a motor stuck above its command reads to the hover model as a loss of the opposite
        # one: nothing is taken while the stuck test has a candidate, nor while the residual
        # suspects a motor of making more than its command asks, which no loss explains)
        suspected = watch.suspected
        excess = suspected is not None and watch.deficit_n.item(suspected - 1) < 0.0
        return (not watch.alarming and watch.stuck_candidate is None and not excess
                and (declared is None or declared[1] == "loe"))

    def lost_motor(self, time_s: float, ftc_active: bool) -> int | None:
        """The motor to fly around in relaxed hover, or None: the one the operator declared
        lost, else in active FTC the one the wrench residual found lost, else the TSKF's
        (declared or suspected beyond ``lost_threshold``) when the residual bears it out.
        Once in relaxed hover the vehicle stays in it until it lands."""
        if self._spinning is not None:
            self._second_loss(time_s)
            return self._spinning
        motors: tuple[int, ...] = ()
        fixed_n = 0.0
        watch = self.watch
        declared = watch.declared
        if self._motor_told is not None:
            motors = (self._motor_told,)
        elif ftc_active and watch.lost is not None:
            motors = (watch.lost,) if watch.second_lost is None else (watch.lost,
                                                                      watch.second_lost)
        elif ftc_active and declared is not None and declared[1] in ("motor_hard_over",
                                                                     "motor_stuck"):
            # it makes what it was stuck at: flown around as a motor of fixed thrust, as long
            # as the other three can still steer (module docstring)
            fixed_n = declared[2] * self.model.thrust_gain * self.model.pwm_max
            if fixed_n > self.max_flyable_stuck_n:
                self.terminate(time_s, f"motor {declared[0]} stuck at {fixed_n:.1f} N "
                               f"({100 * declared[2]:.0f} % of full power)")
                return None
            motors = (declared[0],)
        elif ftc_active and self.tskf_trusted():
            detector = self.detector
            motors = detector.lost
            suspected = detector.suspected
            if (not motors and suspected is not None
                    and float(detector.loe[suspected - 1])
                    > self.config.detector.lost_threshold):
                motors = (suspected,)
            # borne out by the wrench residual: a deficit of a third of hover thrust, and
            # that motor its best single-motor fit (a motor stuck above its command reads to
            # the hover model as a loss of the opposite one, whose deficit fits it nearly
            # as well once the collective's bias has taken in the excess)
            hover_n = self.model.mass * self.model.gravity / 4.0
            motors = tuple(m for m in motors if watch.deficit_n.item(m - 1) > hover_n / 3.0
                           and watch.best_fit == m)

        if not motors:
            return None
        pair = len(motors) == 2 and tuple(sorted(motors)) in OPPOSITE_PAIRS
        if len(motors) > 1 and not pair:
            self.terminate(time_s, f"motors {' and '.join(map(str, sorted(motors)))} lost "
                           "(not an opposite pair)")
            return None
        motor = min(motors)
        if not self._design(time_s, motor, round(fixed_n, 2), pair):
            return None
        return motor

    def _design(self, time_s: float, motor: int, fixed_n: float, pair: bool) -> bool:
        """The reduced-attitude controller around failed ``motor`` making ``fixed_n`` (N),
        with its opposite lost too when ``pair``: designed once, kept as the one to fly;
        False when there is none (announced, and the vehicle lands)."""
        key = (motor, fixed_n, pair)
        if key not in self._reduced:
            try:
                self._reduced[key] = ReducedAttitudeController(
                    self.model, motor, self.dt_s, fixed_thrust_n=fixed_n, opposite_lost=pair)
            except ValueError as err:
                self.cannot_survive(time_s, str(err))
                return False
        self._fixed_n, self._pair_lost = fixed_n, pair
        return True

    def _second_loss(self, time_s: float) -> None:
        """In relaxed hover around a lost motor: when the wrench residual finds the opposite
        one lost too, fly on the other pair (announced)."""
        second = self.watch.second_lost
        first = self._spinning
        third = self.watch.third_lost
        if third is not None and first is not None:
            lost = sorted({first, OPPOSITE_MOTOR[first] if self._pair_lost else first,
                           second or first, third})
            self.terminate(time_s, f"motors {', '.join(map(str, lost))} lost (one rotor makes "
                           f"{self.model.thrust_gain * self.model.pwm_max:.2f} N of the "
                           f"{self.model.mass * self.model.gravity:.1f} N weight)")
            return
        if self._pair_lost or second is None or first is None:
            return
        if second != OPPOSITE_MOTOR[first]:
            self.terminate(time_s, f"motors {min(first, second)} and {max(first, second)} "
                           "lost (not an opposite pair)")
            return
        flying = self._reduced[(first, self._fixed_n, False)]
        motor = min(first, second)
        if not self._design(time_s, motor, 0.0, True):
            return
        reduced = self._reduced[(motor, 0.0, True)]
        reduced.reset(flying.thrust_model)  # what the motors make now (the lag's state)
        self._spinning = motor
        self._announce_pair(time_s, (first, second), reduced)

    @property
    def max_flyable_stuck_n(self) -> float:
        """N, the most a stuck motor may make for the vehicle to fly around it: what leaves
        each side motor 1 N with the opposite motor matching it (the level equilibrium of
        :func:`fcu.control.relaxed_hover.failed_motor_equilibrium`)."""
        return self.model.mass * self.model.gravity / 2.0 - 1.0

    def terminate(self, time_s: float, why: str) -> None:
        """Say once that the fault cannot be flown at all, and stop the motors (the least
        bad thing: the vehicle comes down where the fault struck, without turning, instead
        of tumbling or climbing away)."""
        if self._terminated:
            return
        self._terminated = True
        self._announce(time_s, f"{why}: the other motors cannot fly the vehicle; flight "
                       "terminated, motors off")
        self.navigator.crash(f"{why}: flight terminated")

    def cannot_survive(self, time_s: float, why: str) -> None:
        """Say once that the fault cannot be flown around, and land (the least bad thing)."""
        if self._landing:
            return
        self._landing = True
        self._announce(time_s, f"{why}; descending level (LAND)")
        self.navigator.trigger_failsafe("motor", "land")

    def motors_lost(self) -> tuple[int, ...]:
        """Motors (1..4) declared lost, by the TSKF's detector or the wrench residual."""
        lost = set(self.detector.lost)
        watch = self.watch
        lost.update(m for m in (watch.lost, watch.second_lost, watch.third_lost)
                    if m is not None)
        return tuple(sorted(lost))

    # ------------------------------------------------------------------ flying
    def fly(self, time_s: float, motor: int, estimate: StateEstimate, ref: Reference,
            attitude_filter: AttitudeReferenceFilter, trim_accel: np.ndarray
            ) -> tuple[ReducedAttitudeCommand, AttitudeReference]:
        """One tick of relaxed hover around lost ``motor``: the position loop's thrust
        direction, the primary axis steered along it (:mod:`fcu.control.reduced_attitude`);
        on entry (``trim_accel``: the ordinary position loop's trim, m/s^2) the hold where
        the fault struck, after ``rotor_loss_hold_s`` the LAND failsafe."""
        reduced = self._enter(time_s, motor, estimate, trim_accel)
        cmd = self.position.step(estimate.pos_ned, estimate.vel_ned, ref.pos_ned, ref.vel_ned,
                                 ref.acc_ned, ref.yaw_rad)
        att_ref = attitude_filter.step((cmd.roll_ref_rad, cmd.pitch_ref_rad, ref.yaw_rad))
        if not self._landing and time_s - self._spinning_since_s >= self.config.rotor_loss_hold_s:
            self._landing = True
            # land after the hold unless the pilot chose a mode since (RTL, LAND...), at no
            # less than ArduCopter's LAND_SPEED: the spinning vehicle holds its place worse
            # than a whole one, so the less time it spends up in the wind the better
            if self.navigator.mode == Mode.BRAKE:
                if self.navigator.speed_limits.down_m_s < LANDING_SPEED_M_S:
                    self.navigator.change_speed(LANDING_SPEED_M_S, "descent")
                self.navigator.trigger_failsafe("motor", "land")
        force = np.asarray(cmd.accel_cmd_ned, dtype=float) - (0.0, 0.0, self.model.gravity)
        # the axis is steered only as far as the spin reached allows: before the spin the
        # torques about the lost pair's axis can only go one way, and a tilt asked of it
        # (braking, holding against the wind) adds to the roll the loss started
        fraction = reduced.spin_fraction(estimate.rate_frd)
        force[:2] *= SPIN_UP_STEER + (1.0 - SPIN_UP_STEER) * fraction
        if (self._fixed_n == 0.0 and not self._pair_lost and fraction < SPIN_UP_FRACTION
                and estimate.alt_m < SPIN_UP_LIFT_BELOW_M
                and time_s - self._spinning_since_s < SPIN_UP_LIFT_S):
            # falling is what the spin-up cannot afford this low: at least the weight. (One
            # lost motor only: a stuck one's equilibrium hardly spins, and the lift pushed
            # it 8 m out of the mission area in the outdoor climb; two opposite ones lost
            # start no lean, and the lift cost three more crashes in 4 m/s of wind.)
            force[2] = min(force[2], -self.model.gravity)
        cap = None
        if self.navigator.leg_kind == "land" and self._touched_down(estimate, reduced):
            # less than the weight, so that the ground holds the vehicle and the landing is
            # detected at low thrust
            cap = TOUCHDOWN_THRUST_FRACTION * self.model.mass * self.model.gravity
        return reduced.step(estimate.euler_rad, estimate.rate_frd, force, cap), att_ref

    def _touched_down(self, estimate: StateEstimate, reduced: ReducedAttitudeController
                      ) -> bool:
        """Low over the ground (under the landing detector's height) and stopped there: the
        ground has stopped the spin (its friction does within a tenth of a second), or, for
        an equilibrium that hardly spins, the vertical speed is the landing detector's."""
        config = self.navigator.config
        if estimate.alt_m >= config.land_detect_alt_m:
            return False
        spin = abs(reduced.equilibrium.yaw_rate_rad_s)
        if spin >= MIN_SCHEDULE_SPIN_RAD_S:
            return abs(estimate.rate_frd.item(2)) < TOUCHDOWN_SPIN_FRACTION * spin
        return abs(estimate.vel_ned.item(2)) < config.land_detect_speed_m_s

    def _enter(self, time_s: float, motor: int, estimate: StateEstimate,
               trim_accel: np.ndarray) -> ReducedAttitudeController:
        """The reduced-attitude controller for ``motor``; on entry it is started from the
        estimated thrusts, the position loop from ``trim_accel``, and announced."""
        reduced = self._reduced[(motor, self._fixed_n, self._pair_lost)]  # by lost_motor
        if self._spinning == motor:
            return reduced
        self._spinning = motor
        self._spinning_since_s = time_s
        self._landing = False
        # the TSKF's hover model does not hold in a spin: its per-motor estimates are
        # published as they stood at the switch until the next take-off
        self.loe_at_spin = np.array(self.detector.loe, dtype=float)
        reduced.reset(np.asarray(estimate.thrust_n, dtype=float))
        # hold against the wind from the first tick: the trim the position loop had
        self.position.take_trim(trim_accel)
        eq = reduced.equilibrium
        if self._pair_lost:
            self._announce_pair(time_s, (motor, OPPOSITE_MOTOR[motor]), reduced)
        else:
            what = ("lost" if self._fixed_n == 0.0
                    else f"stuck at {self._fixed_n:.1f} N")
            self._announce(time_s, f"motor {motor} {what}: yaw given up, spinning about the "
                           f"thrust axis (relaxed hover, {abs(eq.yaw_rate_rad_s):.0f} rad/s "
                           f"expected); holding {self.config.rotor_loss_hold_s:.0f} s, then "
                           "LAND")
        # stop where the fault struck (a landing or returning vehicle carries on): the
        # spinning vehicle brakes on at most SPINNING_POSITION_GAINS' tilt, past the
        # stopping point the speed limits assume
        nav = self.navigator
        if not MODE_TABLE[nav.mode].lands:
            nav.set_mode(Mode.BRAKE)
            nav.hold_at(time_s, estimate.pos_ned)
        return reduced

    def _announce_pair(self, time_s: float, lost: tuple[int, int],
                       reduced: ReducedAttitudeController) -> None:
        """Say that two opposite rotors are lost and the vehicle flies on the other two."""
        flying = sorted(set((1, 2, 3, 4)) - set(lost))
        self._announce(time_s, f"motors {lost[0]} and {lost[1]} lost: flying on motors "
                       f"{flying[0]} and {flying[1]}, spinning about the thrust axis (relaxed "
                       f"hover on two rotors, {abs(reduced.equilibrium.yaw_rate_rad_s):.0f} "
                       f"rad/s expected); holding {self.config.rotor_loss_hold_s:.0f} s, then "
                       "LAND")
