"""The words the vehicle, the simulator and the ground station share, each defined once.

Motor numbering, sensor names, the autopilot's configuration choices and the parameter
values that select them, fault kinds, detection kinds and flight outcomes. The autopilot
(``fcu``), the simulator (``sim``) and the ground station (``gcs``) import these names rather
than spelling them out, so a new choice is added here and in the module that implements it.

Configuration choices are ordered tuples: the position of a choice is the value of the
parameter that selects it over MAVLink (``ATT_CTRL = 1`` is ``ATTITUDE_LAWS[1]``, "lqg").
Append new choices at the end so existing parameter values keep their meaning.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Literal, get_args

# ---- the airframe -------------------------------------------------------------------------
MOTORS: tuple[int, ...] = (1, 2, 3, 4)
"""Motor numbers of thesis eq. 3.2: 1 front, 2 back, 3 left, 4 right (docs/design.md)."""
OPPOSITE_MOTOR: Mapping[int, int] = MappingProxyType({1: 2, 2: 1, 3: 4, 4: 3})
"""Each motor's partner on its arm pair (thesis eq. 3.2: 1 and 2 pitch, 3 and 4 roll)."""

# ---- sensors ------------------------------------------------------------------------------
SensorName = Literal["gyro", "accel", "mocap_pos", "mocap_att", "baro"]
SENSORS: tuple[str, ...] = get_args(SensorName)
"""Sensor names, as on every sensor sample (fcu/hal.py)."""

BATTERY_SENSOR = "battery"
"""The power module's samples (terminal voltage V, current A): read by the battery monitor,
not by the estimators, and not a fault target (so not among :data:`SENSORS`)."""

SENSOR_AXES: Mapping[str, int] = MappingProxyType(
    {"gyro": 3, "accel": 3, "mocap_pos": 3, "mocap_att": 3, "baro": 1})
"""Number of elements of each sensor's value."""

# ---- the autopilot's configuration choices (value of the selecting parameter = index) -------
AttitudeLawName = Literal["pd", "lqg"]
ATTITUDE_LAWS: tuple[AttitudeLawName, ...] = get_args(AttitudeLawName)
"""Attitude control laws: PD (eq. 5.6), LQR + integral on the estimate (LQG, eq. 5.10)."""
EstimatorName = Literal["ekf", "tskf"]
ESTIMATORS: tuple[EstimatorName, ...] = get_args(EstimatorName)
"""State estimators whose estimate feeds the controllers."""
DobName = Literal["none", "vbdob", "abdob"]
DISTURBANCE_OBSERVERS: tuple[DobName, ...] = get_args(DobName)
"""Disturbance observers on the attitude loop (eq. 6.27-6.30)."""
HeightSource = Literal["mocap", "baro"]
HEIGHT_SOURCES: tuple[HeightSource, ...] = get_args(HeightSource)
"""Where the estimators take height from."""
AllocatorName = Literal["attitude_first"]
ALLOCATORS: tuple[AllocatorName, ...] = get_args(AllocatorName)
"""Control allocators: the inverse of eq. 3.2 with attitude-first saturation (no parameter
selects one yet)."""

FtcMode = Literal["passive", "active"]
FTC_MODES: tuple[FtcMode, ...] = get_args(FtcMode)
"""Fault-tolerant control: ``passive`` (the thesis: robust control, the estimates only
reported) or ``active`` (the allocation uses the estimated effectiveness of each motor)."""

CONFIG_CHOICES: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "attitude": ATTITUDE_LAWS,
    "estimator": ESTIMATORS,
    "dob": DISTURBANCE_OBSERVERS,
    "height_source": HEIGHT_SOURCES,
    "allocator": ALLOCATORS,
    "ftc": FTC_MODES,
})
"""Configuration key (``[autopilot]`` table) -> its ordered choices."""

CONFIG_PARAMS: Mapping[str, str] = MappingProxyType({
    "attitude": "ATT_CTRL",
    "estimator": "EST_TYPE",
    "dob": "DOB_TYPE",
    "height_source": "HGT_SOURCE",
    "ftc": "FTC_MODE",
})
"""Configuration key -> the MAVLink parameter that selects it (value = index of the choice);
keys of :data:`CONFIG_CHOICES` without a parameter are set in the configuration only."""


def choice_value(key: str, choice: str) -> int:
    """The parameter value selecting ``choice`` of configuration ``key``.

    Raises
    ------
    ValueError
        ``key`` is not a configuration choice, or ``choice`` is not one of its choices.
    """
    if key not in CONFIG_CHOICES:
        raise ValueError(f"{key!r} is not a configuration choice "
                         f"({', '.join(CONFIG_CHOICES)} are)")
    choices = CONFIG_CHOICES[key]
    if choice not in choices:
        raise ValueError(f"{key} = {choice!r}: must be one of {', '.join(choices)}")
    return choices.index(choice)


# ---- telemetry names ----------------------------------------------------------------------
LOE_VALUE_NAMES: tuple[str, ...] = tuple(f"LOE{m}" for m in MOTORS)
"""NAMED_VALUE_FLOAT names of the per-motor effectiveness-loss estimates, motors 1..4."""

# ---- faults -------------------------------------------------------------------------------
ActuatorKind = Literal["loe", "lock", "float", "hardover", "total_loss"]
ACTUATOR_FAULT_KINDS: tuple[ActuatorKind, ...] = get_args(ActuatorKind)
"""Actuator faults: loss of effectiveness (eq. 4.10), stuck command, no thrust, full
output, total loss."""
LoeProfile = Literal["step", "sinusoid", "random", "pulse"]
LOE_PROFILES: tuple[LoeProfile, ...] = get_args(LoeProfile)
"""Time profiles of a loss of effectiveness (Table 6.1)."""
SensorKind = Literal["bias", "loss_of_accuracy", "drift", "freeze", "calibration"]
SENSOR_FAULT_KINDS: tuple[SensorKind, ...] = get_args(SensorKind)
"""Sensor faults (chapter 4)."""
STRUCTURAL_FAULT_KINDS: tuple[str, ...] = ("mass_loss",)
"""Structural faults: part of the airframe's mass leaves it."""
FAULT_KINDS: tuple[str, ...] = (*ACTUATOR_FAULT_KINDS, *SENSOR_FAULT_KINDS,
                                *STRUCTURAL_FAULT_KINDS)
"""Every fault kind (the wire code of a kind is its index here)."""

# ---- what the autopilot concludes ---------------------------------------------------------
DETECTION_KINDS: tuple[str, ...] = ("loe", "motor_lost", "mass_change", "sensor_rejected",
                                    "sensor_frozen", "sensor_inconsistent", "crash",
                                    "thrust_loss", "motor_hard_over", "motor_stuck")
"""Kinds of detection record (the wire code of a kind is its index here):

- ``loe``: a motor lost part of its effectiveness (magnitude: the estimated loss, 0..1);
- ``motor_lost``: a motor lost more than yaw authority allows, or all of it (magnitude 0..1);
- ``mass_change``: the airframe's mass changed (magnitude: estimated change, kg, + heavier);
- ``sensor_rejected``: a sensor's measurements fail the innovation test (magnitude: NIS);
- ``sensor_frozen``: a sensor repeats the same reading (magnitude: seconds frozen);
- ``sensor_inconsistent``: two sources disagree (magnitude: the disagreement, sensor unit);
- ``crash``: the crash check fired (magnitude: attitude error, rad);
- ``thrust_loss``: the thrust-loss check fired (magnitude: collective command, 0..1);
- ``motor_hard_over``: a motor runs at full power whatever its command (magnitude: the
  command it follows, fraction of full power);
- ``motor_stuck``: a motor gives more thrust than commanded, short of full power, as a
  locked command does (magnitude: the command it follows, fraction of full power).
"""

# ---- how a flight ended (simulator truth) -------------------------------------------------
OUTCOMES: tuple[str, ...] = ("landed", "crashed", "flyaway", "airborne")
"""Outcome of a flight: down and safe, down hard, gone, still flying at the end."""
