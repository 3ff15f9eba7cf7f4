"""Fault, detection and outcome records: JSON and MAVLink (DEBUG_FLOAT_ARRAY) round trips."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from flightdata.records import (
    WIRE_NAME,
    DetectionRecord,
    FaultRecord,
    OutcomeRecord,
    from_wire,
    record_from_dict,
    to_wire,
)

RECORDS = [
    FaultRecord(time_s=22.0, action="started", kind="loe", motor=3, magnitude=0.2,
                fault_id=2, profile="step"),
    FaultRecord(time_s=30.5, action="cleared", kind="freeze", sensor="mocap_pos", fault_id=7),
    FaultRecord(time_s=22.0, action="started", kind="mass_loss", magnitude=0.3, fault_id=1),
    DetectionRecord(time_s=22.71, action="detected", kind="loe", motor=3, magnitude=0.19),
    DetectionRecord(time_s=31.0, action="detected", kind="mass_change", magnitude=-0.29),
    DetectionRecord(time_s=40.02, action="cleared", kind="sensor_frozen", sensor="mocap_pos",
                    magnitude=2.0),
    OutcomeRecord(kind="crashed", time_s=38.6, cause="impact_tilt", impact_speed_m_s=2.6,
                  tilt_deg=48.0, distance_m=0.4),
    OutcomeRecord(kind="airborne", time_s=60.0, cause="end_of_run"),
]


def same(a: object, b: object) -> bool:
    """Equal field by field, NaN equal to NaN, floats to float32 precision."""
    for name in a.__dataclass_fields__:  # type: ignore[attr-defined]
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, float):
            if not (math.isnan(x) and math.isnan(y)) and float(np.float32(x)) != float(
                    np.float32(y)):
                return False
        elif x != y:
            return False
    return type(a) is type(b)


@pytest.mark.parametrize("record", RECORDS, ids=lambda r: type(r).__name__)
def test_json_round_trip(record: object) -> None:
    text = json.dumps(record.to_dict())  # type: ignore[attr-defined]
    assert "NaN" not in text  # JSON has no NaN: None instead
    assert same(record_from_dict(json.loads(text)), record)


@pytest.mark.parametrize("record", RECORDS, ids=lambda r: type(r).__name__)
def test_mavlink_round_trip_through_pymavlink(record: object) -> None:
    array_id, data = to_wire(record, seq=41)  # type: ignore[arg-type]
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    mav.robust_parsing = True
    time_s = record.time_s  # type: ignore[attr-defined]
    msg = mavlink.MAVLink_debug_float_array_message(
        int(round(time_s * 1e6)), WIRE_NAME.encode(), array_id, data + [0.0] * (58 - len(data)))
    decoded = mav.parse_char(msg.pack(mav))
    assert decoded is not None and decoded.get_type() == "DEBUG_FLOAT_ARRAY"
    seq, back = from_wire(decoded.array_id, decoded.data, decoded.time_usec / 1e6)
    assert seq == 41
    assert same(back, record)


def test_the_sentence_is_derived_from_the_fields() -> None:
    det = DetectionRecord(time_s=1.0, action="detected", kind="loe", motor=3, magnitude=0.19)
    assert det.text() == "motor 3 lost about 19 % effectiveness"
    out = RECORDS[6]
    assert out.to_dict()["reason"] == "touchdown at 2.60 m/s with 48 deg of tilt (tilted too far)"
    assert out.to_dict()["kind"] == "crashed" and not out.safe


def test_bad_vocabulary_is_refused_with_the_field_named() -> None:
    with pytest.raises(ValueError, match="kind = 'melt'"):
        FaultRecord(time_s=0.0, action="started", kind="melt")
    with pytest.raises(ValueError, match="motor = 5"):
        DetectionRecord(time_s=0.0, action="detected", kind="loe", motor=5)
    with pytest.raises(ValueError, match="array_id 9"):
        from_wire(9, [0.0] * 8, 0.0)
    with pytest.raises(ValueError, match="outcome code"):
        from_wire(3, [1.0, 17.0, 0.0, 0.0, 0.0, 0.0], 0.0)
