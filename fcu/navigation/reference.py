"""The reference guidance hands the position and yaw controllers at one instant.

:class:`Reference` is a position, velocity and acceleration (NED, m, m/s, m/s^2; the
acceleration is the feed-forward of eq. 5.3), a yaw (rad, wrapped to [-pi, pi)) and a yaw
rate (rad/s), in read-only arrays so that one reference can be shared. Guidance builds one
every control tick, so besides the checked public constructor there are unchecked ones for
values already validated (:func:`reference_from_nine`, ``Reference._from_floats``,
``Reference._hold_checked``) that give the same result at a fraction of the cost.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fcu.floats import wrap_pi
from flightdata.config import finite, require

__all__ = ["Reference", "read_only_vec3", "reference_from_nine"]


def read_only_vec3(value: np.ndarray | Sequence[float], name: str) -> np.ndarray:
    """A read-only float64 copy of a 3-vector; raises ValueError naming ``name``."""
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} = {value!r}: must be three finite numbers")
    arr.setflags(write=False)
    return arr


_ZERO3 = np.zeros(3)
_ZERO3.setflags(write=False)
_pack9 = struct.Struct("9d").pack  # nine float64, native order (np.frombuffer's default)
_from_bytes = np.frombuffer  # over bytes: a read-only float64 array, no copy


@dataclass(frozen=True, eq=False)
class Reference:
    """What the position and yaw controllers track at one instant.

    Attributes
    ----------
    pos_ned : numpy.ndarray, shape (3,)
        Reference position, NED, m.
    vel_ned : numpy.ndarray, shape (3,)
        Reference velocity, NED, m/s.
    acc_ned : numpy.ndarray, shape (3,)
        Reference acceleration (feed-forward of eq. 5.3), NED, m/s^2.
    yaw_rad : float
        Reference yaw, rad, in [-pi, pi).
    yaw_rate_rad_s : float
        Reference yaw rate, rad/s.

    The arrays are read-only copies, so a reference can be shared safely.
    """

    pos_ned: np.ndarray
    vel_ned: np.ndarray
    acc_ned: np.ndarray
    yaw_rad: float = 0.0
    yaw_rate_rad_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("pos_ned", "vel_ned", "acc_ned"):
            object.__setattr__(self, name, read_only_vec3(getattr(self, name), name))
        require(finite(self.yaw_rad), "yaw_rad", self.yaw_rad, "must be finite")
        require(finite(self.yaw_rate_rad_s), "yaw_rate_rad_s", self.yaw_rate_rad_s,
                "must be finite")
        object.__setattr__(self, "yaw_rad", wrap_pi(float(self.yaw_rad)))
        object.__setattr__(self, "yaw_rate_rad_s", float(self.yaw_rate_rad_s))

    @classmethod
    def hold(cls, pos_ned: np.ndarray | Sequence[float], yaw_rad: float = 0.0) -> Reference:
        """A constant reference: position ``pos_ned`` (m), yaw ``yaw_rad``, at rest."""
        return cls(pos_ned=np.asarray(pos_ned, dtype=float), vel_ned=_ZERO3, acc_ned=_ZERO3,
                   yaw_rad=yaw_rad, yaw_rate_rad_s=0.0)

    def at_rest(self) -> Reference:
        """The same position and yaw with zero velocity, acceleration and yaw rate."""
        return Reference._hold_checked(self.pos_ned, self.yaw_rad)

    # Guidance builds a reference every control tick from values it has already validated
    # (segment end points are read-only checked copies). The two constructors below skip the
    # public constructor's copies and array checks, which cost more than the rest of a
    # guidance tick, and give the same result: the arrays are read-only and nobody else
    # holds a writable view of them, the yaw is wrapped the same way, and anything
    # non-finite still goes through the public constructor and its error.
    @classmethod
    def _from_floats(cls, pos: list[float], vel: list[float], acc: list[float],
                     yaw_rad: float, yaw_rate_rad_s: float) -> Reference:
        """A reference from freshly computed floats (three per vector)."""
        if not (all(map(math.isfinite, pos + vel + acc)) and math.isfinite(yaw_rad)
                and math.isfinite(yaw_rate_rad_s)):
            return cls(pos_ned=np.array(pos), vel_ned=np.array(vel), acc_ned=np.array(acc),
                       yaw_rad=yaw_rad, yaw_rate_rad_s=yaw_rate_rad_s)  # raises
        rows = np.array((pos, vel, acc))  # one allocation; the vectors are its rows
        rows.setflags(write=False)
        return cls._assemble(rows[0], rows[1], rows[2], yaw_rad, yaw_rate_rad_s)

    @classmethod
    def _hold_checked(cls, pos_ned: np.ndarray, yaw_rad: float) -> Reference:
        """:meth:`hold` at a position that is already a checked read-only 3-vector (shared)."""
        if not finite(yaw_rad):
            return cls.hold(pos_ned, yaw_rad)  # raises
        return cls._assemble(pos_ned, _ZERO3, _ZERO3, yaw_rad, 0.0)

    @classmethod
    def _assemble(cls, pos_ned: np.ndarray, vel_ned: np.ndarray, acc_ned: np.ndarray,
                  yaw_rad: float, yaw_rate_rad_s: float) -> Reference:
        ref = object.__new__(cls)
        # the fields straight into the instance's dict: what the frozen dataclass's own
        # __init__ does through object.__setattr__, at half the cost
        fields = ref.__dict__
        fields["pos_ned"] = pos_ned
        fields["vel_ned"] = vel_ned
        fields["acc_ned"] = acc_ned
        fields["yaw_rad"] = wrap_pi(float(yaw_rad))
        fields["yaw_rate_rad_s"] = float(yaw_rate_rad_s)
        return ref


_new_object = object.__new__
_PI = math.pi
_TWO_PI = 2.0 * math.pi


def reference_from_nine(px: float, py: float, pz: float, vx: float, vy: float, vz: float,
                         ax: float, ay: float, az: float, yaw_rad: float,
                         yaw_rate_rad_s: float) -> Reference:
    """:meth:`Reference._from_floats` for the nine floats of a guidance tick, given one by
    one (a cubic's or a ramp's); once a tick."""
    if not math.isfinite(px + py + pz + vx + vy + vz + ax + ay + az + yaw_rad
                         + yaw_rate_rad_s):  # (a sum of finite floats may overflow)
        return Reference._from_floats([px, py, pz], [vx, vy, vz], [ax, ay, az], yaw_rad,
                                      yaw_rate_rad_s)
    # one read-only buffer (bytes) for the three vectors: half the cost of an array
    # built from nested tuples and then locked
    rows = _from_bytes(_pack9(px, py, pz, vx, vy, vz, ax, ay, az))
    ref = _new_object(Reference)  # Reference._assemble(), inline
    fields = ref.__dict__
    fields["pos_ned"] = rows[0:3]
    fields["vel_ned"] = rows[3:6]
    fields["acc_ned"] = rows[6:9]
    fields["yaw_rad"] = float((yaw_rad + _PI) % _TWO_PI - _PI)  # wrap_pi(), inline
    fields["yaw_rate_rad_s"] = float(yaw_rate_rad_s)
    return ref
