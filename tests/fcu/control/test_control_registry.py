"""Every attitude law, disturbance observer and allocator the registries name builds from the
autopilot's configuration and does its job on a first tick."""

from __future__ import annotations

import numpy as np
import pytest

from fcu.config import AutopilotConfig
from fcu.control.attitude_lqr import AttitudeLQR
from fcu.control.attitude_pd import AttitudePD
from fcu.control.registry import ALLOCATOR_REGISTRY, ATTITUDE_LAW_REGISTRY, DOB_REGISTRY
from flightdata.config import ConfigError
from flightdata.vocabulary import ALLOCATORS, ATTITUDE_LAWS, DISTURBANCE_OBSERVERS

CONFIG = AutopilotConfig()
DT = 1.0 / CONFIG.loop_rate_hz  # s
ZERO = np.zeros(3)


@pytest.mark.parametrize("name", ATTITUDE_LAWS)
def test_each_attitude_law_builds_and_steps(name: str) -> None:
    law = ATTITUDE_LAW_REGISTRY.factory(name)(CONFIG, DT)
    # level, at rest, on its reference: no torque at all (exact, nothing to correct)
    np.testing.assert_array_equal(law.step(ZERO, ZERO, ZERO, ZERO, ZERO), 0.0)
    law.reset()
    # rolled right by 0.1 rad: a restoring (negative) roll torque, none on the other axes
    torque = law.step(np.array([0.1, 0.0, 0.0]), ZERO, ZERO, ZERO, ZERO)
    assert torque.shape == (3,) and torque[0] < 0.0
    np.testing.assert_array_equal(torque[1:], 0.0)


def test_the_attitude_registry_builds_the_configured_gains() -> None:
    pd = ATTITUDE_LAW_REGISTRY.factory("pd")(CONFIG, DT)
    lqg = ATTITUDE_LAW_REGISTRY.factory("lqg")(CONFIG, DT)
    assert isinstance(pd, AttitudePD) and pd.gains == CONFIG.pd and pd.dt_s == DT
    assert isinstance(lqg, AttitudeLQR) and lqg.weights == CONFIG.lqr and lqg.dt_s == DT


@pytest.mark.parametrize("name", DISTURBANCE_OBSERVERS)
def test_each_disturbance_observer_builds_and_steps(name: str) -> None:
    dob = DOB_REGISTRY.factory(name)(CONFIG, DT)
    assert dob.kind == name
    euler, rate = np.array([0.05, -0.02, 1.0]), np.array([0.1, 0.0, -0.2])
    # the first tick starts at rest on its measurement: no estimate yet (N*m; the steady
    # state solve leaves rounding only)
    np.testing.assert_allclose(dob.step(euler, rate, ZERO), 0.0, atol=1e-15)
    for _ in range(3):
        d_hat = dob.step(euler, ZERO, ZERO)
    assert d_hat.shape == (3,) and np.all(np.isfinite(d_hat))


@pytest.mark.parametrize("name", ALLOCATORS)
def test_each_allocator_builds_and_inverts_eq_3_2(name: str) -> None:
    allocator = ALLOCATOR_REGISTRY.factory(name)(CONFIG, DT)
    weight_n = CONFIG.model.mass * CONFIG.model.gravity
    torque = np.array([0.01, -0.02, 0.005])  # N*m, well inside the authority at hover
    thrust_n, torque_out = allocator.mix(allocator.allocate(weight_n, torque))
    assert thrust_n == pytest.approx(weight_n, rel=1e-12)  # rounding of the inverse only
    np.testing.assert_allclose(torque_out, torque, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(("key", "choices"), [
    ("attitude", ATTITUDE_LAWS), ("dob", DISTURBANCE_OBSERVERS), ("allocator", ALLOCATORS),
])
def test_the_configuration_accepts_only_registered_names(key: str,
                                                         choices: tuple[str, ...]) -> None:
    for name in choices:
        AutopilotConfig(**{key: name})
    with pytest.raises(ConfigError, match=f"{key} = 'newcomer': must be one of "
                                          f"{', '.join(map(repr, choices))}"):
        AutopilotConfig(**{key: "newcomer"})
