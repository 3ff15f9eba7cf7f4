"""Rigid-body plant of the quadrotor: motor lag, mixer, Newton-Euler equations, RK4, ground.

Conventions (docs/design.md): world NED (z down), body FRD, thrust along -z_body, quaternion
[w, x, y, z] rotating body vectors into NED, Euler angles ZYX with R = Rz(yaw) Ry(pitch)
Rx(roll). The state is a float64 vector of 17 entries:

=======  ==================  =======
index    name                unit
=======  ==================  =======
0:3      pos_ned             m
3:6      vel_ned             m/s
6:10     quat wxyz           -
10:13    rate_frd (p, q, r)  rad/s
13:17    thrust T1..T4       N
=======  ==================  =======

Model (thesis chapter 3, with the corrections of the reading notes)
-------------------------------------------------------------------
Motors, eq. 3.1 as a state-space lag on thrust::

    dT_i/dt = w (K u_i - T_i)

Body torques from thrusts, eq. 3.17 (motor 1 front, 2 back, 3 left, 4 right; 1 and 2 spin
counter-clockwise seen from above, 3 and 4 clockwise)::

    U1 = T1 + T2 + T3 + T4            (N, along -z_body)
    U2 = L (T3 - T4)                  roll:  the left rotor lifts the left side
    U3 = L (T1 - T2)                  pitch: the front rotor lifts the nose
    U4 = K_psi (T1 + T2 - T3 - T4)    yaw:   reaction of the counter-clockwise pair

These follow from tau = sum r_i x (0, 0, -T_i) with r_1 = (L, 0, 0), r_2 = (-L, 0, 0),
r_3 = (0, -L, 0), r_4 = (0, L, 0) in FRD.

Translation, eq. 3.5 written in the inertial NED frame (which removes eq. 3.5's
``w_b x v_b`` term: it is the derivative of R taken in the body frame)::

    dp/dt = v
    dv/dt = g e3 + R (F_thrust_b + F_drag_b) / m,     F_thrust_b = (0, 0, -U1)

Rotation, eq. 3.6 with the gyroscopic rotor moments ``g_a`` of eq. 3.15 neglected (as the
thesis does: rotor inertia is tiny against the airframe's)::

    d(omega)/dt = I^-1 (tau_B + tau_w - omega x I omega),   tau_B = (U2, U3, U4)
    dq/dt = 0.5 q (x) (0, omega)

Wind force and torque (the ``f_w``, ``tau_w`` of eq. 3.14/3.15) are the drag model documented
in :mod:`sim.world.airframe`, evaluated on the air-relative velocity in body axes
``v_b = R^T (v - wind_ned)``: ``F_drag_b = -D v_b - c_q |v_b| v_b``,
``tau_w = (0, 0, z_cp) x F_drag_b``.

The numerical kernels are numba ``@njit`` functions taking a packed parameter vector
(:func:`pack_params`); :class:`RigidBodyPlant` wraps them with PWM saturation and ground
contact.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from flightdata.config import finite
from sim.world.airframe import Airframe

FloatArray = NDArray[np.float64]

# ---- state layout ------------------------------------------------------------------------
STATE_SIZE = 17  # entries of the plant state vector
POS_NED = slice(0, 3)  # m
VEL_NED = slice(3, 6)  # m/s
QUAT_WXYZ = slice(6, 10)  # unit quaternion, body FRD -> NED
RATE_FRD = slice(10, 13)  # rad/s
THRUST_N = slice(13, 17)  # N, motors 1..4

# ---- packed parameter layout (pack_params) -----------------------------------------------
P_THRUST_GAIN = 0  # K, N per unit PWM
P_MOTOR_BANDWIDTH = 1  # w, rad/s
P_ARM_LENGTH = 2  # L, m
P_YAW_GAIN = 3  # K_psi, N*m per N
P_GRAVITY = 4  # g, m/s^2
P_IXX = 5  # kg*m^2
P_IYY = 6  # kg*m^2
P_IZZ = 7  # kg*m^2
P_DRAG_XY = 8  # N/(m/s)
P_DRAG_Z = 9  # N/(m/s)
P_DRAG_QUAD = 10  # N/(m/s)^2
P_CP_Z = 11  # m, body z of the centre of pressure
P_PWM_MIN = 12  # PWM duty
P_PWM_MAX = 13  # PWM duty
P_CRASH_SPEED = 14  # m/s
PARAM_SIZE = 15

# ---- ground-contact flags of RigidBodyPlant (float64[3]) ---------------------------------
_F_ON_GROUND = 0  # 1.0 while resting on the ground
_F_CRASHED = 1  # 1.0 after a touchdown faster than crash_speed_m_s (sticky until reset)
_F_TOUCHDOWN_SPEED = 2  # m/s of the last touchdown, -1.0 when none since reset


def pack_params(airframe: Airframe) -> FloatArray:
    """Pack an airframe into the float64 parameter vector the numba kernels take.

    Parameters
    ----------
    airframe : Airframe
        Physical parameters (Table 7.1 plus the drag model).

    Returns
    -------
    numpy.ndarray
        Shape (PARAM_SIZE,), indexed by the ``P_*`` constants of this module. The mass is not
        in it: it is an input of every call, because structural faults change it in flight.
    """
    p = np.empty(PARAM_SIZE, dtype=np.float64)
    p[P_THRUST_GAIN] = airframe.thrust_gain
    p[P_MOTOR_BANDWIDTH] = airframe.motor_bandwidth
    p[P_ARM_LENGTH] = airframe.arm_length
    p[P_YAW_GAIN] = airframe.yaw_gain
    p[P_GRAVITY] = airframe.gravity
    p[P_IXX], p[P_IYY], p[P_IZZ] = airframe.inertia
    p[P_DRAG_XY] = airframe.drag_coeff_xy
    p[P_DRAG_Z] = airframe.drag_coeff_z
    p[P_DRAG_QUAD] = airframe.drag_quad_coeff
    p[P_CP_Z] = airframe.cp_offset_z
    p[P_PWM_MIN] = airframe.pwm_min
    p[P_PWM_MAX] = airframe.pwm_max
    p[P_CRASH_SPEED] = airframe.crash_speed_m_s
    return p


# ---- rotations ---------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _rotation_entries(
    qw: float, qx: float, qy: float, qz: float
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """Entries r00..r22 of R(q), body FRD -> NED; q need not be exactly unit (it is scaled)."""
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    r00 = 1.0 - s * (qy * qy + qz * qz)
    r01 = s * (qx * qy - qw * qz)
    r02 = s * (qx * qz + qw * qy)
    r10 = s * (qx * qy + qw * qz)
    r11 = 1.0 - s * (qx * qx + qz * qz)
    r12 = s * (qy * qz - qw * qx)
    r20 = s * (qx * qz - qw * qy)
    r21 = s * (qy * qz + qw * qx)
    r22 = 1.0 - s * (qx * qx + qy * qy)
    return r00, r01, r02, r10, r11, r12, r20, r21, r22


@njit(cache=True, error_model="numpy")
def quat_to_rotation(q: FloatArray) -> FloatArray:
    """Rotation matrix of a quaternion, R = Rz(yaw) Ry(pitch) Rx(roll) (corrected eq. 3.9).

    Parameters
    ----------
    q : numpy.ndarray
        Quaternion [w, x, y, z], float64, shape (4,); a non-unit q is normalised.

    Returns
    -------
    numpy.ndarray
        Shape (3, 3), maps body FRD vectors to NED (v = R v_b, eq. 3.7).
    """
    r = _rotation_entries(q[0], q[1], q[2], q[3])
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = r[3 * i + j]
    return out


@njit(cache=True, error_model="numpy")
def euler_to_quat(roll_rad: float, pitch_rad: float, yaw_rad: float) -> FloatArray:
    """Unit quaternion [w, x, y, z] of ZYX Euler angles, q = q_z(yaw) q_y(pitch) q_x(roll).

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : float
        phi (right side down positive), theta (nose up positive), psi (nose right positive),
        rad.

    Returns
    -------
    numpy.ndarray
        Shape (4,), with the same rotation as R = Rz(psi) Ry(theta) Rx(phi) (eq. 3.9).
    """
    cr, sr = math.cos(0.5 * roll_rad), math.sin(0.5 * roll_rad)
    cp, sp = math.cos(0.5 * pitch_rad), math.sin(0.5 * pitch_rad)
    cy, sy = math.cos(0.5 * yaw_rad), math.sin(0.5 * yaw_rad)
    q = np.empty(4)
    q[0] = cr * cp * cy + sr * sp * sy
    q[1] = sr * cp * cy - cr * sp * sy
    q[2] = cr * sp * cy + sr * cp * sy
    q[3] = cr * cp * sy - sr * sp * cy
    return q


@njit(cache=True, error_model="numpy")
def _yaw_of(qw: float, qx: float, qy: float, qz: float) -> float:
    """ZYX yaw psi of a quaternion, rad in (-pi, pi]."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


@njit(cache=True, error_model="numpy")
def quat_to_euler(q: FloatArray) -> FloatArray:
    """ZYX Euler angles (roll, pitch, yaw) of a unit quaternion [w, x, y, z].

    Parameters
    ----------
    q : numpy.ndarray
        Unit quaternion, float64, shape (4,).

    Returns
    -------
    numpy.ndarray
        [phi, theta, psi] in rad, shape (3,): roll and yaw in (-pi, pi], pitch in
        [-pi/2, pi/2], such that R(q) = Rz(psi) Ry(theta) Rx(phi) (eq. 3.9). At gimbal lock
        (|theta| = pi/2, where only psi -/+ phi is defined) phi is returned as 0.
    """
    qw, qx, qy, qz = q[0], q[1], q[2], q[3]
    out = np.empty(3)
    # sin(theta) = -R[2, 0]; clipped against round-off beyond +-1 at the poles
    s = 2.0 * (qw * qy - qz * qx)
    out[1] = math.asin(min(1.0, max(-1.0, s)))
    if abs(s) > 1.0 - 1e-15:
        # gimbal lock (|theta| = 90 deg): both atan2 below read 0/0. Only psi -/+ phi is
        # defined; with phi = 0, q = (c cos(psi/2), .., .., c sin(psi/2)) for either pole.
        out[0] = 0.0
        yaw = 2.0 * math.atan2(qz, qw)
        out[2] = yaw - 2.0 * math.pi if yaw > math.pi else (
            yaw + 2.0 * math.pi if yaw <= -math.pi else yaw)
        return out
    out[0] = math.atan2(2.0 * (qw * qx + qy * qz), 1.0 - 2.0 * (qx * qx + qy * qy))
    out[2] = _yaw_of(qw, qx, qy, qz)
    return out


# ---- forces ------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _body_force(
    x: FloatArray, wind_ned: FloatArray, p: FloatArray,
    r00: float, r01: float, r02: float,
    r10: float, r11: float, r12: float,
    r20: float, r21: float, r22: float,
) -> tuple[float, float, float, float, float]:
    """Thrust plus drag in body FRD (N), and the drag components fdx, fdy (N) for tau_w."""
    # air-relative velocity in body axes, v_b = R^T (v - wind)
    ax = x[3] - wind_ned[0]
    ay = x[4] - wind_ned[1]
    az = x[5] - wind_ned[2]
    vbx = r00 * ax + r10 * ay + r20 * az
    vby = r01 * ax + r11 * ay + r21 * az
    vbz = r02 * ax + r12 * ay + r22 * az
    quad = p[P_DRAG_QUAD] * math.sqrt(vbx * vbx + vby * vby + vbz * vbz)
    # F_drag_b = -D v_b - c_q |v_b| v_b  (f_w of eq. 3.14)
    fdx = -(p[P_DRAG_XY] + quad) * vbx
    fdy = -(p[P_DRAG_XY] + quad) * vby
    fdz = -(p[P_DRAG_Z] + quad) * vbz
    # thrust along -z_body: F_thrust_b = (0, 0, -U1), U1 = sum T_i (eq. 3.17)
    u1 = x[13] + x[14] + x[15] + x[16]
    return fdx, fdy, fdz - u1, fdx, fdy


@njit(cache=True, error_model="numpy")
def _derivative_into(
    x: FloatArray, u_pwm: FloatArray, wind_ned: FloatArray, mass_kg: float, p: FloatArray,
    out: FloatArray,
) -> None:
    """Write dx/dt into ``out`` (see :func:`derivative`); ``out`` must not alias ``x``."""
    qw, qx, qy, qz = x[6], x[7], x[8], x[9]
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = _rotation_entries(qw, qx, qy, qz)
    fbx, fby, fbz, fdx, fdy = _body_force(
        x, wind_ned, p, r00, r01, r02, r10, r11, r12, r20, r21, r22)

    # dp/dt = v
    out[0] = x[3]
    out[1] = x[4]
    out[2] = x[5]
    # eq. 3.5 in NED: dv/dt = g e3 + R F_b / m
    inv_m = 1.0 / mass_kg
    out[3] = (r00 * fbx + r01 * fby + r02 * fbz) * inv_m
    out[4] = (r10 * fbx + r11 * fby + r12 * fbz) * inv_m
    out[5] = p[P_GRAVITY] + (r20 * fbx + r21 * fby + r22 * fbz) * inv_m

    # dq/dt = 0.5 q (x) (0, omega)
    wp, wq, wr = x[10], x[11], x[12]
    out[6] = -0.5 * (qx * wp + qy * wq + qz * wr)
    out[7] = 0.5 * (qw * wp + qy * wr - qz * wq)
    out[8] = 0.5 * (qw * wq + qz * wp - qx * wr)
    out[9] = 0.5 * (qw * wr + qx * wq - qy * wp)

    # eq. 3.17: control torques from thrusts; tau_w = (0, 0, z_cp) x F_drag_b
    t1, t2, t3, t4 = x[13], x[14], x[15], x[16]
    arm = p[P_ARM_LENGTH]
    zcp = p[P_CP_Z]
    tau_x = arm * (t3 - t4) - zcp * fdy
    tau_y = arm * (t1 - t2) + zcp * fdx
    tau_z = p[P_YAW_GAIN] * (t1 + t2 - t3 - t4)
    # eq. 3.6: I dw/dt = tau - w x I w  (g_a neglected)
    ixx, iyy, izz = p[P_IXX], p[P_IYY], p[P_IZZ]
    out[10] = (tau_x + (iyy - izz) * wq * wr) / ixx
    out[11] = (tau_y + (izz - ixx) * wr * wp) / iyy
    out[12] = (tau_z + (ixx - iyy) * wp * wq) / izz

    # eq. 3.1: dT_i/dt = w (K u_i - T_i)
    k = p[P_THRUST_GAIN]
    bw = p[P_MOTOR_BANDWIDTH]
    for i in range(4):
        out[13 + i] = bw * (k * u_pwm[i] - x[13 + i])


@njit(cache=True, error_model="numpy")
def derivative(
    x: FloatArray, u_pwm: FloatArray, wind_ned: FloatArray, mass_kg: float, params: FloatArray
) -> FloatArray:
    """Time derivative of the airborne plant state (eq. 3.1, 3.5, 3.6, 3.17).

    A pure function: no saturation, no ground (both live in :class:`RigidBodyPlant`).

    Parameters
    ----------
    x : numpy.ndarray
        State, float64, shape (17,) (layout in the module docstring).
    u_pwm : numpy.ndarray
        PWM command per motor 1..4, float64, shape (4,), dimensionless duty.
    wind_ned : numpy.ndarray
        Wind velocity in NED, m/s, float64, shape (3,).
    mass_kg : float
        Current mass, kg.
    params : numpy.ndarray
        Output of :func:`pack_params`.

    Returns
    -------
    numpy.ndarray
        dx/dt, shape (17,), in the state's units per second.
    """
    out = np.empty(STATE_SIZE)
    _derivative_into(x, u_pwm, wind_ned, mass_kg, params, out)
    return out


@njit(cache=True, error_model="numpy")
def _rk4_into(
    x: FloatArray, u_pwm: FloatArray, wind_ned: FloatArray, mass_kg: float, p: FloatArray,
    dt: float, work: FloatArray, out: FloatArray,
) -> None:
    """Classical RK4 step into ``out`` (may alias ``x``); ``work`` is float64[>=5, 17]."""
    k1, k2, k3, k4, tmp = work[0], work[1], work[2], work[3], work[4]
    _derivative_into(x, u_pwm, wind_ned, mass_kg, p, k1)
    h2 = 0.5 * dt
    for i in range(STATE_SIZE):
        tmp[i] = x[i] + h2 * k1[i]
    _derivative_into(tmp, u_pwm, wind_ned, mass_kg, p, k2)
    for i in range(STATE_SIZE):
        tmp[i] = x[i] + h2 * k2[i]
    _derivative_into(tmp, u_pwm, wind_ned, mass_kg, p, k3)
    for i in range(STATE_SIZE):
        tmp[i] = x[i] + dt * k3[i]
    _derivative_into(tmp, u_pwm, wind_ned, mass_kg, p, k4)
    h6 = dt / 6.0
    for i in range(STATE_SIZE):
        out[i] = x[i] + h6 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    # renormalise the quaternion (RK4 does not preserve |q| = 1 exactly)
    n = math.sqrt(out[6] * out[6] + out[7] * out[7] + out[8] * out[8] + out[9] * out[9])
    for i in range(6, 10):
        out[i] /= n


@njit(cache=True, error_model="numpy")
def rk4_step(
    x: FloatArray, u_pwm: FloatArray, wind_ned: FloatArray, mass_kg: float, params: FloatArray,
    dt: float,
) -> FloatArray:
    """One fixed-step classical Runge-Kutta step of :func:`derivative`, |q| renormalised.

    Parameters
    ----------
    x, u_pwm, wind_ned, mass_kg, params
        As for :func:`derivative`; ``u_pwm``, ``wind_ned`` and ``mass_kg`` are held over the
        step (zero-order hold). No saturation, no ground.
    dt : float
        Step, s.

    Returns
    -------
    numpy.ndarray
        New state, shape (17,); ``x`` is not modified.
    """
    work = np.empty((5, STATE_SIZE))
    out = np.empty(STATE_SIZE)
    _rk4_into(x, u_pwm, wind_ned, mass_kg, params, dt, work, out)
    return out


@njit(cache=True, error_model="numpy")
def specific_force_frd(
    x: FloatArray, wind_ned: FloatArray, mass_kg: float, params: FloatArray
) -> FloatArray:
    """Specific force in body FRD, what an ideal accelerometer measures, m/s^2.

    Airborne it is the non-gravitational force over mass, (F_thrust_b + F_drag_b) / m
    (eq. 3.5 without gravity): in hover (0, 0, -U1/m) = (0, 0, -g). In contact with the
    ground (z_ned >= 0 and not climbing) and pressed onto it (the airborne acceleration
    would point down), the ground holds the vehicle at rest, so the specific force is
    a - g e3 = -g e3 in NED, R^T (0, 0, -g) in body: (0, 0, -g) when level.

    Parameters
    ----------
    x : numpy.ndarray
        State, shape (17,).
    wind_ned : numpy.ndarray
        Wind velocity in NED, m/s, shape (3,).
    mass_kg : float
        Current mass, kg.
    params : numpy.ndarray
        Output of :func:`pack_params`.

    Returns
    -------
    numpy.ndarray
        Specific force (f_x, f_y, f_z) in FRD, m/s^2, shape (3,).
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = _rotation_entries(x[6], x[7], x[8], x[9])
    fbx, fby, fbz, _, _ = _body_force(
        x, wind_ned, params, r00, r01, r02, r10, r11, r12, r20, r21, r22)
    out = np.empty(3)
    g = params[P_GRAVITY]
    if x[2] >= 0.0 and x[5] >= 0.0:
        # NED down-acceleration the free body would have (eq. 3.5)
        a_down = g + (r20 * fbx + r21 * fby + r22 * fbz) / mass_kg
        if a_down >= 0.0:
            # the ground reaction cancels it: f = R^T (0, 0, -g), the third row of R times -g
            out[0] = -g * r20
            out[1] = -g * r21
            out[2] = -g * r22
            return out
    out[0] = fbx / mass_kg
    out[1] = fby / mass_kg
    out[2] = fbz / mass_kg
    return out


# ---- stepping with saturation and ground contact -----------------------------------------
@njit(cache=True, error_model="numpy")
def _plant_step(
    x: FloatArray, u_cmd: FloatArray, wind_ned: FloatArray, mass_kg: float, p: FloatArray,
    dt: float, flags: FloatArray, work: FloatArray,
) -> None:
    """Saturate PWM, RK4, then ground contact; updates ``x`` and ``flags`` in place.

    ``work`` is float64[7, 17]: rows 0-4 RK4 scratch, row 5 the candidate state, row 6 the
    saturated PWM. A NaN command counts as pwm_min (no power).
    """
    u = work[6, 0:4]
    lo = p[P_PWM_MIN]
    hi = p[P_PWM_MAX]
    for i in range(4):
        ui = u_cmd[i]
        if not ui >= lo:  # also catches NaN
            ui = lo
        elif ui > hi:
            ui = hi
        u[i] = ui
    xn = work[5]
    _rk4_into(x, u, wind_ned, mass_kg, p, dt, work, xn)

    if xn[2] < 0.0:  # airborne at the end of the step
        flags[_F_ON_GROUND] = 0.0
        for i in range(STATE_SIZE):
            x[i] = xn[i]
        return

    if flags[_F_ON_GROUND] > 0.5:
        # resting and not lifted off (thrust < weight): the ground holds position and yaw
        yaw = _yaw_of(x[6], x[7], x[8], x[9])
    else:
        # touchdown inside this step: speed at the contact instant, linear in z over the step
        z0 = x[2]
        dz = xn[2] - z0
        a = -z0 / dz if dz > 0.0 else 1.0
        vx = x[3] + a * (xn[3] - x[3])
        vy = x[4] + a * (xn[4] - x[4])
        vz = x[5] + a * (xn[5] - x[5])
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        flags[_F_TOUCHDOWN_SPEED] = speed
        if speed > p[P_CRASH_SPEED]:
            flags[_F_CRASHED] = 1.0
        flags[_F_ON_GROUND] = 1.0
        yaw = _yaw_of(xn[6], xn[7], xn[8], xn[9])
        x[0] = xn[0]
        x[1] = xn[1]
    # on the ground: z = 0, at rest, level with the yaw kept, motors keep their lag states
    x[2] = 0.0
    for i in range(3, 6):
        x[i] = 0.0
    x[6] = math.cos(0.5 * yaw)
    x[7] = 0.0
    x[8] = 0.0
    x[9] = math.sin(0.5 * yaw)
    for i in range(10, 13):
        x[i] = 0.0
    for i in range(13, 17):
        x[i] = xn[i]


@njit(cache=True)
def _inside_band(value: float, lo: float, hi: float, margin: float) -> bool:
    """``lo <= value <= hi`` with ``value`` at least ``margin`` (relative) inside finite ends."""
    if value != value:
        return False
    if lo > -math.inf and not value >= lo + abs(lo) * margin:
        return False
    return not (hi < math.inf and not value <= hi - abs(hi) * margin)


# Python's math.hypot may differ from the compiled one in the last bit: an airspeed this
# close (relative) to a band end is left to the caller.
_HYPOT_MARGIN = 1e-12

_STEPS_DONE, _STEPS_STOPPED, _STEPS_CONTACT = 0, 1, 2  # why _plant_steps returned


@njit(cache=True, error_model="numpy")
def _plant_steps(
    n_max: int, step0: int, dt: float, t_limit: float, x: FloatArray, u_eff: FloatArray,
    mass_kg: float, p: FloatArray, flags: FloatArray, work: FloatArray,
    was_on_ground: bool, was_crashed: bool, check_band: bool, band: FloatArray,
    winds: FloatArray, wind_prev: FloatArray, accel_every: int, specific_force: FloatArray,
    states: FloatArray, forces: FloatArray,
) -> tuple[int, int]:
    """Up to ``n_max`` :func:`_plant_step` calls with the PWM, mass and per-step wind held,
    for :class:`sim.world.World`'s compiled stepping (see ``World._steps_compiled``).

    Step ``j`` (the plant's step count ``step0 + j`` before it) uses ``winds[j]``; it is not
    taken when it starts at or after ``t_limit`` or, with ``check_band``, when the altitude
    ``-z`` or the airspeed relative to the previous wind (``wind_prev``, then ``winds[j - 1]``)
    leaves ``band`` = (h_lo, h_hi, v_lo, v_hi). After step count ``k`` a multiple of
    ``accel_every`` the specific force is recomputed. ``states[j]`` and ``forces[j]``
    receive the state and the latest specific force after step ``j`` (``specific_force``
    is updated in place too). Returns ``(steps, why)``: why is _STEPS_DONE, _STEPS_STOPPED
    (the next step was not taken) or _STEPS_CONTACT (the last step changed on_ground or
    crashed from ``was_on_ground`` / ``was_crashed``).
    """
    h_lo, h_hi, v_lo, v_hi = band[0], band[1], band[2], band[3]
    for j in range(n_max):
        k0 = step0 + j
        if not k0 * dt < t_limit:
            return j, _STEPS_STOPPED
        w = winds[j]
        if check_band:
            prev = wind_prev if j == 0 else winds[j - 1]
            airspeed = math.hypot(x[3] - prev[0], x[4] - prev[1])
            if not (_inside_band(-x[2], h_lo, h_hi, 0.0)
                    and _inside_band(airspeed, v_lo, v_hi, _HYPOT_MARGIN)):
                return j, _STEPS_STOPPED
        _plant_step(x, u_eff, w, mass_kg, p, dt, flags, work)
        if (k0 + 1) % accel_every == 0:
            specific_force[:] = specific_force_frd(x, w, mass_kg, p)
        states[j] = x
        forces[j] = specific_force
        if (flags[_F_ON_GROUND] > 0.5) != was_on_ground or \
                (flags[_F_CRASHED] > 0.5) != was_crashed:
            return j + 1, _STEPS_CONTACT
    return n_max, _STEPS_DONE


class RigidBodyPlant:
    """Stateful plant: PWM saturation, RK4 of :func:`derivative`, and ground contact.

    The ground is the plane z_ned = 0. A vehicle reaching it stops there (position z
    clamped to 0, velocity and body rates zeroed, attitude levelled to roll = pitch = 0 with
    its yaw kept) and rests, ``on_ground`` True, while its thrust cannot lift it (an RK4 step
    from rest ends at z >= 0, i.e. thrust < weight). It never sinks through the ground. A
    touchdown at more than ``airframe.crash_speed_m_s`` (speed at the contact instant,
    horizontal and vertical) sets ``crashed``, which stays set until :meth:`reset`; the
    physics keeps running after a crash (what a crash means is the caller's business).

    Parameters
    ----------
    airframe : Airframe
        Physical parameters.
    dt_s : float
        Integration step, s (2 ms at the default 500 Hz plant rate).

    Attributes
    ----------
    airframe : Airframe
        As given.
    dt_s : float
        As given, s.
    """

    def __init__(self, airframe: Airframe, dt_s: float) -> None:
        if not (finite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be a finite number of seconds > 0")
        self.airframe = airframe
        self.dt_s = float(dt_s)
        self._params = pack_params(airframe)
        self._x = np.zeros(STATE_SIZE)
        self._flags = np.zeros(3)
        self._work = np.zeros((7, STATE_SIZE))
        # read-only view sharing memory with _x: callers see each step, cannot corrupt it
        self._state_view = self._x.view()
        self._state_view.flags.writeable = False
        self._steps = 0
        self.reset()

    def reset(
        self,
        *,
        pos_ned: ArrayLike = (0.0, 0.0, 0.0),
        vel_ned: ArrayLike = (0.0, 0.0, 0.0),
        yaw_rad: float = 0.0,
        thrust_n: ArrayLike = (0.0, 0.0, 0.0, 0.0),
    ) -> None:
        """Put the vehicle level at ``pos_ned`` with ``yaw_rad``, zero body rates, time 0.

        Parameters
        ----------
        pos_ned : array_like
            Position, m, shape (3,); z_ned = 0 is on the ground, z_ned > 0 is rejected.
        vel_ned : array_like
            Velocity, m/s, shape (3,); must be zero on the ground.
        yaw_rad : float
            Heading psi, rad (nose right positive).
        thrust_n : array_like
            Initial motor thrusts T1..T4 (lag states of eq. 3.1), N, each >= 0.

        Raises
        ------
        ValueError
            For a position below the ground, motion on the ground, negative or non-finite
            values.
        """
        pos = np.asarray(pos_ned, dtype=np.float64).reshape(3)
        vel = np.asarray(vel_ned, dtype=np.float64).reshape(3)
        thrust = np.asarray(thrust_n, dtype=np.float64).reshape(4)
        if not (np.all(np.isfinite(pos)) and pos[2] <= 0.0):
            raise ValueError(f"pos_ned = {pos.tolist()}: must be finite with z <= 0 "
                             "(z = 0 is the ground, NED z points down)")
        if not np.all(np.isfinite(vel)) or (pos[2] == 0.0 and np.any(vel != 0.0)):
            raise ValueError(f"vel_ned = {vel.tolist()}: must be finite, and zero on the ground")
        if not finite(yaw_rad):
            raise ValueError(f"yaw_rad = {yaw_rad!r}: must be a finite angle in rad")
        if not (np.all(np.isfinite(thrust)) and np.all(thrust >= 0.0)):
            raise ValueError(f"thrust_n = {thrust.tolist()}: each must be finite and >= 0 N")
        self._x[POS_NED] = pos
        self._x[VEL_NED] = vel
        self._x[QUAT_WXYZ] = (math.cos(0.5 * yaw_rad), 0.0, 0.0, math.sin(0.5 * yaw_rad))
        self._x[RATE_FRD] = 0.0
        self._x[THRUST_N] = thrust
        self._flags[_F_ON_GROUND] = 1.0 if pos[2] == 0.0 else 0.0
        self._flags[_F_CRASHED] = 0.0
        self._flags[_F_TOUCHDOWN_SPEED] = -1.0
        self._steps = 0

    def step(self, u_pwm: ArrayLike, wind_ned: ArrayLike, mass_kg: float) -> FloatArray:
        """Advance one ``dt_s``: saturate PWM to [pwm_min, pwm_max], RK4, ground contact.

        Parameters
        ----------
        u_pwm : array_like
            PWM per motor 1..4, shape (4,), held over the step (after actuator faults).
            Values outside [pwm_min, pwm_max] are clipped; NaN counts as pwm_min.
        wind_ned : array_like
            Wind velocity in NED, m/s, shape (3,), held over the step.
        mass_kg : float
            Current mass, kg (> 0).

        Returns
        -------
        numpy.ndarray
            The (read-only, live) state after the step, as :attr:`state`.
        """
        u = np.asarray(u_pwm, dtype=np.float64)
        w = np.asarray(wind_ned, dtype=np.float64)
        if u.shape != (4,) or w.shape != (3,) or not mass_kg > 0.0:
            raise ValueError(f"u_pwm shape {u.shape} (want (4,)), wind_ned shape {w.shape} "
                             f"(want (3,)), mass_kg = {mass_kg!r} (want > 0)")
        return self._step_checked(u, w, float(mass_kg))

    def _stepping_state(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(x, params, flags, work)`` for :class:`sim.world.World`'s compiled stepping, which
        advances them with :func:`_plant_step` and reports the steps with
        :meth:`_count_steps`."""
        return self._x, self._params, self._flags, self._work

    def _count_steps(self, n_steps: int) -> None:
        """Account for ``n_steps`` steps taken by the world's compiled stepping."""
        self._steps += n_steps

    def _step_checked(self, u_pwm: FloatArray, wind_ned: FloatArray,
                      mass_kg: float) -> FloatArray:
        """:meth:`step` for a caller whose inputs are known good: float64 arrays of shapes
        (4,) and (3,) and a float mass > 0 (the world's stepping loop, which checks its
        command once per call instead of once per plant step)."""
        _plant_step(self._x, u_pwm, wind_ned, mass_kg, self._params, self.dt_s, self._flags,
                    self._work)
        self._steps += 1
        return self._state_view

    @property
    def state(self) -> FloatArray:
        """Plant state, float64[17] (module docstring layout); a read-only live view.

        It changes in place at every :meth:`step`: copy it to keep a snapshot.
        """
        return self._state_view

    @property
    def time_s(self) -> float:
        """Simulated time since :meth:`reset`, s (steps times dt_s, no accumulated round-off)."""
        return self._steps * self.dt_s

    @property
    def on_ground(self) -> bool:
        """True while the vehicle rests on the ground plane z_ned = 0."""
        return bool(self._flags[_F_ON_GROUND] > 0.5)

    @property
    def crashed(self) -> bool:
        """True once a touchdown exceeded ``crash_speed_m_s`` since the last reset."""
        return bool(self._flags[_F_CRASHED] > 0.5)

    @property
    def touchdown_speed_m_s(self) -> float | None:
        """Speed of the last touchdown at the contact instant, m/s; None if none since reset."""
        speed = float(self._flags[_F_TOUCHDOWN_SPEED])
        return speed if speed >= 0.0 else None
