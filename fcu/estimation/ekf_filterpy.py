"""The EKF as filterpy's ``ExtendedKalmanFilter`` holds it: the view
:attr:`fcu.estimation.ekf.ExtendedKalmanEstimator.filter` returns, and the contract the
compiled algebra of :mod:`fcu.estimation.ekf` is tested against.

A module of its own so that importing the estimator does not import filterpy (and the
scipy.stats it loads, about a second of start-up): the autopilot's tick never needs it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter

from fcu.estimation.ekf_model import discrete_transition
from fcu.estimation.ekf_predict import predict_covariance
from fcu.estimation.kalman_update import kalman_update
from fcu.estimation.state import STATE_DIM, YAW_INDEX, FloatArray
from fcu.floats import wrap_pi

__all__ = ["QuadrotorEKF"]


class QuadrotorEKF(ExtendedKalmanFilter):
    """filterpy's EKF with the nonlinear prediction of this module and a compiled update.

    filterpy's ``predict(u)`` calls :meth:`predict_x`, then applies ``P = F P F' + Q`` with the
    ``F`` and ``Q`` that :meth:`predict_x` just set, and stores ``x_prior``, ``P_prior``;
    :meth:`predict` here does the same in one compiled call (:func:`predict_covariance`).

    :meth:`update` keeps filterpy's signature and effects (``y``, ``S``, ``SI``, ``K``, ``z``,
    ``x_post``, ``P_post``; Joseph-form covariance) but runs the matrix algebra in
    :func:`kalman_update`: filterpy's own version (scipy ``inv`` with its argument checks,
    ``deepcopy``) costs 16-35 us per call on this machine, and a tick has three or four.
    ``tests/fcu/estimation/test_ekf.py`` checks the two against each other. The estimator
    goes further and runs a whole tick (predictions, screening, updates) in one compiled call
    (:func:`ekf_tick`, the same algebra); its :attr:`ExtendedKalmanEstimator.filter` is this
    object with the attributes the last :meth:`predict` and :meth:`update` would have set.
    """

    x: FloatArray
    P: FloatArray
    F: FloatArray
    Q: FloatArray
    y: FloatArray
    S: FloatArray
    SI: FloatArray
    K: FloatArray
    z: FloatArray
    x_prior: FloatArray
    P_prior: FloatArray
    x_post: FloatArray
    P_post: FloatArray

    def __init__(self, params: FloatArray, qc_diag: FloatArray) -> None:
        super().__init__(dim_x=STATE_DIM, dim_z=3)
        self.params = params
        self.qc_diag = qc_diag
        self.x = np.zeros(STATE_DIM)
        self.step_dt_s = 0.0  # set before each predict()
        self.on_ground = False  # set before each predict()

    def predict(self, u: FloatArray = 0) -> None:  # type: ignore[assignment]
        """filterpy's ``predict`` (``predict_x``, ``P = F P F' + Q``, priors), compiled."""
        self.x, self.F, self.Q, self.P = predict_covariance(
            self.x, self.P, u, self.step_dt_s, self.params, self.on_ground, self.qc_diag)
        self.x_prior = self.x.copy()
        self.P_prior = self.P.copy()

    def predict_x(self, u: FloatArray = 0) -> None:  # type: ignore[assignment]
        # x_{k+1|k} = RK4(f, x_{k|k}, u_k, dt);  F = sum (A dt)^n/n!;  Q = Van Loan (see module)
        x_next, f_mat, q_mat = discrete_transition(self.x, u, self.step_dt_s, self.params,
                                                   self.on_ground, self.qc_diag)
        x_next[YAW_INDEX] = wrap_pi(x_next[YAW_INDEX])
        self.x = x_next
        self.F = f_mat
        self.Q = q_mat

    def update(self, z: FloatArray | None, HJacobian: Callable[..., FloatArray],  # noqa: N803
               Hx: Callable[..., FloatArray], R: FloatArray | float | None = None,  # noqa: N803
               args: tuple[object, ...] = (), hx_args: tuple[object, ...] = (),
               residual: Callable[[FloatArray, FloatArray], FloatArray] = np.subtract,
               ) -> None:
        """filterpy's ``ExtendedKalmanFilter.update`` contract, compiled algebra."""
        if z is None:
            self.x_post = self.x.copy()
            self.P_post = self.P.copy()
            return
        r_mat: FloatArray
        if R is None:
            r_mat = np.asarray(self.R, dtype=float)
        elif isinstance(R, (int, float)):
            r_mat = np.eye(len(z)) * float(R)
        else:
            r_mat = np.asarray(R, dtype=float)
        h_mat = HJacobian(self.x, *args)
        # y = z - h(x)
        self.y = residual(z, Hx(self.x, *hx_args))
        # K = P H' (H P H' + R)^-1;  x = x + K y;  P = (I-KH) P (I-KH)' + K R K'
        self.x, self.P, self.S, self.SI, self.K = kalman_update(
            self.x, self.P, self.y, h_mat, r_mat)
        self.z = np.array(z, dtype=float)
        self.x_post = self.x.copy()
        self.P_post = self.P.copy()
