"""Attitude disturbance observers (eq. 6.27-6.30): estimate a lumped torque to cancel.

Per axis a DOB inverts a nominal plant ``G_n`` and low-passes the difference between the
torque the measurement implies and the torque that was applied::

    d_hat = Q(s) [G_n(s)^-1 y - tau_applied]

* AbDOB (eq. 6.27, 6.28): ``G_n = 1/(I s^2)`` from torque to Euler angle, and
  ``Q = w^2 / (s^2 + 2 w s + w^2)`` (the thesis prints ``2 w`` for ``2 w s``). The angle
  channel ``Q(s) I s^2 = I w^2 s^2 / (s + w)^2`` is biproper, hence realisable: no explicit
  differentiation of the measurement.
* VbDOB (eq. 6.29, 6.30): ``G_n = 1/(I s)`` from torque to body rate, ``Q = w / (s + w)``;
  the rate channel is ``I w s / (s + w)``.

``w = 5 rad/s`` (section 6.2). With a constant disturbance torque ``d`` on the nominal plant,
``G_n^-1 y - tau = d`` exactly, so ``d_hat = Q d -> d`` (``Q(0) = 1``) with the filter's time
constants: 2 % settling in about 5.8/w (AbDOB, double pole) or 3.9/w (VbDOB).

Realisation and discretisation: each channel is a SISO python-control transfer function
turned into state space, the three axes in block-diagonal form, and the two channels are
discretised separately with ``control.c2d`` at the loop rate and summed:

* torque channel, ZOH: exact, since the torque is held between ticks, and strictly
  proper, so the estimate at tick k never depends on the torque about to be computed from
  it (no algebraic loop);
* measurement channel, FOH (triangle hold): the sampled angle or rate is a smooth signal,
  and FOH is exact for ramps. ZOH would read the staircase of a constant-rate yaw as an
  acceleration (a bias of about 5 mN*m per rad/s through the AbDOB's ``s^2``) and add
  a half-sample lag; Tustin would also keep ``s = 0`` zeros but warps frequencies.

Timing contract of ``step`` (:class:`fcu.control.registry.DisturbanceObserver`): call it
once per tick with the newest measurement and the torque that was *applied over the interval
just ended*, i.e. the torque allocated on the previous tick (best: what the saturated PWM
really produces, ``Allocator.mix(pwm_prev)``, after the DOB compensation was subtracted).
The autopilot then commands ``tau = tau_controller - d_hat``. The step first completes the
state update of the last interval with that torque, then outputs the estimate for the
current measurement.

Motor lag. The thesis's nominal plants leave out the 15 rad/s motor lag (w_m), so the
observer reads ``tau_commanded - tau_actual`` (about ``tau_dot / w_m``) as disturbance and
feeds it back. The loop stays stable, but the margins shrink. Input sensitivity peaks of
the VbDOB loop (per axis, position loop closed): 2.9 for a plain eq. 5.6 PD (kp = 16,
kd = 7); with the attitude controllers' :class:`~fcu.control.motor_lead.MotorLead`, which
overdrives the motors on purpose, 2.2 nominally but 24 when the motors are 33 % slower
and the measurement 10 ms late. In the autopilot (:mod:`fcu.control.registry` passes the
model's ``motor_bandwidth``) the nominal plant therefore includes the known motor model,
``G_n = w_m/(s + w_m) * 1/(I s^2)`` (resp. ``1/(I s)``), realised by filtering the torque
channel: ``d_hat = Q [I s^2 y - w_m/(s + w_m) tau]`` (resp. ``I s y``). The estimate of a
constant disturbance and the filter Q are unchanged, ZOH stays exact for the held command
through the motor model, and the peaks become 1.9, 1.6 and 6.4.
``motor_bandwidth_rad_s=None`` (the classes' default) gives the thesis's form. Loop stability
with the real lag is checked in tests/fcu/control/test_disturbance_observer.py for both.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

import fcu.floats
from fcu.floats import floats, wrap_pi
from fcu.model import VehicleModel
from flightdata.design_cache import cached_design
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import hold

drop_stale_kernels(__file__, fcu.floats.__file__)  # dob_tick compiles in fcu.floats' wrap_pi

if TYPE_CHECKING:
    import control


class NoDob:
    """The absent observer (``"none"``): d_hat = 0."""

    kind = "none"

    def reset(self) -> None:
        """Nothing to forget."""

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray,
             torque_applied_nm: np.ndarray) -> np.ndarray:
        """Always zeros (N*m), shape (3,)."""
        return np.zeros(3)


def _block_system(systems: list[control.StateSpace]) -> control.StateSpace:
    """Block-diagonal (one input and one output per axis) connection of SISO systems."""
    import control
    from scipy.linalg import block_diag

    return control.ss(block_diag(*[np.asarray(g.A) for g in systems]),
                      block_diag(*[np.asarray(g.B) for g in systems]),
                      block_diag(*[np.asarray(g.C) for g in systems]),
                      block_diag(*[np.asarray(g.D) for g in systems]))


@njit(cache=True, error_model="numpy")
def _mul_add_into(out: np.ndarray, a: np.ndarray, x: np.ndarray, b: np.ndarray,
                  u: np.ndarray) -> None:
    """``out = a x + b u`` (the observers' matrices are a few rows: plain loops, no BLAS
    call; ``out`` must not share memory with ``x`` or ``u``)."""
    for i in range(a.shape[0]):
        acc = 0.0
        for j in range(a.shape[1]):
            acc += a[i, j] * x[j]
        for j in range(b.shape[1]):
            acc += b[i, j] * u[j]
        out[i] = acc


@njit(cache=True, error_model="numpy")
def dob_tick(abdob: bool, am: np.ndarray, bm: np.ndarray, at: np.ndarray, bt: np.ndarray,
             cm: np.ndarray, dm: np.ndarray, ct: np.ndarray, xm: np.ndarray, xt: np.ndarray,
             prev_meas: np.ndarray, euler_rad: np.ndarray, rate_frd: np.ndarray,
             tau: np.ndarray, d_hat: np.ndarray) -> None:
    """One tick of a started observer (:meth:`_DiscreteDob.step` after the first), both
    discrete channels, all three axes: writes ``d_hat`` (N*m, (3,)) and advances ``xm``,
    ``xt`` and ``prev_meas`` in place.

    ``x_y[k] = A_y x_y[k-1] + B_y y[k-1]``, ``x_tau[k] = A_tau x_tau[k-1] + B_tau tau[k-1]``,
    ``d_hat[k] = C_y x_y[k] + D_y y[k] + C_tau x_tau[k]`` (``D_tau = 0``). The measurement
    ``y`` is the body rate (VbDOB) or, with ``abdob``, the Euler angles unwrapped against
    the previous measurement (``prev_meas``, which then holds the unwrapped angles).
    """
    n_m, n_t = xm.shape[0], xt.shape[0]
    work = np.empty(n_m + n_t + 3)
    xm_next, xt_next, y = work[:n_m], work[n_m:n_m + n_t], work[n_m + n_t:]
    for i in range(3):
        if abdob:  # unwrap: u + wrap(e - wrap(u)), so a pass through +/-pi is no 2 pi jump
            u = prev_meas[i]
            y[i] = u + wrap_pi(euler_rad[i] - wrap_pi(u))
        else:
            y[i] = rate_frd[i]
    # x[k] = A x[k-1] + B u[k-1], for each channel
    _mul_add_into(xm_next, am, xm, bm, prev_meas)
    _mul_add_into(xt_next, at, xt, bt, tau)
    # d_hat[k] = C_y x_y[k] + D_y y[k] + C_tau x_tau[k]
    _mul_add_into(d_hat, cm, xm_next, dm, y)
    for i in range(3):
        for j in range(n_t):
            d_hat[i] += ct[i, j] * xt_next[j]
    xm[:] = xm_next
    xt[:] = xt_next
    prev_meas[:] = y


_Channel = tuple["control.TransferFunction", "control.TransferFunction"]


def _channels(kind: str, inertia_kgm2: tuple[float, ...], cutoff_rad_s: float,
              motor_bandwidth_rad_s: float | None) -> list[_Channel]:
    """Per axis (measurement filter, torque filter) of observer ``kind``, continuous, with the
    motor model in the torque path."""
    import control

    observer = _KINDS[kind]
    channels = [observer._channel(inertia, cutoff_rad_s) for inertia in inertia_kgm2]
    if motor_bandwidth_rad_s is not None:
        motor = control.tf([motor_bandwidth_rad_s], [1.0, motor_bandwidth_rad_s])
        channels = [(meas_tf, torque_tf * motor) for meas_tf, torque_tf in channels]
    return channels


@cached_design  # made once per configuration and kept (flightdata.design_cache)
def _discretise(kind: str, inertia_kgm2: tuple[float, ...], dt_s: float, cutoff_rad_s: float,
                motor_bandwidth_rad_s: float | None) -> tuple[np.ndarray, ...]:
    """Both channels discretised: A, B, C, D of the measurement path, then of the torque
    path, block-diagonal over the axes."""
    import control

    channels = _channels(kind, inertia_kgm2, cutoff_rad_s, motor_bandwidth_rad_s)
    # measurement: sampled, smooth -> FOH (exact for ramps: a constant rate reads as no
    # acceleration); torque: held between ticks -> ZOH (exact, strictly proper)
    meas = control.c2d(_block_system([control.ss(m) for m, _ in channels]), dt_s,
                       method="foh")
    torque = control.c2d(_block_system([control.ss(t) for _, t in channels]), dt_s,
                         method="zoh")
    return tuple(np.asarray(m, dtype=float) for m in (meas.A, meas.B, meas.C, meas.D,
                                                      torque.A, torque.B, torque.C, torque.D))


class _DiscreteDob:
    """Shared machinery: d_hat = F_meas(z) y + F_torque(z) tau, three axes.

    A concrete observer names its ``kind``, which picks the measurement (``"abdob"``: the
    Euler angles, unwrapped; ``"vbdob"``: the body rates), and gives its per-axis channels
    (:meth:`_channel`: the measurement filter ``Q G_n^-1`` and the torque filter ``-Q``,
    continuous). After the first step (:meth:`start`) each tick is the compiled
    :func:`dob_tick`, which :mod:`fcu.control.chain` also calls directly.

    Parameters
    ----------
    model : VehicleModel
        Supplies the inertia diagonal I (kg*m^2).
    dt_s : float
        Loop period, s.
    cutoff_rad_s : float
        Q-filter bandwidth w, rad/s (5 in the thesis).
    motor_bandwidth_rad_s : float or None
        Motor lag included in the nominal plant, rad/s; None = the thesis's plant.
    """

    kind = "abstract"

    def __init__(self, model: VehicleModel, dt_s: float = 0.01, cutoff_rad_s: float = 5.0,
                 motor_bandwidth_rad_s: float | None = None) -> None:
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be > 0")
        if not (np.isfinite(cutoff_rad_s) and 0 < cutoff_rad_s < np.pi / dt_s):
            raise ValueError(f"cutoff_rad_s = {cutoff_rad_s!r}: must be in (0, pi/dt_s)")
        if motor_bandwidth_rad_s is not None and not (np.isfinite(motor_bandwidth_rad_s)
                                                      and motor_bandwidth_rad_s > 0):
            raise ValueError(f"motor_bandwidth_rad_s = {motor_bandwidth_rad_s!r}: must be > 0 "
                             "or None")
        self.model = model
        self.dt_s = float(dt_s)
        self.cutoff_rad_s = float(cutoff_rad_s)
        self.motor_bandwidth_rad_s = motor_bandwidth_rad_s
        (self._am, self._bm, self._cm, self._dm, self._at, self._bt, self._ct,
         self._d_torque) = _discretise(self.kind, tuple(float(i) for i in model.inertia),
                                       self.dt_s, self.cutoff_rad_s, motor_bandwidth_rad_s)
        if not np.allclose(self._d_torque, 0.0):
            raise AssertionError("torque channel must be strictly proper after ZOH")
        # steady-state map for a constant measurement: x = (I - A)^-1 B y
        self._xm_per_meas = np.linalg.solve(np.eye(self._am.shape[0]) - self._am, self._bm)
        # contiguous, writable copies for the compiled per-tick update (the cached design's
        # arrays are read-only: numba would compile and load a second, read-only signature)
        self._k_am, self._k_bm, self._k_at, self._k_bt, self._k_cm, self._k_dm, self._k_ct = (
            np.array(m, dtype=float, order="C") for m in (
                self._am, self._bm, self._at, self._bt, self._cm, self._dm, self._ct))
        self._xm = np.zeros(self._am.shape[0])
        self._xt = np.zeros(self._at.shape[0])
        self._prev_meas = np.zeros(3)  # y[k-1] (AbDOB: the unwrapped angles, rad)
        self.started = False  # False until the first step has initialised the states

    @property
    def channels(self) -> list[_Channel]:
        """Per axis (measurement filter, torque filter), continuous, the motor model in the
        torque path (python-control transfer functions; imports python-control)."""
        return _channels(self.kind, tuple(float(i) for i in self.model.inertia),
                         self.cutoff_rad_s, self.motor_bandwidth_rad_s)

    @property
    def discrete_measurement(self) -> control.StateSpace:
        """The measurement path discretised (FOH), all axes (imports python-control)."""
        import control

        return control.ss(self._am, self._bm, self._cm, self._dm, self.dt_s)

    @property
    def discrete_torque(self) -> control.StateSpace:
        """The torque path discretised (ZOH), all axes (imports python-control)."""
        import control

        return control.ss(self._at, self._bt, self._ct, self._d_torque, self.dt_s)

    # ---- the compiled chain's view (fcu.control.chain.CompiledPart) -----------------------
    def kernel_params(self) -> tuple[np.ndarray, ...]:
        """What the compiled tick reads: the measurement and torque filters' matrices
        A_m, B_m, A_t, B_t, C_m, D_m, C_t."""
        return (self._k_am, self._k_bm, self._k_at, self._k_bt, self._k_cm, self._k_dm,
                self._k_ct)

    def kernel_states(self) -> tuple[np.ndarray, ...]:
        """What the compiled tick updates: the two filters' states and the previous
        measurement (3)."""
        return (self._xm, self._xt, self._prev_meas)

    def hold_states_in(self, views: Sequence[np.ndarray]) -> None:
        """Keep :meth:`kernel_states` in ``views`` (same sizes) from now on."""
        self._xm, self._xt, self._prev_meas = (hold(v, s) for v, s in zip(
            views, self.kernel_states(), strict=True))

    def reset(self) -> None:
        """Forget the filter state; the next step re-initialises at rest on its measurement."""
        self._xm[:] = 0.0
        self._xt[:] = 0.0
        self._prev_meas[:] = 0.0
        self.started = False

    @staticmethod
    def _channel(inertia_kgm2: float, w: float
                 ) -> tuple[control.TransferFunction, control.TransferFunction]:
        """One axis's (measurement filter, torque filter) for inertia I (kg*m^2) and the
        Q-filter bandwidth w (rad/s), continuous, before the motor model."""
        raise NotImplementedError

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray,
             torque_applied_nm: np.ndarray) -> np.ndarray:
        """Estimate d_hat (N*m), shape (3,); see the module docstring for the timing."""
        euler = np.array(floats(euler_rad, 3))
        rate = np.array(floats(rate_frd, 3))
        if not self.started:
            return self.start(euler, rate)
        tau = np.asarray(torque_applied_nm, dtype=float).reshape(3)
        d_hat = np.empty(3)
        # x[k] = A x[k-1] + B u[k-1] for each channel; d_hat[k] (dob_tick)
        dob_tick(self.kind == "abdob", self._k_am, self._k_bm, self._k_at, self._k_bt,
                 self._k_cm, self._k_dm, self._k_ct, self._xm, self._xt, self._prev_meas,
                 euler, rate, tau, d_hat)
        return d_hat

    def start(self, euler_rad: np.ndarray, rate_frd: np.ndarray) -> np.ndarray:
        """The first step after a reset: start at rest on the measurement (no derivative kick
        from y(0) != 0); returns d_hat (N*m), shape (3,)."""
        y = (np.array(floats(euler_rad, 3)) if self.kind == "abdob"
             else np.array(floats(rate_frd, 3)))
        self._xm[:] = self._xm_per_meas @ y
        self._prev_meas[:] = y
        self.started = True
        # d_hat[k] = C_y x_y[k] + D_y y[k] + C_tau x_tau[k]   (D_tau = 0)
        return self._cm @ self._xm + self._dm @ y + self._ct @ self._xt


class AccelerationDob(_DiscreteDob):
    """AbDOB (eq. 6.27, 6.28) on the Euler angles.

    Per axis ``d_hat = Q(s) [I s^2 angle - M(s) tau]``, ``Q = w^2/(s + w)^2``, ``M`` the
    motor model (or 1). The yaw angle is unwrapped internally so a pass through +/-pi is not
    read as a 2 pi jump. Parameters as :class:`_DiscreteDob`'s.
    """

    kind = "abdob"

    @staticmethod
    def _channel(inertia_kgm2: float, w: float
                 ) -> tuple[control.TransferFunction, control.TransferFunction]:
        import control

        den = [1.0, 2.0 * w, w * w]  # (s + w)^2, eq. 6.28 with the missing s restored
        return (control.tf([inertia_kgm2 * w * w, 0.0, 0.0], den),  # Q I s^2
                control.tf([-w * w], den))  # -Q


class VelocityDob(_DiscreteDob):
    """VbDOB (eq. 6.29, 6.30) on the body rates.

    Per axis ``d_hat = Q(s) [I s rate - M(s) tau]``, ``Q = w/(s + w)``, ``M`` the motor
    model (or 1). Parameters as :class:`_DiscreteDob`'s.
    """

    kind = "vbdob"

    @staticmethod
    def _channel(inertia_kgm2: float, w: float
                 ) -> tuple[control.TransferFunction, control.TransferFunction]:
        import control

        den = [1.0, w]  # s + w, eq. 6.30
        return (control.tf([inertia_kgm2 * w, 0.0], den),  # Q I s
                control.tf([-w], den))  # -Q


_KINDS: dict[str, type[_DiscreteDob]] = {dob.kind: dob for dob in (AccelerationDob, VelocityDob)}
