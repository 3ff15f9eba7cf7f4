"""The TSKF's model: the augmented linear hover model (eq. 6.1-6.9) and its discretisation.

Used by the filter in :mod:`fcu.estimation.tskf`.

Model
-----
Eq. 6.1 is the hover linearisation; written in NED/FRD it reads (the thesis's first line,
``x' = theta g``, is a typo for ``x'' = theta g`` in its z-up frame; in NED a nose-up pitch
tilts the thrust backwards)::

    x'' = -g theta        y'' = g phi        z'' = g - U1/m
    phi'' = U2/Ixx        theta'' = U3/Iyy   psi'' = U4/Izz

with U = eq. 3.17 applied to the motor thrusts. The state is augmented with the four thrusts,
whose lag is eq. 6.4 (``T_i' = w (K u_i - T_i)``), giving eq. 6.3 with the layout of
:mod:`fcu.estimation.state` (the thesis orders it [x, x', y, y', ...]; same content)::

    x_a = [p (3), v (3), (phi, theta, psi), (p, q, r), T1..T4]                  (16)
    x_a' = A_a x_a + B_a (I - Gamma) u + g_a                                     (eq. 6.5)

``B_a`` is non-zero only in the thrust rows (``K w I``): a PWM command acts on the motion only
through its thrust. Loss of effectiveness in additive form (eq. 6.6):
``B_a (I - Gamma) u = B_a u + E_a gamma`` with ``E_a = -B_a diag(u)``.

Gravity. Linearised about hover, the vertical row keeps the affine term ``g``
(``z'' = g - sum(T)/m``, eq. 6.1) because the thrusts are absolute states, not deviations.
It is handled as a known constant input: the continuous model is discretised with the input
vector ``[u1, u2, u3, u4, 1]`` and input matrix ``[B_a, g e_vz]`` by zero-order hold
(``scipy.signal.cont2discrete``; gravity is constant over a tick, so ZOH is exact for it). The
discrete model is therefore (eq. 6.8, with ``g_k`` the gravity column)::

    x_{k+1} = A_k x_k + B_k u_k + g_k + E_k gamma_k + w_k,    E_k = -B_k diag(u_k)
    gamma_{k+1} = gamma_k + w^gamma_k                                           (eq. 6.9)
    y_k = C_k x_k + v_k

The linear model assumes small roll and pitch and a yaw near zero (the horizontal rows are
those of psi = 0). Its rate states are read as body rates (what the gyro measures) and the
attitude kinematics are linearised to ``eta' = omega``; the second-order kinematic error
(``psi' - r ~ q phi`` while pitching at 2 rad/s with a few hundredths of roll: 0.04 rad/s)
is left to the attitude rows' process noise rather than to the rate rows, where it would read
as a yaw torque and so as a gamma (see :class:`TskfProcessNoise`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from fcu.estimation.estimator import ProcessNoiseDensities
from fcu.estimation.state import EULER, POS, RATE, STATE_DIM, THRUST, VEL, FloatArray
from fcu.model import VehicleModel
from flightdata.design_cache import cached_design, cont2discrete
from flightdata.vocabulary import MOTORS

N_MOTORS = len(MOTORS)


@dataclass(frozen=True, kw_only=True)
class TskfProcessNoise(ProcessNoiseDensities):
    """Continuous process-noise spectral densities ``Q^x`` of the TSKF's linear model.

    Tuned on the closed-loop harness of tests/fcu/estimation/test_tskf.py (nonlinear
    quaternion plant, motor lag, drag and gusts, noisy sensors at their own rates, Table 6.1
    step profile); seeds 1-6, gusts 0.3-1.0 m/s:

    * ``euler`` 1e-3 rad^2/s: absorbs the kinematic linearisation error (module docstring).
      At 1e-7 the error went into gamma: motor 4 read 0.11 before its fault and motor 3 left
      its 0.05 band for 17 s when motor 1 failed (1e-2: no change from 1e-3).
    * ``ang_accel`` 0.3 (rad/s^2)^2/Hz: 0.1 let unmodelled torques into gamma (band left on
      one seed), 1.0 slowed the motors' separation (healthy estimates up to 0.1).
    * ``accel`` 0.05 (m/s^2)^2/Hz: drag and the thrust-tilt term of the z row.
    * ``thrust`` 0.01 N^2/s: small, so that a persistent thrust deficit is explained by
      gamma rather than by thrust-state noise (0.001-0.1 made no measurable difference).
    * ``pos`` 1e-8 m^2/s: the position rows are exact.
    """

    pos: float = 1e-8  # m^2/s
    accel: float = 0.05  # (m/s^2)^2/Hz, each NED axis
    euler: float = 1e-3  # rad^2/s
    ang_accel: float = 0.3  # (rad/s^2)^2/Hz, each axis
    thrust: float = 0.01  # N^2/s, each motor


@dataclass(frozen=True)
class LinearHoverModel:
    """Continuous and ZOH-discrete matrices of the augmented hover model (module docstring).

    Attributes
    ----------
    a_c : ndarray, shape (16, 16)
        Continuous ``A_a``.
    b_c : ndarray, shape (16, 4)
        Continuous ``B_a`` (PWM to thrust-rate, ``K w`` in the thrust rows).
    g_c : ndarray, shape (16,)
        Continuous gravity input (``g`` in the vz row; zero for the ground model).
    a_d, b_d, g_d : ndarrays, shapes (16, 16), (16, 4), (16,)
        ZOH discretisation over ``dt_s``.
    q_d : ndarray, shape (16, 16)
        Discrete ``Q^x = int_0^dt e^{A s} Qc e^{A' s} ds`` (Van Loan, exact).
    """

    a_c: FloatArray
    b_c: FloatArray
    g_c: FloatArray
    a_d: FloatArray
    b_d: FloatArray
    g_d: FloatArray
    q_d: FloatArray


def hover_model(model: VehicleModel, dt_s: float, qc_diag: FloatArray,
                on_ground: bool = False) -> LinearHoverModel:
    """Build the augmented linear hover model (eq. 6.1, 6.3, 6.4) and discretise it (ZOH).

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe.
    dt_s : float
        Sample period, s.
    qc_diag : ndarray, shape (16,)
        Continuous process-noise spectral densities.
    on_ground : bool
        Build the ground model (no accelerations, no gravity input).

    Returns
    -------
    LinearHoverModel
    """
    g, m, k, w = model.gravity, model.mass, model.thrust_gain, model.motor_bandwidth
    inertia = model.inertia_diag
    torque = model.thrust_mixer()[1:, :]  # (3, 4): thrusts -> roll, pitch, yaw torques
    a = np.zeros((STATE_DIM, STATE_DIM))
    b = np.zeros((STATE_DIM, N_MOTORS))
    gc = np.zeros(STATE_DIM)
    # p' = v
    a[POS, VEL] = np.eye(3)
    # (phi, theta, psi)' = (p, q, r)   (attitude kinematics linearised at hover)
    a[EULER, RATE] = np.eye(3)
    if not on_ground:
        # x'' = -g theta;  y'' = g phi;  z'' = g - sum(T)/m
        a[3, 7] = -g
        a[4, 6] = g
        a[5, THRUST] = -1.0 / m
        gc[5] = g
        # (p, q, r)' = I^-1 (L (T3 - T4), L (T1 - T2), K_psi (T1 + T2 - T3 - T4))
        a[RATE, THRUST] = torque / inertia[:, None]
    # T' = -w T + K w u
    a[THRUST, THRUST] = -w * np.eye(N_MOTORS)
    b[THRUST, :] = k * w * np.eye(N_MOTORS)
    b_ext = np.hstack((b, gc[:, None]))
    a_d, b_ext_d, _, _, _ = cont2discrete((a, b_ext, np.eye(STATE_DIM),
                                           np.zeros((STATE_DIM, N_MOTORS + 1))),
                                          dt_s, method="zoh")
    (q_d,) = van_loan_noise(a, np.asarray(qc_diag, dtype=float), float(dt_s))

    def contiguous(arr: ArrayLike) -> FloatArray:
        return np.ascontiguousarray(arr, dtype=float)

    return LinearHoverModel(a_c=contiguous(a), b_c=contiguous(b), g_c=contiguous(gc),
                            a_d=contiguous(a_d), b_d=contiguous(b_ext_d[:, :N_MOTORS]),
                            g_d=contiguous(b_ext_d[:, N_MOTORS]), q_d=contiguous(q_d))


@cached_design  # made once per configuration and kept (flightdata.design_cache)
def van_loan_noise(a: FloatArray, qc_diag: FloatArray, dt_s: float) -> tuple[FloatArray]:
    """``Qd = int_0^dt e^(A s) Qc e^(A' s) ds`` by Van Loan's method (scipy's ``expm``,
    imported only when the design cache misses), made exactly symmetric."""
    from scipy.linalg import expm

    # Van Loan: expm([[-A, Qc], [0, A']] dt) = [[., Phi^-1 Qd], [0, Phi']]
    n = a.shape[0]
    vl = np.zeros((2 * n, 2 * n))
    vl[:n, :n] = -a
    vl[:n, n:] = np.diag(qc_diag)
    vl[n:, n:] = a.T
    e = expm(vl * dt_s)
    phi = e[n:, n:].T
    q_d = phi @ e[:n, n:]
    return (0.5 * (q_d + q_d.T),)


@functools.lru_cache(maxsize=16)
def shared_hover_model(model: VehicleModel, dt_s: float, qc_diag: tuple[float, ...],
                        on_ground: bool) -> LinearHoverModel:
    """:func:`hover_model`, built once per process and configuration (read-only arrays).

    Its discretisation calls scipy's ``expm`` and ``solve``, which wake OpenBLAS's worker
    threads; those then spin for about 0.1 s of CPU time. A process that builds many
    filters (a batch of flights, a benchmark, the tests) pays that once.
    """
    lm = hover_model(model, dt_s, np.array(qc_diag), on_ground)
    for arr in (lm.a_c, lm.b_c, lm.g_c, lm.a_d, lm.b_d, lm.g_d, lm.q_d):
        arr.setflags(write=False)
    return lm


__all__ = [
    "N_MOTORS",
    "LinearHoverModel",
    "TskfProcessNoise",
    "hover_model",
    "shared_hover_model",
    "van_loan_noise",
]
