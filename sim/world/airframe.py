"""Physical parameters of the simulated quadrotor: Table 7.1 (Qball-X4) plus a drag model.

The thesis gives the motor, mixer and rigid-body constants (Table 7.1, eq. 3.1, 3.2, 3.17)
but leaves the wind force ``f_w`` and torque ``tau_w`` of eq. 3.14/3.15 unspecified. This
module fixes them with a documented aerodynamic model, evaluated by :mod:`sim.world.dynamics` on
the air-relative velocity expressed in body axes, ``v_b = R^T (v_ned - wind_ned)``::

    F_drag_b = -D v_b - c_q |v_b| v_b,    D = diag(d_xy, d_xy, d_z)        (N, body FRD)
    tau_wind = r_cp x F_drag_b,           r_cp = (0, 0, z_cp)              (N*m, body FRD)

The linear term is rotor drag (induced drag and blade flapping), which dominates for small
rotorcraft at the speeds of an indoor mission; the quadratic term is parasitic drag of the
frame and its protective cage. The centre of pressure sits on the body z axis, above the
centre of gravity (negative z in FRD), so flying forward (or a head wind) pitches the nose
up, as blade flapping does on real quadrotors.

Rate damping
------------
A spinning body meets air resistance: the rotors' in-plane (H-force) and axial drag at the
hubs, which move at ``omega x r_i``, and the frame's own drag. The linear part is::

    tau_d = -diag(g_xy, g_xy, g_z) omega                               (N*m, body FRD)

Mueller and D'Andrea (ICRA 2014, "Stability and control of a quadrocopter despite the
complete loss of one, two, or three propellers", section II) model the same torque,
``tau_d = -gamma omega``, and identify ``gamma = 2.75e-3 N*m*s/rad`` on a 0.5 kg vehicle with
0.17 m arms. Evaluating the rotor-drag model above at the hubs gives the same order for that
vehicle and, for the Qball-X4, ``g_z = d_xy L^2 = 0.010`` and ``g_xy = d_z L^2 / 2 = 0.007``
N*m*s/rad (see the field comments). At the rates of normal flight (below 1 rad/s) this is
under 0.01 N*m, a few per cent of the attitude torques; it matters when a vehicle that has
lost a rotor spins about its thrust axis: the reaction torque of the remaining rotors is then
balanced by ``g_z r`` alone, which fixes the spin rate (:mod:`fcu.control.relaxed_hover`:
about 19 rad/s, 3 rev/s, with one rotor lost). Without it the spin would grow without bound.

The field names follow ``flightdata/data/thesis_tables.toml`` ``[airframe]`` (and the autopilot's
nominal ``fcu.model.VehicleModel``), so that table loads directly with :meth:`Airframe.from_toml`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from flightdata.config import finite, from_toml, require


@dataclass(frozen=True, kw_only=True)
class Airframe:
    """Rigid-body, motor and aerodynamic parameters of the simulated quadrotor.

    Defaults are Table 7.1 of the thesis (Quanser Qball-X4) for the first nine fields; the
    drag fields are this simulator's choice for eq. 3.14/3.15's unspecified wind terms (see
    the module docstring); ``crash_speed_m_s`` classifies touchdowns.

    Raises
    ------
    ConfigError
        When a value is out of range; the message names the key, the value and what is
        allowed.
    """

    thrust_gain: float = 175.0  # K, N per unit PWM: steady thrust T = K u (eq. 3.1)
    motor_bandwidth: float = 15.0  # w, rad/s: motor lag K w / (s + w) (eq. 3.1)
    arm_length: float = 0.2  # L, m: centre of mass to rotor axis (eq. 3.2, 3.17)
    yaw_gain: float = 0.023  # K_psi, N*m of yaw reaction torque per N of thrust (eq. 3.17)
    mass: float = 1.42  # m, kg: nominal mass (structural faults change it at run time)
    gravity: float = 9.81  # g, m/s^2
    inertia: tuple[float, float, float] = (0.03, 0.03, 0.04)  # Ixx, Iyy, Izz, kg*m^2 (eq. 3.6)
    pwm_min: float = 0.0  # dimensionless PWM duty at no power (thesis saturation, ch. 3)
    pwm_max: float = 0.05  # dimensionless PWM duty at full power: 4 K pwm_max / (m g) = 2.51
    # Linear rotor drag, N per m/s of air-relative speed, body x and y. 0.25 N/(m/s) is
    # 1.8 % of the weight per m/s (1 deg of tilt holds station in a 1 m/s wind), the order of
    # the rotor-drag coefficients identified on 1-2 kg quadrotors (a few tenths of N per m/s).
    drag_coeff_xy: float = 0.25  # N/(m/s)
    # Linear drag along body z (climb/descent through the rotor disks): larger than in-plane
    # because the axial inflow changes each rotor's thrust directly (thrust ~ inflow).
    drag_coeff_z: float = 0.35  # N/(m/s)
    # Quadratic frame/cage drag 0.5 rho Cd A = 0.5 * 1.225 kg/m^3 * 1.0 * 0.02 m^2 ~ 0.012;
    # it is 5 % of the linear term at 1 m/s and 15 % at 3 m/s.
    drag_quad_coeff: float = 0.012  # N/(m/s)^2, force = -c_q |v_b| v_b
    # Centre of pressure on body z, m (FRD: negative = above the centre of gravity). The rotor
    # plane of the Qball-X4 is a few centimetres above its CG; rotor drag acts at the hubs.
    cp_offset_z: float = -0.05  # m
    # Aerodynamic damping of the body rates, tau_d = -diag(g_xy, g_xy, g_z) omega (module
    # docstring, "Rate damping"): the rotor drag above acting at the hubs, which move at
    # omega x r_i. Yaw: the four hubs move tangentially at r L, each rotor's in-plane drag is
    # drag_coeff_xy / 4, so g_z = drag_coeff_xy L^2 = 0.25 * 0.2^2 = 0.010. Roll and pitch:
    # two hubs move axially at p L (or q L), so g_xy = 2 (drag_coeff_z / 4) L^2 = 0.007.
    rate_damping: tuple[float, float, float] = (0.007, 0.007, 0.010)  # N*m per rad/s, x y z
    crash_speed_m_s: float = 3.0  # m/s: a touchdown faster than this is a crash

    def __post_init__(self) -> None:
        positive = {
            "thrust_gain": "N per unit PWM",
            "motor_bandwidth": "rad/s",
            "arm_length": "m",
            "yaw_gain": "N*m per N",
            "mass": "kg",
            "gravity": "m/s^2",
            "crash_speed_m_s": "m/s",
        }
        for key, unit in positive.items():
            value = getattr(self, key)
            require(finite(value) and value > 0, key, value,
                    f"must be a finite number > 0 ({unit})")
        for key in ("drag_coeff_xy", "drag_coeff_z", "drag_quad_coeff"):
            value = getattr(self, key)
            require(finite(value) and value >= 0, key, value, "must be a finite number >= 0")
        damping = self.rate_damping
        require(isinstance(damping, tuple) and len(damping) == 3
                and all(finite(v) and v >= 0 for v in damping), "rate_damping", damping,
                "must be a tuple of three finite numbers >= 0 (N*m per rad/s, body x y z)")
        require(finite(self.cp_offset_z) and abs(self.cp_offset_z) <= 1.0, "cp_offset_z",
                self.cp_offset_z, "must be a finite number of metres within [-1, 1]")
        inertia = self.inertia
        require(isinstance(inertia, tuple) and len(inertia) == 3, "inertia", inertia,
                "must be a tuple of three moments (Ixx, Iyy, Izz) in kg*m^2")
        for i, value in enumerate(inertia):
            require(finite(value) and value > 0, f"inertia[{i}]", value,
                    "must be a finite number > 0 (kg*m^2)")
        ixx, iyy, izz = inertia
        # A rigid body's principal moments obey the triangle inequality (Ixx + Iyy >= Izz ...).
        require(ixx + iyy >= izz and iyy + izz >= ixx and izz + ixx >= iyy, "inertia", inertia,
                "each principal moment must be no larger than the sum of the other two")
        require(finite(self.pwm_min) and self.pwm_min >= 0, "pwm_min", self.pwm_min,
                "must be a finite number >= 0 (PWM duty, no negative thrust)")
        require(finite(self.pwm_max) and self.pwm_max > self.pwm_min, "pwm_max", self.pwm_max,
                f"must be a finite number > pwm_min ({self.pwm_min!r})")

    @classmethod
    def from_toml(cls, path: str | Path, table: str | None = "airframe") -> Airframe:
        """Load an airframe from a TOML file's ``[table]`` (the whole file if ``table`` is None).

        Keys absent from the table keep the Table 7.1 defaults.

        Raises
        ------
        ConfigError
            For a missing or malformed file, a missing table, an unknown key, a value of the
            wrong type or out of range; the message names the file, key and allowed values.
        """
        return from_toml(cls, path, table)

    @property
    def hover_pwm(self) -> float:
        """PWM per motor holding the nominal mass in hover, m g / (4 K) (eq. 3.1, 3.5): 0.0199."""
        return self.mass * self.gravity / (4.0 * self.thrust_gain)

    @property
    def max_thrust_n(self) -> float:
        """Steady thrust of one motor at ``pwm_max``, N (eq. 3.1): K pwm_max = 8.75 N."""
        return self.thrust_gain * self.pwm_max
