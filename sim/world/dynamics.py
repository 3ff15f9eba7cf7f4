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

    d(omega)/dt = I^-1 (tau_B + tau_w + tau_d - omega x I omega),   tau_B = (U2, U3, U4)
    dq/dt = 0.5 q (x) (0, omega)

Wind force and torque (the ``f_w``, ``tau_w`` of eq. 3.14/3.15) are the drag model documented
in :mod:`sim.world.airframe`, evaluated on the air-relative velocity in body axes
``v_b = R^T (v - wind_ned)``: ``F_drag_b = -D v_b - c_q |v_b| v_b``,
``tau_w = (0, 0, z_cp) x F_drag_b``. The body rates are damped by
``tau_d = -diag(g_xy, g_xy, g_z) omega`` (rotor drag at the moving hubs, same module), added
to ``tau_B + tau_w``: it is what gives a vehicle spinning after the loss of a rotor a finite
spin rate.

The numerical kernels are numba ``@njit`` functions taking a packed parameter vector
(:func:`pack_params`). :func:`plant_step` adds PWM saturation and ground contact and advances
one :data:`PLANT_STATE` record (state vector, contact flags, step count, scratch), the whole
changing state of a :class:`RigidBodyPlant` (its ``kernel_state``), so that the plant's own
:meth:`RigidBodyPlant.step` and the world's compiled steps advance the same state.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from flightdata.config import finite
from jitsupport.cache import drop_stale_kernels
from jitsupport.layout import Layout
from sim.world.airframe import Airframe
from sim.world.rotations import rotation_entries, yaw_of

drop_stale_kernels(__file__)  # the plant kernels compile in those of rotations

FloatArray = NDArray[np.float64]

# ---- state layout ------------------------------------------------------------------------
STATE_SIZE = 17  # entries of the plant state vector
POS_NED = slice(0, 3)  # m
VEL_NED = slice(3, 6)  # m/s
QUAT_WXYZ = slice(6, 10)  # unit quaternion, body FRD -> NED
RATE_FRD = slice(10, 13)  # rad/s
THRUST_N = slice(13, 17)  # N, motors 1..4

# ---- packed parameter layout (pack_params): each field is the Airframe attribute -------
PARAMS = Layout("plant parameters (pack_params)")
P_THRUST_GAIN = PARAMS.field("thrust_gain", 1)  # K, N per unit PWM
P_MOTOR_BANDWIDTH = PARAMS.field("motor_bandwidth", 1)  # w, rad/s
P_ARM_LENGTH = PARAMS.field("arm_length", 1)  # L, m
P_YAW_GAIN = PARAMS.field("yaw_gain", 1)  # K_psi, N*m per N
P_GRAVITY = PARAMS.field("gravity", 1)  # g, m/s^2
P_IXX, P_IYY, P_IZZ = range(PARAMS.field("inertia", 3), PARAMS.size)  # kg*m^2
P_DRAG_XY = PARAMS.field("drag_coeff_xy", 1)  # N/(m/s)
P_DRAG_Z = PARAMS.field("drag_coeff_z", 1)  # N/(m/s)
P_DRAG_QUAD = PARAMS.field("drag_quad_coeff", 1)  # N/(m/s)^2
P_CP_Z = PARAMS.field("cp_offset_z", 1)  # m, body z of the centre of pressure
P_PWM_MIN = PARAMS.field("pwm_min", 1)  # PWM duty
P_PWM_MAX = PARAMS.field("pwm_max", 1)  # PWM duty
P_CRASH_SPEED = PARAMS.field("crash_speed_m_s", 1)  # m/s
# N*m per rad/s: roll-, pitch- and yaw-rate damping
P_DAMP_X, P_DAMP_Y, P_DAMP_Z = range(PARAMS.field("rate_damping", 3), PARAMS.size)
PARAM_SIZE = PARAMS.size

# ---- the stepping state of RigidBodyPlant (one record) -----------------------------------
PLANT_STATE = np.dtype([
    ("x", np.float64, (STATE_SIZE,)),  # the state vector (layout above)
    ("on_ground", np.bool_),  # resting on the ground
    ("crashed", np.bool_),  # a touchdown was faster than crash_speed_m_s (sticky until reset)
    ("touchdown_speed_m_s", np.float64),  # m/s, of the last touchdown; -1 when none since reset
    ("steps", np.int64),  # steps since reset
    ("dt_s", np.float64),  # s, integration step
    ("params", np.float64, (PARAM_SIZE,)),  # pack_params(airframe)
    ("work", np.float64, (7, STATE_SIZE)),  # scratch of plant_step
], align=True)
"""What :func:`plant_step` advances: the state, the ground contact and its scratch."""


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
    for f in PARAMS.fields:
        p[f.start:f.stop] = getattr(airframe, f.name)
    return p


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
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation_entries(qw, qx, qy, qz)
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
    # rate damping tau_d = -diag(g_x, g_y, g_z) omega (sim.world.airframe)
    tau_x = arm * (t3 - t4) - zcp * fdy - p[P_DAMP_X] * wp
    tau_y = arm * (t1 - t2) + zcp * fdx - p[P_DAMP_Y] * wq
    tau_z = p[P_YAW_GAIN] * (t1 + t2 - t3 - t4) - p[P_DAMP_Z] * wr
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
def specific_force_into(
    x: FloatArray, wind_ned: FloatArray, mass_kg: float, params: FloatArray, out: FloatArray
) -> None:
    """:func:`specific_force_frd` written into ``out`` (shape (3,))."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation_entries(x[6], x[7], x[8], x[9])
    fbx, fby, fbz, _, _ = _body_force(
        x, wind_ned, params, r00, r01, r02, r10, r11, r12, r20, r21, r22)
    g = params[P_GRAVITY]
    if x[2] >= 0.0 and x[5] >= 0.0:
        # NED down-acceleration the free body would have (eq. 3.5)
        a_down = g + (r20 * fbx + r21 * fby + r22 * fbz) / mass_kg
        if a_down >= 0.0:
            # the ground reaction cancels it: f = R^T (0, 0, -g), the third row of R times -g
            out[0] = -g * r20
            out[1] = -g * r21
            out[2] = -g * r22
            return
    # f = (F_thrust_b + F_drag_b) / m
    out[0] = fbx / mass_kg
    out[1] = fby / mass_kg
    out[2] = fbz / mass_kg


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
    x, wind_ned, mass_kg, params
        As for :func:`derivative`.

    Returns
    -------
    numpy.ndarray
        Specific force (f_x, f_y, f_z) in FRD, m/s^2, shape (3,).
    """
    out = np.empty(3)
    specific_force_into(x, wind_ned, mass_kg, params, out)
    return out


# ---- stepping with saturation and ground contact -----------------------------------------
@njit(cache=True, error_model="numpy")
def plant_step(plant: np.ndarray, u_cmd: FloatArray, wind_ned: FloatArray,
               mass_kg: float) -> None:
    """One step of :class:`RigidBodyPlant`: saturate PWM, RK4, then ground contact.

    Parameters
    ----------
    plant : numpy.ndarray
        One :data:`PLANT_STATE` record (``RigidBodyPlant.kernel_state``), advanced in place.
    u_cmd : numpy.ndarray
        PWM per motor 1..4, shape (4,), held over the step; clipped to [pwm_min, pwm_max], a
        NaN counts as pwm_min (no power).
    wind_ned : numpy.ndarray
        Wind velocity in NED, m/s, shape (3,), held over the step.
    mass_kg : float
        Current mass, kg (> 0).
    """
    s = plant[0]
    # the record's arrays as plain views (``[:]``): the kernels below are then compiled for
    # the arrays the Python path passes too, not once more for the record's own type
    x, p, work = s.x[:], s.params[:], s.work[:]
    # work rows 0-4: RK4 scratch, row 5: the candidate state, row 6: the saturated PWM
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
    _rk4_into(x, u, wind_ned, mass_kg, p, s.dt_s, work, xn)
    s.steps += 1

    if xn[2] < 0.0:  # airborne at the end of the step
        s.on_ground = False
        for i in range(STATE_SIZE):
            x[i] = xn[i]
        return

    if s.on_ground:
        # resting and not lifted off (thrust < weight): the ground holds position and yaw
        yaw = yaw_of(x[6], x[7], x[8], x[9])
    else:
        # touchdown inside this step: speed at the contact instant, linear in z over the step
        z0 = x[2]
        dz = xn[2] - z0
        a = -z0 / dz if dz > 0.0 else 1.0
        vx = x[3] + a * (xn[3] - x[3])
        vy = x[4] + a * (xn[4] - x[4])
        vz = x[5] + a * (xn[5] - x[5])
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        s.touchdown_speed_m_s = speed
        if speed > p[P_CRASH_SPEED]:
            s.crashed = True
        s.on_ground = True
        yaw = yaw_of(xn[6], xn[7], xn[8], xn[9])
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
    kernel_state : numpy.ndarray
        One :data:`PLANT_STATE` record holding everything the plant changes (state vector,
        ground contact, step count): what :func:`plant_step` advances. The world's compiled
        stepping passes it to that function; nothing else should write it.
    """

    def __init__(self, airframe: Airframe, dt_s: float) -> None:
        if not (finite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s = {dt_s!r}: must be a finite number of seconds > 0")
        self.airframe = airframe
        self.dt_s = float(dt_s)
        self.kernel_state = np.zeros(1, dtype=PLANT_STATE)
        self._s = self.kernel_state[0]  # a view: writes go to the array
        self._s["dt_s"] = self.dt_s
        self._s["params"] = pack_params(airframe)
        self._x = self.kernel_state["x"][0]
        # the flags read every tick, as field views (item() is a quarter of a record's read)
        self._on_ground = self.kernel_state["on_ground"]
        self._crashed = self.kernel_state["crashed"]
        # read-only view sharing memory with _x: callers see each step, cannot corrupt it
        self._state_view = self._x.view()
        self._state_view.flags.writeable = False
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
        self._s["on_ground"] = pos[2] == 0.0
        self._s["crashed"] = False
        self._s["touchdown_speed_m_s"] = -1.0
        self._s["steps"] = 0

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
        return self.step_unchecked(u, w, float(mass_kg))

    def step_unchecked(self, u_pwm: FloatArray, wind_ned: FloatArray,
                       mass_kg: float) -> FloatArray:
        """:meth:`step` for a caller whose inputs are known good: float64 arrays of shapes
        (4,) and (3,) and a float mass > 0 (the world's Python stepping, which checks its
        command once per call instead of once per plant step)."""
        plant_step(self.kernel_state, u_pwm, wind_ned, mass_kg)
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
        return int(self._s["steps"]) * self.dt_s

    @property
    def on_ground(self) -> bool:
        """True while the vehicle rests on the ground plane z_ned = 0."""
        return bool(self._on_ground.item(0))

    @property
    def crashed(self) -> bool:
        """True once a touchdown exceeded ``crash_speed_m_s`` since the last reset."""
        return bool(self._crashed.item(0))

    @property
    def touchdown_speed_m_s(self) -> float | None:
        """Speed of the last touchdown at the contact instant, m/s; None if none since reset."""
        speed = float(self._s["touchdown_speed_m_s"])
        return speed if speed >= 0.0 else None


__all__ = ["PARAM_SIZE", "PLANT_STATE", "POS_NED", "QUAT_WXYZ", "RATE_FRD", "STATE_SIZE",
           "THRUST_N", "VEL_NED", "RigidBodyPlant", "derivative", "pack_params", "plant_step",
           "rk4_step", "specific_force_frd", "specific_force_into"]
