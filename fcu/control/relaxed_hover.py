"""Relaxed hover: the equilibrium of a quadrotor that has lost one rotor and gives up yaw.

With one rotor lost the remaining three cannot balance the yaw reaction torque while also
holding roll and pitch: the vehicle must spin. Mueller and D'Andrea (ICRA 2014, "Stability
and control of a quadrocopter despite the complete loss of one, two, or three propellers")
call the resulting periodic solution *relaxed hover*: the body turns at a constant rate
``omega_bar`` about a primary axis ``n`` fixed in the body and pointing up in the world; the
thrust, fixed in the body along ``-z_b``, then sweeps a cone about ``n`` and its mean over a
turn holds the weight. This module computes that equilibrium from the autopilot's vehicle
model (:class:`fcu.model.VehicleModel`), so the reduced-attitude controller
(:mod:`fcu.control.reduced_attitude`) can be designed about it at start-up.

Model (FRD body axes, motors 1 front, 2 back, 3 left, 4 right at ``r_i`` = (L, 0, 0),
(-L, 0, 0), (0, -L, 0), (0, L, 0); 1 and 2 counter-clockwise, 3 and 4 clockwise; eq. 3.17)::

    tau_B = sum_i r_i x (0, 0, -T_i) + (0, 0, K_psi (T1 + T2 - T3 - T4))
    tau_d = -diag(g_xy, g_xy, g_z) omega            (rate damping, sim.world.airframe)
    I d(omega)/dt = tau_B + tau_d - omega x I omega (eq. 3.6)

Relaxed hover is ``d(omega)/dt = 0`` with ``omega = w n`` (so ``n`` stays fixed in the world
too, the body turning about it) and a mean vertical force equal to the weight::

    tau_B(T) - w diag(g) n - w^2 n x I n = 0        (3 equations)
    (T1 + T2 + T3 + T4) (-n_z) = m g                (thrust component along n, 1 equation)
    |n| = 1                                         (1 equation)

Unknowns: the three remaining thrusts, ``n`` (three components) and ``w``: seven, against
five equations. Following Mueller and D'Andrea, the two rotors beside the lost one give equal
thrust ``T_s`` and the one opposite gives ``rho T_s``, ``rho`` a design choice: the five
equations then fix ``T_s``, ``n`` and ``w``. ``rho = 0`` (the opposite rotor off too, two
rotors flying) needs the most thrust from the two and spins fastest; ``rho = 1`` spins slowest
but its uncompensated pitch (or roll) torque ``L rho T_s`` must be balanced by the gyroscopic
term, which tilts ``n`` far from the thrust axis and wastes thrust. ``rho = 0.5`` keeps the
two side rotors below two thirds of full thrust (room for control) at a tilt under 10 deg.

Yaw balance, the equation that sets the spin: the lost rotor's reaction torque is missing,
``K_psi (T_opp - 2 T_s)`` in the sense of the lost rotor's own rotation, and only the rate
damping opposes it, so ``w g_z (-n_z) = K_psi (2 - rho) T_s``. For the Qball-X4 (Table 7.1:
m = 1.42 kg, L = 0.2 m, K_psi = 0.023 m, I = diag(0.03, 0.03, 0.04) kg*m^2; g_z = 0.010
N*m*s/rad from the drag model) and rho = 0.5, with motor 1 lost::

    T_s = T3 = T4 ~ m g / ((2 + rho) (-n_z)) = 5.6 N     (64 % of the 8.75 N maximum)
    T2 = rho T_s = 2.8 N,   T1 = 0
    w ~ K_psi (2 - rho) T_s / g_z = 19 rad/s             (3 turns per second)
    n ~ (-0.15, 0.0, -0.99): tilted about 9 deg towards the opposite rotor, where the
    gyroscopic torque (Izz - Ixx) w^2 n_z n_x balances the pitch torque L T2.

Solved exactly (with the roll damping's small cross term): T3 = T4 = 5.634 N, T2 = 2.817 N,
n = (-0.1473, -0.0053, -0.9891), w = 19.65 rad/s, body rates (-2.90, -0.10, -19.44) rad/s
(the vehicle turns anticlockwise seen from above, the sense of the missing counter-clockwise
rotor's reaction), tilt 8.5 deg. Motor 3 lost mirrors it: n = (0.0053, 0.1473, -0.9891),
r = +19.44 rad/s. With rho = 0: n = (0, 0, -1), T = 6.97 N (80 %), r = 32 rad/s; with
rho = 1: tilt 34 deg.

The solution is computed by Newton's method (:func:`scipy.optimize.fsolve`) on the five
equations; :func:`relaxed_hover` returns it, and tests/fcu/control/test_relaxed_hover.py
integrates the simulator's plant open loop from it and checks that it stays there. The
translational drag and the tiny circle the vehicle flies (the thrust's horizontal component
turns with the body: radius ``g tan(tilt) / w^2``, about 4 mm) are left out of the
equilibrium: their torques are three orders of magnitude below the terms above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fcu.model import VehicleModel
from flightdata.vocabulary import OPPOSITE_MOTOR

DEFAULT_OPPOSITE_RATIO = 0.5  # rho, T_opposite / T_side (module docstring)


def motor_positions(model: VehicleModel) -> np.ndarray:
    """Rotor hub positions r_i in body FRD, m, shape (4, 3) (eq. 3.17 layout)."""
    arm = model.arm_length
    return np.array([[arm, 0.0, 0.0], [-arm, 0.0, 0.0], [0.0, -arm, 0.0], [0.0, arm, 0.0]])


def torque_matrix(model: VehicleModel) -> np.ndarray:
    """Body torque per N of each motor's thrust, N*m/N, shape (3, 4): tau_B = M T (eq. 3.17)."""
    r = motor_positions(model)
    spin = np.array([1.0, 1.0, -1.0, -1.0])  # reaction torque sign (1, 2 counter-clockwise)
    # r_i x (0, 0, -1) = (-r_y, r_x, 0)
    return np.vstack([-r[:, 1], r[:, 0], model.yaw_gain * spin])


@dataclass(frozen=True)
class RelaxedHoverEquilibrium:
    """The relaxed-hover equilibrium with one rotor lost (module docstring).

    Attributes
    ----------
    lost_motor : int
        The lost motor, 1..4.
    opposite_ratio : float
        rho, thrust of the opposite motor over that of each side motor.
    thrust_n : numpy.ndarray
        Thrust per motor 1..4, N, shape (4,); 0 for the lost one.
    axis_frd : numpy.ndarray
        Primary axis n, unit vector in body FRD pointing up in the world, shape (3,).
    rate_frd : numpy.ndarray
        Body rates omega_bar = w n, rad/s, shape (3,).
    spin_rad_s : float
        w, rad/s: the signed turn rate about n (positive: right-handed about n, which points
        up, i.e. anticlockwise seen from above; the yaw rate ``w n_z`` is then negative).
    """

    lost_motor: int
    opposite_ratio: float
    thrust_n: np.ndarray
    axis_frd: np.ndarray
    rate_frd: np.ndarray
    spin_rad_s: float

    @property
    def yaw_rate_rad_s(self) -> float:
        """Body yaw rate r of the equilibrium, rad/s (what a gyro's z axis reads)."""
        return float(self.rate_frd[2])

    @property
    def tilt_rad(self) -> float:
        """Angle between the thrust axis -z_b and the primary axis n, rad."""
        return float(np.arccos(np.clip(-self.axis_frd[2], -1.0, 1.0)))

    @property
    def collective_n(self) -> float:
        """Sum of the motor thrusts, N."""
        return float(np.sum(self.thrust_n))


def _residual(unknowns: np.ndarray, model: VehicleModel, lost: int, rho: float,
              fixed_n: float) -> np.ndarray:
    """The five equations of the module docstring for (T_s, n_x, n_y, n_z, w)."""
    t_side, nx, ny, nz, w = unknowns
    thrust = _thrusts(lost, rho, float(t_side), fixed_n)
    n = np.array([nx, ny, nz])
    inertia = np.diag(model.inertia_diag)
    omega = w * n
    # tau_B + tau_d - omega x I omega = 0
    moment = (torque_matrix(model) @ thrust - np.asarray(model.rate_damping) * omega
              - np.cross(omega, inertia @ omega))
    weight = np.sum(thrust) * (-nz) - model.mass * model.gravity  # U1 (-n_z) = m g
    return np.array([*moment, weight, n @ n - 1.0])


def _thrusts(lost: int, rho: float, t_side: float, fixed_n: float) -> np.ndarray:
    """Motor thrusts (N): ``fixed_n`` for ``lost`` (0 when lost, what it is stuck at),
    ``fixed_n + rho (t_side - fixed_n)`` opposite, ``t_side`` beside it."""
    thrust = np.full(4, t_side)
    thrust[lost - 1] = fixed_n
    thrust[OPPOSITE_MOTOR[lost] - 1] = fixed_n + rho * (t_side - fixed_n)
    return thrust


MAX_TILT_RAD = math.radians(25.0)
"""The most a flyable equilibrium tilts its primary axis from the thrust axis: beyond it the
body wobbles so far about the axis that the mean thrust holds little of the weight."""
MAX_THRUST_FRACTION = 0.9
"""Of full thrust, the most a flyable equilibrium asks of a working motor: the rest steers."""


def _level_spin(model: VehicleModel, lost_motor: int, fixed_n: float
                 ) -> RelaxedHoverEquilibrium:
    """The equilibrium with the opposite motor at the failed one's thrust (rho = 0): no torque
    about their axis, so the primary axis is the thrust axis (n = (0, 0, -1)), the other
    pair holds the rest of the weight and the yaw torque, whatever it is, sets the spin
    (zero for a motor stuck at a quarter of the weight)."""
    side = (model.mass * model.gravity - 2.0 * fixed_n) / 2.0
    thrust = _thrusts(lost_motor, 0.0, side, fixed_n)
    if side < 0.0 or side > model.thrust_gain * model.pwm_max:
        raise ValueError(f"relaxed hover with motor {lost_motor} at {fixed_n:.2f} N needs "
                         f"{side:.2f} N on each side motor: the vehicle cannot hover")
    yaw_rate = float(torque_matrix(model)[2] @ thrust) / model.rate_damping[2]
    n = np.array([0.0, 0.0, -1.0])
    return RelaxedHoverEquilibrium(lost_motor=lost_motor, opposite_ratio=0.0, thrust_n=thrust,
                                   axis_frd=n, rate_frd=np.array([0.0, 0.0, yaw_rate]),
                                   spin_rad_s=-yaw_rate)


def relaxed_hover(model: VehicleModel, lost_motor: int,
                  opposite_ratio: float = DEFAULT_OPPOSITE_RATIO,
                  fixed_thrust_n: float = 0.0) -> RelaxedHoverEquilibrium:
    """Solve the relaxed-hover equilibrium of ``model`` with ``lost_motor`` (1..4) lost.

    Parameters
    ----------
    model : VehicleModel
        Nominal airframe, with its rate damping (> 0 in yaw: without it no equilibrium).
    lost_motor : int
        1..4.
    opposite_ratio : float
        rho in [0, 1]: thrust of the motor opposite the lost one over a side motor's.

    Raises
    ------
    ValueError
        For a motor outside 1..4, rho outside [0, 1], no yaw damping, or when Newton's
        method does not converge or the thrusts exceed the motors' range (the vehicle cannot
        hover on the remaining rotors).
    """
    if lost_motor not in OPPOSITE_MOTOR:
        raise ValueError(f"lost_motor = {lost_motor!r}: must be one of 1, 2, 3, 4")
    if not 0.0 <= opposite_ratio <= 1.0:
        raise ValueError(f"opposite_ratio = {opposite_ratio!r}: must lie in [0, 1]")
    g_z = model.rate_damping[2]
    if not g_z > 0.0:
        raise ValueError(f"rate_damping = {model.rate_damping!r}: the yaw damping must be > 0 "
                         "for a relaxed hover (else the spin grows without bound)")
    rho = float(opposite_ratio)
    fixed = float(fixed_thrust_n)
    weight = model.mass * model.gravity
    max_thrust = model.thrust_gain * model.pwm_max
    if not 0.0 <= fixed <= max_thrust:
        raise ValueError(f"fixed_thrust_n = {fixed_thrust_n!r}: must lie in [0, {max_thrust}] N")
    if rho == 0.0:
        return _level_spin(model, lost_motor, fixed)
    # level guess: U1 = weight
    t_side = (weight - (2.0 - rho) * fixed) / (2.0 + rho)
    # yaw torque of the level guess: the lost rotor's reaction is missing
    yaw_torque = float(torque_matrix(model)[2] @ _thrusts(lost_motor, rho, t_side, fixed))
    w0 = yaw_torque / (g_z * -1.0)  # omega_z = w n_z = yaw_torque / g_z with n_z = -1
    guess = np.array([t_side, 0.0, 0.0, -1.0, w0])
    from scipy.optimize import fsolve  # only once a rotor is lost: not at start-up

    solution, _, status, message = fsolve(_residual, guess,
                                          args=(model, lost_motor, rho, fixed),
                                          full_output=True, xtol=1e-12)
    residual = _residual(solution, model, lost_motor, rho, fixed)
    if status != 1 or not np.all(np.abs(residual) < 1e-9):
        raise ValueError(f"relaxed hover with motor {lost_motor} lost did not converge: "
                         f"{message}")
    t_side, nx, ny, nz, w = (float(v) for v in solution)
    thrust = _thrusts(lost_motor, rho, t_side, fixed)
    if nz >= 0.0 or np.max(thrust) > max_thrust or np.min(thrust) < 0.0:
        raise ValueError(f"relaxed hover with motor {lost_motor} lost needs {np.max(thrust):.2f} N "
                         f"per motor (at most {max_thrust:.2f} N): the vehicle cannot hover")
    n = np.array([nx, ny, nz])
    return RelaxedHoverEquilibrium(lost_motor=lost_motor, opposite_ratio=rho, thrust_n=thrust,
                                   axis_frd=n, rate_frd=w * n, spin_rad_s=w)





def failed_motor_equilibrium(model: VehicleModel, motor: int, fixed_thrust_n: float = 0.0
                             ) -> RelaxedHoverEquilibrium:
    """The relaxed hover around ``motor`` (1..4), which makes ``fixed_thrust_n`` (N) whatever
    it is told: 0 when lost, its thrust when stuck, full thrust when hard-over.

    rho is chosen by that thrust: 0.5 for a lost motor (Mueller and D'Andrea's choice: the
    side motors at two thirds of full thrust, 19 rad/s, 8.5 deg of tilt), and below 2 N
    (where the level solution would spin at 14-32 rad/s); 0 (level, the opposite motor
    matching the failed one) for one stuck between 2 N and what leaves the side motors 1 N
    each; 0.8 above (a hard-over: the side motors keep a margin for the
    torque they must make). When that rho has no solution, or one tilted more than
    ``MAX_TILT_RAD`` or asking more than ``MAX_THRUST_FRACTION`` of full thrust of a working
    motor, the next of 0.5, 0.8, 0.3, 1.0 is tried.

    Raises
    ------
    ValueError
        When none has a solution within the motors' range (the vehicle cannot hover).
    """
    fixed = float(fixed_thrust_n)
    if fixed < 2.0:
        preferred = DEFAULT_OPPOSITE_RATIO
    elif fixed <= model.mass * model.gravity / 2.0 - 1.0:
        preferred = 0.0
    else:
        preferred = 0.8
    error: ValueError | None = None
    for rho in dict.fromkeys((preferred, 0.5, 0.8, 0.3, 1.0)):
        try:
            eq = relaxed_hover(model, motor, rho, fixed)
        except ValueError as err:
            error = err
            continue
        top = MAX_THRUST_FRACTION * model.thrust_gain * model.pwm_max
        free = [t for i, t in enumerate(eq.thrust_n) if i != motor - 1]
        if eq.tilt_rad <= MAX_TILT_RAD and max(free) <= top:
            return eq
        error = ValueError(f"relaxed hover around motor {motor} at {fixed:.2f} N needs "
                           f"{max(free):.2f} N of a motor and tilts the primary axis "
                           f"{math.degrees(eq.tilt_rad):.0f} deg from the thrust axis (at most "
                           f"{top:.2f} N, {math.degrees(MAX_TILT_RAD):.0f} deg): the vehicle "
                           "cannot hover")
    assert error is not None
    raise error


__all__ = ["DEFAULT_OPPOSITE_RATIO", "OPPOSITE_MOTOR", "RelaxedHoverEquilibrium",
           "failed_motor_equilibrium", "motor_positions", "relaxed_hover", "torque_matrix"]
