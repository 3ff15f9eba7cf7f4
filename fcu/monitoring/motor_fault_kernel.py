"""The motor fault detector's tick, compiled: its workspace layout, the weighted fit of the
fault signatures and :func:`detector_tick` (the arithmetic of
:class:`fcu.monitoring.motor_faults.MotorFaultDetector`, whose module docstring gives the
method: the common mode, the GLR over the signatures, the measured excitation, the mass
change's spread and settling).

The detector keeps its floats in one array (slices ``W_*``: the low-passed PWM, the measured
excitation, its floor, the scalar state, the settings at indices ``P_*``) and its integers
in another (indices ``I_*``: the mass history's ring buffer, the declared motors).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from jitsupport.calls import KernelCall

# fault signatures in (roll, pitch, yaw) deficit, normalised (module docstring)
SIGNATURES = np.array([[0.0, 0.0, -1.0, 1.0],
                       [-1.0, 1.0, 0.0, 0.0],
                       [-1.0, -1.0, 1.0, 1.0]])
_PWM_FILTER_S = 0.2  # s, time constant of the PWM low-pass
_ATTACK_S = 2.0  # s, time constant of the noise estimate's rise


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
W_U = slice(0, 4)
W_VAR = slice(4, 7)
W_FLOOR = slice(7, 10)
W_STATE = slice(10, 16)
W_PARAMS = slice(16, 27)
W_SIZE = 27
# the scalar state (indices into the W_STATE view)
_E = 0  # PWM, common-mode thrust deficit per motor, e
MASS_KG = 1  # kg, mass change dm = 4 K e / g
_N_LEARNED = 2  # ticks of excitation learned
MASS_VAR = 3  # kg^2, measured spread of the common mode, s_m^2
_MASS_N = 4  # ticks of that spread learned
_HALF = 5  # 1 while a motor is half suspected (the latest tick that looked)
_STATE_SIZE = 6
# the settings (indices into the W_PARAMS view)
P_DT, P_U_HOVER, P_K, P_G, P_COMMON_TAU, P_NOISE_TAU, P_THRESHOLD, P_SIGNIFICANCE, \
    P_MASS_THRESHOLD, P_MASS_SIGMAS, P_MASS_SETTLE = range(11)
# the detector's integer workspace (MotorFaultDetector._iwork): the mass history's ring
# buffer (first slot, count), the number k of declared motors, then the declared motors
# (0..3, in declaration order) and room for one candidate after them
_I_FIRST, _I_COUNT, I_DECLARED, I_MOTORS = 0, 1, 2, 3
I_SIZE = 8
_FIT_SCRATCH = 41  # floats _fit_into works in
# the kernel's own scratch: _fit_into's, then the fits f0 and f, deficit and d
_S_F0, _S_F, _S_DEFICIT, _S_D, _S_SIZE = 41, 45, 49, 53, 56
MASS_WINDOW_S = 0.5  # s, over which the mass estimate must have settled
MASS_VAR_FLOOR = 0.01 ** 2  # kg^2, the least spread of the common mode (10 g)


@njit(cache=True, error_model="numpy")
def detector_tick(time_s: float, gamma: np.ndarray, pwm: np.ndarray, work: np.ndarray,
                  iwork: np.ndarray, history: np.ndarray, isolate: bool, evidence: bool,
                  learn: bool, settling: bool, mass_reported: bool, loe: np.ndarray
                  ) -> tuple[int, float, float, bool, float]:
    """The detector's arithmetic for one tick (module docstring, steps 1 and 2 and the mass
    change's spread and settling), compiled; the decisions stay with the caller.

    Updates in place, in the float workspace ``work`` (``W_*``), the low-passed PWM ``u``,
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
    u = work[W_U]
    var = work[W_VAR]
    floor_var = work[W_FLOOR]
    state = work[W_STATE]
    params = work[W_PARAMS]
    motors = iwork[I_MOTORS:]
    k = iwork[I_DECLARED]
    scratch = np.empty(_S_SIZE)
    fit_work = scratch[:_FIT_SCRATCH]
    f0 = scratch[_S_F0:_S_F]
    f = scratch[_S_F:_S_DEFICIT]
    deficit = scratch[_S_DEFICIT:_S_D]
    d = scratch[_S_D:_S_SIZE]
    dt = params[P_DT]
    u_hover = params[P_U_HOVER]
    threshold = params[P_THRESHOLD]
    significance = params[P_SIGNIFICANCE]
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
        state[_E] += min(1.0, dt / params[P_COMMON_TAU]) * (raw - state[_E])
    e = state[_E]
    state[MASS_KG] = 4.0 * params[P_K] * e / params[P_G]  # dm = 4 K e / g
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
        down = max(dt / params[P_NOISE_TAU], 1.0 / state[_N_LEARNED])
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
    dm = state[MASS_KG]
    mass_threshold = max(params[P_MASS_THRESHOLD],
                         params[P_MASS_SIGMAS] * math.sqrt(state[MASS_VAR]))
    settled = False
    capacity = history.shape[1]
    if not evidence:
        iwork[_I_COUNT] = 0
    else:
        if not mass_reported and abs(dm) < params[P_MASS_THRESHOLD] and not half:
            state[_MASS_N] += 1.0
            sq_m = dm * dm
            rate_m = max(dt / (_ATTACK_S if sq_m > state[MASS_VAR] else params[P_NOISE_TAU]),
                         1.0 / state[_MASS_N])
            state[MASS_VAR] = max(state[MASS_VAR] + rate_m * (sq_m - state[MASS_VAR]),
                                   MASS_VAR_FLOOR)
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
                history[0, iwork[_I_FIRST]] < time_s - MASS_WINDOW_S - 1e-9:
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
            settled = (history[0, last] - history[0, first] >= MASS_WINDOW_S - 1e-9
                       and high - low <= params[P_MASS_SETTLE])
    return best, best_t, best_loe, settled, mass_threshold


# (its arguments: the TSKF's gamma and the PWM, float64 (4,); the detector's buffers)
detector_tick_call = KernelCall(detector_tick)
