"""State estimators as a pluggable kind: their interface and the registry that builds them.

:class:`StateEstimator` is what the autopilot needs from an estimator; ``ESTIMATOR_REGISTRY``
maps each name of :data:`flightdata.vocabulary.ESTIMATORS` ("ekf", section 6.1.2; "tskf",
eq. 6.10-6.26), selected by ``AutopilotConfig.estimator``, to a factory
``factory(config, dt_s) -> estimator`` that takes what it needs from the autopilot's
:class:`~fcu.config.AutopilotConfig` and the tick period (s). The registry checks at import
that its names are exactly the vocabulary's (:class:`fcu.registry.Registry`).

Adding an estimator, e.g. ``"ukf"``: write its module (a class with the
:class:`StateEstimator` methods; :class:`fcu.estimation.estimator.TickEstimator` supplies the
shared frame), add one line to ``ESTIMATOR_REGISTRY`` below (plus its import), and append
``"ukf"`` to ``flightdata.vocabulary.ESTIMATORS``, which gives it its ``EST_TYPE`` value.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from typing import Protocol

from numpy.typing import ArrayLike

from fcu.config import AutopilotConfig
from fcu.estimation.ekf import ExtendedKalmanEstimator
from fcu.estimation.estimator import ChannelCheck
from fcu.estimation.state import Innovation, SampleBatch, SensorNoise, StateEstimate
from fcu.estimation.tskf import FLYING_ACCEL_MODEL_SIGMA, TwoStageKalmanFilter
from fcu.registry import Registry
from flightdata import vocabulary


class StateEstimator(Protocol):
    """A state estimator run once per control tick (:mod:`fcu.estimation.state`)."""

    @property
    def sensor_kinds(self) -> frozenset[str]:
        """The sensor kinds it uses (the autopilot groups only those)."""
        ...

    @property
    def estimate(self) -> StateEstimate:
        """The latest estimate."""
        ...

    @property
    def last_innovation(self) -> Mapping[str, Innovation]:
        """Innovation, its covariance and NIS of each sensor updated at the latest tick."""
        ...

    @property
    def screening(self) -> Mapping[str, ChannelCheck]:
        """Each sensor's screening against the prior at the latest tick (what the health
        monitor reads, :mod:`fcu.monitoring.sensor_health`)."""
        ...

    height_source: str  # where height comes from now; settable between ticks
    noise: SensorNoise  # the measurement noise it assumes

    def reset(self, time_s: float = 0.0, initial: StateEstimate | None = None) -> None:
        """Restart at ``time_s`` (s) from ``initial`` (None: at rest at the origin)."""
        ...

    def step_grouped(self, time_s: float, pwm_applied: ArrayLike,
                     batches: Mapping[str, SampleBatch], *,
                     excluded: Collection[str] = (), reject: bool = True) -> StateEstimate:
        """Advance to the tick ``time_s`` (s) with ``pwm_applied`` (4,) held since the
        previous tick and update with the tick's averaged samples, screened, without the
        ``excluded`` sensors; returns the estimate."""
        ...


EstimatorFactory = Callable[[AutopilotConfig, float], StateEstimator]

ESTIMATOR_REGISTRY: Registry[EstimatorFactory] = Registry(
    "state estimator", "estimator", vocabulary.ESTIMATORS, {
        "ekf": lambda cfg, dt_s: ExtendedKalmanEstimator(cfg.model, dt_s, cfg.height_source),
        # flying, the TSKF uses the accelerometer as the EKF does (fcu.estimation.tskf)
        "tskf": lambda cfg, dt_s: TwoStageKalmanFilter(
            cfg.model, dt_s, height_source=cfg.height_source,
            accel_z_model_sigma=FLYING_ACCEL_MODEL_SIGMA),
    })
"""State estimators by ``AutopilotConfig.estimator`` name."""
