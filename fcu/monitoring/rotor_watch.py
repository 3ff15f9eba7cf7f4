"""Large motor faults isolated from the IMU in every phase of flight: the wrench residual.

The TSKF-based detector (:mod:`fcu.monitoring.motor_faults`) reads per-motor effectiveness
off a hover model: it says nothing while the vehicle climbs, descends or leaves the hover
regime, and it removes the collective as a mass change, so that a motor running away at full
thrust looks to it like a loss of the opposite motor (they differ only in the small yaw
torque). This watch needs no hover model. Every tick it compares the wrench the motors
should make with the wrench the IMU measures, both in the body frame:

    expected  w_e = B T_e                                    (eq. 3.17; B = thrust mixer)
    measured  w_m = (-m a_z,  J w' + w x J w + G w - r_cp x m a_xy)
                                          (eq. 3.15, rate damping G, in-plane drag moment)
    residual  r   = w_e - w_m - (mu, 0, 0, 0)

with ``T_e`` the thrusts the commanded PWM gives through the motor lag (eq. 3.1, the
commands held over each tick, times the effectiveness each motor is reckoned with: in active
FTC the allocator's, else that of the motors the TSKF's detector has declared partially
lost), ``w'`` the gyro's difference between consecutive ticks (their means, so the torque
is that at the boundary between them, where ``T_e`` and the two ticks' mean specific force
``a`` are taken too), ``r_cp x m a_xy`` the moment of the
in-plane drag about the centre of gravity (the thrust has no in-plane part, so the
accelerometer's x and y read the drag alone; the centre of pressure sits ``cp_offset_z``
above the centre of gravity: in moderate turbulence this takes the torque channels' noise
from about 0.07 to 0.02 N*m) and ``mu`` the collective bias (drag along the body axis in
steady flight, a mass change: low-passed over ``bias_tau_s``, held while a large fault
is building up or a motor is suspected of an excess with its command near its floor,
``excess_hold_command``: learning the collective part of such an excess, a lock the
controller drives down, would leave only its torque, which that motor's excess and the
opposite motor's deficit fit alike; with the command higher a lighter vehicle beside a
partial loss of the opposite motor looks like it, and the bias must learn the mass).
Climb, descent, cruise and turns are all in ``w_m``: only what the motors fail to deliver
stays in ``r``.

A fault of motor ``j`` that leaves it ``f`` newtons short (negative: in excess) gives
``r = b_j f``, ``b_j`` the column ``j`` of ``B``. Against the per-channel noise ``Sigma``
(measured, attack 1 s, decay ``noise_tau_s``, floored; frozen while a motor is suspected or
the best statistic is above a quarter of ``significance``, so that a fault building up is
never learned: a motor locked while its command moves away grows slowly) the best
single-motor fit and its statistic are::

    f_j = b_j' S^-1 r / (b_j' S^-1 b_j),     T_j = f_j^2 b_j' S^-1 b_j

A motor is suspected when ``T_j > significance``, ``|f_j| > min_deficit`` of its expected
thrust and ``b_j f_j`` explains the residual (``T_j > consistency x RSS_j``: a gust twists
the frame without the collective a motor's thrust carries). A suspicion is *alarming* when
the command the motor follows (below) says lost or hard-over, or the fault exceeds
``alarm_deficit`` of the thrust: the bias is then held, and the TSKF's detector takes no
evidence (its hover model misreads such a fault, :mod:`fcu.rotor_loss`). A lost or hard-over
motor is declared after ``persistence_ticks`` consecutive ticks of suspicion of the same
motor, about 0.04 s after a total loss (the motor lag spreads the deficit over 67 ms).
Partial losses are left to the TSKF's detector. The collective separates a motor's loss
from the opposite motor's excess, which give the same roll or pitch torque.

The kind comes from the motor's own thrust, ``T_j = T_e,j - f_j``, inverted through the lag
over the persistence window (the command the motor actually follows, ``u_f``)::

    u_f = (T(t) - T(t - D) e^(-w D)) / ((1 - e^(-w D)) K)

``motor_lost`` (deficit, ``u_f`` under ``1 - lost_fraction`` of the command: a lost
propeller, a freewheeling or dead motor) or ``motor_hard_over`` (excess, ``u_f`` at 85 % of
full power or more); the magnitude is the fraction of effectiveness lost or the command
followed as a fraction of full power.

Stuck motors
------------
A motor locked where it was makes no sudden residual: it shows only as the controller moves
its command. How far its own thrust falls short of what its command asks (``K u`` through
the lag, less ``T_e,j - f_j``) then follows that command one for one, where a healthy
motor's stays noise and a partial loss's follows at the slope ``gamma``. Here ``f_j`` is the
fit of the residual without the collective bias ``mu``: the bias follows the collective
within ``bias_tau_s`` and would take part of a locked motor's growing shortfall out of the
fit (a lock in the take-off, its command driven up to full power, followed at a slope of
0.73); its slow changes (mass, axial drag) are what the split leaves out. While the
controller makes up for a step loss of effectiveness, the weakened motor's shortfall moves
with its command one for one too (the deficit's step and the command's rise, both fast);
what tells the two apart is the time order: a loss steps the motor's own thrust down
within the motor lag, before the command moves, and a lock never moves it. The stuck test
leaves a motor alone for ``loss_step_hold_s`` after its own thrust fell by
``loss_step_fraction`` of full thrust within ``loss_step_ticks``. Per motor the watch
splits both at ``follow_split_s`` (what is slower is the controller's compensation of a
fault, which carries a weakened motor's shortfall up with its command for a while, one for
one) and keeps exponentially weighted moments of their fast parts (``follow_tau_s``); it
declares ``motor_stuck`` (``motor_hard_over`` at 85 % of full power or more) for the motor
whose shortfall correlates with its command above ``stuck_correlation``, by
``stuck_margin`` more than any other motor's, at a slope within ``stuck_slope``, once the
command's fast part has spread by ``stuck_spread_n`` (the command moved), for
``stuck_ticks`` ticks in a row when the motor makes more than its command asks (an excess,
which no loss explains), ``stuck_shortfall_ticks`` when less (a compensated loss's
shortfall, after the step gate, still follows at a slope of 0.9 or more for up to a fifth
of a second). The magnitude is its own thrust
(the slow parts), as a fraction of full thrust.

Two rotors
----------
After a motor is declared lost, a second one may be declared lost too (the relaxed hover
around the first commands the other three; when one fails, its deficit fits the residual as
the first one's did), and a third after those. Two opposite motors lost together leave no
roll or pitch torque, only a collective deficit and a yaw torque (each pair turns the same
way): the sum of their columns fits that, and when it explains the residual better than any
one motor and than the other pairs, and by ``pair_torque_significance`` more than the
collective alone (a change of mass or of the axial drag has no torque to fit; before the
collective bias has learned the drag of a take-off into a strong gust, the collective alone
would otherwise pass for a pair), with a deficit of at least ``alarm_deficit`` of each, for
``persistence_ticks`` ticks, both are declared lost. Adjacent pairs are fitted the same
way (their sum leaves a roll and a pitch torque at once).

Beyond those, one motor is declared per flight (after the first, the residual carries the
controller's response to it); other second faults are beyond this watch. The per-motor deficits stay
up to date after it (:attr:`RotorWatch.deficit_n`): the autopilot checks the TSKF's
findings against them.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from fcu.model import VehicleModel
from fcu.monitoring.rotor_watch_kernel import (
    NOISE_FREEZE,
    PAIRS,
    S_DEFICIT,
    S_SLOW,
    S_START,
    S_STAT,
    STATE_SIZE,
    pack_params,
    reset_state,
    watch_tick,
)
from flightdata.config import finite, require
from flightdata.records import DetectionRecord


@dataclass(frozen=True, kw_only=True)
class RotorWatchConfig:
    """Settings of the wrench-residual watch (module docstring)."""

    significance: float = 60.0  # statistic T_j (chi-square, 1 dof under no fault) to suspect
    min_deficit: float = 0.25  # |f_j| / expected thrust of motor j needed to suspect
    # |f_j| / expected thrust beyond which a suspicion is alarming whatever its kind
    alarm_deficit: float = 0.5
    consistency: float = 3.0  # T_j must exceed this many times what the fit leaves (RSS_j)
    persistence_ticks: int = 2  # consecutive ticks suspecting the same motor that declare
    # a lost or hard-over motor
    bias_tau_s: float = 0.5  # s, low-pass of the collective bias mu
    noise_tau_s: float = 20.0  # s, decay of the measured noise (attack: 1 s)
    # noise floors, 1 sigma: collective N, roll, pitch, yaw N*m (indoor air, IMU noise)
    noise_floor: tuple[float, float, float, float] = (0.1, 0.015, 0.015, 0.012)
    min_alt_m: float = 0.15  # m, estimated altitude above which the watch takes evidence
    # the part of a pair's statistic beyond that of the collective alone (the pair's torque:
    # 3 sigma of it) needed to declare two motors lost together: a change of mass or of the
    # axial drag has no torque (a take-off tilted into a 14 m/s ground gust, before the
    # bias has learned the drag, read as motors 1 and 2 lost with the pairs' full
    # statistic; two motors really lost carry 11-85 beyond the collective's, indoor and in
    # 4 m/s of moderate turbulence)
    pair_torque_significance: float = 9.0
    # fraction of a motor's effectiveness lost above which a deficit is declared a lost
    # motor (``motor_lost``), below it a partial loss (``loe``)
    lost_fraction: float = 0.75
    # a motor stuck where it was (module docstring, "Stuck motors"): the moments' time
    # constant, the least spread of its expected thrust, the correlation of its deficit with
    # that thrust and the slope between them, the margin over the next motor's correlation,
    # and how many ticks in a row it must hold
    follow_tau_s: float = 0.3  # s
    follow_split_s: float = 0.25  # s, what is slower is the controller's compensation
    stuck_spread_n: float = 0.05  # N, standard deviation of the fast part of T_e
    stuck_correlation: float = 0.9
    stuck_slope: tuple[float, float] = (0.9, 1.25)
    stuck_margin: float = 0.05
    stuck_ticks: int = 12  # with an excess: the motor makes more than its command asks
    # with a shortfall, which a step loss of effectiveness also shows while the controller
    # makes up for it (module docstring, "Stuck motors")
    stuck_shortfall_ticks: int = 30
    # a drop of a motor's own thrust by this fraction of full thrust within
    # ``loss_step_ticks`` is a loss, not a lock (a lock never moves it): the stuck test
    # leaves that motor alone for ``loss_step_hold_s``
    loss_step_fraction: float = 0.05
    loss_step_ticks: int = 5
    loss_step_hold_s: float = 0.5
    # of full power: a motor suspected of an excess while its command is at most this is
    # making thrust its command no longer asks for (a lock the controller is driving down),
    # and the collective bias is held (module docstring); above it, a mass drop beside the
    # opposite motor's partial loss looks the same and the bias must learn the mass (at
    # 0.25 the thesis's case 8, 0.3 kg dropped as motor 3 loses 20 %, starts to move)
    excess_hold_command: float = 0.2

    def __post_init__(self) -> None:
        for name in ("significance", "min_deficit", "alarm_deficit", "consistency",
                     "follow_tau_s", "follow_split_s", "stuck_spread_n", "stuck_correlation",
                     "bias_tau_s", "noise_tau_s", "min_alt_m", "lost_fraction",
                     "excess_hold_command", "pair_torque_significance",
                     "loss_step_fraction", "loss_step_hold_s"):
            value = getattr(self, name)
            require(finite(value) and value > 0.0, name, value, "must be > 0")
        require(self.excess_hold_command <= 1.0, "excess_hold_command",
                self.excess_hold_command, "must lie in (0, 1] (of full power)")
        require(isinstance(self.persistence_ticks, int) and self.persistence_ticks >= 2,
                "persistence_ticks", self.persistence_ticks, "must be an integer >= 2")
        for name in ("stuck_ticks", "stuck_shortfall_ticks", "loss_step_ticks"):
            value = getattr(self, name)
            require(isinstance(value, int) and value >= 1, name, value,
                    "must be an integer >= 1")
        low, high = self.stuck_slope
        require(0.0 < low < 1.0 < high, "stuck_slope", self.stuck_slope,
                "must be (low, high) with 0 < low < 1 < high")
        require(finite(self.stuck_margin) and self.stuck_margin >= 0.0, "stuck_margin",
                self.stuck_margin, "must be >= 0")
        require(len(self.noise_floor) == 4 and all(finite(v) and v > 0
                                                   for v in self.noise_floor),
                "noise_floor", self.noise_floor, "must be four numbers > 0")


_NO_READING = np.zeros(3)  # the kernel's reading arguments on a tick without the IMU
_NOMINAL = np.ones(4)  # every motor delivering what it is told
_NOMINAL.setflags(write=False)


class RotorWatch:
    """The wrench-residual watch of one vehicle (module docstring).

    Call :meth:`step` every tick with the tick's mean gyro and accelerometer readings and
    the PWM held over the tick; it returns the records of what it decided. The arithmetic is
    the compiled :func:`fcu.monitoring.rotor_watch_kernel.watch_tick`; the decisions are
    here.
    """

    def __init__(self, model: VehicleModel, config: RotorWatchConfig, dt_s: float) -> None:
        self.config = config
        self.dt_s = dt_s
        self._k = model.thrust_gain
        self._pwm_max = model.pwm_max
        self._w = model.motor_bandwidth
        self._par = pack_params(model, dt_s, config)
        self._state = np.zeros(STATE_SIZE)
        # N, the latest single-motor fit f_j per motor (a view of the kernel's state)
        self.deficit_n = self._state[S_DEFICIT:S_DEFICIT + 4]
        self.reset()

    def reset(self) -> None:
        """Back to the boot state: motors at rest, nothing learned or declared."""
        reset_state(self._par, self._state)
        self._streak = 0
        self._candidate = -1
        # the candidate's own thrust (N) and its command, tick by tick since its streak began
        self._history: list[tuple[float, float]] = []
        self._best = -1  # the best single-motor fit of the latest residual (0..3)
        self.second_lost: int | None = None  # a motor lost after the first, or with it
        self.third_lost: int | None = None  # one more
        self._pair_candidate, self._pair_streak = -1, 0  # a pair lost together (0, 1)
        self._stuck_motor = -1  # the motor the stuck test picks (0..3), and for how long
        self._stuck_ticks = 0
        # each motor's own thrust (N) over the last loss_step_ticks + 1 ticks, and until when
        # (s) the stuck test leaves it alone after a step down in it (a loss, not a lock)
        self._own_recent: list[deque[float]] = [
            deque(maxlen=self.config.loss_step_ticks + 1) for _ in range(4)]
        self._loss_step_until_s = [-math.inf] * 4
        self.declared: tuple[int, str, float] | None = None  # (motor 1..4, kind, magnitude)
        # a motor is suspected of more than a partial loss at the latest tick: lost, stuck
        # or hard-over by the command it follows, or short of half its thrust (the TSKF's
        # hover model misreads such a fault, fcu.rotor_loss)
        self.alarming = False
        # a motor is suspected of making more than its command asks, the command near its
        # floor, at the latest tick: no loss and no change of mass explains that (module
        # docstring), so the collective bias is held meanwhile
        self._excess = False

    @property
    def statistic(self) -> float:
        """The latest best single-motor statistic T_j."""
        return self._state.item(S_STAT)

    def own_thrust_n(self, motor: int) -> float:
        """N, what ``motor`` (1..4) makes by the residual: the thrust its command asks for
        less its deficit, both low-passed over ``follow_split_s`` (at full effectiveness:
        what the stuck test needs, which runs on motors reckoned whole)."""
        return self._state.item(S_SLOW + 2 * (motor - 1)) - self.slow_shortfall_n(motor)

    def slow_shortfall_n(self, motor: int) -> float:
        """N, how far ``motor``'s (1..4) own thrust falls short of what its command asks,
        low-passed over ``follow_split_s`` (< 0: an excess)."""
        return self._state.item(S_SLOW + 2 * (motor - 1) + 1)

    @property
    def stuck_candidate(self) -> int | None:
        """The motor (1..4) the stuck test picks at the latest tick (module docstring, "Stuck
        motors"), before it has held long enough to be declared, if any."""
        return self._stuck_motor + 1 if self._stuck_ticks > 0 and self.declared is None else None

    @property
    def best_fit(self) -> int | None:
        """The motor (1..4) whose single-motor fit best explained the latest residual (None
        before one was formed)."""
        return self._best + 1 if self._best >= 0 else None

    @property
    def excess_fit(self) -> int | None:
        """The motor (1..4) whose excess (more thrust than its command asks) best fitted the
        latest residual with a statistic above NOISE_FREEZE of the significance (where the
        noise estimate stops learning), suspected or not yet, if any."""
        best = self._best
        if (best < 0 or self.deficit_n.item(best) >= 0.0
                or self.statistic <= NOISE_FREEZE * self.config.significance):
            return None
        return best + 1

    @property
    def suspected(self) -> int | None:
        """The motor (1..4) suspected at the latest tick and not yet declared, if any."""
        return self._candidate + 1 if self._streak > 0 and self.declared is None else None

    @property
    def lost(self) -> int | None:
        """The motor (1..4) declared lost (no thrust), if any."""
        d = self.declared
        return d[0] if d is not None and d[1] == "motor_lost" else None

    def step(self, time_s: float, gyro: list[float] | None, accel: list[float] | None,
             pwm: np.ndarray, airborne: bool, effectiveness: np.ndarray = _NOMINAL
             ) -> list[DetectionRecord]:
        """One tick: ``gyro`` (rad/s) and ``accel`` (m/s^2) means over the tick (None when
        the tick had none), ``pwm`` the commands held over it, ``airborne`` whether the
        vehicle flies clear of the ground (the evidence is taken only then),
        ``effectiveness`` what each motor is reckoned to deliver of its command (shape (4,):
        1, or 1 - the LOE of a partial loss the autopilot knows of or compensates): the
        watch looks for what is new."""
        if gyro is None or accel is None:
            best, suspect, pair, stuck = watch_tick(
                self._par, self._state, _NO_READING, _NO_READING, False, pwm, effectiveness,
                airborne, False, True)
        else:
            best, suspect, pair, stuck = watch_tick(
                self._par, self._state, np.asarray(gyro, dtype=float),
                np.asarray(accel, dtype=float), True, pwm, effectiveness, airborne,
                self.declared is None, self.alarming or self._excess)
        self.alarming = self._excess = False
        if best >= 0:
            self._best = best
            stuck = self._unless_stepped_down(time_s, stuck)
        if best >= 0 and self.declared is None:
            found = self._pair_lost(time_s, pair) or self._stuck(time_s, stuck)
            if found:
                return found
        second = self._second_candidate(best)
        if best < 0 or not suspect or (self.declared is not None and not second):
            self._streak = 0
            return []
        state = self._state
        own = state.item(S_START + best) - state.item(S_DEFICIT + best)  # N, its own thrust
        command = min(max(float(pwm[best]), 0.0), self._pwm_max)
        if best != self._candidate or self._streak == 0:
            self._candidate, self._streak = best, 0
            self._history.clear()
        self._streak += 1
        self._excess = (state.item(S_DEFICIT + best) < 0.0
                        and command <= self.config.excess_hold_command * self._pwm_max)
        self._history.append((own, command))
        expected = state.item(S_START + best)  # N, what the motor should make
        large = abs(state.item(S_DEFICIT + best)) >= self.config.alarm_deficit * expected
        if self._streak == 1:
            self.alarming = large
            return []
        kind, magnitude = self._kind(best)
        # the TSKF's hover model misreads a lost or hard-over motor (fcu.rotor_loss); a large
        # deficit that the command it follows does not say is lost is a partial loss, the
        # TSKF's, and a stuck motor the stuck test's
        self.alarming = large and kind in ("motor_lost", "motor_hard_over")
        if self._streak < self.config.persistence_ticks or kind not in ("motor_lost",
                                                                        "motor_hard_over"):
            # a partial loss is the TSKF detector's; a stuck motor the stuck test's
            return []
        if second:
            if kind != "motor_lost":
                return []
            if self.second_lost is None:
                self.second_lost = best + 1
            else:
                self.third_lost = best + 1
        else:
            self.declared = (best + 1, kind, magnitude)
        self._streak = 0
        return [DetectionRecord(time_s=time_s, action="detected", kind=kind, motor=best + 1,
                                magnitude=magnitude)]

    def _second_candidate(self, best: int) -> bool:
        """Whether ``best`` (0..3) may be declared as a second loss: another motor than the
        one declared lost, none declared second yet (module docstring, "Two rotors")."""
        d = self.declared
        return (d is not None and d[1] == "motor_lost" and self.third_lost is None
                and best + 1 not in (d[0], self.second_lost))

    def _pair_lost(self, time_s: float, found: int) -> list[DetectionRecord]:
        """The test for two motors lost together (module docstring, "Two rotors"): the pair
        ``found`` (index into ``PAIRS``, -1 for none) whose summed columns explain the latest
        residual better than any one motor and than the other pairs (the yaw torque tells 1
        and 2 from 3 and 4), with a deficit of at least ``alarm_deficit`` of each
        (:func:`~fcu.monitoring.rotor_watch_kernel.watch_tick`'s pick), for
        ``persistence_ticks`` ticks in a row."""
        if found < 0 or found != self._pair_candidate:
            self._pair_candidate, self._pair_streak = found, 0
        if found < 0:
            return []
        self._pair_streak += 1
        self.alarming = True
        if self._pair_streak < self.config.persistence_ticks:
            return []
        a, b = PAIRS[found]
        self.declared = (a + 1, "motor_lost", 1.0)
        self.second_lost = b + 1
        return [DetectionRecord(time_s=time_s, action="detected", kind="motor_lost",
                                motor=m + 1, magnitude=1.0) for m in (a, b)]

    def _unless_stepped_down(self, time_s: float, j: int) -> int:
        """The stuck test's pick ``j`` (0..3, -1 for none), or -1 while that motor's own
        thrust stepped down within the last ``loss_step_hold_s`` (module docstring, "Stuck
        motors"); the motors' recent own thrusts brought up to this tick."""
        cfg = self.config
        drop_n = cfg.loss_step_fraction * self._k * self._pwm_max
        state = self._state
        for i in range(4):
            own = state.item(S_START + i) - state.item(S_DEFICIT + i)
            recent = self._own_recent[i]
            recent.append(own)
            if len(recent) == recent.maxlen and recent[0] - own > drop_n:
                self._loss_step_until_s[i] = time_s + cfg.loss_step_hold_s
        return -1 if j >= 0 and time_s < self._loss_step_until_s[j] else j

    def _stuck(self, time_s: float, j: int) -> list[DetectionRecord]:
        """The test for a motor stuck where it was (module docstring, "Stuck motors"): the
        motor ``j`` (0..3, -1 for none) whose shortfall follows its command one for one,
        clearly better than any other's (:func:`~fcu.monitoring.rotor_watch_kernel.watch_tick`'s
        pick), for ``stuck_ticks`` ticks in a row."""
        if j < 0:
            self._stuck_ticks, self._stuck_motor = 0, -1
            return []
        self._stuck_ticks = self._stuck_ticks + 1 if self._stuck_motor == j else 1
        self._stuck_motor = j
        cfg = self.config
        # a loss never makes more than the command asks: an excess is declared sooner
        excess = self.slow_shortfall_n(j + 1) < 0.0
        if self._stuck_ticks < (cfg.stuck_ticks if excess else cfg.stuck_shortfall_ticks):
            return []
        own_n = self.own_thrust_n(j + 1)
        magnitude = min(max(own_n / (self._k * self._pwm_max), 0.0), 1.0)
        kind = "motor_hard_over" if magnitude > 0.85 else "motor_stuck"
        self.declared = (j + 1, kind, magnitude)
        self._streak = 0
        return [DetectionRecord(time_s=time_s, action="detected", kind=kind, motor=j + 1,
                                magnitude=magnitude)]

    def _kind(self, j: int) -> tuple[str, float]:
        """The kind and magnitude of motor ``j``'s (0..3) fault, from the command it follows
        over the streak (module docstring)."""
        decay = math.exp(-self._w * (len(self._history) - 1) * self.dt_s)
        own_first, own_last = self._history[0][0], self._history[-1][0]
        followed = (own_last - own_first * decay) / ((1.0 - decay) * self._k)
        command = self._history[-1][1]
        if self.deficit_n.item(j) <= 0.0:
            kind = "motor_hard_over" if followed > 0.85 * self._pwm_max else "motor_stuck"
            return kind, min(max(followed / self._pwm_max, 0.0), 1.0)
        lost = 1.0 - followed / command if command > 0.0 else 1.0
        kind = "motor_lost" if lost > self.config.lost_fraction else "loe"
        return kind, min(max(lost, 0.0), 1.0)
