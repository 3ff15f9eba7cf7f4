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
from flightdata.kernel_calls import KernelCall
from flightdata.records import DetectionRecord

# fault signatures in (roll, pitch, yaw) deficit, normalised (module docstring)
SIGNATURES = np.array([[0.0, 0.0, -1.0, 1.0],
                       [-1.0, 1.0, 0.0, 0.0],
                       [-1.0, -1.0, 1.0, 1.0]])
_PWM_FILTER_S = 0.2  # s, time constant of the PWM low-pass


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


@njit(cache=True, error_model="numpy")
def _fit_into(d: np.ndarray, var: np.ndarray, motors: np.ndarray, k: int,
              scratch: np.ndarray, f: np.ndarray) -> float:
    """:func:`weighted_fit` over the first ``k`` of ``motors`` without allocating: ``f[:k]``
    receives the fit, ``scratch`` (at least 41 floats) the intermediate products; returns
    the weighted residual sum of squares."""
    # scratch: w 0:3, b 3:6, A (3 x k, row stride 4) 6:18, [A' A | A' b] (k x k+1,
    # row stride 5) 18:38
    for i in range(3):
        scratch[i] = 1.0 / math.sqrt(var[i])  # w = Sigma^-1/2
        scratch[3 + i] = d[i] * scratch[i]  # b = Sigma^-1/2 d
        for j in range(k):
            scratch[6 + 4 * i + j] = SIGNATURES[i, motors[j]] * scratch[i]  # A = Sigma^-1/2 M_S
    # augmented normal equations [A' A | A' b]
    for p in range(k):
        for q in range(k):
            scratch[18 + 5 * p + q] = (scratch[6 + p] * scratch[6 + q]
                                       + scratch[10 + p] * scratch[10 + q]
                                       + scratch[14 + p] * scratch[14 + q])
        scratch[18 + 5 * p + k] = (scratch[6 + p] * scratch[3] + scratch[10 + p] * scratch[4]
                                   + scratch[14 + p] * scratch[5])
    for c in range(k):  # elimination, the largest pivot of column c first
        pivot = c
        for r in range(c + 1, k):
            if abs(scratch[18 + 5 * r + c]) > abs(scratch[18 + 5 * pivot + c]):
                pivot = r
        if pivot != c:
            for q in range(k + 1):
                scratch[18 + 5 * c + q], scratch[18 + 5 * pivot + q] = \
                    scratch[18 + 5 * pivot + q], scratch[18 + 5 * c + q]
        for r in range(c + 1, k):
            factor = scratch[18 + 5 * r + c] / scratch[18 + 5 * c + c]
            for q in range(c, k + 1):
                scratch[18 + 5 * r + q] -= factor * scratch[18 + 5 * c + q]
    for c in range(k - 1, -1, -1):  # back substitution
        acc = scratch[18 + 5 * c + k]
        for q in range(c + 1, k):
            acc -= scratch[18 + 5 * c + q] * f[q]
        f[c] = acc / scratch[18 + 5 * c + c]
    rss = 0.0  # |b - A f|^2
    for i in range(3):
        r_i = scratch[3 + i]
        for j in range(k):
            r_i -= scratch[6 + 4 * i + j] * f[j]
        rss += r_i * r_i
    return rss


@njit(cache=True, error_model="numpy")
def weighted_fit(d: np.ndarray, var: np.ndarray, motors: np.ndarray
                 ) -> tuple[np.ndarray, float]:
    """``f = argmin (d - M_S f)' Sigma^-1 (d - M_S f)`` over the signatures of ``motors``
    (indices 0..3, at most 3 of them) and its weighted residual sum of squares.

    With ``A = Sigma^-1/2 M_S`` and ``b = Sigma^-1/2 d``: the normal equations
    ``(A' A) f = A' b`` (the signatures of distinct motors are independent), solved by
    Gaussian elimination with partial pivoting; ``RSS = |b - A f|^2``. Written out in loops
    (:func:`_fit_into`, which the detector's tick calls on its own workspace): at most 3
    unknowns, where a BLAS or LAPACK call costs more than the arithmetic.
    """
    k = motors.shape[0]
    f = np.empty(k)
    rss = _fit_into(d, var, motors, k, np.empty(_FIT_SCRATCH), f)
    return f, rss


# the detector's float workspace, one array (MotorFaultDetector._work): views of it are the
# low-passed PWM u, the measured excitation Sigma (diagonal), its floor, the scalar state and
# the settings the kernel reads
_W_U = slice(0, 4)
_W_VAR = slice(4, 7)
_W_FLOOR = slice(7, 10)
_W_STATE = slice(10, 16)
_W_PARAMS = slice(16, 27)
_W_SIZE = 27
# the scalar state (indices into the _W_STATE view)
_E = 0  # PWM, common-mode thrust deficit per motor, e
_MASS_KG = 1  # kg, mass change dm = 4 K e / g
_N_LEARNED = 2  # ticks of excitation learned
_MASS_VAR = 3  # kg^2, measured spread of the common mode, s_m^2
_MASS_N = 4  # ticks of that spread learned
_HALF = 5  # 1 while a motor is half suspected (the latest tick that looked)
_STATE_SIZE = 6
# the settings (indices into the _W_PARAMS view)
_DT, _U_HOVER, _K, _G, _COMMON_TAU, _NOISE_TAU, _THRESHOLD, _SIGNIFICANCE, _MASS_THRESHOLD, \
    _MASS_SIGMAS, _MASS_SETTLE = range(11)
# the detector's integer workspace (MotorFaultDetector._iwork): the mass history's ring
# buffer (first slot, count), the number k of declared motors, then the declared motors
# (0..3, in declaration order) and room for one candidate after them
_I_FIRST, _I_COUNT, _I_DECLARED, _I_MOTORS = 0, 1, 2, 3
_I_SIZE = 8
_FIT_SCRATCH = 41  # floats _fit_into works in
# the kernel's own scratch: _fit_into's, then the fits f0 and f, deficit and d
_S_F0, _S_F, _S_DEFICIT, _S_D, _S_SIZE = 41, 45, 49, 53, 56
_MASS_WINDOW_S = 0.5  # s, over which the mass estimate must have settled
_MASS_VAR_FLOOR = 0.01 ** 2  # kg^2, the least spread of the common mode (10 g)


@njit(cache=True, error_model="numpy")
def _detector_tick(time_s: float, gamma: np.ndarray, pwm: np.ndarray, work: np.ndarray,
                   iwork: np.ndarray, history: np.ndarray, isolate: bool, evidence: bool,
                   learn: bool, settling: bool, mass_reported: bool, loe: np.ndarray
                   ) -> tuple[int, float, float, bool, float]:
    """The detector's arithmetic for one tick (module docstring, steps 1 and 2 and the mass
    change's spread and settling), compiled; the decisions stay with the caller.

    Updates in place, in the float workspace ``work`` (``_W_*``), the low-passed PWM ``u``,
    the measured excitation ``var`` (Sigma's diagonal) and the scalar state (``_E``...),
    and the mass history ``history`` (rows time s, dm kg; a ring buffer whose first slot
    and count are in ``iwork``). ``iwork`` holds the declared motors (0..3) in declaration
    order; ``isolate`` is False once a motor is lost or three are declared (a fourth is not
    identifiable). Writes the per-motor LOE ``delta`` into ``loe`` (an array returned to
    Python would cost more than the tick's arithmetic). One allocation: the scratch.

    Returns the strongest suspected motor (0..3, -1 for none) with its GLR statistic T and
    LOE, whether the mass estimate has settled and the mass threshold
    ``max(mass_threshold_kg, mass_sigmas s_m)`` (before this tick's spread update).
    """
    u = work[_W_U]
    var = work[_W_VAR]
    floor_var = work[_W_FLOOR]
    state = work[_W_STATE]
    params = work[_W_PARAMS]
    motors = iwork[_I_MOTORS:]
    k = iwork[_I_DECLARED]
    scratch = np.empty(_S_SIZE)
    fit_work = scratch[:_FIT_SCRATCH]
    f0 = scratch[_S_F0:_S_F]
    f = scratch[_S_F:_S_DEFICIT]
    deficit = scratch[_S_DEFICIT:_S_D]
    d = scratch[_S_D:_S_SIZE]
    dt = params[_DT]
    u_hover = params[_U_HOVER]
    threshold = params[_THRESHOLD]
    significance = params[_SIGNIFICANCE]
    # u: PWM low-passed over _PWM_FILTER_S, u = u + a (max(pwm, 1e-4) - u)
    a = min(1.0, dt / _PWM_FILTER_S)
    for j in range(4):
        p = pwm[j]
        u[j] = u[j] + a * ((p if p > 1e-4 or p != p else 1e-4) - u[j])
    # gamma_i u_i, PWM units; d = M a with a_i = gamma_i u_i / u_h: no common mode
    for j in range(4):
        deficit[j] = gamma[j] * u[j]
    for i in range(3):
        acc = 0.0
        for j in range(4):
            acc += SIGNATURES[i, j] * (deficit[j] / u_hover)
        d[i] = acc
    is_declared = 0  # bit j: motor j declared
    for i in range(k):
        is_declared |= 1 << motors[i]

    # step 2: GLR of one more fault on each motor j, T_j = RSS(declared) - RSS(declared + j)
    best, best_t, best_loe = -1, 0.0, 0.0
    half_now = False
    fitted = False
    if evidence or learn:
        if isolate:
            rss0 = _fit_into(d, var, motors, k, fit_work, f0)
            fitted = True
            for j in range(4):
                if is_declared & (1 << j):
                    continue
                motors[k] = j  # the candidate after the declared ones
                rss = _fit_into(d, var, motors, k + 1, fit_work, f)
                loe_j = f[k] * u_hover / u[j]  # LOE_j = f_j u_h / u_j
                t = rss0 - rss
                if loe_j > 0.5 * threshold and t > 0.25 * significance:
                    half_now = True
                if loe_j > threshold and t > significance and (best < 0 or t > best_t):
                    best, best_t, best_loe = j, t, loe_j
        state[_HALF] = 1.0 if half_now else 0.0
    half = state[_HALF] != 0.0

    # step 1: e = mean of gamma_j u_j over the motors not declared (the smallest when all
    # are), low-passed over common_tau_s, held while a motor is half suspected
    if not half:
        n = 0
        total = 0.0
        for j in range(4):
            if not is_declared & (1 << j):
                total += deficit[j]
                n += 1
        if n > 0:
            raw = total / n
        else:
            raw = deficit[0]
            for j in range(1, 4):
                if deficit[j] < raw or deficit[j] != deficit[j]:
                    raw = deficit[j]
        state[_E] += min(1.0, dt / params[_COMMON_TAU]) * (raw - state[_E])
    e = state[_E]
    state[_MASS_KG] = 4.0 * params[_K] * e / params[_G]  # dm = 4 K e / g
    for j in range(4):  # delta_i = gamma_i - e / u_i, clipped to [0, 1]
        x = deficit[j] / u[j] - e / u[j]
        loe[j] = x if x != x else min(max(x, 0.0), 1.0)

    # measured excitation: Sigma from the residual of d after the declared faults, fast
    # attack _ATTACK_S, slow decay noise_tau_s, unbiased while young, floored
    if not half_now and learn and not settling:
        if not fitted:
            _fit_into(d, var, motors, k, fit_work, f0)
        state[_N_LEARNED] += 1.0
        up = max(dt / _ATTACK_S, 1.0 / state[_N_LEARNED])
        down = max(dt / params[_NOISE_TAU], 1.0 / state[_N_LEARNED])
        for i in range(3):
            res = d[i]  # d - M_declared f
            for j in range(k):
                res -= SIGNATURES[i, motors[j]] * f0[j]
            sq = res * res
            rate = up if sq > var[i] else down
            v = var[i] + rate * (sq - var[i])
            var[i] = v if v > floor_var[i] or v != v else floor_var[i]

    # the mass change's threshold max(mass_threshold_kg, mass_sigmas s_m), its spread s_m
    # (learned while nothing is reported, |dm| < mass_threshold_kg and nothing is half
    # suspected) and whether dm has settled (within mass_settle_kg over the last 0.5 s)
    dm = state[_MASS_KG]
    mass_threshold = max(params[_MASS_THRESHOLD],
                         params[_MASS_SIGMAS] * math.sqrt(state[_MASS_VAR]))
    settled = False
    capacity = history.shape[1]
    if not evidence:
        iwork[_I_COUNT] = 0
    else:
        if not mass_reported and abs(dm) < params[_MASS_THRESHOLD] and not half:
            state[_MASS_N] += 1.0
            sq_m = dm * dm
            rate_m = max(dt / (_ATTACK_S if sq_m > state[_MASS_VAR] else params[_NOISE_TAU]),
                         1.0 / state[_MASS_N])
            state[_MASS_VAR] = max(state[_MASS_VAR] + rate_m * (sq_m - state[_MASS_VAR]),
                                   _MASS_VAR_FLOOR)
        if half:  # the common mode is held: no news about the mass
            iwork[_I_COUNT] = 0
        else:
            if iwork[_I_COUNT] == capacity:  # ticks faster than the capacity allows: forget
                iwork[_I_FIRST] = (iwork[_I_FIRST] + 1) % capacity  # the oldest
                iwork[_I_COUNT] -= 1
            slot = (iwork[_I_FIRST] + iwork[_I_COUNT]) % capacity
            history[0, slot] = time_s
            history[1, slot] = dm
            iwork[_I_COUNT] += 1
        while iwork[_I_COUNT] > 0 and \
                history[0, iwork[_I_FIRST]] < time_s - _MASS_WINDOW_S - 1e-9:
            iwork[_I_FIRST] = (iwork[_I_FIRST] + 1) % capacity
            iwork[_I_COUNT] -= 1
        count = iwork[_I_COUNT]
        if count > 1:
            first = iwork[_I_FIRST]
            last = (first + count - 1) % capacity
            low = high = history[1, first]
            for i in range(1, count):
                v = history[1, (first + i) % capacity]
                low = min(low, v)
                high = max(high, v)
            settled = (history[0, last] - history[0, first] >= _MASS_WINDOW_S - 1e-9
                       and high - low <= params[_MASS_SETTLE])
    return best, best_t, best_loe, settled, mass_threshold


# (its arguments: the TSKF's gamma and the PWM, float64 (4,); the detector's buffers)
_detector_tick_call = KernelCall(_detector_tick)


class MotorFaultDetector:
    """Motor fault detection, isolation and the mass change (module docstring).

    The arithmetic of a tick is one compiled call (:func:`_detector_tick`); the decisions
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
        # the kernel's workspaces (_W_*, _I_*); the attributes below are views of them
        self._work = np.zeros(_W_SIZE)
        self._iwork = np.zeros(_I_SIZE, dtype=np.int64)
        self._u = self._work[_W_U]
        self._var = self._work[_W_VAR]
        self._floor_var = self._work[_W_FLOOR]
        self._state = self._work[_W_STATE]
        self._params = self._work[_W_PARAMS]
        self._floor_var[:] = np.square(np.array(config.noise_floor, dtype=float))
        self._calm_var = _CALM_RATIO**2 * self._floor_var
        self._params[[_DT, _U_HOVER, _K, _G, _COMMON_TAU, _NOISE_TAU, _THRESHOLD,
                      _SIGNIFICANCE, _MASS_THRESHOLD, _MASS_SIGMAS, _MASS_SETTLE]] = (
            self.dt_s, model.hover_pwm, model.thrust_gain, model.gravity, config.common_tau_s,
            config.noise_tau_s, config.threshold, config.significance,
            config.mass_threshold_kg, config.mass_sigmas, config.mass_settle_kg)
        # the mass history holds 0.5 s of ticks; room for ticks up to 4 times faster
        self._history = np.zeros((2, 4 * math.ceil(_MASS_WINDOW_S / self.dt_s) + 8))
        self.reset()

    def reset(self) -> None:
        """Forget every fault, the learned excitation and the timers."""
        self._var[:] = self._floor_var
        self._u[:] = self._u_hover
        self._state[:] = 0.0
        self._state[_MASS_VAR] = _MASS_VAR_FLOOR
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
        self._iwork[_I_DECLARED] = k
        self._iwork[_I_MOTORS:_I_MOTORS + k] = self._declared
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
        best, t, loe, settled, mass_threshold = _detector_tick_call.call(
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
        dm = self._state.item(_MASS_KG)
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
        return self._state.item(_MASS_KG)

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
