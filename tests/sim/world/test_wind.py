"""Tests of sim/world/wind.py: MIL-F-8785C low-altitude Dryden turbulence plus mean wind.

The statistical tests run the exact discretisation at 1, 2 and 5 ms and compare the output
with the Dryden model: the standard deviation of each channel with sigma, and its correlation
time with L / V. All randomness comes from seeded generators, so every run is identical.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.linalg import solve_continuous_lyapunov
from scipy.optimize import brentq

from flightdata.config import ConfigError, from_mapping
from sim.world.dryden import (
    FT_TO_M,
    GRID_BLOCK,
    GRID_RATIO,
    KT_TO_M_S,
    LOW_ALTITUDE_CEILING_M,
    _second_order_grid_block,
    _second_order_step,
    _second_order_step_on_grid,
    dryden_length_scales_m,
    dryden_sigmas_m_s,
    second_order_model,
    van_loan,
)
from sim.world.wind import BLOCK_STEPS, DrydenWind, WindConfig

# Statistics conditions: the 10 ft altitude floor and a fast airspeed keep the correlation
# times short (T_u = T_v = 0.461 s, T_w = 0.061 s), so 10 000 T_u is 4.6 M steps at 1 ms.
ALT_M = 10.0 * FT_TO_M
SPEED_M_S = 50.0
N_CORRELATION_TIMES = 10_000
STEPS_PER_CHUNK = 1 << 20


def _make(seed: int, dt_s: float = 0.002, **config: object) -> DrydenWind:
    return DrydenWind(WindConfig(**config), dt_s, np.random.default_rng(seed))  # type: ignore[arg-type]


def _second_order_rho(lag_s: float, corr_time_s: float) -> float:
    """Analytic normalised Dryden v/w autocorrelation (1 - tau/(2T)) exp(-tau/T)."""
    return (1.0 - lag_s / (2.0 * corr_time_s)) * math.exp(-lag_s / corr_time_s)


def _autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Normalised sample autocorrelation at lags 0..max_lag (FFT, biased estimator)."""
    x = x - x.mean()
    n_fft = 1 << int(math.ceil(math.log2(2 * x.size)))
    spectrum = np.fft.rfft(x, n_fft)
    r = np.fft.irfft(spectrum * np.conj(spectrum), n_fft)[: max_lag + 1]
    return r / r[0]


# ---------------------------------------------------------------------------------------
# Intensities, scale lengths and unit conversions
# ---------------------------------------------------------------------------------------
def test_intensity_table_light_moderate_severe() -> None:
    # MIL-F-8785C: W20 = 15, 30, 45 kt; sigma_w = 0.1 W20. 1 kt = 1852/3600 m/s exactly.
    for name, w20_kt in (("light", 15.0), ("moderate", 30.0), ("severe", 45.0)):
        config = WindConfig(turbulence=name)
        assert config.w20_effective_m_s == pytest.approx(w20_kt * 0.514444, rel=1e-6)
        wind = DrydenWind(config, 0.002, np.random.default_rng(0))
        # rel 1e-12: two products of exact constants, only rounding differs.
        assert wind.sigma_uvw_m_s[2] == pytest.approx(0.1 * w20_kt * 1852 / 3600, rel=1e-12)
    light = DrydenWind(WindConfig(turbulence="light"), 0.002, np.random.default_rng(0))
    # The brief's numbers: 15 kt = 7.72 m/s and sigma_w = 0.772 m/s (to the digits quoted).
    assert WindConfig().w20_effective_m_s == pytest.approx(7.7167, abs=1e-4)
    assert light.sigma_uvw_m_s[2] == pytest.approx(0.772, abs=5e-4)


def test_w20_overrides_named_intensity() -> None:
    wind = _make(0, turbulence="severe", w20_m_s=5.0)
    # rel 1e-12: sigma_w = 0.1 * 5.0 computed once.
    assert wind.sigma_uvw_m_s[2] == pytest.approx(0.5, rel=1e-12)


def test_scale_lengths_and_sigmas_are_computed_in_feet() -> None:
    # At h = 100 ft = 30.48 m: L_u = 100 / (0.177 + 0.0823)^1.2 ft = 505.2 ft = 153.98 m and
    # sigma_u / sigma_w = 0.2593^-0.4 = 1.7158 (hand calculation). Plugging metres into the
    # feet formula instead would give L_u = 207.7 m, which these tolerances reject.
    l_u, l_v, l_w = dryden_length_scales_m(30.48)
    assert l_u == pytest.approx(153.98, abs=0.01)  # 0.01 m: the hand value's last digit
    assert l_v == l_u
    assert l_w == pytest.approx(30.48, rel=1e-12)  # L_w = h, only two unit conversions
    s_u, s_v, s_w = dryden_sigmas_m_s(1.0, 30.48)
    assert s_w == pytest.approx(0.1, rel=1e-12)  # 0.1 W20, one multiplication
    assert s_u / s_w == pytest.approx(1.7158, abs=1e-4)  # hand value to 4 decimals
    assert s_v == s_u
    # Same formulas evaluated independently in feet, converted at the end.
    h_ft = 250.0
    den = 0.177 + 0.000823 * h_ft
    assert_allclose(dryden_length_scales_m(h_ft * 0.3048),
                    (h_ft / den**1.2 * 0.3048, h_ft / den**1.2 * 0.3048, h_ft * 0.3048),
                    rtol=1e-12)  # identical maths, rounding only


def test_at_1000_ft_all_channels_agree() -> None:
    # 0.177 + 0.000823 * 1000 = 1: sigma_u = sigma_w and L_u = L_w = 1000 ft = 304.8 m.
    assert_allclose(dryden_length_scales_m(LOW_ALTITUDE_CEILING_M), (304.8,) * 3, rtol=1e-12)
    assert_allclose(dryden_sigmas_m_s(10.0, LOW_ALTITUDE_CEILING_M), (1.0,) * 3, rtol=1e-12)


# ---------------------------------------------------------------------------------------
# The normalised model and its exact discretisation
# ---------------------------------------------------------------------------------------
def test_second_order_model_is_the_dryden_filter_with_unit_variance() -> None:
    a, b, c = second_order_model()
    p = solve_continuous_lyapunov(a, -b @ b.T)  # A P + P A' + B B' = 0
    assert_allclose(p, [[0.5, 0.25], [0.25, 0.25]], atol=1e-14)  # closed form, rounding only
    assert (c @ p @ c.T).item() == pytest.approx(1.0, abs=1e-14)  # unit stationary variance
    for omega in (0.0, 0.3, 1.0, 3.0, 30.0):
        h = (c @ np.linalg.solve(1j * omega * np.eye(2) - a, b)).item()
        # |(1 + sqrt(3) j w) / (1 + j w)^2|^2 = (1 + 3 w^2) / (1 + w^2)^2, the Dryden shape.
        assert abs(h) ** 2 == pytest.approx((1 + 3 * omega**2) / (1 + omega**2) ** 2, rel=1e-12)


@pytest.mark.parametrize("h", [1e-8, 1e-6, 3e-6, 1e-4, 1e-2, 0.1, 0.5, 1.0, 2.0, 5.0, 20.0])
def test_van_loan_matches_closed_form_and_preserves_stationarity(h: float) -> None:
    a, b, _ = second_order_model()
    ad, qd = van_loan(a, b, h)
    # expm(A h) = exp(-h) [[1, 0], [h, 1]]
    # rtol 1e-12: expm's scaling and squaring loses a few digits at h = 20 (1e-13 observed).
    assert_allclose(ad, math.exp(-h) * np.array([[1.0, 0.0], [h, 1.0]]), rtol=1e-12, atol=1e-300)
    # Qd = int_0^h exp(-2s) [[1, s], [s, s^2]] ds: a power series for small h (no
    # cancellation), the closed form for larger h.
    def moment(k: int) -> float:
        if h < 0.5:
            return sum((-2.0) ** n / math.factorial(n) * h ** (n + k + 1) / (n + k + 1)
                       for n in range(40))
        e = math.exp(-2 * h)
        return ((1 - e) / 2, (1 - e * (1 + 2 * h)) / 4, (1 - e * (1 + 2 * h + 2 * h * h)) / 4)[k]
    ref = np.array([[moment(0), moment(1)], [moment(1), moment(2)]])
    # rtol 1e-11: expm is accurate to ~1e-13 relative per entry even for h = 1e-8, where
    # Qd[1, 1] = h^3 / 3 = 3e-25; the closed form loses a few digits at h = 20.
    assert_allclose(qd, ref, rtol=1e-11)
    # Exact discretisation keeps the stationary covariance: Ad P Ad' + Qd = P for every step.
    p = np.array([[0.5, 0.25], [0.25, 0.25]])
    assert_allclose(ad @ p @ ad.T + qd, p, atol=1e-13)  # rounding of O(1) entries
    assert np.all(np.linalg.eigvalsh(qd) > 0)  # a valid covariance, Cholesky exists


# ---------------------------------------------------------------------------------------
# Statistics at 1, 2 and 5 ms
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("dt_s", [0.001, 0.002, 0.005])
def test_standard_deviation_and_correlation_time_match_dryden(dt_s: float) -> None:
    """10 000 correlation times of u (76 000 of w), seed 1234, moderate turbulence.

    Statistics (estimator spreads measured over 12 seeds while writing this test):
    * std / sigma per channel: spread 0.5-0.9 % at 5 000 T, tolerance 10 % (brief).
    * u: the integral of the normalised autocorrelation over 0..5 T_u, divided by
      (1 - e^-5) (the exponential tail beyond 5 T), estimates T_u = L_u / V; spread about
      3.5 %, tolerance 20 % (brief).
    * v and w: the autocorrelation at the lag tau0 nearest T = L / V, inverted through the
      analytic (1 - tau/(2T)) exp(-tau/T) for T (monotonic in T). At tau = T the curve is
      steep in T (a 20 % change of T moves it from 0.184 to 0.253), unlike the zero crossing
      at 2T where the slope is e^-2 / (2T) and noise dominates; spread 1-2 %, tolerance 20 %.
    """
    wind = DrydenWind(WindConfig(turbulence="moderate"), dt_s, np.random.default_rng(1234))
    wind.generate(0, ALT_M, SPEED_M_S)  # set the discretisation for the test conditions
    sigma = wind.sigma_uvw_m_s
    l_u, l_v, l_w = wind.length_scale_uvw_m
    t_u, t_v, t_w = l_u / SPEED_M_S, l_v / SPEED_M_S, l_w / SPEED_M_S
    n_steps = int(N_CORRELATION_TIMES * t_u / dt_s)
    # Keep every stride-th sample: stride * dt <= T_w / 20, fine enough that the
    # autocorrelation integral's trapezoid error is below 0.1 % and nothing is aliased.
    stride = max(1, int(t_w / (20 * dt_s)))
    chunk = STEPS_PER_CHUNK - STEPS_PER_CHUNK % stride  # keeps the subsampling uniform
    kept = []
    done = 0
    while done < n_steps:
        m = min(chunk, n_steps - done)
        kept.append(wind.generate(m, ALT_M, SPEED_M_S)[::stride].copy())  # copy frees chunk
        done += m
    # No mean wind: u is north, v is west (-east), w is up (-down); signs do not matter here.
    gust = np.concatenate(kept)
    dt_kept = stride * dt_s

    std_ratio = gust.std(axis=0) / sigma
    assert_allclose(std_ratio, 1.0, atol=0.10)

    max_lag = int(round(5 * t_u / dt_kept))
    rho_u = _autocorrelation(gust[:, 0], max_lag)
    integral = dt_kept * (rho_u.sum() - 0.5 * rho_u[0] - 0.5 * rho_u[-1])
    t_u_hat = integral / (1 - math.exp(-max_lag * dt_kept / t_u))
    assert t_u_hat / t_u == pytest.approx(1.0, abs=0.20)

    for column, t_true in ((1, t_v), (2, t_w)):
        lag = max(1, int(round(t_true / dt_kept)))
        x = gust[:, column] - gust[:, column].mean()
        rho = float(np.dot(x[:-lag], x[lag:]) / np.dot(x, x))
        tau0 = lag * dt_kept
        t_hat = brentq(lambda t, r=rho, tau=tau0: _second_order_rho(tau, t) - r,
                       0.5001 * tau0, 1000 * tau0)
        assert t_hat / t_true == pytest.approx(1.0, abs=0.20), column


def test_first_outputs_already_have_the_stationary_variance() -> None:
    # An ensemble of 1000 fresh objects, one step each: the initial state is drawn from the
    # stationary covariance, so the very first output has standard deviation sigma. Had the
    # state started at zero the first output's std would be sigma * sqrt(1 - exp(-2h)) ~ 0.09
    # sigma for u. Tolerance 10 %: the sample std of 1000 draws has a 2.2 % spread. (Each
    # object draws a whole block of normals, ~1 ms, which bounds the ensemble size.)
    seeds = np.random.SeedSequence(99).spawn(1000)
    first = np.array([DrydenWind(WindConfig(), 0.002, np.random.default_rng(s)).step(ALT_M, 5.0)
                      for s in seeds])
    sigma = DrydenWind(WindConfig(), 0.002, np.random.default_rng(0)).sigma_uvw_m_s
    assert_allclose(first.std(axis=0) / sigma, 1.0, atol=0.10)


def test_mean_wind_axis_and_channel_shapes() -> None:
    # Mean wind from the east (90 deg): the air moves west, so u lies along -east and v along
    # north. At lag T the first-order u autocorrelation is e^-1 = 0.368 and the second-order
    # v one (1 - 1/2) e^-1 = 0.184: east must show the first, north the second. 3000 T_u at
    # 2 ms; the autocorrelation estimates spread by about 0.02, tolerance 0.06 (half the gap).
    dt_s = 0.002
    wind = _make(7, dt_s, mean_speed_m_s=4.0, mean_from_deg=90.0, turbulence="moderate")
    wind.generate(0, ALT_M, SPEED_M_S)
    t_u = wind.length_scale_uvw_m[0] / SPEED_M_S
    out = wind.generate(int(3000 * t_u / dt_s), ALT_M, SPEED_M_S)
    lag = int(round(t_u / dt_s))

    def rho(x: np.ndarray) -> float:
        x = x - x.mean()
        return float(np.dot(x[:-lag], x[lag:]) / np.dot(x, x))

    assert rho(out[:, 1]) == pytest.approx(math.exp(-1), abs=0.06)
    assert rho(out[:, 0]) == pytest.approx(0.5 * math.exp(-1), abs=0.06)
    # The mean east velocity is -4 m/s; 3000 T_u of sigma_u = 3 m/s turbulence leave a
    # standard error of sigma sqrt(2 T / T_run) = 0.08 m/s, tolerance 0.4 m/s.
    assert out[:, 1].mean() == pytest.approx(-4.0, abs=0.4)
    assert out[:, 0].mean() == pytest.approx(0.0, abs=0.4)


# ---------------------------------------------------------------------------------------
# Mean wind, determinism and the "none" setting
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("from_deg", "expected"),
    [
        (0.0, (-5.0, 0.0, 0.0)),  # from the north: the air moves south
        (360.0, (-5.0, 0.0, 0.0)),  # 360 is north too
        (90.0, (0.0, -5.0, 0.0)),  # from the east: the air moves west
        (225.0, (5.0 / math.sqrt(2), 5.0 / math.sqrt(2), 0.0)),  # from SW: toward NE
    ],
)
def test_mean_wind_direction_convention(from_deg: float, expected: tuple[float, ...]) -> None:
    wind = _make(0, mean_speed_m_s=5.0, mean_from_deg=from_deg, turbulence="none")
    # atol 1e-12 m/s: sin/cos of multiples of pi/2 are not exactly 0 in floating point.
    assert_allclose(wind.step(2.0, 0.0), expected, atol=1e-12)
    assert_allclose(wind.mean_ned_m_s, expected, atol=1e-12)


def test_turbulence_none_is_exactly_the_mean_wind_and_draws_nothing() -> None:
    rng = np.random.default_rng(5)
    state = rng.bit_generator.state
    wind = DrydenWind(WindConfig(mean_speed_m_s=3.0, mean_from_deg=30.0, turbulence="none"),
                      0.002, rng)
    mean = wind.mean_ned_m_s
    for altitude in (0.0, 0.6, 50.0):
        assert_array_equal(wind.step(altitude, 0.4), mean)
    assert_array_equal(wind.generate(1000, 10.0, 3.0), np.tile(mean, (1000, 1)))
    assert_array_equal(wind.sigma_uvw_m_s, np.zeros(3))
    assert rng.bit_generator.state == state


def test_zero_w20_gives_exactly_the_mean_wind() -> None:
    wind = _make(0, mean_speed_m_s=2.0, w20_m_s=0.0)
    assert_array_equal(wind.generate(100, 1.0, 1.0), np.tile(wind.mean_ned_m_s, (100, 1)))


def test_same_seed_is_bit_identical_and_different_seed_differs() -> None:
    def run(seed: int) -> np.ndarray:
        wind = _make(seed, mean_speed_m_s=2.0, mean_from_deg=45.0)
        return np.array([wind.step(0.6 + 0.001 * k, 0.5) for k in range(2000)])

    assert_array_equal(run(11), run(11))
    assert not np.array_equal(run(11), run(12))


def test_generate_is_the_same_recursion_as_step() -> None:
    # Mixed calls crossing block boundaries (BLOCK_STEPS normals rows per draw) must give
    # the same numbers as plain steps: same maths, same order, same normals. Bit-identical
    # is expected (numba does not contract or reorder floating point without fastmath); the
    # 1e-15 m/s tolerance only forgives an FMA contraction on some other CPU.
    n1, n2, n3 = 5000, 10, BLOCK_STEPS + 123
    a = _make(3, mean_speed_m_s=1.5, mean_from_deg=200.0)
    mixed = np.concatenate([a.generate(n1, 12.0, 4.0),
                            np.array([a.step(12.0, 4.0) for _ in range(n2)]),
                            a.generate(n3, 12.0, 4.0)])
    b = _make(3, mean_speed_m_s=1.5, mean_from_deg=200.0)
    stepped = np.array([b.step(12.0, 4.0) for _ in range(n1 + n2 + n3)])
    assert_allclose(mixed, stepped, rtol=0, atol=1e-15)


def test_reset_restarts_at_the_floors_without_rewinding_the_generator() -> None:
    wind = _make(4)
    first = wind.step(60.0, 5.0)
    assert_allclose(wind.length_scale_uvw_m, dryden_length_scales_m(60.0), rtol=1e-12)
    wind.reset()
    assert_allclose(wind.length_scale_uvw_m, dryden_length_scales_m(10 * FT_TO_M), rtol=1e-12)
    assert not np.array_equal(wind.step(60.0, 5.0), first)  # a fresh draw, not a replay


# ---------------------------------------------------------------------------------------
# Floors, ceiling and the discretisation cache
# ---------------------------------------------------------------------------------------
def test_altitude_and_airspeed_floors_and_ceiling() -> None:
    floor_m = 10 * FT_TO_M
    ground = _make(8)
    at_floor = _make(8)
    # Below the floors every input behaves exactly as the floors themselves.
    low = np.array([ground.step(alt, spd) for alt, spd in [(0.0, 0.0), (-1.0, 0.3), (0.6, 0.9)]])
    ref = np.array([at_floor.step(floor_m, 1.0) for _ in range(3)])
    assert_array_equal(low, ref)
    assert_allclose(ground.length_scale_uvw_m, dryden_length_scales_m(floor_m), rtol=1e-12)
    high = _make(8)
    high.step(2000.0, 5.0)
    assert_allclose(high.length_scale_uvw_m, (304.8,) * 3, rtol=1e-12)  # clipped at 1000 ft


def test_discretisation_is_cached_within_two_percent() -> None:
    wind = _make(9)
    wind.step(50.0, 5.0)
    l_50 = dryden_length_scales_m(50.0)
    wind.step(50.5, 5.0)  # +1 %: inside the band, not recomputed
    assert_allclose(wind.length_scale_uvw_m, l_50, rtol=1e-12)
    wind.step(53.0, 5.0)  # +6 %: recomputed for 53 m
    assert_allclose(wind.length_scale_uvw_m, dryden_length_scales_m(53.0), rtol=1e-12)
    # Airspeed: +1 % reuses the discretisation (identical numbers), +5 % does not.
    steady, nudged, pushed = _make(10), _make(10), _make(10)
    steady_out = [steady.step(50.0, 10.0) for _ in range(2)]
    nudged_out = [nudged.step(50.0, 10.0), nudged.step(50.0, 10.1)]
    pushed_out = [pushed.step(50.0, 10.0), pushed.step(50.0, 10.5)]
    assert_array_equal(nudged_out[1], steady_out[1])
    assert not np.array_equal(pushed_out[1], steady_out[1])


def test_non_finite_inputs_are_rejected() -> None:
    wind = _make(0)
    with pytest.raises(ValueError, match="altitude_m = nan"):
        wind.step(float("nan"), 3.0)
    with pytest.raises(ValueError, match="airspeed_m_s = inf"):
        wind.step(3.0, float("inf"))


# ---------------------------------------------------------------------------------------
# Configuration
# ---------------------------------------------------------------------------------------
def test_config_loads_from_a_toml_table() -> None:
    table = tomllib.loads(
        'mean_speed_m_s = 3\nmean_from_deg = 270.0\nturbulence = "severe"\n'
        "w20_m_s = 12.5\nairspeed_floor_m_s = 0.5\nmin_altitude_m = 0.5\n"
    )
    config = from_mapping(WindConfig, table)
    assert config == WindConfig(mean_speed_m_s=3.0, mean_from_deg=270.0, turbulence="severe",
                                w20_m_s=12.5, airspeed_floor_m_s=0.5, min_altitude_m=0.5)
    assert from_mapping(WindConfig, {}) == WindConfig()
    assert WindConfig().min_altitude_m == pytest.approx(3.048, abs=1e-12)  # 10 ft


@pytest.mark.parametrize(
    ("table", "fragments"),
    [
        ({"mean_speed_m_s": -1.0}, ["mean_speed_m_s = -1.0", ">= 0"]),
        ({"mean_from_deg": 400.0}, ["mean_from_deg = 400.0", "[0, 360]"]),
        ({"turbulence": "strong"}, ["turbulence = 'strong'", "'light'", "'severe'"]),
        ({"w20_m_s": -2.0}, ["w20_m_s = -2.0", ">= 0"]),
        ({"turbulence": "none", "w20_m_s": 5.0}, ["w20_m_s = 5.0", "turbulence = 'none'"]),
        ({"airspeed_floor_m_s": 0.0}, ["airspeed_floor_m_s = 0.0", "> 0"]),
        ({"min_altitude_m": 0.0}, ["min_altitude_m = 0.0", "> 0"]),
        ({"min_altitude_m": 400.0}, ["min_altitude_m = 400.0", "1000 ft"]),
        ({"mean_speed_m_s": "fast"}, ["mean_speed_m_s = 'fast'", "finite number"]),
        ({"gustiness": 1.0}, ["unknown key gustiness", "mean_speed_m_s"]),
    ],
)
def test_config_errors_name_key_value_and_allowed(table: dict[str, object],
                                                  fragments: list[str]) -> None:
    with pytest.raises(ConfigError) as info:
        from_mapping(WindConfig, table)
    for fragment in fragments:
        assert fragment in str(info.value)


def test_constructor_rejects_bad_step_and_generator() -> None:
    with pytest.raises(ConfigError, match=r"dt_s = 0\.0: must be a finite number > 0"):
        DrydenWind(WindConfig(), 0.0, np.random.default_rng(0))
    with pytest.raises(ConfigError, match="rng = 42: must be a numpy.random.Generator"):
        DrydenWind(WindConfig(), 0.002, 42)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="n_steps = -1"):
        _make(0).generate(-1, 1.0, 1.0)


def test_knot_conversion_is_exact() -> None:
    assert KT_TO_M_S == 1852.0 / 3600.0  # 1 nmi = 1852 m by definition
    assert FT_TO_M == 0.3048  # international foot by definition


@pytest.mark.parametrize("index", [-2000, -1025, -1024, -1, 0, 31, 32, 70])
def test_grid_coefficients_read_from_their_cached_block_are_the_computed_ones(
        index: int) -> None:
    # a block holds GRID_BLOCK consecutive grid steps (negative indices and both block ends
    # included); stored on disk and read back, each row must be the direct computation's floats
    first = index - index % GRID_BLOCK
    block = _second_order_grid_block.design(first)[0]
    stored = _second_order_grid_block(first)[0]
    direct = _second_order_step(GRID_RATIO**index)
    assert tuple(block[index - first].tolist()) == direct
    assert tuple(stored[index - first].tolist()) == direct
    _second_order_step_on_grid.cache_clear()
    assert _second_order_step_on_grid(index) == direct
