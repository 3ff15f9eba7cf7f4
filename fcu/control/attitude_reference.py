"""Attitude reference filter: a smoothed attitude reference with consistent derivatives.

Shapes the roll/pitch the position loop (:mod:`fcu.control.position`) asks for, and the yaw
of the guidance, into the (angle, rate, acceleration) references the attitude laws track
(:mod:`fcu.control.attitude`, wiring 1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fcu.control.attitude import check_period
from fcu.design_cache import cached_design
from fcu.floats import floats, wrap_pi


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


@cached_design  # made once per configuration and kept (fcu.design_cache)
def _reference_filter_design(dt_s: float, wf: float, zf: float) -> tuple[np.ndarray, ...]:
    """:class:`AttitudeReferenceFilter`'s ZOH discretisation: A (2, 2) and B (2, 1)."""
    import control

    continuous = control.ss([[0.0, 1.0], [-wf * wf, -2.0 * zf * wf]], [[0.0], [wf * wf]],
                            np.eye(2), np.zeros((2, 1)))
    discrete = control.c2d(continuous, dt_s, method="zoh")
    return np.asarray(discrete.A), np.asarray(discrete.B)


class AttitudeReferenceFilter:
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
        self._a_f, self._b_f = self._a.tolist(), self._b.tolist()
        self._angle: list[float] | None = None  # theta_f per axis, rad (unwrapped)
        self._rate = [0.0, 0.0, 0.0]  # theta_f', rad/s

    def reset(self, euler_rad: np.ndarray | None = None) -> None:
        """Forget the state; start at rest on ``euler_rad`` (else on the next input)."""
        self._angle = None if euler_rad is None else floats(euler_rad, 3)
        self._rate = [0.0, 0.0, 0.0]

    def step(self, ref_euler_rad: np.ndarray | Sequence[float]) -> AttitudeReference:
        """Filter one raw reference [roll, pitch, yaw] (rad); see the class docstring."""
        raw = floats(ref_euler_rad, 3)
        if self._angle is None:
            self._angle = list(raw)
        wf, zf = self.bandwidth_rad_s, self.damping
        (a00, a01), (a10, a11) = self._a_f
        b0, b1 = self._b_f
        angle, rate = self._angle, self._rate
        out_angle, acc, new_angle, new_rate = [], [], [], []
        for i in range(3):  # per axis, in plain floats
            th, th_dot = angle[i], rate[i]
            # work in coordinates relative to the filter angle: input offset wrapped
            offset = wrap_pi(raw[i] - th)  # theta_r - theta_f, rad
            # theta_f'' at the start of the interval
            acc.append(wf * wf * offset - 2.0 * zf * wf * th_dot)
            out_angle.append(wrap_pi(th))
            # [theta_f, theta_f'][k+1] = A [theta_f, theta_f'][k] + B theta_r[k]  (ZOH), with
            # theta_r[k] = theta_f[k] + offset so a 2 pi jump of the raw yaw is not followed;
            # the dynamics are shift-invariant in the angle (A[:, 0] + B = [1, 0]): keep it
            # wrapped
            new_angle.append(wrap_pi(a00 * th + a01 * th_dot + b0 * (th + offset)))
            new_rate.append(a10 * th + a11 * th_dot + b1 * (th + offset))
        out = AttitudeReference(euler_rad=np.array(out_angle), rate=np.array(rate),
                                acc=np.array(acc))
        self._angle, self._rate = new_angle, new_rate
        return out
