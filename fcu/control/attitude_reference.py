"""Attitude reference filter: a smoothed attitude reference with consistent derivatives.

Shapes the roll/pitch the position loop (:mod:`fcu.control.position`) asks for, and the yaw
of the guidance, into the (angle, rate, acceleration) references the attitude laws track
(:mod:`fcu.control.attitude`, wiring 1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

import fcu.floats
from fcu.control.attitude import check_period
from fcu.floats import floats, wrap_pi
from flightdata.design_cache import cached_design
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import Layout, OneStatePart

drop_stale_kernels(__file__, fcu.floats.__file__)  # the kernel compiles in fcu.floats' wrap_pi


@dataclass(frozen=True, slots=True)
class AttitudeReference:
    """A smoothed attitude reference and its derivatives, ZYX Euler.

    Attributes
    ----------
    euler_rad : numpy.ndarray
        Reference [roll, pitch, yaw], rad, shape (3,).
    rate : numpy.ndarray
        Its time derivative, rad/s, shape (3,).
    acc : numpy.ndarray
        Its second derivative, rad/s^2, shape (3,).
    """

    euler_rad: np.ndarray
    rate: np.ndarray
    acc: np.ndarray


@cached_design  # made once per configuration and kept (flightdata.design_cache)
def _reference_filter_design(dt_s: float, wf: float, zf: float) -> tuple[np.ndarray, ...]:
    """:class:`AttitudeReferenceFilter`'s ZOH discretisation: A (2, 2) and B (2, 1)."""
    import control

    continuous = control.ss([[0.0, 1.0], [-wf * wf, -2.0 * zf * wf]], [[0.0], [wf * wf]],
                            np.eye(2), np.zeros((2, 1)))
    discrete = control.c2d(continuous, dt_s, method="zoh")
    return np.asarray(discrete.A), np.asarray(discrete.B)


# AttitudeReferenceFilter's parameter vector: A (row-major), B, w_f (rad/s), zeta
_A00, _A01, _A10, _A11, _B0, _B1, _WF, _ZF = range(8)
PAR_SIZE = 8
# its state: theta_f (rad, wrapped), theta_f' (rad/s) per axis, then 1 once started
_ANGLE, _RATE, _STARTED = 0, 3, 6
STATE_SIZE = 7
# the kernel's output record (jitsupport.layout)
OUT = Layout("attitude reference")
OUT_EULER = OUT.field("euler_rad", 3)  # rad, reference roll, pitch, yaw
OUT_RATE = OUT.field("rate_rad_s", 3)  # rad/s, their rates
OUT_ACC = OUT.field("acc_rad_s2", 3)  # rad/s^2, their accelerations
OUT_SIZE = OUT.size


@njit(cache=True, error_model="numpy")
def reference_filter_tick(par: np.ndarray, state: np.ndarray, raw_roll: float,
                          raw_pitch: float, raw_yaw: float, out: np.ndarray) -> None:
    """One tick of :class:`AttitudeReferenceFilter` on the raw reference (rad): writes
    ``out`` (``OUT_*``) and advances ``state``."""
    if state[_STARTED] == 0.0:  # start at rest on the first input
        state[_ANGLE], state[_ANGLE + 1], state[_ANGLE + 2] = raw_roll, raw_pitch, raw_yaw
        state[_RATE:_RATE + 3] = 0.0
        state[_STARTED] = 1.0
    wf, zf = par[_WF], par[_ZF]
    a00, a01, a10, a11, b0, b1 = par[_A00], par[_A01], par[_A10], par[_A11], par[_B0], par[_B1]
    raw = (raw_roll, raw_pitch, raw_yaw)
    for i in range(3):
        th, th_dot = state[_ANGLE + i], state[_RATE + i]
        # work in coordinates relative to the filter angle: input offset wrapped
        offset = wrap_pi(raw[i] - th)  # theta_r - theta_f, rad
        out[OUT_EULER + i] = wrap_pi(th)
        out[OUT_RATE + i] = th_dot
        # theta_f'' = w_f^2 (theta_r - theta_f) - 2 zeta w_f theta_f', at the start of the
        # interval
        out[OUT_ACC + i] = wf * wf * offset - 2.0 * zf * wf * th_dot
        # [theta_f, theta_f'][k+1] = A [theta_f, theta_f'][k] + B theta_r[k]  (ZOH), with
        # theta_r[k] = theta_f[k] + offset so a 2 pi jump of the raw yaw is not followed;
        # the dynamics are shift-invariant in the angle (A[:, 0] + B = [1, 0]): keep it
        # wrapped
        state[_ANGLE + i] = wrap_pi(a00 * th + a01 * th_dot + b0 * (th + offset))
        state[_RATE + i] = a10 * th + a11 * th_dot + b1 * (th + offset)


class AttitudeReferenceFilter(OneStatePart):
    """Second-order state-variable filter giving a reference with consistent derivatives.

    Per axis ``theta_f'' = w_f^2 (theta_r - theta_f) - 2 zeta w_f theta_f'``, i.e.
    ``theta_f = w_f^2 / (s^2 + 2 zeta w_f s + w_f^2) theta_r``; its states (theta_f,
    theta_f') and the acceleration computed from them are handed to the attitude controller
    as (ref_euler, ref_rate, ref_acc). Discretised with ``control.c2d`` (ZOH: the raw
    reference is held between ticks). The outputs at tick k are the filter's state at k (so
    the error ``theta_f - theta`` compares the same instant) and the acceleration at the
    start of the interval; the state then advances with the new input.

    The input difference is wrapped to [-pi, pi] so a yaw reference crossing +/-pi does not
    spin the filter round; the output angle is wrapped too.

    Parameters
    ----------
    dt_s : float
        Control period, s.
    bandwidth_rad_s : float
        w_f, rad/s. 15 rad/s: about the attitude loop's own bandwidth, so the shaped
        reference is one the loop can follow, with a short lag (2 zeta / w_f = 0.13 s) for
        the position loop; the acceleration output amplifies reference noise by
        w_f^2 = 225.
    damping : float
        zeta, 1 = critically damped (no overshoot of the tilt reference).
    """

    def __init__(self, dt_s: float = 0.01, bandwidth_rad_s: float = 15.0,
                 damping: float = 1.0) -> None:
        check_period(dt_s)
        if not (np.isfinite(bandwidth_rad_s) and 0 < bandwidth_rad_s < np.pi / dt_s):
            raise ValueError(f"bandwidth_rad_s = {bandwidth_rad_s!r}: must be in (0, pi/dt_s)")
        if not (np.isfinite(damping) and damping > 0):
            raise ValueError(f"damping = {damping!r}: must be > 0")
        self.dt_s = float(dt_s)
        self.bandwidth_rad_s = float(bandwidth_rad_s)
        self.damping = float(damping)
        wf, zf = self.bandwidth_rad_s, self.damping
        # states [theta_f, theta_f'], input theta_r - (wrapped offset handled in step)
        self._a, b = _reference_filter_design(self.dt_s, wf, zf)
        self._b = b[:, 0]
        self.par = np.array([self._a[0, 0], self._a[0, 1], self._a[1, 0], self._a[1, 1],
                             self._b[0], self._b[1], wf, zf])
        self.state = np.zeros(STATE_SIZE)  # not started: starts on the next input

    def reset(self, euler_rad: np.ndarray | None = None) -> None:
        """Forget the state; start at rest on ``euler_rad`` (else on the next input)."""
        self.state[:] = 0.0
        if euler_rad is not None:
            self.state[_ANGLE:_ANGLE + 3] = floats(euler_rad, 3)
            self.state[_STARTED] = 1.0

    def step(self, ref_euler_rad: np.ndarray | Sequence[float]) -> AttitudeReference:
        """Filter one raw reference [roll, pitch, yaw] (rad); see the class docstring."""
        roll, pitch, yaw = floats(ref_euler_rad, 3)
        out = np.empty(OUT_SIZE)
        reference_filter_tick(self.par, self.state, roll, pitch, yaw, out)
        return reference_of(out)


def reference_of(out: np.ndarray) -> AttitudeReference:
    """The :class:`AttitudeReference` whose arrays are views of a filter output ``out``
    (``OUT_*`` layout, which the caller hands over)."""
    return AttitudeReference(euler_rad=out[OUT_EULER:OUT_EULER + 3],
                             rate=out[OUT_RATE:OUT_RATE + 3], acc=out[OUT_ACC:OUT_ACC + 3])
