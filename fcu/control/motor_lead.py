"""Motor-lag lead: a discrete lead that swaps the motors' lag for a faster one, per axis.

The rotors follow their commands with a 15 rad/s first-order lag (eq. 3.1) that eq. 5.6/5.10
leave out. With PD alone the three closed-loop poles of ``s^3 + w s^2 + w kd s + w kp``
always sum to ``-w = -15 rad/s``, which caps a well damped attitude loop at about 5 rad/s and
makes a motor fault (a 0.14-0.21 N*m torque step) tilt the vehicle by 10-17 deg. Both
attitude laws therefore pass their torque through a :class:`MotorLead` (on by default,
``motor_lead_rad_s``): the discrete lead ``c2d(w_d/(s+w_d)) / c2d(w/(s+w))`` that cancels the
(known, nominal) motor pole and puts a 60 rad/s one in its place, so the lag-free model of
eq. 5.10 becomes nearly true and the gains can be six to twelve times stiffer. It multiplies
a torque step by 3.2 at first and high-frequency noise by up to 3.9: fed the raw sensor noise
of docs/design.md (0.002 rad, 0.003 rad/s) the motor PWM jitters by about 2.5 % (PD) or
5.5 % (LQR) of its hover value, less behind an estimator; the mean, hence the control
effort, is unchanged. The loop stays stable with a motor 33 % slower than nominal plus a
10 ms measurement delay (tests/fcu/control/test_attitude_control.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from fcu.floats import floats
from flightdata.design_cache import cached_design

if TYPE_CHECKING:
    import control


# the lead's parameter vector: its first-order realisation A, B, C, D, then 1 when the lead
# is in the loop (0: the torque passes unchanged, the laws without a lead)
_A, _B, _C, _D, _ON = range(5)
PAR_SIZE = 5


@njit(cache=True, error_model="numpy")
def lead_tick(par: np.ndarray, x: np.ndarray, u: np.ndarray) -> None:
    """One tick of :class:`MotorLead` on the torque ``u`` (N*m, (3,)), in place (``u``
    becomes the lead's output); ``x`` is the filter state per axis. Passes ``u`` unchanged
    when ``par`` says the lead is off."""
    if par[_ON] == 0.0:
        return
    a, b, c, d = par[_A], par[_B], par[_C], par[_D]
    for i in range(3):
        y = c * x[i] + d * u[i]  # y[k] = C x[k] + D u[k]
        x[i] = a * x[i] + b * u[i]  # x[k+1] = A x[k] + B u[k]
        u[i] = y


NO_LEAD = np.zeros(PAR_SIZE)  # the parameters of an absent lead
NO_LEAD.setflags(write=False)


class MotorLead:
    """Discrete lead that swaps the motors' lag for a faster one, per axis.

    ``C(z) = c2d(w_d/(s + w_d)) / c2d(w/(s + w))`` (both ZOH at the loop rate), i.e.
    ``C(z) = G (z - a)/(z - b)`` with ``a = exp(-w dt)``, ``b = exp(-w_d dt)`` and
    ``G = (1 - b)/(1 - a)``: in series with the motors' ZOH-sampled lag (eq. 3.1) it leaves
    exactly the target lag ``w_d``. DC gain 1, step gain G (3.2 for 15 -> 60 rad/s at
    100 Hz), Nyquist gain ``G (1 + a)/(1 + b)`` (3.9). Because the mixer of eq. 3.2
    is linear and all four motors share the lag, the lead can act on the torques instead of
    on each motor.

    Parameters
    ----------
    motor_bandwidth_rad_s : float
        w, the nominal motor lag (VehicleModel.motor_bandwidth), rad/s.
    target_bandwidth_rad_s : float
        w_d, rad/s, > w.
    dt_s : float
        Loop period, s.
    """

    def __init__(self, motor_bandwidth_rad_s: float, target_bandwidth_rad_s: float,
                 dt_s: float) -> None:
        if not target_bandwidth_rad_s > motor_bandwidth_rad_s:
            raise ValueError(f"motor_lead_rad_s = {target_bandwidth_rad_s!r}: must exceed the "
                             f"motor bandwidth ({motor_bandwidth_rad_s} rad/s) or be None")
        # discrete, first order over first order (designed once per configuration)
        self.dt_s = float(dt_s)
        self._num, self._den, realisation = _lead_design(
            float(motor_bandwidth_rad_s), float(target_bandwidth_rad_s), self.dt_s)
        self._a, self._b, self._c, self._d = (float(v) for v in realisation)
        self.par = np.array([self._a, self._b, self._c, self._d, 1.0])  # lead_tick's
        self.state = np.zeros(3)  # filter state per axis

    @property
    def transfer_function(self) -> control.TransferFunction:
        """``C(z)``, a discrete python-control transfer function (imports python-control)."""
        import control

        return control.tf(self._num, self._den, self.dt_s)

    @property
    def high_frequency_gain(self) -> float:
        """Gain at the Nyquist frequency, |C(-1)| (noise amplification)."""
        return float(abs(np.polyval(self._num, -1.0) / np.polyval(self._den, -1.0)))

    def reset(self) -> None:
        """Zero the filter state."""
        self.state[:] = 0.0

    def step(self, torque_nm: np.ndarray) -> np.ndarray:
        """Lead-filtered torque (N*m), shape (3,)."""
        u = np.array(floats(torque_nm, 3))
        lead_tick(self.par, self.state, u)
        return u


# The controller designs (_lead_design here, the LQR's and the reference filter's) call
# python-control's c2d and dlqr, hence scipy's expm and solve; importing python-control alone
# takes seconds. Each design is a pure function of its parameters, so it is made once per
# configuration and kept on disk (flightdata.design_cache). Cached arrays are read-only.
@cached_design
def _lead_design(w: float, wd: float, dt_s: float) -> tuple[np.ndarray, ...]:
    """:class:`MotorLead`'s ``C(z)`` (numerator, denominator: coefficients in descending
    powers of z) and its first-order realisation ``[A, B, C, D]``."""
    import control

    target = control.c2d(control.tf([wd], [1.0, wd]), dt_s, method="zoh")
    motor = control.c2d(control.tf([w], [1.0, w]), dt_s, method="zoh")
    transfer_function = target / motor  # discrete, first order over first order
    realised = control.ss(transfer_function)
    return (np.asarray(transfer_function.num[0][0], dtype=float),
            np.asarray(transfer_function.den[0][0], dtype=float),
            np.array([np.asarray(m)[0, 0] for m in (realised.A, realised.B, realised.C,
                                                     realised.D)], dtype=float))
