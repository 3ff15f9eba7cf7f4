"""The wrench-residual watch's tick, compiled: its state and parameter layouts and
:func:`watch_tick`, the arithmetic of :class:`fcu.monitoring.rotor_watch.RotorWatch` (whose
module docstring gives the method: the expected and measured wrench, the single-motor fit,
the measured noise and the collective bias) and the picks of its two other tests (a pair of
motors lost together, a motor stuck where it was). The watch's decisions (persistence, kind,
records) stay in Python.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from fcu.model import VehicleModel
from jitsupport.layout import Layout

if TYPE_CHECKING:
    from fcu.monitoring.rotor_watch import RotorWatchConfig

STATE = Layout("rotor watch state")
S_THRUST = STATE.field("thrust_n", 4)  # N, expected thrusts T_e at the end of the tick
S_START = STATE.field("start_thrust_n", 4)  # N, T_e at the tick's start (the residual's)
S_GYRO = STATE.field("prev_gyro", 3)  # rad/s, the previous tick's mean gyro
S_ACCEL = STATE.field("prev_accel", 3)  # m/s^2, its mean specific force, body FRD
S_HAVE_PREV = STATE.field("have_prev", 1)  # 1 when the previous tick had both readings
S_BIAS = STATE.field("bias_n", 1)  # N, the collective bias mu
S_VAR = STATE.field("var", 4)  # measured noise variance: collective N^2, torques (N*m)^2
S_DEFICIT = STATE.field("deficit_n", 4)  # N, the latest single-motor fit f_j per motor
S_STAT = STATE.field("statistic", 1)  # the latest best T_j
# two motors lost together, each pair of PAIRS: the fit of their summed columns (a deficit of
# each, N) and its statistic, and whether it explains the residual
PAIRS = ((0, 1), (2, 3), (0, 2), (0, 3), (1, 2), (1, 3))  # the opposite pairs first
S_PAIR_DEFICIT = STATE.field("pair_deficit_n", len(PAIRS))
S_PAIR_STAT = STATE.field("pair_statistic", len(PAIRS))
S_PAIR_CONSISTENT = STATE.field("pair_consistent", len(PAIRS))  # 1: T_pair > consistency RSS
# the statistic of the collective alone, res_0^2 / Sigma_0: what a change of mass or of the
# axial drag explains (a pair's statistic must carry more, its torque, to be a pair)
S_COLLECTIVE_STAT = STATE.field("collective_statistic", 1)
# per motor, the thrust its command asks for (K u through the lag, at full effectiveness)
# and how far its own thrust (T_e - f_j) falls short of that, low-passed over
# follow_split_s (their slow parts: what the controller's compensation of a fault does),
# then exponentially weighted moments of the fast parts (what the motor's own thrust does
# when its command moves: a stuck motor's deficit follows its command one for one): variance
# of the command's, covariance, variance of the deficit's
S_CMD = STATE.field("command_thrust_n", 4)  # N, K u through the lag, at full effectiveness
S_CMD_START = STATE.field("start_command_thrust_n", 4)  # N, the same at the tick's start
S_SLOW = STATE.field("follow_slow", 8)  # N: slow K u, slow shortfall, motor by motor
S_FOLLOW = STATE.field("follow_moments", 12)
STATE_SIZE = STATE.size

PARAMS = Layout("rotor watch parameters")
P_K = PARAMS.field("thrust_gain", 1)  # N per unit PWM
P_PWM_MAX = PARAMS.field("pwm_max", 1)
P_MASS = PARAMS.field("mass", 1)  # kg
P_LAG = PARAMS.field("lag", 1)  # exp(-w dt), the motor lag over a tick
P_DT = PARAMS.field("dt_s", 1)  # s
P_INERTIA = PARAMS.field("inertia", 3)  # kg*m^2
P_DAMPING = PARAMS.field("rate_damping", 3)  # N*m per rad/s
P_CP_Z = PARAMS.field("cp_offset_z", 1)  # m, body z of the centre of pressure (FRD)
P_COLUMNS = PARAMS.field("columns", 16)  # b_j, motor by motor: collective, roll, pitch, yaw
P_ATTACK = PARAMS.field("attack", 1)  # noise gain per tick while rising
P_DECAY = PARAMS.field("decay", 1)  # noise gain per tick while falling
P_BIAS_GAIN = PARAMS.field("bias_gain", 1)  # mu's gain per tick
P_FLOOR = PARAMS.field("floor_var", 4)  # the noise floor, variances
P_SIGNIFICANCE = PARAMS.field("significance", 1)
P_MIN_DEFICIT = PARAMS.field("min_deficit", 1)
P_CONSISTENCY = PARAMS.field("consistency", 1)
P_FOLLOW_GAIN = PARAMS.field("follow_gain", 1)  # the moments' gain per tick
P_SPLIT_GAIN = PARAMS.field("split_gain", 1)  # the slow parts' low-pass gain per tick
P_ALARM_DEFICIT = PARAMS.field("alarm_deficit", 1)  # a pair's deficit, of its thrust
P_PAIR_TORQUE = PARAMS.field("pair_torque_significance", 1)  # T_pair - T_collective needed
P_STUCK_CORRELATION = PARAMS.field("stuck_correlation", 1)
P_STUCK_MARGIN = PARAMS.field("stuck_margin", 1)
P_STUCK_SLOPE = PARAMS.field("stuck_slope", 2)  # low, high
P_STUCK_SPREAD_VAR = PARAMS.field("stuck_spread_var", 1)  # N^2, stuck_spread_n squared
PARAMS_SIZE = PARAMS.size

_ATTACK_S = 1.0  # s, time constant of the noise estimate's rise
# of the significance: above this best statistic the noise estimate is frozen (a fault
# building up, a motor locked while its command moves away, is never learned as noise)
NOISE_FREEZE = 0.25


def pack_params(model: VehicleModel, dt_s: float, config: RotorWatchConfig) -> np.ndarray:
    """The parameter vector of :func:`watch_tick` for a watch with ``config`` on a tick of
    ``dt_s`` (s)."""
    par = np.zeros(PARAMS_SIZE)
    par[P_K], par[P_PWM_MAX], par[P_MASS] = model.thrust_gain, model.pwm_max, model.mass
    par[P_LAG] = math.exp(-model.motor_bandwidth * dt_s)
    par[P_DT] = dt_s
    par[P_INERTIA:P_INERTIA + 3] = model.inertia
    par[P_DAMPING:P_DAMPING + 3] = model.rate_damping
    par[P_CP_Z] = model.cp_offset_z
    par[P_COLUMNS:P_COLUMNS + 16] = model.thrust_mixer().T.ravel()  # eq. 3.17
    par[P_ATTACK] = 1.0 - math.exp(-dt_s / _ATTACK_S)
    par[P_DECAY] = 1.0 - math.exp(-dt_s / config.noise_tau_s)
    par[P_BIAS_GAIN] = 1.0 - math.exp(-dt_s / config.bias_tau_s)
    par[P_FLOOR:P_FLOOR + 4] = np.square(config.noise_floor)
    par[P_SIGNIFICANCE], par[P_MIN_DEFICIT] = config.significance, config.min_deficit
    par[P_CONSISTENCY] = config.consistency
    par[P_FOLLOW_GAIN] = 1.0 - math.exp(-dt_s / config.follow_tau_s)
    par[P_SPLIT_GAIN] = 1.0 - math.exp(-dt_s / config.follow_split_s)
    par[P_ALARM_DEFICIT] = config.alarm_deficit
    par[P_PAIR_TORQUE] = config.pair_torque_significance
    par[P_STUCK_CORRELATION], par[P_STUCK_MARGIN] = config.stuck_correlation, \
        config.stuck_margin
    par[P_STUCK_SLOPE:P_STUCK_SLOPE + 2] = config.stuck_slope
    par[P_STUCK_SPREAD_VAR] = config.stuck_spread_n ** 2
    return par


def reset_state(par: np.ndarray, state: np.ndarray) -> None:
    """The boot state: motors at rest, nothing learned, no previous reading."""
    state[:] = 0.0
    state[S_VAR:S_VAR + 4] = par[P_FLOOR:P_FLOOR + 4]


@njit(cache=True, error_model="numpy")
def _follow(state: np.ndarray, j: int, split: float, gain: float, x: float, y: float
            ) -> None:
    """Motor ``j``'s expected thrust ``x`` and deficit ``y`` (N): their slow parts
    low-passed with ``split``, the moments of their fast parts with ``gain``."""
    slow = S_SLOW + 2 * j
    state[slow] += split * (x - state[slow])
    state[slow + 1] += split * (y - state[slow + 1])
    dx = x - state[slow]
    dy = y - state[slow + 1]
    at = S_FOLLOW + 3 * j
    keep = 1.0 - gain
    state[at] = keep * state[at] + gain * dx * dx
    state[at + 1] = keep * state[at + 1] + gain * dx * dy
    state[at + 2] = keep * state[at + 2] + gain * dy * dy


@njit(cache=True, error_model="numpy")
def _pair_pick(par: np.ndarray, state: np.ndarray) -> int:
    """The pair (index into PAIRS; -1: none) whose summed columns explain the latest residual
    better than any one motor and than the other pairs, and by more than
    ``pair_torque_significance`` better than the collective alone (a pair's torque, which a
    change of mass or of the axial drag does not make), with a deficit of at least
    ``alarm_deficit`` of each (:mod:`fcu.monitoring.rotor_watch`, "Two rotors")."""
    found, found_t = -1, 0.0
    collective_t = state[S_COLLECTIVE_STAT]
    for pair in range(len(PAIRS)):
        a, b = PAIRS[pair]
        t = state[S_PAIR_STAT + pair]
        expected = 0.5 * (state[S_START + a] + state[S_START + b])
        beaten = par[P_SIGNIFICANCE]  # the statistic to beat: max(significance, T_j, found)
        if state[S_STAT] > beaten:
            beaten = state[S_STAT]
        if found_t > beaten:
            beaten = found_t
        if (t > beaten and state[S_PAIR_CONSISTENT + pair] > 0.5
                and t - collective_t > par[P_PAIR_TORQUE]
                and state[S_PAIR_DEFICIT + pair] > par[P_ALARM_DEFICIT] * expected):
            found, found_t = pair, t
    return found


@njit(cache=True, error_model="numpy")
def _stuck_pick(par: np.ndarray, state: np.ndarray) -> int:
    """The motor (0..3; -1: none) whose shortfall follows its command at the latest tick
    (:mod:`fcu.monitoring.rotor_watch`, "Stuck motors"): the best correlation of the fast
    parts, above ``stuck_correlation`` and by ``stuck_margin`` above the next motor's, at a
    slope within ``stuck_slope``, the command's fast part spread by ``stuck_spread_n``."""
    j, top, runner_up = -1, -math.inf, -math.inf
    for i in range(4):
        at = S_FOLLOW + 3 * i
        var_x, cov, var_y = state[at], state[at + 1], state[at + 2]
        corr = cov / math.sqrt(var_x * var_y) if var_x > 0.0 and var_y > 0.0 else 0.0
        if corr != corr:  # NaN: no motor passes
            return -1
        if corr > top:
            j, top, runner_up = i, corr, top
        elif corr > runner_up:
            runner_up = corr
    var_x, cov = state[S_FOLLOW + 3 * j], state[S_FOLLOW + 3 * j + 1]
    slope = cov / var_x if var_x > 0.0 else 0.0
    if (top > par[P_STUCK_CORRELATION] and top - runner_up > par[P_STUCK_MARGIN]
            and par[P_STUCK_SLOPE] <= slope <= par[P_STUCK_SLOPE + 1]
            and var_x > par[P_STUCK_SPREAD_VAR]):
        return j
    return -1


@njit(cache=True, error_model="numpy")
def watch_tick(par: np.ndarray, state: np.ndarray, gyro: np.ndarray, accel: np.ndarray,
               have_imu: bool, pwm: np.ndarray, effectiveness: np.ndarray, airborne: bool,
               learn: bool, hold_bias: bool) -> tuple[int, bool, int, int]:
    """One tick (module docstring of :mod:`fcu.monitoring.rotor_watch`): the motor lag
    advanced under ``pwm`` times the known ``effectiveness`` of each motor (shape (4,), 1
    but for the partial losses already declared), then, with this tick's and the previous
    tick's mean readings (``gyro`` rad/s and specific force ``accel`` m/s^2, body FRD,
    shape (3,)) and
    ``airborne``, the residual and the best single-motor fit; the noise and the bias are
    learned when ``learn``: the bias unless ``hold_bias`` (a large fault is building up, or
    a motor is suspected of an excess with its command near its floor),
    the noise while the fit suspects nothing (best statistic under NOISE_FREEZE of the
    significance).

    Returns the best motor (0..3; -1 when no residual was formed), whether it is suspected
    (statistic, deficit and consistency tests), the pair lost together (:func:`_pair_pick`)
    and the stuck motor (:func:`_stuck_pick`), each -1 when none (or no residual).
    """
    k, pwm_max, lag = par[P_K], par[P_PWM_MAX], par[P_LAG]
    for i in range(4):
        u = min(max(pwm[i], 0.0), pwm_max)
        state[S_START + i] = state[S_THRUST + i]
        state[S_THRUST + i] = (lag * state[S_THRUST + i]
                               + (1.0 - lag) * k * u * effectiveness[i])
        state[S_CMD_START + i] = state[S_CMD + i]
        state[S_CMD + i] = lag * state[S_CMD + i] + (1.0 - lag) * k * u
    have_prev = state[S_HAVE_PREV] > 0.5
    state[S_HAVE_PREV] = 1.0 if have_imu else 0.0
    if not have_imu:
        return -1, False, -1, -1
    # the boundary between the two ticks: mean rates and specific force there, and the
    # previous tick's readings replaced by this one's
    dt = par[P_DT]
    w = np.empty(3)
    dw = np.empty(3)
    a = np.empty(3)
    for i in range(3):
        w[i] = 0.5 * (gyro[i] + state[S_GYRO + i])
        dw[i] = (gyro[i] - state[S_GYRO + i]) / dt
        a[i] = 0.5 * (accel[i] + state[S_ACCEL + i])
        state[S_GYRO + i] = gyro[i]
        state[S_ACCEL + i] = accel[i]
    if not (have_prev and airborne):
        return -1, False, -1, -1
    jx, jy, jz = par[P_INERTIA], par[P_INERTIA + 1], par[P_INERTIA + 2]
    p, q, r = w[0], w[1], w[2]
    m, z_cp = par[P_MASS], par[P_CP_Z]
    # the motors' torque: J w' + w x J w + G w (eq. 3.15, rate damping) less the moment of
    # the in-plane drag about the centre of gravity, r_cp x F with F = m a (the thrust
    # has no in-plane part, so the accelerometer's x and y read the drag alone)
    tau_x = jx * dw[0] + (jz - jy) * q * r + par[P_DAMPING] * p + z_cp * m * a[1]
    tau_y = jy * dw[1] + (jx - jz) * p * r + par[P_DAMPING + 1] * q - z_cp * m * a[0]
    tau_z = jz * dw[2] + (jy - jx) * p * q + par[P_DAMPING + 2] * r
    # r = B T_e - w_m - (mu, 0, 0, 0)
    res = np.zeros(4)
    for j in range(4):
        t = state[S_START + j]
        for i in range(4):
            res[i] += par[P_COLUMNS + 4 * j + i] * t
    res[0] += m * a[2] - state[S_BIAS]
    res[1] -= tau_x
    res[2] -= tau_y
    res[3] -= tau_z
    # the best single-motor fit against the measured noise
    rss0 = 0.0
    for i in range(4):
        rss0 += res[i] * res[i] / state[S_VAR + i]
    best, best_t, best_f = 0, -1.0, 0.0
    for j in range(4):
        den = 0.0
        num = 0.0
        for i in range(4):
            b = par[P_COLUMNS + 4 * j + i]
            den += b * b / state[S_VAR + i]
            num += b * res[i] / state[S_VAR + i]
        f = num / den
        state[S_DEFICIT + j] = f
        # what the command asks of the motor against what it falls short of that by its own
        # thrust (T_e - f_u): the effectiveness the allocator reckons with moves neither; f_u
        # is the fit without the collective bias, whose own following of the collective
        # would take part of a stuck motor's shortfall out of the fit (the bias's slow
        # changes, a change of mass or of the axial drag, are left out by the split)
        f_u = (num + par[P_COLUMNS + 4 * j] * state[S_BIAS] / state[S_VAR]) / den
        asked = state[S_CMD_START + j]
        _follow(state, j, par[P_SPLIT_GAIN], par[P_FOLLOW_GAIN], asked,
                asked - (state[S_START + j] - f_u))
        t = f * f * den
        if t > best_t:
            best, best_t, best_f = j, t, f
    state[S_STAT] = best_t
    state[S_COLLECTIVE_STAT] = res[0] * res[0] / state[S_VAR]
    # two motors together: their columns summed (equal deficits)
    for pair in range(len(PAIRS)):
        first, second = PAIRS[pair]
        den = 0.0
        num = 0.0
        for i in range(4):
            b = par[P_COLUMNS + 4 * first + i] + par[P_COLUMNS + 4 * second + i]
            den += b * b / state[S_VAR + i]
            num += b * res[i] / state[S_VAR + i]
        f = num / den
        t = f * f * den
        state[S_PAIR_DEFICIT + pair] = f
        state[S_PAIR_STAT + pair] = t
        state[S_PAIR_CONSISTENT + pair] = 1.0 if t > par[P_CONSISTENCY] * max(rss0 - t, 0.0) \
            else 0.0
    rss = max(rss0 - best_t, 0.0)
    expected = max(state[S_START + best], 0.05 * k * pwm_max)
    suspect = (best_t > par[P_SIGNIFICANCE] and abs(best_f) > par[P_MIN_DEFICIT] * expected
               and best_t > par[P_CONSISTENCY] * rss)
    pair_lost, stuck = _pair_pick(par, state), _stuck_pick(par, state)
    if not learn:
        return best, suspect, pair_lost, stuck
    if not hold_bias:
        # the collective follows a change of mass or of the axial drag whatever the
        # statistic: a lighter vehicle reads as excess thrust on every motor at once, and
        # beside a partial loss of one motor as a smaller excess of the opposite one
        state[S_BIAS] += par[P_BIAS_GAIN] * res[0]
    if not suspect and best_t < NOISE_FREEZE * par[P_SIGNIFICANCE]:
        # a fault building up is never learned as noise
        for i in range(4):
            v = state[S_VAR + i]
            e2 = res[i] * res[i]
            v += (par[P_ATTACK] if e2 > v else par[P_DECAY]) * (e2 - v)
            state[S_VAR + i] = max(v, par[P_FLOOR + i])
    return best, suspect, pair_lost, stuck
