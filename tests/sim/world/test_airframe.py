"""Airframe parameters: Table 7.1 defaults, TOML loading, and errors a person can act on."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

import flightdata
from flightdata.config import ConfigError
from sim.world.airframe import Airframe

THESIS_TABLES = Path(flightdata.__file__).parent / "data" / "thesis_tables.toml"


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "airframe.toml"
    path.write_text(text)
    return path


def test_defaults_are_table_7_1_and_hover_pwm_is_m_g_over_4k() -> None:
    af = Airframe()
    assert (af.thrust_gain, af.motor_bandwidth, af.arm_length, af.yaw_gain) == (
        175.0, 15.0, 0.2, 0.023)
    assert (af.mass, af.gravity, af.inertia) == (1.42, 9.81, (0.03, 0.03, 0.04))
    assert (af.pwm_min, af.pwm_max, af.crash_speed_m_s) == (0.0, 0.05, 3.0)
    # m g / (4 K) = 1.42 * 9.81 / 700; rel 1e-12: a closed form evaluated in float64
    assert af.hover_pwm == pytest.approx(1.42 * 9.81 / 700.0, rel=1e-12)
    assert round(af.hover_pwm, 4) == 0.0199  # the thesis's quoted hover PWM
    # thrust-to-weight 4 K pwm_max / (m g) = 2.51 (reading notes); 0.005: quoted to 2 decimals
    assert 4 * af.max_thrust_n / (af.mass * af.gravity) == pytest.approx(2.51, abs=0.005)


def test_thesis_tables_airframe_table_loads_to_the_defaults() -> None:
    assert Airframe.from_toml(THESIS_TABLES) == Airframe()


def test_from_toml_overrides_given_keys_and_keeps_the_rest(tmp_path: Path) -> None:
    path = _write(tmp_path, "[airframe]\nmass = 1.12\ninertia = [0.02, 0.03, 0.04]\n")
    af = Airframe.from_toml(path)
    assert af.mass == 1.12 and af.inertia == (0.02, 0.03, 0.04)
    assert af.thrust_gain == 175.0 and af.drag_coeff_xy == Airframe().drag_coeff_xy


def test_from_toml_whole_file_when_table_is_none(tmp_path: Path) -> None:
    path = _write(tmp_path, "mass = 2.0\n")
    assert Airframe.from_toml(path, table=None).mass == 2.0


def test_unknown_key_is_named_with_the_allowed_keys(tmp_path: Path) -> None:
    path = _write(tmp_path, "[airframe]\nmasss = 1.0\n")
    with pytest.raises(ConfigError) as err:
        Airframe.from_toml(path)
    msg = str(err.value)
    assert "unknown key airframe.masss" in msg
    assert "mass" in msg.split("allowed keys are")[1] and str(path) in msg


def test_zero_mass_names_key_value_and_range(tmp_path: Path) -> None:
    path = _write(tmp_path, "[airframe]\nmass = 0\n")
    with pytest.raises(ConfigError) as err:
        Airframe.from_toml(path)
    assert "airframe.mass = 0.0: must be a finite number > 0 (kg)" in str(err.value)


def test_negative_inertia_names_the_element(tmp_path: Path) -> None:
    path = _write(tmp_path, "[airframe]\ninertia = [0.03, -0.03, 0.04]\n")
    with pytest.raises(ConfigError) as err:
        Airframe.from_toml(path)
    assert "airframe.inertia[1] = -0.03: must be a finite number > 0 (kg*m^2)" in str(err.value)


@pytest.mark.parametrize("pwm_max", [0.02, 0.01])
def test_pwm_max_not_above_pwm_min_is_rejected(tmp_path: Path, pwm_max: float) -> None:
    path = _write(tmp_path, f"[airframe]\npwm_min = 0.02\npwm_max = {pwm_max}\n")
    with pytest.raises(ConfigError) as err:
        Airframe.from_toml(path)
    assert f"airframe.pwm_max = {pwm_max}: must be a finite number > pwm_min (0.02)" in str(
        err.value)


def test_malformed_toml_names_the_file(tmp_path: Path) -> None:
    path = _write(tmp_path, "[airframe\nmass = 1.0\n")
    with pytest.raises(ConfigError) as err:
        Airframe.from_toml(path)
    assert str(err.value).startswith(f"{path}: not valid TOML")


def test_missing_file_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.toml"
    with pytest.raises(ConfigError, match="no such file") as err:
        Airframe.from_toml(path)
    assert str(path) in str(err.value)


def test_missing_table_is_named(tmp_path: Path) -> None:
    path = _write(tmp_path, "[frame]\nmass = 1.0\n")
    with pytest.raises(ConfigError, match=r"missing table \[airframe\]"):
        Airframe.from_toml(path)


def test_wrong_type_is_rejected(tmp_path: Path) -> None:
    path = _write(tmp_path, '[airframe]\narm_length = "0.2"\n')
    with pytest.raises(ConfigError, match="airframe.arm_length = '0.2': must be a finite number"):
        Airframe.from_toml(path)


@pytest.mark.parametrize(
    ("kwargs", "expected"),
    [
        ({"thrust_gain": -175.0}, "thrust_gain = -175.0: must be a finite number > 0"),
        ({"motor_bandwidth": float("nan")}, "motor_bandwidth = nan: must be a finite number > 0"),
        ({"drag_coeff_z": -0.1}, "drag_coeff_z = -0.1: must be a finite number >= 0"),
        ({"pwm_min": -0.01}, "pwm_min = -0.01: must be a finite number >= 0"),
        ({"crash_speed_m_s": 0.0}, "crash_speed_m_s = 0.0: must be a finite number > 0"),
        ({"inertia": (0.01, 0.01, 0.04)}, "each principal moment must be no larger"),
        ({"inertia": (0.03, 0.03)}, "inertia = (0.03, 0.03): must be a tuple of three"),
    ],
)
def test_direct_construction_validates(kwargs: dict[str, object], expected: str) -> None:
    with pytest.raises(ConfigError) as err:
        Airframe(**kwargs)  # type: ignore[arg-type]
    assert expected in str(err.value)


def test_airframe_is_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        Airframe().mass = 2.0  # type: ignore[misc]
