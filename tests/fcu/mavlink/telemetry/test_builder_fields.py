"""Every builder fills its message's fields by name (a record of ``fields_of(cls)``, of the
class its table entry names), and the packer, which reads the record by position, writes what
pymavlink writes for ``cls(**record._asdict())``, the message made from the same names: the
record's order and the packer's map to the wire agree with pymavlink for every builder. The
sweep covers every message that can be streamed or requested (the streamed table, from a
snapshot where each has something to report) and the replies (HEARTBEAT, AUTOPILOT_VERSION,
COMMAND_ACK, STATUSTEXT). A misspelt or missing name raises."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from test_mavlink_messages import snap
from test_messages_extended import IMU, Extended

from fcu.mavlink.port_records import (
    AttitudeTarget,
    BatteryState,
    PositionTarget,
    SimTruth,
)
from fcu.mavlink.telemetry import messages as build
from fcu.mavlink.telemetry import streamed
from fcu.mavlink.telemetry.extended import (
    EkfReport,
    NavControllerReport,
    PressureReading,
    SecondaryAttitude,
    VibrationLevels,
)
from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ
from fcu.mavlink.transport.codec import Codec, fields_of, heartbeat_fields, mavlink2
from fcu.navigation.modes import Mode

M = mavlink2
CONTEXT = build.TelemetryContext(pwm_max=0.05, mission_total=3, errors_comm=7,
                                 boot_unix_time_s=1.7e9)


def flying() -> Any:
    """A snapshot in flight where every builder has something to report, each field its own
    value (so that a swap of two fields changes the bytes)."""
    euler = np.array([0.05, -0.08, 1.2])
    return snap(
        time_s=123.456, armed=True, custom_mode=Mode.AUTO, euler_rad=euler,
        rate_frd=np.array([0.01, -0.02, 0.03]), home_pos_ned=np.array([0.5, -0.25, -0.1]),
        position_target=PositionTarget(pos_ned=np.array([3.5, -4.5, -2.5]),
                                       vel_ned=np.array([0.9, 0.4, -0.2]),
                                       acc_ned=np.array([0.1, 0.05, -0.3]), yaw_rad=1.1),
        attitude_target=AttitudeTarget(euler_rad=np.array([0.04, -0.07, 1.15]),
                                       rate_frd=np.array([0.02, -0.01, 0.04]), thrust=0.55),
        pwm=np.array([0.021, 0.022, 0.023, 0.024]),
        battery=BatteryState(voltage_v=11.7, current_a=9.5, remaining=0.62, consumed_mah=830.0,
                             consumed_j=35_000.0, time_remaining_s=600.0),
        truth=SimTruth(pos_ned=np.array([3.1, -3.9, -2.05]), vel_ned=np.array([1.1, 0.45, -0.3]),
                       quat_wxyz=np.array([0.82, 0.03, -0.04, 0.57]),
                       rate_frd=np.array([0.015, -0.025, 0.035]),
                       accel_frd=np.array([0.2, -0.1, -9.7]),
                       wind_ned=np.array([1.5, -2.0, 0.2]),
                       esc_rpm=np.array([5100.0, 5200.0, 5300.0, 5400.0]),
                       esc_current_a=np.array([2.1, 2.2, 2.3, 2.4]), esc_voltage_v=11.6),
        loe=np.array([0.0, 0.3, 0.05, 0.1]), mission_seq=2, mission_state=3,
        extended=Extended(
            imu_reading=IMU,
            pressure_reading=PressureReading(time_s=12.5, pressure_pa=100_120.0,
                                             temperature_c=24.5),
            vibration_levels=VibrationLevels(time_s=12.5,
                                             vibration_m_s2=np.array([0.3, 0.4, 0.5]),
                                             clipping=(4, 0, 1)),
            ekf_report=EkfReport(flags=0x3FF, velocity_variance=0.1, pos_horiz_variance=0.2,
                                 pos_vert_variance=0.3, compass_variance=0.4,
                                 terrain_alt_variance=0.5),
            second=SecondaryAttitude(euler_rad=np.array([0.06, -0.09, 1.21]),
                                     pos_ned=np.array([3.2, -4.1, -2.1])),
            nav=NavControllerReport(roll_rad=0.03, pitch_rad=-0.06, bearing_rad=1.0,
                                    target_bearing_rad=1.3, wp_dist_m=12.7,
                                    alt_error_m=0.4, xtrack_error_m=0.6)))


def streamed_records() -> list[tuple[type, Any]]:
    """(message class, record) of every message in the streamed table, built from
    :func:`flying`."""
    s = flying()
    out = []
    for msg_id in streamed.ALL_BUILDERS:
        cls, built = streamed.stream_fields(msg_id, s, CONTEXT)
        assert built, f"{cls.msgname}: nothing to report from the flying snapshot"
        out += [(cls, record) for record in built]
    return out


def reply_records() -> list[tuple[type, Any]]:
    """(message class, record) of the replies and events the builders make."""
    out: list[tuple[type, Any]] = [
        (M.MAVLink_heartbeat_message, heartbeat_fields(81, 3, 4)),
        (M.MAVLink_autopilot_version_message, build.autopilot_version(7, (4, 5, 1))),
        (M.MAVLink_command_ack_message,
         build.command_ack(M.MAV_CMD_COMPONENT_ARM_DISARM, M.MAV_RESULT_DENIED, 255, 190))]
    for text in ("Arm: pre-arm checks failed", "x" * 51 + "yz" * 40):
        out += [(M.MAVLink_statustext_message, record)
                for record in build.statustext_chunks(4, text, 9)]
    return out


def test_the_sweep_covers_every_builder_and_every_stream() -> None:
    built = {cls.id for cls, _ in streamed_records()}
    assert built == set(streamed.ALL_BUILDERS)
    assert set(DEFAULT_RATES_HZ) <= built


@pytest.mark.parametrize("records", [streamed_records, reply_records],
                         ids=["streamed", "replies"])
def test_every_builder_packs_as_pymavlink_packs_its_named_fields(records: Any) -> None:
    codec = Codec(1, 1)
    ref = M.MAVLink(None, srcSystem=1, srcComponent=1)
    for cls, record in records():
        assert type(record) is fields_of(cls), cls.msgname  # the builder table's class
        assert record._fields == tuple(cls.fieldnames)
        expected = cls(**record._asdict()).pack(ref)
        ref.seq = (ref.seq + 1) % 256
        assert codec.pack_fields(cls, record) == expected, cls.msgname


def test_a_misspelt_or_missing_field_raises() -> None:
    record = fields_of(M.MAVLink_attitude_message)
    assert fields_of(M.MAVLink_attitude_message) is record  # made once per message type
    good = {"time_boot_ms": 10, "roll": 0.1, "pitch": 0.2, "yaw": 0.3, "rollspeed": 0.01,
            "pitchspeed": 0.02, "yawspeed": 0.03}
    assert record(**good) == (10, 0.1, 0.2, 0.3, 0.01, 0.02, 0.03)  # constructor order
    misspelt = {**good, "pitch_speed": good["pitchspeed"]}
    del misspelt["pitchspeed"]
    with pytest.raises(TypeError, match="pitch_speed"):
        record(**misspelt)
    missing = dict(good)
    del missing["yaw"]
    with pytest.raises(TypeError, match="yaw"):
        record(**missing)
    with pytest.raises(TypeError):
        fields_of(M.MAVLink_servo_output_raw_message)(time_usec=1, port=0, servo1_raw=1000)
