"""Control allocation: thrust and torques to four PWM commands through the inverse of eq. 3.2.

:class:`Allocator` is the ``"attitude_first"`` allocator of :mod:`fcu.control.registry`.

Eq. 3.2 (motors 1 front, 2 back, 3 left, 4 right; docs/design.md)::

    U1 = K (u1 + u2 + u3 + u4)                      thrust, N
    U2 = K L (u3 - u4)                              roll torque, N*m
    U3 = K L (u1 - u2)                              pitch torque, N*m
    U4 = K K_psi (u1 + u2 - u3 - u4)                yaw torque, N*m

Its inverse splits the PWM vector into four orthogonal patterns::

    u = c [1, 1, 1, 1] + U2/(2 K L) [0, 0, 1, -1] + U3/(2 K L) [1, -1, 0, 0]
          + U4/(4 K K_psi) [1, 1, -1, -1],          c = U1 / (4 K)

Saturation strategy (each motor must stay in [pwm_min, pwm_max]); attitude comes first
because a quadrotor that loses roll/pitch control loses everything, while a yaw or altitude
error is recoverable:

0. when the whole request fits, it is allocated exactly;
1. else keep the requested collective ``c`` and roll/pitch pattern, scale the yaw pattern by
   the largest ``s_yaw`` in [0, 1] that fits;
2. if roll/pitch alone does not fit at ``c``, drop yaw and shift the collective to the nearest
   value that fits (trading altitude for attitude), then give back as much yaw as fits at the
   shifted collective;
3. only when the roll/pitch spread alone exceeds the PWM range, scale roll and pitch down
   together (direction of the tilt torque kept) until the spread equals the range.

Active fault-tolerant control (beyond the thesis, which stops at passive tolerance; chapter 8
names reconfiguration as future work): with the estimated effectiveness ``e_i = 1 - gamma_i``
of each motor (:meth:`Allocator.set_effectiveness`), eq. 3.2 becomes ``U = B diag(e) u``.
Writing ``v = diag(e) u`` (the thrust each motor actually gives, in PWM units) the nominal
inverse applies to ``v`` unchanged, and only the bounds move: ``e_i pwm_min <= v_i <= e_i
pwm_max``. The same strategy, with per-motor bounds, gives ``v``; the command is
``u_i = v_i / e_i``. So the controllers see the nominal airframe (no gain changes: the loop
gains of eq. 5.3-5.10 are those of the nominal plant again), the priorities are kept
(thrust and roll/pitch before yaw), and a weak motor's smaller range is where saturation
shows first. With every ``e_i = 1`` this is exactly the nominal allocation, to the bit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

import fcu.floats
from fcu.floats import clip, floats, py_max, py_min
from fcu.model import VehicleModel
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import hold

drop_stale_kernels(__file__, fcu.floats.__file__)  # the kernels compile in fcu.floats' helpers

_EPS_PWM = 1e-12  # numerical slack on the PWM bounds, far below any physical PWM step
MIN_EFFECTIVENESS = 0.05  # the least effectiveness the allocation assumes of a motor


# Allocator's parameter vector: PWM per N of U1, the PWM patterns per N*m of U2, U3 and U4
# (four motors each, the columns of the inverse of eq. 3.2), the PWM bounds
_PER_THRUST, _PER_ROLL, _PER_PITCH, _PER_YAW, _PWM_MIN, _PWM_MAX = 0, 1, 5, 9, 13, 14
PAR_SIZE = 15
# allocate_tick's report: s_yaw, s_rp, the collective c and the requested c0 (PWM)
REPORT_SIZE = 4


@njit(cache=True, error_model="numpy")
def allocate_tick(par: np.ndarray, e: np.ndarray, thrust_n: float, t_roll: float,
                  t_pitch: float, t_yaw: float, pwm: np.ndarray, report: np.ndarray) -> None:
    """The strategy of the module docstring: PWM u1..u4 into ``pwm`` (4,) for thrust U1 (N)
    and torques U2..U4 (N*m) with the effectiveness ``e`` (4,); (s_yaw, s_rp, c, c0) into
    ``report``."""
    lo = np.empty(4)
    hi = np.empty(4)
    d_rp = np.empty(4)
    d_yaw = np.empty(4)
    base = np.empty(4)
    for i in range(4):
        lo[i] = par[_PWM_MIN] * e[i]  # bounds on v = e u (module docstring)
        hi[i] = par[_PWM_MAX] * e[i]
        d_rp[i] = t_roll * par[_PER_ROLL + i] + t_pitch * par[_PER_PITCH + i]
        d_yaw[i] = t_yaw * par[_PER_YAW + i]
    c0 = thrust_n * par[_PER_THRUST]  # requested collective PWM, c = U1/(4K)

    # 0. the whole request fits: exact; 1. else collective and roll/pitch as requested,
    # yaw scaled to fit
    fits = True
    for i in range(4):
        x = c0 + d_rp[i] + d_yaw[i]
        if not lo[i] - _EPS_PWM <= x <= hi[i] + _EPS_PWM:
            fits = False
    if fits:
        s_yaw = 1.0
    else:
        for i in range(4):
            base[i] = c0 + d_rp[i]
        s_yaw = _largest_scale_k(base, d_yaw, lo, hi)
    if s_yaw >= 0.0:
        c, s_rp = c0, 1.0
    else:
        c_lo = lo[0] - d_rp[0]
        c_hi = hi[0] - d_rp[0]
        for i in range(1, 4):
            c_lo = py_max(c_lo, lo[i] - d_rp[i])
            c_hi = py_min(c_hi, hi[i] - d_rp[i])
        if c_lo <= c_hi:
            # 2. roll/pitch fits the range: shift the collective to the nearest feasible
            c, s_rp = clip(c0, c_lo, c_hi), 1.0
        else:
            # 3. roll/pitch alone exceeds the range: scale it until it fits, no yaw
            s_rp = _largest_spread_scale(d_rp, lo, hi)
            c = lo[0] - s_rp * d_rp[0]
            for i in range(1, 4):
                c = py_max(c, lo[i] - s_rp * d_rp[i])
        for i in range(4):
            base[i] = c + s_rp * d_rp[i]
        s_yaw = py_max(_largest_scale_k(base, d_yaw, lo, hi), 0.0)  # infeasible (-1): 0
    for i in range(4):
        pwm[i] = clip(c + s_rp * d_rp[i] + s_yaw * d_yaw[i], lo[i], hi[i]) / e[i]
    report[0], report[1], report[2], report[3] = s_yaw, s_rp, c, c0


@njit(cache=True, error_model="numpy")
def mix_tick(mixer: np.ndarray, e: np.ndarray, pwm: np.ndarray) -> np.ndarray:
    """Eq. 3.2 with the effectiveness: ``[U1, U2, U3, U4] = B diag(e) u`` (N, N*m), (4,)."""
    wrench = np.empty(4)
    for i in range(4):  # 4 x 4: plain loops, no BLAS call
        acc = 0.0
        for j in range(4):
            acc += mixer[i, j] * (pwm[j] * e[j])
        wrench[i] = acc
    return wrench


@dataclass(frozen=True, slots=True)
class AllocationResult:
    """One allocation and what the saturation strategy had to give up.

    Attributes
    ----------
    pwm : numpy.ndarray
        Motor commands u1..u4, shape (4,), inside [pwm_min, pwm_max].
    yaw_scale : float
        Fraction of the requested yaw torque kept, in [0, 1].
    roll_pitch_scale : float
        Fraction of the requested roll/pitch torque kept, in [0, 1].
    collective_shift_pwm : float
        Collective PWM added per motor to fit the bounds (0 when unsaturated).
    saturated : bool
        True when the requested (U1, U2, U3, U4) could not be produced exactly.
    """

    pwm: np.ndarray
    yaw_scale: float
    roll_pitch_scale: float
    collective_shift_pwm: float
    saturated: bool


class Allocator:
    """Inverse of eq. 3.2 with an attitude-first saturation strategy (see module docstring).

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe: K, L, K_psi and the PWM bounds.
    """

    def __init__(self, model: VehicleModel) -> None:
        self.model = model
        self._mixer = model.mixer()  # eq. 3.2, (4, 4)
        k, kl = model.thrust_gain, model.thrust_gain * model.arm_length
        kk = model.thrust_gain * model.yaw_gain
        # PWM patterns per unit request (columns of the inverse of eq. 3.2)
        self._per_thrust = np.full(4, 1.0 / (4.0 * k))  # PWM per N of U1
        self._per_roll = np.array([0.0, 0.0, 1.0, -1.0]) / (2.0 * kl)  # PWM per N*m of U2
        self._per_pitch = np.array([1.0, -1.0, 0.0, 0.0]) / (2.0 * kl)  # PWM per N*m of U3
        self._per_yaw = np.array([1.0, 1.0, -1.0, -1.0]) / (4.0 * kk)  # PWM per N*m of U4
        # the same as allocate_tick reads them
        self._par = np.concatenate([self._per_thrust[:1], self._per_roll, self._per_pitch,
                                    self._per_yaw, [model.pwm_min, model.pwm_max]])
        self._mixer_c = np.ascontiguousarray(self._mixer, dtype=float)
        self._effectiveness = np.ones(4)  # e_i = 1 - gamma_i believed (active FTC)
        self._nominal = True  # every e_i set to 1 by set_effectiveness(None)

    # ---- the compiled chain's view (fcu.control.chain.CompiledPart) -----------------------
    def kernel_params(self) -> tuple[np.ndarray, ...]:
        """What the compiled tick reads: the allocation's gains and PWM range
        (``PAR_SIZE``), then the mixer (4 x 4)."""
        return (self._par, self._mixer_c)

    def kernel_states(self) -> tuple[np.ndarray, ...]:
        """What the compiled tick updates: the believed per-motor effectiveness (4)."""
        return (self._effectiveness,)

    def hold_states_in(self, views: Sequence[np.ndarray]) -> None:
        """Keep :meth:`kernel_states` in ``views`` (same sizes) from now on."""
        (view,) = views
        self._effectiveness = hold(view, self._effectiveness)

    @property
    def effectiveness(self) -> np.ndarray:
        """The per-motor effectiveness the allocation assumes, shape (4,), in (0, 1]."""
        return self._effectiveness.copy()

    def set_effectiveness(self, effectiveness: np.ndarray | None) -> None:
        """Assume motor i gives ``effectiveness[i]`` of its nominal thrust (None: all 1).

        Values are clipped to [:data:`MIN_EFFECTIVENESS`, 1]: a motor believed dead is still
        commanded (at most full power), never divided by zero.
        """
        if effectiveness is None:
            if not self._nominal:
                self._effectiveness[:] = 1.0
                self._nominal = True
            return
        self._effectiveness[:] = [clip(e, MIN_EFFECTIVENESS, 1.0)
                                  for e in floats(effectiveness, 4)]
        self._nominal = False

    @property
    def max_thrust_n(self) -> float:
        """Collective thrust with every motor at pwm_max, N."""
        return 4.0 * self.model.thrust_gain * self.model.pwm_max

    def allocate(self, thrust_n: float, torque_nm: np.ndarray) -> np.ndarray:
        """PWM commands u1..u4, shape (4,), for thrust U1 (N) and torques U2..U4 (N*m).

        Exactly the inverse of eq. 3.2 when no motor saturates; otherwise see the module
        docstring.
        """
        return self._allocate(thrust_n, torque_nm)[0]

    def allocate_report(self, thrust_n: float, torque_nm: np.ndarray) -> AllocationResult:
        """Like :meth:`allocate`, returning also the scales the saturation strategy applied.

        Parameters
        ----------
        thrust_n : float
            Requested collective thrust U1, N.
        torque_nm : numpy.ndarray
            Requested [U2 roll, U3 pitch, U4 yaw], N*m, shape (3,).
        """
        pwm, s_yaw, s_rp, c, c0 = self._allocate(thrust_n, torque_nm)
        saturated = bool(s_yaw < 1.0 or s_rp < 1.0 or c != c0)
        return AllocationResult(pwm=pwm, yaw_scale=float(s_yaw), roll_pitch_scale=float(s_rp),
                                collective_shift_pwm=float(c - c0), saturated=saturated)

    def _allocate(self, thrust_n: float, torque_nm: np.ndarray
                  ) -> tuple[np.ndarray, float, float, float, float]:
        """The strategy of the module docstring (:func:`allocate_tick`):
        (pwm, s_yaw, s_rp, c, c0)."""
        t_roll, t_pitch, t_yaw = floats(torque_nm, 3)
        pwm, report = np.empty(4), np.empty(REPORT_SIZE)
        allocate_tick(self._par, self._effectiveness, float(thrust_n), t_roll, t_pitch, t_yaw,
                      pwm, report)
        s_yaw, s_rp, c, c0 = report.tolist()
        return pwm, s_yaw, s_rp, c, c0

    def mix(self, pwm: np.ndarray) -> tuple[float, np.ndarray]:
        """Eq. 3.2: thrust U1 (N) and torques [U2, U3, U4] (N*m, shape (3,)) from PWM u[4],
        with the effectiveness the allocation assumes (``B diag(e) u``)."""
        u = mix_tick(self._mixer_c, self._effectiveness,
                     np.ascontiguousarray(pwm, dtype=float).reshape(4))
        return float(u[0]), u[1:]


def _largest_scale(base: np.ndarray, pattern: np.ndarray, lo: float, hi: float) -> float | None:
    """Largest s in [0, 1] with lo <= base + s * pattern <= hi, or None if s = 0 is infeasible."""
    n = len(base)
    s = _largest_scale_k(np.asarray(base, dtype=float), np.asarray(pattern, dtype=float),
                         np.full(n, float(lo)), np.full(n, float(hi)))
    return None if s < 0.0 else s


@njit(cache=True, error_model="numpy")
def _largest_scale_k(base: np.ndarray, pattern: np.ndarray, lo: np.ndarray, hi: np.ndarray
                     ) -> float:
    """:func:`_largest_scale` with per-motor bounds; -1 where it returns None."""
    for i in range(base.size):
        if base[i] < lo[i] - _EPS_PWM or base[i] > hi[i] + _EPS_PWM:
            return -1.0
    s = 1.0
    for i in range(base.size):
        b, p = base[i], pattern[i]
        # |p| <= _EPS_PWM cannot leave the bounds by more than the slack at any s in [0, 1]
        if p > _EPS_PWM:
            s = py_min(s, (hi[i] - b) / p)
        elif p < -_EPS_PWM:
            s = py_min(s, (lo[i] - b) / p)
    return s if s > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def _largest_spread_scale(d: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """Largest s in [0, 1] for which some c puts every ``c + s d_i`` in [lo_i, hi_i].

    For each pair with ``d_j > d_i``: ``lo_i - s d_i <= hi_j - s d_j``, i.e.
    ``s <= (hi_j - lo_i) / (d_j - d_i)``. With equal bounds this is range / spread.
    """
    s = 1.0
    for i in range(d.size):
        for j in range(d.size):
            if d[j] > d[i]:
                s = py_min(s, (hi[j] - lo[i]) / (d[j] - d[i]))
    return py_max(s, 0.0)
