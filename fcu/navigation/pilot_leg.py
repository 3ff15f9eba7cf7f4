"""The pilot's leg: what STABILIZE, ALT_HOLD, LOITER and POSHOLD fly while sticks are in use,
and what GUIDED flies from velocity and attitude set-points.

Each control tick :meth:`PilotLeg.advance` turns a :class:`Demand` (lean angles, collective,
climb rate, horizontal velocity, yaw) into a :class:`~fcu.navigation.guidance.Reference` for
the position loop, the one control chain every mode flies through. The sticks give a demand
through ArduCopter's stick laws (:meth:`Demand.of_sticks`, :mod:`fcu.navigation.sticks`);
GUIDED's SET_POSITION_TARGET velocity and SET_ATTITUDE_TARGET set-points give one directly
(:mod:`fcu.navigation.guided_setpoints`). The position loop computes (``fcu.control.position``)::

    mu = ref_acc + kp (ref_pos - pos) + kd (ref_vel - vel) + ki int (ref_pos - pos) dt

so an axis whose reference position and velocity are the estimate itself is flown open loop
by ``ref_acc`` (plus the integrator's trim, frozen meanwhile), and an axis with a moving
target is tracked with ``ref_acc`` as feed-forward. The laws (``law``):

``"stabilize"`` (STABILIZE)
    Horizontal and vertical open loop: the reference follows the estimate and
    ``ref_acc`` is the specific force that tilts the thrust to the demand's lean angles at its
    collective, ``U = g c`` up with ``c`` the collective as a multiple of the hover thrust
    (sticks: :func:`~fcu.navigation.sticks.collective_of_hover`, 1 at mid-stick)::

        f_forward = -U tan(pitch),   f_right = U tan(roll) / cos(pitch),   mu_z = g - U

    which the position loop's attitude inversion turns back into exactly (roll, pitch).
``"alt_hold"`` (ALT_HOLD; GUIDED attitude set-points)
    Horizontal as STABILIZE (with ``U = g - ref_acc_z``); vertical: a target altitude moved
    at the demand's climb rate (sticks: :func:`~fcu.navigation.sticks.climb_rate_m_s`), the
    rate following the demand at ``accel_z_m_s2``; a zero climb rate holds the altitude.
``"loiter"`` (LOITER, POSHOLD; GUIDED velocity set-points)
    Vertical as ALT_HOLD; horizontal: a target position moved at a velocity that follows the
    demand's (sticks: :func:`~fcu.navigation.sticks.stick_velocity_ned`) at
    ``loiter_accel_m_s2``; a zero velocity brakes at that rate and holds where the target
    stopped.

Every law turns the yaw reference at the demand's yaw rate, or towards its heading at up to
``yaw_rate_deg_s`` when it gives one (set-points). A target never runs further than
``LEASH_XY_M`` / ``LEASH_Z_M`` ahead of the estimate (ArduCopter's position controller leash):
a vehicle that cannot follow (held on the ground, a wall of wind) is not wound up against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from fcu.floats import wrap_pi
from fcu.navigation.guidance import Reference
from fcu.navigation.sticks import (
    PilotConfig,
    Sticks,
    climb_rate_m_s,
    collective_of_hover,
    lean_angles_rad,
    stick_velocity_ned,
    yaw_rate_rad_s,
)

__all__ = ["GRAVITY_M_S2", "LEASH_XY_M", "LEASH_Z_M", "Demand", "PilotLaw", "PilotLeg"]

PilotLaw = Literal["stabilize", "alt_hold", "loiter"]
"""What the sticks fly (module docstring)."""

GRAVITY_M_S2 = 9.81  # m/s^2, the model's g (fcu.model.VehicleModel.gravity's default)
LEASH_XY_M = 1.0  # m, farthest a horizontal target runs ahead of the estimate
LEASH_Z_M = 0.5  # m, farthest a vertical target runs ahead of the estimate


@dataclass(frozen=True, slots=True)
class Demand:
    """What a pilot leg is asked to fly (module docstring); each law reads its own fields."""

    lean_rad: tuple[float, float] = (0.0, 0.0)  # rad, roll and pitch (STABILIZE, ALT_HOLD)
    collective: float = 1.0  # multiple of the hover thrust (STABILIZE)
    climb_m_s: float = 0.0  # m/s, up > 0 (ALT_HOLD, LOITER)
    vel_ne_m_s: tuple[float, float] = (0.0, 0.0)  # m/s, north and east (LOITER)
    heading_frame: bool = False  # vel_ne_m_s is (forward, right) of the leg's heading: it
    # turns with the yaw reference (sticks, body-frame set-points)
    yaw_rate_rad_s: float = 0.0  # rad/s, > 0 clockwise seen from above
    yaw_rad: float | None = None  # rad: turn to this heading instead (at most the pilot's
    # yaw rate); None: turn at yaw_rate_rad_s

    @classmethod
    def of_sticks(cls, sticks: Sticks, config: PilotConfig) -> Demand:
        """What ``sticks`` ask, by ArduCopter's stick laws."""
        return cls(lean_rad=lean_angles_rad(sticks, config),
                   collective=collective_of_hover(sticks.throttle, config),
                   climb_m_s=climb_rate_m_s(sticks.throttle, config),
                   vel_ne_m_s=stick_velocity_ned(sticks, 0.0, config), heading_frame=True,
                   yaw_rate_rad_s=yaw_rate_rad_s(sticks, config))


HOLD = Demand()
"""Level, hover thrust, no climb, no velocity, no turn: what centred sticks ask."""


def _toward(value: float, target: float, step: float) -> float:
    """``value`` moved toward ``target`` by at most ``step``."""
    return target if abs(target - value) <= step else value + math.copysign(step, target - value)


@dataclass
class PilotLeg:
    """The state of one pilot leg (module docstring) and its latest reference.

    Parameters
    ----------
    law : PilotLaw
    config : PilotConfig
    start_time_s : float
        When the leg starts, s.
    pos_ned, vel_ned : numpy.ndarray, shape (3,)
        Where the targets start (the reference flown so far, or the estimate on the
        ground), m and m/s, NED.
    yaw_rad : float
        Start yaw, rad.
    from_ground : bool
        The leg starts on the ground (a take-off by throttle).
    """

    law: PilotLaw
    config: PilotConfig
    start_time_s: float
    pos_ned: np.ndarray
    vel_ned: np.ndarray
    yaw_rad: float
    from_ground: bool = False
    grounded: bool = False  # the vehicle looked on the ground at the latest tick (the
    # navigator's verdict)
    demand: Demand = HOLD  # the demand of the latest advance
    time_s: float = field(init=False)  # s, the latest advance
    reference: Reference = field(init=False)  # the latest advance's

    def __post_init__(self) -> None:
        self.pos_ned = np.array(self.pos_ned, dtype=float)
        self.vel_ned = np.array(self.vel_ned, dtype=float)
        if self.law != "loiter":
            self.vel_ned[:2] = 0.0
        self.time_s = self.start_time_s
        self.reference = Reference(pos_ned=self.pos_ned, vel_ned=self.vel_ned,
                                   acc_ned=np.zeros(3), yaw_rad=self.yaw_rad)

    @property
    def descending(self) -> bool:
        """The demand asks to go down (sticks: throttle below the dead zone): landing may be
        detected."""
        return self.demand.climb_m_s < 0.0

    @property
    def climbing(self) -> bool:
        """The demand asks to go up (sticks: throttle above the dead zone)."""
        return self.demand.climb_m_s > 0.0

    def advance(self, time_s: float, demand: Demand, est_pos_ned: np.ndarray,
                est_vel_ned: np.ndarray) -> Reference:
        """Move the targets to ``time_s`` (s) under ``demand`` and return the reference.

        ``est_pos_ned``, ``est_vel_ned`` (m, m/s, NED): the latest estimate. Called again at
        the same time, it returns the same reference (only time moves the targets).
        """
        dt = time_s - self.time_s
        if dt <= 0.0 and demand is self.demand:
            return self.reference
        dt = max(dt, 0.0)
        self.time_s = time_s
        self.demand = demand
        cfg = self.config
        rate = demand.yaw_rate_rad_s
        if demand.yaw_rad is not None:  # turn to the heading at up to the pilot's yaw rate
            max_rate = math.radians(cfg.yaw_rate_deg_s)
            error = wrap_pi(demand.yaw_rad - self.yaw_rad)
            rate = min(max(error / dt, -max_rate), max_rate) if dt > 0.0 else 0.0
        self.yaw_rad = wrap_pi(self.yaw_rad + rate * dt)
        pos = np.array(est_pos_ned, dtype=float)
        vel = np.array(est_vel_ned, dtype=float)
        acc = np.zeros(3)
        if self.law == "stabilize":
            up = GRAVITY_M_S2 * demand.collective
            acc[2] = GRAVITY_M_S2 - up
        else:
            vz_old = self.vel_ned[2]
            vz = _toward(vz_old, -demand.climb_m_s, cfg.accel_z_m_s2 * dt)
            z = self.pos_ned[2] + 0.5 * (vz_old + vz) * dt
            z = min(max(z, est_pos_ned[2] - LEASH_Z_M), est_pos_ned[2] + LEASH_Z_M)
            self.pos_ned[2], self.vel_ned[2] = z, vz
            pos[2], vel[2] = z, vz
            acc[2] = (vz - vz_old) / dt if dt > 0.0 else 0.0
            up = GRAVITY_M_S2 - acc[2]
        if self.law == "loiter":
            acc[:2] = self._loiter(dt, demand, est_pos_ned)
            pos[:2], vel[:2] = self.pos_ned[:2], self.vel_ned[:2]
        else:
            acc[:2] = _lean_acceleration(demand.lean_rad, self.yaw_rad, up)
            self.pos_ned[:2], self.vel_ned[:2] = pos[:2], vel[:2]
        self.reference = Reference(pos_ned=pos, vel_ned=vel, acc_ned=acc, yaw_rad=self.yaw_rad,
                                   yaw_rate_rad_s=rate)
        return self.reference

    def _loiter(self, dt: float, demand: Demand, est_pos_ned: np.ndarray) -> np.ndarray:
        """Horizontal target of LOITER/POSHOLD moved by ``dt`` (s); its acceleration, m/s^2."""
        cfg = self.config
        want = np.array(demand.vel_ne_m_s, dtype=float)
        if demand.heading_frame:  # (forward, right) -> (north, east)
            c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
            want = np.array([c * want[0] - s * want[1], s * want[0] + c * want[1]])
        old = self.vel_ned[:2].copy()
        change = want - old
        step = cfg.loiter_accel_m_s2 * dt
        size = float(np.hypot(change[0], change[1]))
        new = want if size <= step else old + change * (step / size)
        target = self.pos_ned[:2] + 0.5 * (old + new) * dt
        ahead = target - est_pos_ned[:2]
        distance = float(np.hypot(ahead[0], ahead[1]))
        if distance > LEASH_XY_M:
            target = est_pos_ned[:2] + ahead * (LEASH_XY_M / distance)
        self.pos_ned[:2], self.vel_ned[:2] = target, new
        return (new - old) / dt if dt > 0.0 else np.zeros(2)


def _lean_acceleration(lean_rad: tuple[float, float], yaw_rad: float, up_m_s2: float
                       ) -> np.ndarray:
    """North and east specific force (m/s^2) that, with ``up_m_s2`` up, tilts the thrust to
    (roll, pitch) ``lean_rad`` at heading ``yaw_rad`` (module docstring)."""
    roll, pitch = lean_rad
    forward = -up_m_s2 * math.tan(pitch)
    right = up_m_s2 * math.tan(roll) / math.cos(pitch)
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([c * forward - s * right, s * forward + c * right])
