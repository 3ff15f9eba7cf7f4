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
from numba import njit

from fcu.model import VehicleModel
from flightdata.config import finite, require
from flightdata.records import DetectionRecord

# fault signatures in (roll, pitch, yaw) deficit, normalised (module docstring)
SIGNATURES = np.array([[0.0, 0.0, -1.0, 1.0],
                       [-1.0, 1.0, 0.0, 0.0],
                       [-1.0, -1.0, 1.0, 1.0]])
_PWM_FILTER_S = 0.2  # s, time constant of the PWM low-pass


@njit(cache=True, error_model="numpy")
def weighted_fit(d: np.ndarray, var: np.ndarray, motors: np.ndarray
                 ) -> tuple[np.ndarray, float]:
    """``f = argmin (d - M_S f)' Sigma^-1 (d - M_S f)`` over the signatures of ``motors``
    (indices 0..3, at most 3 of them) and its weighted residual sum of squares."""
    w = 1.0 / np.sqrt(var)
    b = d * w
    k = motors.shape[0]
    if k == 0:
        return np.zeros(0), float(b @ b)
    a = np.empty((3, k))
    for i in range(3):
        for j in range(k):
            a[i, j] = SIGNATURES[i, motors[j]] * w[i]
    # normal equations (A' A) f = A' b: the signatures of distinct motors are independent
    f = np.linalg.solve(a.T @ a, a.T @ b)
    r = b - a @ f
    return f, float(r @ r)
_CALM_RATIO = 2.0  # measured excitation within this many times its floor: calm air
_ATTACK_S = 2.0  # s, time constant of the noise estimate's rise


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
        self._k = model.thrust_gain
        self._g = model.gravity
        self._u_hover = model.hover_pwm
        self._floor_var = np.square(np.array(config.noise_floor, dtype=float))
        self.reset()

    def reset(self) -> None:
        """Forget every fault, the learned excitation and the timers."""
        self._var = self._floor_var.copy()
        self._n_learned = 0
        self._u = np.full(4, self._u_hover)
        self._declared: list[int] = []  # motor indices 0..3, in declaration order
        self._lost: set[int] = set()
        self._suspect: int | None = None
        self._suspect_since = 0.0
        self._half: set[int] = set()  # motors half suspected at the latest tick
        self._last_declared_s = -math.inf
        self._recover_since: dict[int, float] = {}
        self._lost_since: dict[int, float] = {}
        self._mass_reported = False
        self._mass_since: float | None = None
        self._mass_history: list[tuple[float, float]] = []  # (time s, kg) over the last 0.5 s
        self._mass_var = 0.01 ** 2  # kg^2, measured spread of the common mode (floor 10 g)
        self._mass_n = 0
        self._loe = np.zeros(4)
        self._mass_kg = 0.0
        self._e = 0.0  # PWM, common-mode thrust deficit per motor

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
        a = min(1.0, self.dt_s / _PWM_FILTER_S)
        self._u = self._u + a * (np.maximum(np.asarray(pwm, dtype=float), 1e-4) - self._u)
        u = self._u
        g = np.asarray(gamma, dtype=float)
        deficit = g * u  # PWM units
        d = SIGNATURES @ (deficit / self._u_hover)  # mass-invariant: no common mode
        records: list[DetectionRecord] = []
        best, half_suspected = self._candidates(d, u) if (evidence or learn) else (None, False)
        self._update_common_mode(deficit, u)
        settling = time_s - self._last_declared_s < self.config.settle_s
        if not half_suspected and learn and not settling:
            self._learn(d)
        if best is not None and not evidence:
            best = None
        if not evidence:
            self._suspect = None
            self._recover_since.clear()
            self._mass_since = None
            self._mass_history.clear()
            return records
        records += self._declare(time_s, best)
        records += self._track_declared(time_s)
        records += self._track_mass(time_s)
        return records

    def _update_common_mode(self, deficit: np.ndarray, u: np.ndarray) -> None:
        if not self._half:
            others = [j for j in range(4) if j not in self._declared]
            raw = float(np.mean(deficit[others])) if others else float(np.min(deficit))
            self._e += min(1.0, self.dt_s / self.config.common_tau_s) * (raw - self._e)
        e = self._e
        self._mass_kg = 4.0 * self._k * e / self._g
        self._loe = np.clip(deficit / u - e / u, 0.0, 1.0)

    def _fit(self, d: np.ndarray, motors: list[int]) -> tuple[np.ndarray, float]:
        """Weighted least squares of ``d`` on the signatures of ``motors``: (f, RSS)."""
        return weighted_fit(d, self._var, np.array(motors, dtype=np.int64))

    def _candidates(self, d: np.ndarray, u: np.ndarray
                    ) -> tuple[tuple[int, float, float] | None, bool]:
        """(motor index, T, LOE) of the strongest suspected fault (or None), and whether any
        motor is half suspected (module docstring)."""
        if self._lost or len(self._declared) >= 3:  # a fourth is not identifiable
            self._half = set()
            return None, False
        cfg = self.config
        _, rss0 = self._fit(d, self._declared)
        best: tuple[int, float, float] | None = None
        self._half = set()
        for j in range(4):
            if j in self._declared:
                continue
            f, rss = self._fit(d, [*self._declared, j])
            loe = float(f[-1]) * self._u_hover / u[j]
            t = rss0 - rss
            if loe > 0.5 * cfg.threshold and t > 0.25 * cfg.significance:
                self._half.add(j)
            if loe > cfg.threshold and t > cfg.significance and (best is None or t > best[1]):
                best = (j, t, loe)
        return best, bool(self._half)

    def _learn(self, d: np.ndarray) -> None:
        """Measured excitation: fast attack, slow decay, unbiased while young."""
        f, _ = self._fit(d, self._declared)
        res = d - (SIGNATURES[:, self._declared] @ f if self._declared else 0.0)
        self._n_learned += 1
        sq = res * res
        up = max(self.dt_s / _ATTACK_S, 1.0 / self._n_learned)
        down = max(self.dt_s / self.config.noise_tau_s, 1.0 / self._n_learned)
        rate = np.where(sq > self._var, up, down)
        self._var = np.maximum(self._var + rate * (sq - self._var), self._floor_var)

    def _declare(self, time_s: float,
                 best: tuple[int, float, float] | None) -> list[DetectionRecord]:
        cfg = self.config
        if best is None or time_s - self._last_declared_s < cfg.settle_s:
            self._suspect = None
            return []
        j, t, loe = best
        if self._suspect != j:
            self._suspect, self._suspect_since = j, time_s
        calm = bool(np.all(self._var <= _CALM_RATIO**2 * self._floor_var))
        need = declaration_delay_s(cfg, loe, t, calm)
        if time_s - self._suspect_since < need - 1e-9:
            return []
        self._suspect = None
        self._declared.append(j)
        self._last_declared_s = time_s
        kind = "motor_lost" if loe > cfg.lost_threshold else "loe"
        if kind == "motor_lost":
            self._lost.add(j)
        return [DetectionRecord(time_s=time_s, action="detected", kind=kind, motor=j + 1,
                                magnitude=min(1.0, loe))]

    def _track_declared(self, time_s: float) -> list[DetectionRecord]:
        """Upgrade declared motors to lost, clear recovered ones."""
        cfg = self.config
        out: list[DetectionRecord] = []
        for j in list(self._declared):
            loe = float(self._loe[j])
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
        return out

    def _track_mass(self, time_s: float) -> list[DetectionRecord]:
        cfg = self.config
        dm = self._mass_kg
        threshold = max(cfg.mass_threshold_kg, cfg.mass_sigmas * math.sqrt(self._mass_var))
        if not self._mass_reported and abs(dm) < cfg.mass_threshold_kg and not self._half:
            self._mass_n += 1
            sq = dm * dm
            rate = max(self.dt_s / (_ATTACK_S if sq > self._mass_var else cfg.noise_tau_s),
                       1.0 / self._mass_n)
            self._mass_var = max(self._mass_var + rate * (sq - self._mass_var), 0.01 ** 2)
        history = self._mass_history
        if self._half:  # the common mode is held: no news about the mass
            history.clear()
        else:
            history.append((time_s, dm))
        while history and history[0][0] < time_s - 0.5 - 1e-9:
            history.pop(0)
        values = [v for _, v in history]
        settled = (len(history) > 1 and history[-1][0] - history[0][0] >= 0.5 - 1e-9
                   and max(values) - min(values) <= cfg.mass_settle_kg)
        limit = threshold if not self._mass_reported else 0.5 * threshold
        pending = abs(dm) > limit if not self._mass_reported else abs(dm) < limit
        if not pending:
            self._mass_since = None
            return []
        if self._mass_since is None:
            self._mass_since = time_s
        if time_s - self._mass_since < cfg.mass_persistence_s - 1e-9 or not settled:
            return []
        self._mass_since = None
        self._mass_reported = not self._mass_reported
        return [DetectionRecord(time_s=time_s, action="detected" if self._mass_reported
                                else "cleared", kind="mass_change", magnitude=dm)]

    # ------------------------------------------------------------------ observation
    @property
    def evidence(self) -> MotorEvidence:
        """The latest per-motor LOE, mass change, declarations and measured excitation."""
        return MotorEvidence(self._loe.copy(), self._mass_kg,
                             tuple(sorted(j + 1 for j in self._declared)),
                             tuple(sorted(j + 1 for j in self._lost)),
                             np.sqrt(self._var))

    @property
    def active(self) -> tuple[int, ...]:
        """Motors (1..4) currently declared faulty."""
        return tuple(sorted(j + 1 for j in self._declared))

    @property
    def suspected(self) -> int | None:
        """The motor (1..4) suspected now and not yet declared (LOE above the threshold and
        GLR above the significance, persistence running), if any."""
        return None if self._suspect is None else self._suspect + 1

    @property
    def lost(self) -> tuple[int, ...]:
        """Motors (1..4) currently declared lost."""
        return tuple(sorted(j + 1 for j in self._lost))
