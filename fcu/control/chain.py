"""The autopilot's control chain in one compiled call per tick.

In flight, every tick runs::

    PositionController (eq. 5.3, 5.4)      --> U1, roll_d, pitch_d, mu
    AttitudeReferenceFilter                --> reference angles, rates, accelerations
    attitude law (PD eq. 5.6 | LQR eq. 5.7-5.10) through the motor lead --> torque
    disturbance observer (AbDOB eq. 6.27-6.28 | VbDOB eq. 6.29-6.30)    --> d_hat
    allocator (inverse of eq. 3.2, attitude first) on torque - d_hat    --> PWM u1..u4
    mixer (eq. 3.2, B diag(e) u)           --> torque applied, fed to the DOB next tick
    crash-check measures (lean, attitude error, speed, collective)
    crash and thrust-loss checks (fcu.monitoring.crash_check), when the chain has them

:func:`control_tick` is that sequence, calling each part's own kernel (``position_tick``,
``reference_filter_tick``, ``pd_tick`` / ``lqr_tick``, ``dob_tick``, ``allocate_tick``,
``mix_tick``, ``crash_tick``) on the parts' parameter and state vectors, which stay the
parts' own: their
objects keep the gains (designed at construction), ``reset()``, the telemetry properties and
a ``step`` that runs the same kernel alone. A :class:`ControlChain` binds one set of parts;
its :meth:`~ControlChain.step` returns one fresh vector laid out by the ``OUT_*`` offsets
below (views of it stand in for the per-part result objects).

Parts other than the registered ones (a law, observer or allocator added through
:mod:`fcu.control.registry` without a kernel) run through their ``step`` / ``allocate`` /
``mix`` methods in the same order, into the same vector.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numba import njit

import fcu.floats
from fcu.control import attitude_reference as reference_module
from fcu.control import position as position_module
from fcu.control.allocation import PAR_SIZE as ALLOC_PAR_SIZE
from fcu.control.allocation import REPORT_SIZE, Allocator, allocate_tick, mix_tick
from fcu.control.attitude_lqr import AttitudeLQR, lqr_tick
from fcu.control.attitude_pd import AttitudePD, pd_tick
from fcu.control.attitude_reference import (
    AttitudeReference,
    AttitudeReferenceFilter,
    reference_filter_tick,
)
from fcu.control.dob import NoDob, _DiscreteDob, dob_tick
from fcu.control.motor_lead import PAR_SIZE as LEAD_PAR_SIZE
from fcu.control.position import PositionController, position_tick
from fcu.control.registry import AttitudeLaw, ControlAllocator, DisturbanceObserver
from fcu.floats import py_max, py_min
from fcu.monitoring import crash_check as crash_module
from fcu.monitoring.crash_check import CrashCheck, crash_tick
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.calls import KernelCall
from jitsupport.layout import Layout
from jitsupport.views import borrowed, shaped

# control_tick compiles in the kernels of the parts' modules and of kernel_views
drop_stale_kernels(__file__, kernel_views.__file__, crash_module.__file__, fcu.floats.__file__)

__all__ = ["ControlChain", "attitude_reference", "control_tick", "crash_measures"]

LAW_OTHER, LAW_PD, LAW_LQR = 0, 1, 2
DOB_NONE, DOB_VB, DOB_AB, DOB_OTHER = 0, 1, 2, 3

# the output vector of a tick (jitsupport.layout)
OUT = Layout("control tick output")
OUT_PWM = OUT.field("pwm", 4)  # PWM u1..u4 commanded
OUT_THRUST = OUT.field("thrust_n", 1)  # N, U1 commanded
# N*m, torque allocated, after the DOB compensation
OUT_TORQUE_CMD = OUT.field("torque_cmd_nm", 3)
OUT_D_HAT = OUT.field("d_hat_nm", 3)  # N*m, DOB estimate (zeros without a DOB)
# attitude reference, reference_filter_tick's record
OUT_REF = OUT.nest("reference", reference_module.OUT)
OUT_ACCEL = OUT.field("accel_ned", 3)  # m/s^2 NED, mu after the limits
# N*m, what the PWM asks of the airframe, eq. 3.2
OUT_TORQUE_APPLIED = OUT.field("torque_applied_nm", 3)
# the crash check's measures, in fcu.monitoring.crash_check's order (ALT...COLLECTIVE)
OUT_ALT = OUT.field("alt_m", 1)  # m, estimated altitude (up)
OUT_VEL_DOWN = OUT.field("vel_down_m_s", 1)  # m/s, estimated vertical speed (+ down)
OUT_SPEED = OUT.field("speed_m_s", 1)  # m/s, estimated speed |v|
OUT_LEAN = OUT.field("lean_rad", 1)  # rad, angle of the body z axis from the vertical
# rad, larger of the roll and pitch errors against the reference
OUT_ATT_ERROR = OUT.field("att_error_rad", 1)
OUT_COLLECTIVE = OUT.field("collective", 1)  # U1 as a fraction of full thrust
# what the crash check found: crash_tick's bits (0 without the check)
OUT_CRASH_FOUND = OUT.field("crash_found", 1)
OUT_SIZE = OUT.size

# control_tick's scratch: each part's output
SCRATCH = Layout("control tick scratch")
_S_POS = SCRATCH.field("position", position_module.OUT_SIZE)
_S_REF = SCRATCH.field("reference", reference_module.OUT_SIZE)
_S_TORQUE = SCRATCH.field("torque", 3)
_S_D_HAT = SCRATCH.field("d_hat", 3)
_S_REPORT = SCRATCH.field("report", REPORT_SIZE)
_S_PWM = SCRATCH.field("pwm", 4)
_SCRATCH_SIZE = SCRATCH.size

_EULER = OUT["reference.euler_rad"].start
_RATE = OUT["reference.rate_rad_s"].start
_ACC = OUT["reference.acc_rad_s2"].start


@njit(cache=True, error_model="numpy")
def crash_measures(euler_rad: np.ndarray, ref_euler_rad: np.ndarray, pos_ned: np.ndarray,
                   vel_ned: np.ndarray, thrust_n: float, full_thrust_n: float,
                   out: np.ndarray) -> None:
    """What the crash check reads (:mod:`fcu.monitoring.crash_check`), into ``out[OUT_ALT:
    OUT_COLLECTIVE + 1]``."""
    roll, pitch = euler_rad[0], euler_rad[1]
    out[OUT_ALT] = -pos_ned[2]
    out[OUT_VEL_DOWN] = vel_ned[2]
    out[OUT_SPEED] = math.sqrt(np.dot(vel_ned, vel_ned))  # |v|
    # lean = acos(cos(phi) cos(theta)): the body z axis against the vertical
    out[OUT_LEAN] = math.acos(py_max(-1.0, py_min(1.0, math.cos(roll) * math.cos(pitch))))
    out[OUT_ATT_ERROR] = py_max(abs(ref_euler_rad[0] - roll), abs(ref_euler_rad[1] - pitch))
    out[OUT_COLLECTIVE] = thrust_n / full_thrust_n


# the index vector of a chain's workspace: where each part's parameters and states start
(I_POS_PAR, I_POS_INTEGRAL, I_REF_PAR, I_REF_STATE, I_LAW_PAR, I_LAW_PAR_END, I_LAW_STATE,
 I_LAW_STATE_END, I_LEAD_PAR, I_LEAD_STATE, I_ALLOC_PAR, I_EFFECTIVENESS, I_MIXER, I_AM, I_BM,
 I_AT, I_BT, I_CM, I_DM, I_CT, I_XM, I_XT, I_PREV_MEAS, I_N_XM, I_N_XT, I_LAW_KIND,
 I_DOB_KIND, I_CRASH_PAR, I_CRASH_STATE) = range(29)
INDEX_SIZE = 29


@njit(cache=True, error_model="numpy", inline="always")
def _matrix(ws: np.ndarray, start: int, rows: int, cols: int) -> np.ndarray:
    """The (rows, cols) matrix stored row-major in ``ws`` from ``start`` (a view)."""
    return shaped(ws[start:start + rows * cols], (rows, cols))


@njit(cache=True, error_model="numpy")
def control_tick(ws: np.ndarray, idx: np.ndarray, full_thrust_n: float, dob_run: bool,
                 pos_ned: np.ndarray, vel_ned: np.ndarray, euler_rad: np.ndarray,
                 rate_frd: np.ndarray, ref_pos: np.ndarray, ref_vel: np.ndarray,
                 ref_acc: np.ndarray, yaw_ref: float, torque_applied: np.ndarray,
                 out: np.ndarray, time_s: float, contact_leg: bool) -> None:
    """One flying tick at ``time_s`` (s) of the chain of the module docstring into ``out``
    (``OUT_*``).

    ``ws`` holds the parts' parameters and states where ``idx`` (``I_*``) says; the states
    (position integral, reference filter, law integrals and lead, DOB, effectiveness, crash
    check timers) advance in place. ``out[OUT_D_HAT:OUT_D_HAT + 3]`` must hold the DOB
    estimate already unless ``dob_run`` (zeros without a DOB; the observer's own first step
    after a reset). ``contact_leg``: the leg flown is neither a take-off nor a landing (the
    crash check's ground-contact test applies).
    """
    # the arguments as views that hold no references: no reference counting in the tick
    ws, idx, out, torque_applied = borrowed(ws), borrowed(idx), borrowed(out), borrowed(
        torque_applied)
    pos_ned, vel_ned, euler_rad = borrowed(pos_ned), borrowed(vel_ned), borrowed(euler_rad)
    rate_frd, ref_pos, ref_vel = borrowed(rate_frd), borrowed(ref_pos), borrowed(ref_vel)
    ref_acc = borrowed(ref_acc)
    # the parts' outputs, in one scratch vector (owned here: not borrowed)
    scratch = np.empty(_SCRATCH_SIZE)
    pos_out = scratch[_S_POS:_S_POS + position_module.OUT_SIZE]
    reference = scratch[_S_REF:_S_REF + reference_module.OUT_SIZE]
    torque, d_hat = scratch[_S_TORQUE:_S_TORQUE + 3], scratch[_S_D_HAT:_S_D_HAT + 3]
    report, pwm = scratch[_S_REPORT:_S_REPORT + REPORT_SIZE], scratch[_S_PWM:_S_PWM + 4]
    # position loop, eq. 5.1-5.4: U1, roll_d, pitch_d, mu
    position_tick(ws[idx[I_POS_PAR]:idx[I_POS_PAR] + position_module.PAR_SIZE],
                  ws[idx[I_POS_INTEGRAL]:idx[I_POS_INTEGRAL] + 3], pos_ned, vel_ned, ref_pos,
                  ref_vel, ref_acc, yaw_ref, pos_out)
    thrust_n = pos_out[position_module.OUT_THRUST]
    # the attitude reference: (roll_d, pitch_d, psi_d) through the second-order filter
    reference_filter_tick(ws[idx[I_REF_PAR]:idx[I_REF_PAR] + reference_module.PAR_SIZE],
                          ws[idx[I_REF_STATE]:idx[I_REF_STATE] + reference_module.STATE_SIZE],
                          pos_out[position_module.OUT_ROLL],
                          pos_out[position_module.OUT_PITCH], yaw_ref, reference)
    ref_euler = reference[reference_module.OUT_EULER:reference_module.OUT_EULER + 3]
    ref_rate = reference[reference_module.OUT_RATE:reference_module.OUT_RATE + 3]
    ref_accel = reference[reference_module.OUT_ACC:reference_module.OUT_ACC + 3]
    # the attitude law (eq. 5.6 or 5.9) through the motor lead
    law_par = ws[idx[I_LAW_PAR]:idx[I_LAW_PAR_END]]
    law_state = ws[idx[I_LAW_STATE]:idx[I_LAW_STATE_END]]
    lead_par = ws[idx[I_LEAD_PAR]:idx[I_LEAD_PAR] + LEAD_PAR_SIZE]
    lead_state = ws[idx[I_LEAD_STATE]:idx[I_LEAD_STATE] + 3]
    if idx[I_LAW_KIND] == LAW_LQR:
        lqr_tick(law_par, law_state, lead_par, lead_state, euler_rad, rate_frd, ref_euler,
                 ref_rate, ref_accel, torque)
    else:
        pd_tick(law_par, law_state, lead_par, lead_state, euler_rad, rate_frd, ref_euler,
                ref_rate, ref_accel, torque)
    # the DOB (eq. 6.27-6.30) on the torque applied over the interval just ended
    if dob_run:
        n_m, n_t = idx[I_N_XM], idx[I_N_XT]
        dob_tick(idx[I_DOB_KIND] == DOB_AB, _matrix(ws, idx[I_AM], n_m, n_m),
                 _matrix(ws, idx[I_BM], n_m, 3), _matrix(ws, idx[I_AT], n_t, n_t),
                 _matrix(ws, idx[I_BT], n_t, 3), _matrix(ws, idx[I_CM], 3, n_m),
                 _matrix(ws, idx[I_DM], 3, 3), _matrix(ws, idx[I_CT], 3, n_t),
                 ws[idx[I_XM]:idx[I_XM] + n_m], ws[idx[I_XT]:idx[I_XT] + n_t],
                 ws[idx[I_PREV_MEAS]:idx[I_PREV_MEAS] + 3], euler_rad, rate_frd,
                 torque_applied, d_hat)
    else:
        d_hat[:] = out[OUT_D_HAT:OUT_D_HAT + 3]
    # tau = tau_controller - d_hat, then the allocation (inverse of eq. 3.2) and eq. 3.2 back
    effectiveness = ws[idx[I_EFFECTIVENESS]:idx[I_EFFECTIVENESS] + 4]
    allocate_tick(ws[idx[I_ALLOC_PAR]:idx[I_ALLOC_PAR] + ALLOC_PAR_SIZE], effectiveness,
                  thrust_n, torque[0] - d_hat[0], torque[1] - d_hat[1], torque[2] - d_hat[2],
                  pwm, report)
    wrench = mix_tick(_matrix(ws, idx[I_MIXER], 4, 4), effectiveness, pwm)
    for i in range(3):
        out[OUT_TORQUE_CMD + i] = torque[i] - d_hat[i]
        out[OUT_D_HAT + i] = d_hat[i]
        out[OUT_ACCEL + i] = pos_out[position_module.OUT_MU + i]
        out[OUT_TORQUE_APPLIED + i] = wrench[1 + i]
    out[OUT_PWM:OUT_PWM + 4] = pwm
    out[OUT_THRUST] = thrust_n
    out[OUT_REF:OUT_REF + reference_module.OUT_SIZE] = reference
    crash_measures(euler_rad, ref_euler, pos_ned, vel_ned, thrust_n, full_thrust_n, out)
    if idx[I_CRASH_STATE] >= 0:  # the crash and thrust-loss checks on those measures
        out[OUT_CRASH_FOUND] = crash_tick(
            ws[idx[I_CRASH_PAR]:idx[I_CRASH_PAR] + crash_module.PAR_SIZE],
            ws[idx[I_CRASH_STATE]:idx[I_CRASH_STATE] + crash_module.STATE_SIZE], time_s,
            contact_leg, out[OUT_ALT:OUT_ALT + crash_module.MEASURES_SIZE])


def _law_kind(law: AttitudeLaw) -> int:
    if isinstance(law, AttitudeLQR):
        return LAW_LQR
    if isinstance(law, AttitudePD):
        return LAW_PD
    return LAW_OTHER


def _dob_kind(dob: DisturbanceObserver) -> int:
    if isinstance(dob, NoDob):
        return DOB_NONE
    if isinstance(dob, _DiscreteDob) and dob.kind in ("abdob", "vbdob"):
        return DOB_AB if dob.kind == "abdob" else DOB_VB
    return DOB_OTHER


class CompiledPart(Protocol):
    """A part the chain steps inside its compiled call: the arrays its kernel reads and
    updates, and where it keeps its state."""

    def kernel_params(self) -> tuple[np.ndarray, ...]:
        """The arrays the kernel reads (copied into the chain's workspace)."""
        ...

    def kernel_states(self) -> tuple[np.ndarray, ...]:
        """The 1-D arrays the kernel updates."""
        ...

    def hold_states_in(self, views: Sequence[np.ndarray]) -> None:
        """Keep the states in ``views`` (views of the workspace, same sizes) from now on, so
        that the part's own ``step`` and ``reset`` and the compiled call share them."""
        ...


class _Workspace:
    """Builds a chain's workspace: the parts' parameters copied in, their states appended
    and, once built, handed back to each part as views (:meth:`CompiledPart.hold_states_in`)."""

    def __init__(self) -> None:
        self.blocks: list[np.ndarray] = []
        self.holders: list[tuple[CompiledPart, list[tuple[int, int]]]] = []
        self.size = 0

    def _put(self, values: np.ndarray) -> int:
        """Append a copy of ``values`` (flattened, row-major); returns its offset."""
        start = self.size
        flat = np.ascontiguousarray(values, dtype=float).reshape(-1)
        self.blocks.append(flat)
        self.size += flat.size
        return start

    def params(self, part: CompiledPart) -> list[int]:
        """Append ``part``'s kernel parameters; returns their offsets."""
        return [self._put(values) for values in part.kernel_params()]

    def states(self, part: CompiledPart) -> list[int]:
        """Append ``part``'s kernel states, which it keeps in the workspace once built;
        returns their offsets."""
        spans = [(self._put(state), state.size) for state in part.kernel_states()]
        self.holders.append((part, spans))
        return [start for start, _ in spans]

    def build(self) -> np.ndarray:
        ws = np.concatenate(self.blocks) if self.blocks else np.zeros(0)
        for part, spans in self.holders:
            part.hold_states_in([ws[start:start + size] for start, size in spans])
        return ws


# (its arguments: the chain's workspace and output, the estimate's and the reference's float64
# 3-vectors, floats and bools)
_control_tick = KernelCall(control_tick)


class ControlChain:
    """The parts of one autopilot's flying control chain, stepped by :func:`control_tick`.

    Parameters
    ----------
    position : PositionController
        The position loop flown with all rotors.
    reference_filter : AttitudeReferenceFilter
        Shapes the attitude reference.
    law, dob, allocator
        The attitude law, disturbance observer and allocator the configuration names
        (:mod:`fcu.control.registry`).
    full_thrust_n : float
        N, collective thrust at full PWM (the crash check's collective scale).
    crash_check : CrashCheck, optional
        The crash and thrust-loss checks, run on each tick's measures (their timers adopted
        like the parts' states); the bits they found are ``out[OUT_CRASH_FOUND]``.

    The chain packs the parts' parameters and states into one workspace (one argument for
    the compiled call instead of some thirty): parameters are copied, state arrays adopted
    (the parts' arrays become views of the workspace, so the parts' own ``step`` and
    ``reset``, which update their states in place, keep working on the same numbers).
    """

    def __init__(self, position: PositionController, reference_filter: AttitudeReferenceFilter,
                 law: AttitudeLaw, dob: DisturbanceObserver, allocator: ControlAllocator,
                 full_thrust_n: float, crash_check: CrashCheck | None = None) -> None:
        self.position = position
        self.reference_filter = reference_filter
        self.law = law
        self.dob = dob
        self.allocator = allocator
        self.full_thrust_n = float(full_thrust_n)
        self.crash_check = crash_check
        law_kind, dob_kind = _law_kind(law), _dob_kind(dob)
        self._dob_kind = dob_kind
        self.compiled = (law_kind != LAW_OTHER and dob_kind != DOB_OTHER
                         and isinstance(allocator, Allocator))
        self._ws = np.zeros(0)
        self._idx = np.zeros(INDEX_SIZE, dtype=np.int64)
        self._idx[I_CRASH_STATE] = -1  # no crash check
        if not self.compiled:
            return
        assert isinstance(law, (AttitudeLQR, AttitudePD)) and isinstance(allocator, Allocator)
        w, idx = _Workspace(), self._idx
        idx[I_LAW_KIND], idx[I_DOB_KIND] = law_kind, dob_kind
        idx[I_POS_PAR], = w.params(position)
        idx[I_POS_INTEGRAL], = w.states(position)
        idx[I_REF_PAR], = w.params(reference_filter)
        idx[I_REF_STATE], = w.states(reference_filter)
        idx[I_LAW_PAR], idx[I_LEAD_PAR] = w.params(law)
        idx[I_LAW_PAR_END] = idx[I_LAW_PAR] + law.kernel_params()[0].size
        idx[I_LAW_STATE], idx[I_LEAD_STATE] = w.states(law)
        idx[I_LAW_STATE_END] = idx[I_LAW_STATE] + law.kernel_states()[0].size
        idx[I_ALLOC_PAR], idx[I_MIXER] = w.params(allocator)
        idx[I_EFFECTIVENESS], = w.states(allocator)
        if isinstance(dob, _DiscreteDob):
            idx[[I_AM, I_BM, I_AT, I_BT, I_CM, I_DM, I_CT]] = w.params(dob)
            idx[I_XM], idx[I_XT], idx[I_PREV_MEAS] = w.states(dob)
            xm, xt, _ = dob.kernel_states()
            idx[I_N_XM], idx[I_N_XT] = xm.size, xt.size
        if crash_check is not None:
            idx[I_CRASH_PAR], = w.params(crash_check)
            idx[I_CRASH_STATE], = w.states(crash_check)
        self._ws = w.build()

    def touchdown(self, on: bool) -> None:
        """The position loop's tilt limit of the next steps
        (:meth:`~fcu.control.position.PositionController.touchdown`), in the workspace's copy
        of its parameters too."""
        position = self.position
        position.touchdown(on)
        if self.compiled:
            at = self._idx[I_POS_PAR] + position_module.PAR_TAN_TILT_MAX
            self._ws[at] = position.par[position_module.PAR_TAN_TILT_MAX]

    def step(self, pos_ned: np.ndarray, vel_ned: np.ndarray, euler_rad: np.ndarray,
             rate_frd: np.ndarray, ref_pos: np.ndarray, ref_vel: np.ndarray,
             ref_acc: np.ndarray, yaw_ref: float, torque_applied: np.ndarray,
             effectiveness: np.ndarray | None, *, time_s: float = 0.0,
             contact_leg: bool = True) -> np.ndarray:
        """One flying tick; returns a fresh vector laid out by ``OUT_*``.

        Parameters
        ----------
        pos_ned, vel_ned, euler_rad, rate_frd : numpy.ndarray
            Estimated position (m), velocity (m/s), attitude (rad) and body rates (rad/s), (3,).
        ref_pos, ref_vel, ref_acc : numpy.ndarray
            Position reference (m), its velocity (m/s) and acceleration (m/s^2), NED, (3,).
        yaw_ref : float
            Yaw reference, rad.
        torque_applied : numpy.ndarray
            N*m, torque the previous tick's PWM asked for (eq. 3.2), (3,).
        effectiveness : numpy.ndarray or None
            Per-motor effectiveness for the allocation (active FTC), (4,); None: nominal.
        time_s : float
            Tick time, s (the crash check's timers).
        contact_leg : bool
            The leg flown is neither a take-off nor a landing (the crash check's
            ground-contact test applies).
        """
        self.allocator.set_effectiveness(effectiveness)
        out = np.zeros(OUT_SIZE)
        if not self.compiled:
            self._step_parts(pos_ned, vel_ned, euler_rad, rate_frd, ref_pos, ref_vel, ref_acc,
                             yaw_ref, torque_applied, out)
            if self.crash_check is not None:
                out[OUT_CRASH_FOUND] = self.crash_check.tick(
                    time_s, contact_leg, out[OUT_ALT:OUT_ALT + crash_module.MEASURES_SIZE])
            return out
        dob = self.dob
        dob_run = self._dob_kind != DOB_NONE
        if dob_run and not dob.started:  # type: ignore[attr-defined]
            # the observer's first step after a reset starts it at rest (numpy, once)
            out[OUT_D_HAT:OUT_D_HAT + 3] = dob.start(euler_rad, rate_frd)  # type: ignore
            dob_run = False
        _control_tick.call(self._ws, self._idx, self.full_thrust_n, dob_run, pos_ned, vel_ned,
                           euler_rad, rate_frd, ref_pos, ref_vel, ref_acc, yaw_ref,
                           torque_applied, out, time_s, contact_leg)
        return out

    def _step_parts(self, pos_ned: np.ndarray, vel_ned: np.ndarray, euler_rad: np.ndarray,
                    rate_frd: np.ndarray, ref_pos: np.ndarray, ref_vel: np.ndarray,
                    ref_acc: np.ndarray, yaw_ref: float, torque_applied: np.ndarray,
                    out: np.ndarray) -> None:
        """:func:`control_tick` through the parts' methods (parts without a kernel)."""
        cmd = self.position.step(pos_ned, vel_ned, ref_pos, ref_vel, ref_acc, yaw_ref)
        att_ref = self.reference_filter.step((cmd.roll_ref_rad, cmd.pitch_ref_rad, yaw_ref))
        torque = self.law.step(euler_rad, rate_frd, att_ref.euler_rad, att_ref.rate,
                               att_ref.acc)
        d_hat = self.dob.step(euler_rad, rate_frd, torque_applied)
        torque_cmd = torque - d_hat
        pwm = self.allocator.allocate(cmd.thrust_n, torque_cmd)
        _, applied = self.allocator.mix(pwm)
        out[OUT_PWM:OUT_PWM + 4] = pwm
        out[OUT_THRUST] = cmd.thrust_n
        out[OUT_TORQUE_CMD:OUT_TORQUE_CMD + 3] = torque_cmd
        out[OUT_D_HAT:OUT_D_HAT + 3] = d_hat
        out[_EULER:_EULER + 3] = att_ref.euler_rad
        out[_RATE:_RATE + 3] = att_ref.rate
        out[_ACC:_ACC + 3] = att_ref.acc
        out[OUT_ACCEL:OUT_ACCEL + 3] = cmd.accel_cmd_ned
        out[OUT_TORQUE_APPLIED:OUT_TORQUE_APPLIED + 3] = applied
        crash_measures(euler_rad, att_ref.euler_rad, pos_ned, vel_ned, cmd.thrust_n,
                       self.full_thrust_n, out)


def attitude_reference(out: np.ndarray) -> AttitudeReference:
    """The attitude reference of a tick's output ``out`` (views of it, no copies): what
    :func:`~fcu.control.attitude_reference.reference_of` makes of ``out[OUT_REF:]``, with
    the views taken from ``out`` directly (once a tick: one slicing fewer)."""
    ref = _NEW_OBJECT(AttitudeReference)  # AttitudeReference(...) without its __setattr__s
    _SET_EULER(ref, out[_EULER:_EULER + 3])
    _SET_RATE(ref, out[_RATE:_RATE + 3])
    _SET_ACC(ref, out[_ACC:_ACC + 3])
    return ref


# the slots of AttitudeReference (a frozen dataclass without __post_init__), set directly
_NEW_OBJECT = object.__new__
_SET_EULER, _SET_RATE, _SET_ACC = (getattr(AttitudeReference, name).__set__
                                   for name in ("euler_rad", "rate", "acc"))
