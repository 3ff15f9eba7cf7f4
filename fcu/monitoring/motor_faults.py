"""Motor fault detection and isolation, and the mass change, from the TSKF's gamma estimates.

The thesis reads the TSKF's per-motor gamma_hat (eq. 6.13) as the loss of effectiveness and a
threshold on it as the detector. Outside calm air that fails three ways: vertical gusts and a
change of mass move all four estimates together, gust torques on the frame look like a
roll or pitch fault, and after a large loss the estimate spreads onto healthy motors. This
module goes beyond the thesis with three steps, each a few lines of linear algebra on the
TSKF's output.

1. The common mode is a mass change, not a fault
------------------------------------------------
A uniform thrust deficit ``e`` (PWM units) on every motor, ``gamma_i u_i = e``, changes no
torque (eq. 3.2: roll, pitch and yaw are differences) and only the collective: it is what a
mass change ``dm`` looks like to a filter built on the nominal mass, ``4 K e = g dm``, and it
cannot be told from an equal loss on all four motors. Assuming that at least one motor is
healthy (a quadrotor with four degraded motors is outside this detector), the estimates split
into a mass change and per-motor losses::

    e       = mean of gamma_j u_j over the motors not declared (the smallest gamma_j u_j
              when all are), low-passed over ``common_tau_s`` and held while any motor is
              half suspected (a fault building up is not a mass change)
    dm      = 4 K e / g                                   (kg, + heavier)
    delta_i = gamma_i - e / u_i                           (loss of effectiveness of motor i)

with ``u`` the PWM low-passed over 0.2 s. ``delta`` is what telemetry reports as LOE.

2. Isolation by fault signatures, weighted by the measured excitation
--------------------------------------------------------------------
A loss on motor i is a thrust deficit ``a_i = gamma_i u_i / u_h`` (``u_h`` hover PWM) whose
torques have a fixed signature (eq. 3.2, normalised by L and K_psi): ``d = M a`` with ::

    M = [[ 0,  0, -1, +1],     roll deficit  (motors 3 left, 4 right)
         [-1, +1,  0,  0],     pitch deficit (motors 1 front, 2 back)
         [-1, -1, +1, +1]]     yaw deficit   (1, 2 counter-clockwise; 3, 4 clockwise)

The mass change is in M's null space, so ``d`` sees only motor faults and disturbances.
Turbulence shows up in ``d`` as noise whose size differs per axis: gusts act on the drag's
centre of pressure and twist the frame in roll and pitch, never in yaw. The detector keeps a
running estimate of that noise, ``Sigma = diag(s_roll^2, s_pitch^2, s_yaw^2)``, from the
residual of ``d`` after the faults already declared (fast attack 2 s, slow decay
``noise_tau_s``, floored at ``noise_floor``, not learned for ``settle_s`` after a
declaration (the TSKF's transient), and frozen while any motor is even half
suspected: LOE above half the threshold with a statistic above a quarter of the
significance, so that a fault building up is never learned as noise), and tests
each candidate motor j with the generalised likelihood ratio of "one more fault on j"::

    f_S   = argmin (d - M_S f)' Sigma^-1 (d - M_S f)   over S = declared + {j}
    T_j   = RSS(declared) - RSS(declared + {j})        (chi-square, 1 dof, under no fault)
    LOE_j = f_j u_h / u_j

A motor is *suspected* when ``LOE_j > threshold`` **and** ``T_j > significance`` (the
largest T when several are); the thresholds therefore follow the measured excitation: in
turbulence the roll and pitch channels weigh little, a gust that twists the frame produces no
yaw, and it no longer looks like a motor. It is *declared* after ``persistence_s x threshold /
LOE_j`` seconds of suspicion, up to half less in calm air when the evidence is strong (at most
``persistence_s``, at least ``min_persistence_s``; :func:`declaration_delay_s`): a
large loss is declared within a tenth of a second, before the vehicle leaves the hover
regime; a small one needs the full persistence.

3. Isolation of large losses
----------------------------
Evidence is only taken in free flight and while the hover model (eq. 6.1) holds: yaw rate
below ``valid_yaw_rate_rad_s``, roll and pitch below ``valid_tilt_rad``, no sensor under
suspicion. After a declaration no other motor is declared for ``settle_s`` (the TSKF's
transient after a fault spreads estimates for about a second), and after a motor is found
lost (LOE above ``lost_threshold``: beyond what yaw authority allows, thesis note: ~60 %) no
further motor is isolated at all: the vehicle is then outside the hover model, and a second
lost motor would not be survivable anyway.

Recovery: a declared motor whose LOE stays below ``recovery_threshold`` for
``recovery_persistence_s`` in free flight is cleared. Vertical gusts move the common mode
too (0.05-0.07 kg one sigma in MIL-F-8785C moderate turbulence, 0.004 kg in the thesis's
indoor air), so the mass threshold follows its measured spread ``s_m`` as the motor
thresholds follow theirs (learned while no change is reported and ``|dm|`` is below
``mass_threshold_kg``, so that a change ramping up is never learned as spread; fast attack
2 s, slow decay ``noise_tau_s``). A mass change is reported when
``|dm| > max(mass_threshold_kg, mass_sigmas x s_m)`` holds for ``mass_persistence_s`` and
the estimate has settled
(no motor half suspected, so the common mode is not held; within ``mass_settle_kg`` over the
last 0.5 s), so that the magnitude reported is the settled one; it is cleared below half the
threshold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fcu.model import VehicleModel
from fcu.monitoring.motor_fault_kernel import (
    I_DECLARED,
    I_MOTORS,
    I_SIZE,
    MASS_KG,
    MASS_VAR,
    MASS_VAR_FLOOR,
    MASS_WINDOW_S,
    P_COMMON_TAU,
    P_DT,
    P_G,
    P_K,
    P_MASS_SETTLE,
    P_MASS_SIGMAS,
    P_MASS_THRESHOLD,
    P_NOISE_TAU,
    P_SIGNIFICANCE,
    P_THRESHOLD,
    P_U_HOVER,
    W_FLOOR,
    W_PARAMS,
    W_SIZE,
    W_STATE,
    W_U,
    W_VAR,
    detector_tick_call,
)
from flightdata.config import finite, require
from flightdata.records import DetectionRecord

_CALM_RATIO = 2.0  # measured excitation within this many times its floor: calm air


@dataclass(frozen=True, kw_only=True)
class DetectorConfig:
    """Settings of motor fault detection and isolation (module docstring)."""

    threshold: float = 0.1  # LOE fraction above which a motor is suspected
    persistence_s: float = 0.5  # s of suspicion that declare a fault at the threshold
    min_persistence_s: float = 0.1  # s, the least suspicion that declares a large fault
    recovery_threshold: float = 0.05  # LOE fraction below which a faulty motor may recover
    recovery_persistence_s: float = 1.0  # s below it before recovery is declared
    significance: float = 25.0  # GLR statistic (chi-square, 1 dof) needed: 5 sigma
    noise_tau_s: float = 20.0  # s, decay of the measured excitation
    noise_floor: tuple[float, float, float] = (0.01, 0.01, 0.004)  # roll, pitch, yaw deficit
    settle_s: float = 2.0  # s after a declaration before another motor is declared
    lost_threshold: float = 0.6  # LOE above which a motor counts as lost
    # m, in a landing leg evidence is taken only above this estimated altitude (the
    # touchdown below; the thesis mission's landings start under it)
    landing_evidence_alt_m: float = 1.0
    valid_yaw_rate_rad_s: float = 1.0  # rad/s, hover model valid below
    valid_tilt_rad: float = 0.5  # rad, hover model valid below (roll and pitch)
    mass_threshold_kg: float = 0.1  # kg, |mass change| reported
    mass_persistence_s: float = 1.0  # s above it before it is reported
    mass_settle_kg: float = 0.02  # kg, the most the estimate may move in 0.5 s when reported
    common_tau_s: float = 0.3  # s, low-pass of the common mode (mass change)
    mass_sigmas: float = 5.0  # measured spreads of the common mode that a change must exceed

    def __post_init__(self) -> None:
        require(finite(self.threshold) and 0.0 < self.threshold < 1.0, "threshold",
                self.threshold, "must lie in (0, 1)")
        require(finite(self.recovery_threshold)
                and 0.0 <= self.recovery_threshold < self.threshold, "recovery_threshold",
                self.recovery_threshold, f"must lie in [0, threshold = {self.threshold})")
        require(finite(self.lost_threshold) and self.threshold < self.lost_threshold <= 1.0,
                "lost_threshold", self.lost_threshold, "must lie in (threshold, 1]")
        for name in ("persistence_s", "min_persistence_s", "recovery_persistence_s",
                     "settle_s", "mass_persistence_s"):
            value = getattr(self, name)
            require(finite(value) and value >= 0.0, name, value, "must be >= 0 s")
        for name in ("significance", "noise_tau_s", "valid_yaw_rate_rad_s", "valid_tilt_rad",
                     "landing_evidence_alt_m",
                     "mass_threshold_kg", "mass_settle_kg", "common_tau_s", "mass_sigmas"):
            value = getattr(self, name)
            require(finite(value) and value > 0.0, name, value, "must be > 0")
        require(len(self.noise_floor) == 3 and all(finite(v) and v > 0
                                                   for v in self.noise_floor),
                "noise_floor", self.noise_floor, "must be three numbers > 0")


def declaration_delay_s(cfg: DetectorConfig, loe: float, statistic: float,
                        calm: bool) -> float:
    """Seconds of suspicion that declare a fault of size ``loe`` with GLR ``statistic``.

    ``persistence_s x threshold / LOE`` (a large loss is declared sooner); in calm air
    (measured excitation within twice its floor on every axis: indoors it sits at the floor,
    in MIL-F-8785C moderate turbulence at 3-17 times it) shortened by up to half when the
    evidence is strong, ``x sqrt(significance / T)`` clipped to [0.5, 1]: there a 15 % loss
    stands many sigmas above the excitation and needs no full persistence, while in
    turbulence a gust can raise T as much, and the full time applies (severe turbulence,
    10 seeds: 2 false alarms with the shortening in wind, 1 without). Bounded by
    [``min_persistence_s``, ``persistence_s``].
    """
    evidence = min(1.0, max(0.5, math.sqrt(cfg.significance / max(statistic, 1e-12))))
    scale = cfg.persistence_s * cfg.threshold / loe * (evidence if calm else 1.0)
    return min(cfg.persistence_s, max(cfg.min_persistence_s, scale))


@dataclass(frozen=True, slots=True)
class MotorEvidence:
    """What the detector concluded at one tick, for telemetry and logs."""

    loe: np.ndarray  # (4,) loss of effectiveness per motor, common mode removed, 0..1
    mass_change_kg: float  # kg, + heavier
    declared: tuple[int, ...]  # motors 1..4 declared faulty
    lost: tuple[int, ...]  # motors 1..4 declared lost
    noise: np.ndarray  # (3,) measured excitation (roll, pitch, yaw deficit, 1 sigma)


class MotorFaultDetector:
    """Motor fault detection, isolation and the mass change (module docstring).

    The arithmetic of a tick is one compiled call
    (:func:`fcu.monitoring.motor_fault_kernel.detector_tick`); the decisions
    (suspicion, declaration, recovery, the mass report) and their records are made here.

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe (K, hover PWM, g).
    config : DetectorConfig
    dt_s : float
        Tick period, s.
    """

    def __init__(self, model: VehicleModel, config: DetectorConfig, dt_s: float) -> None:
        self.config = config
        self.dt_s = float(dt_s)
        self._settle_s = config.settle_s  # (read every tick)
        self._u_hover = model.hover_pwm
        # the kernel's workspaces (W_*, I_*); the attributes below are views of them
        self._work = np.zeros(W_SIZE)
        self._iwork = np.zeros(I_SIZE, dtype=np.int64)
        self._u = self._work[W_U]
        self._var = self._work[W_VAR]
        self._floor_var = self._work[W_FLOOR]
        self._state = self._work[W_STATE]
        self._params = self._work[W_PARAMS]
        self._floor_var[:] = np.square(np.array(config.noise_floor, dtype=float))
        self._calm_var = _CALM_RATIO**2 * self._floor_var
        self._params[[P_DT, P_U_HOVER, P_K, P_G, P_COMMON_TAU, P_NOISE_TAU, P_THRESHOLD,
                      P_SIGNIFICANCE, P_MASS_THRESHOLD, P_MASS_SIGMAS, P_MASS_SETTLE]] = (
            self.dt_s, model.hover_pwm, model.thrust_gain, model.gravity, config.common_tau_s,
            config.noise_tau_s, config.threshold, config.significance,
            config.mass_threshold_kg, config.mass_sigmas, config.mass_settle_kg)
        # the mass history holds 0.5 s of ticks; room for ticks up to 4 times faster
        self._history = np.zeros((2, 4 * math.ceil(MASS_WINDOW_S / self.dt_s) + 8))
        self.reset()

    def reset(self) -> None:
        """Forget every fault, the learned excitation and the timers."""
        self._var[:] = self._floor_var
        self._u[:] = self._u_hover
        self._state[:] = 0.0
        self._state[MASS_VAR] = MASS_VAR_FLOOR
        self._iwork[:] = 0  # mass history: no slot used; no motor declared
        self._declared: list[int] = []  # motor indices 0..3, in declaration order
        self._lost: set[int] = set()
        self._suspect: int | None = None
        self._suspect_since = 0.0
        self._last_declared_s = -math.inf
        self._recover_since: dict[int, float] = {}
        self._lost_since: dict[int, float] = {}
        self._mass_reported = False
        self._mass_since: float | None = None
        self._loe = np.zeros(4)
        self._declarations_changed()

    def _declarations_changed(self) -> None:
        """Refresh what follows from the declared and lost motors (read every tick)."""
        k = len(self._declared)
        self._iwork[I_DECLARED] = k
        self._iwork[I_MOTORS:I_MOTORS + k] = self._declared
        self._isolate = not self._lost and len(self._declared) < 3
        self._active = tuple(sorted(j + 1 for j in self._declared))
        self._declared_flags = (1 in self._active, 2 in self._active, 3 in self._active,
                                4 in self._active)
        self._lost_motors = tuple(sorted(j + 1 for j in self._lost))

    # ------------------------------------------------------------------ the tick
    def step(self, time_s: float, gamma: np.ndarray, pwm: np.ndarray, *, evidence: bool,
             learn: bool) -> list[DetectionRecord]:
        """One tick.

        Parameters
        ----------
        time_s : float
            Tick time, s.
        gamma : ndarray, shape (4,)
            The TSKF's raw gamma_hat (eq. 6.13).
        pwm : ndarray, shape (4,)
            PWM commanded over the last interval.
        evidence : bool
            The tick may decide (free flight, hover model valid, sensors trusted).
        learn : bool
            The tick may update the measured excitation (airborne, model valid, sensors
            trusted); ignored while a motor is suspected.

        Returns
        -------
        list of DetectionRecord
            What was decided at this tick.
        """
        settling = time_s - self._last_declared_s < self._settle_s
        self._loe = loe_out = np.empty(4)  # a new one every tick: the previous one may be kept
        best, t, loe, settled, mass_threshold = detector_tick_call.call(
            time_s, gamma, pwm, self._work, self._iwork, self._history, self._isolate,
            evidence, learn, settling, self._mass_reported, loe_out)
        if not evidence:
            self._suspect = None
            self._recover_since.clear()
            self._mass_since = None
            return []
        if best < 0 or settling:
            self._suspect = None
            records = []
        else:
            records = self._declare(time_s, best, t, loe)
        if self._declared:
            records += self._track_declared(time_s)
        mass = self._track_mass(time_s, settled, mass_threshold)
        if mass is not None:
            records.append(mass)
        return records

    def _declare(self, time_s: float, j: int, t: float, loe: float) -> list[DetectionRecord]:
        """Motor ``j`` (0..3) is the strongest suspect, with GLR ``t`` and LOE ``loe``."""
        cfg = self.config
        if self._suspect != j:
            self._suspect, self._suspect_since = j, time_s
        calm = bool((self._var <= self._calm_var).all())
        need = declaration_delay_s(cfg, loe, t, calm)
        if time_s - self._suspect_since < need - 1e-9:
            return []
        self._suspect = None
        self._declared.append(j)
        self._last_declared_s = time_s
        kind = "motor_lost" if loe > cfg.lost_threshold else "loe"
        if kind == "motor_lost":
            self._lost.add(j)
        self._declarations_changed()
        return [DetectionRecord(time_s=time_s, action="detected", kind=kind, motor=j + 1,
                                magnitude=min(1.0, loe))]

    def _track_declared(self, time_s: float) -> list[DetectionRecord]:
        """Upgrade declared motors to lost, clear recovered ones."""
        cfg = self.config
        loes = self._loe.tolist()
        if not self._lost_since and not self._recover_since:
            # the common tick: no timer running, and none to start (nothing can change)
            for j in self._declared:
                loe = loes[j]
                if (j not in self._lost and loe > cfg.lost_threshold) or \
                        loe < cfg.recovery_threshold:
                    break
            else:
                return []
        out: list[DetectionRecord] = []
        for j in list(self._declared):
            loe = loes[j]
            if j not in self._lost and loe > cfg.lost_threshold:
                since = self._lost_since.setdefault(j, time_s)
                if time_s - since >= cfg.min_persistence_s - 1e-9:
                    self._lost.add(j)
                    out.append(DetectionRecord(time_s=time_s, action="detected",
                                               kind="motor_lost", motor=j + 1, magnitude=loe))
            else:
                self._lost_since.pop(j, None)
            if loe < cfg.recovery_threshold:
                since = self._recover_since.setdefault(j, time_s)
                if time_s - since >= cfg.recovery_persistence_s - 1e-9:
                    self._declared.remove(j)
                    self._lost.discard(j)
                    self._recover_since.pop(j)
                    out.append(DetectionRecord(time_s=time_s, action="cleared", kind="loe",
                                               motor=j + 1, magnitude=loe))
            else:
                self._recover_since.pop(j, None)
        if out:
            self._declarations_changed()
        return out

    def _track_mass(self, time_s: float, settled: bool,
                    threshold: float) -> DetectionRecord | None:
        """Report a mass change beyond ``threshold`` (kg) held for ``mass_persistence_s``
        once ``settled``, clear it below half the threshold (module docstring)."""
        dm = self._state.item(MASS_KG)
        if not self._mass_reported:
            pending = abs(dm) > threshold
        else:
            pending = abs(dm) < 0.5 * threshold
        if not pending:
            self._mass_since = None
            return None
        if self._mass_since is None:
            self._mass_since = time_s
        if time_s - self._mass_since < self.config.mass_persistence_s - 1e-9 or not settled:
            return None
        self._mass_since = None
        self._mass_reported = not self._mass_reported
        return DetectionRecord(time_s=time_s, action="detected" if self._mass_reported
                               else "cleared", kind="mass_change", magnitude=dm)

    # ------------------------------------------------------------------ observation
    @property
    def evidence(self) -> MotorEvidence:
        """The latest per-motor LOE, mass change, declarations and measured excitation."""
        return MotorEvidence(self._loe.copy(), self.mass_change_kg, self._active,
                             self._lost_motors, np.sqrt(self._var))

    @property
    def loe(self) -> np.ndarray:
        """The latest per-motor LOE, (4,), common mode removed, 0..1 (a new array every
        tick: read it, do not modify it)."""
        return self._loe

    @property
    def mass_change_kg(self) -> float:
        """The latest mass change estimate, kg, + heavier."""
        return self._state.item(MASS_KG)

    @property
    def active(self) -> tuple[int, ...]:
        """Motors (1..4) currently declared faulty."""
        return self._active

    @property
    def declared_flags(self) -> tuple[bool, bool, bool, bool]:
        """Motors 1..4 currently declared faulty, one flag each."""
        return self._declared_flags

    @property
    def suspected(self) -> int | None:
        """The motor (1..4) suspected now and not yet declared (LOE above the threshold and
        GLR above the significance, persistence running), if any."""
        return None if self._suspect is None else self._suspect + 1

    @property
    def lost(self) -> tuple[int, ...]:
        """Motors (1..4) currently declared lost."""
        return self._lost_motors
