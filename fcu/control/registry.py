"""The pluggable kinds of control part: their interfaces and the registries that build them.

Three kinds, each a :class:`typing.Protocol` and a :class:`fcu.registry.Registry` whose names
are exactly a tuple of :mod:`flightdata.vocabulary` (checked at import):

* :class:`AttitudeLaw`: ``ATTITUDE_LAW_REGISTRY``, names ``ATTITUDE_LAWS`` ("pd", eq. 5.6;
  "lqg", eq. 5.7-5.10), selected by ``AutopilotConfig.attitude``;
* :class:`DisturbanceObserver`: ``DOB_REGISTRY``, names ``DISTURBANCE_OBSERVERS`` ("none";
  "vbdob", eq. 6.29-6.30; "abdob", eq. 6.27-6.28), selected by ``AutopilotConfig.dob``;
* :class:`ControlAllocator`: ``ALLOCATOR_REGISTRY``, names ``ALLOCATORS``
  ("attitude_first", the inverse of eq. 3.2), selected by ``AutopilotConfig.allocator``.

Every factory has the same signature, ``factory(config, dt_s) -> part``: it gets the
autopilot's whole :class:`~fcu.config.AutopilotConfig` and the loop period (s) and takes the
settings its part needs.

Adding a part, e.g. a new attitude law ``"smc"``: write its module (a class with the
:class:`AttitudeLaw` methods, its gains a frozen dataclass there), add one line to
``ATTITUDE_LAW_REGISTRY`` below (plus its import), and append ``"smc"`` to
``flightdata.vocabulary.ATTITUDE_LAWS``, which gives it its ``ATT_CTRL`` value. Nothing else
changes: the configuration validates the name against the vocabulary, and the autopilot
builds the part through the registry. The same holds for a disturbance observer
(``DOB_REGISTRY``, ``DISTURBANCE_OBSERVERS``) and an allocator (``ALLOCATOR_REGISTRY``,
``ALLOCATORS``). Gains that should be set from TOML need a field in
:class:`~fcu.config.AutopilotConfig` as well; without one the part uses its defaults.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from fcu.config import AutopilotConfig
from fcu.control.allocation import Allocator
from fcu.control.attitude_lqr import AttitudeLQR
from fcu.control.attitude_pd import AttitudePD
from fcu.control.dob import AccelerationDob, NoDob, VelocityDob
from fcu.registry import Registry
from flightdata import vocabulary


class AttitudeLaw(Protocol):
    """An attitude control law (:mod:`fcu.control.attitude` describes the arguments)."""

    def reset(self) -> None:
        """Forget internal state (integrators, filters)."""
        ...

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray, ref_euler_rad: np.ndarray,
             ref_rate: np.ndarray, ref_acc: np.ndarray) -> np.ndarray:
        """Torques [U2, U3, U4] (N*m), shape (3,), for one control tick."""
        ...


class DisturbanceObserver(Protocol):
    """A disturbance observer on the attitude loop (eq. 6.27-6.30, :mod:`fcu.control.dob`)."""

    kind: str

    def reset(self) -> None:
        """Forget the filter state; the next step re-initialises on its measurement."""
        ...

    def step(self, euler_rad: np.ndarray, rate_frd: np.ndarray,
             torque_applied_nm: np.ndarray) -> np.ndarray:
        """Estimated disturbance torque d_hat (N*m), shape (3,), for this tick.

        Parameters
        ----------
        euler_rad : numpy.ndarray
            Measured [roll, pitch, yaw] (rad), shape (3,); used by the AbDOB.
        rate_frd : numpy.ndarray
            Measured body rates [p, q, r] (rad/s), shape (3,); used by the VbDOB.
        torque_applied_nm : numpy.ndarray
            Torque [U2, U3, U4] (N*m) applied over the interval that just ended.
        """
        ...


class ControlAllocator(Protocol):
    """Thrust and torques to four PWM commands, and back (eq. 3.2)."""

    def allocate(self, thrust_n: float, torque_nm: np.ndarray) -> np.ndarray:
        """PWM u1..u4, shape (4,), for thrust U1 (N) and torques [U2, U3, U4] (N*m)."""
        ...

    def mix(self, pwm: np.ndarray) -> tuple[float, np.ndarray]:
        """Eq. 3.2: thrust U1 (N) and torques [U2, U3, U4] (N*m, (3,)) that ``pwm`` asks for."""
        ...

    def set_effectiveness(self, effectiveness: np.ndarray | None) -> None:
        """Per-motor effectiveness (4,) to allocate for (active FTC); None: nominal."""
        ...


AttitudeLawFactory = Callable[[AutopilotConfig, float], AttitudeLaw]
DobFactory = Callable[[AutopilotConfig, float], DisturbanceObserver]
AllocatorFactory = Callable[[AutopilotConfig, float], ControlAllocator]

ATTITUDE_LAW_REGISTRY: Registry[AttitudeLawFactory] = Registry(
    "attitude law", "attitude", vocabulary.ATTITUDE_LAWS, {
        "pd": lambda cfg, dt_s: AttitudePD(cfg.model, cfg.pd, dt_s),
        "lqg": lambda cfg, dt_s: AttitudeLQR(cfg.model, cfg.lqr, dt_s),
    })
"""Attitude laws by ``AutopilotConfig.attitude`` name."""

# the observers include the known motor lag in their nominal plant (fcu.control.dob)
DOB_REGISTRY: Registry[DobFactory] = Registry(
    "disturbance observer", "dob", vocabulary.DISTURBANCE_OBSERVERS, {
        "none": lambda cfg, dt_s: NoDob(),
        "vbdob": lambda cfg, dt_s: VelocityDob(cfg.model, dt_s, cfg.dob_cutoff_rad_s,
                                               cfg.model.motor_bandwidth),
        "abdob": lambda cfg, dt_s: AccelerationDob(cfg.model, dt_s, cfg.dob_cutoff_rad_s,
                                                   cfg.model.motor_bandwidth),
    })
"""Disturbance observers by ``AutopilotConfig.dob`` name."""

ALLOCATOR_REGISTRY: Registry[AllocatorFactory] = Registry(
    "control allocator", "allocator", vocabulary.ALLOCATORS, {
        "attitude_first": lambda cfg, dt_s: Allocator(cfg.model),
    })
"""Control allocators by ``AutopilotConfig.allocator`` name."""
