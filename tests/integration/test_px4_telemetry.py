"""PX4's telemetry and ArduPilot's ESC report from the vehicle process, on request.

ESC_TELEMETRY_1_TO_4 carries what the simulated ESCs measure: in a hover the four rotors turn
alike and their currents add up to the battery's (less the avionics), and a rotor lost in
flight reads 0 rpm. A message the vehicle cannot produce gets UNSUPPORTED, not DENIED.
"""

from __future__ import annotations

import statistics

from test_extended_telemetry import no_idle_disarm, sim_window
from vehicle_harness import Gcs, M

GUIDED = 4
ACCEPTED, UNSUPPORTED = M.MAV_RESULT_ACCEPTED, M.MAV_RESULT_UNSUPPORTED
ESC_STATUS, ESC_INFO = 291, 290  # PX4's, not in the vehicle's dialect


def test_requestable_messages_and_unsupported_ones(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", "5", outs=[gcs.port])
    gcs.wait_heartbeat()
    gcs.wait("RAW_IMU", timeout_s=60.0)  # an IMU sample exists (before it: TEMPORARILY_REJECTED)
    for msg_id, kind in ((M.MAVLINK_MSG_ID_HIGHRES_IMU, "HIGHRES_IMU"),
                         (M.MAVLINK_MSG_ID_ODOMETRY, "ODOMETRY"),
                         (M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, "ACTUATOR_OUTPUT_STATUS"),
                         (M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, "ATTITUDE_QUATERNION")):
        since = gcs.mark()
        assert gcs.command(M.MAV_CMD_REQUEST_MESSAGE, msg_id).result == ACCEPTED
        gcs.wait(kind, since=since)
        assert gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 100_000).result == ACCEPTED
        gcs.wait(kind, since=gcs.mark())
    for msg_id in (ESC_STATUS, ESC_INFO, M.MAVLINK_MSG_ID_OPTICAL_FLOW):
        assert gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 100_000).result == \
            UNSUPPORTED
        assert gcs.command(M.MAV_CMD_REQUEST_MESSAGE, msg_id).result == UNSUPPORTED
    # ArduPilot's group: EXTRA3 starts the ESC report
    since = gcs.mark()
    gcs.send(M.MAVLink_request_data_stream_message(1, 1, M.MAV_DATA_STREAM_EXTRA3, 2, 1))
    gcs.wait("ESC_TELEMETRY_1_TO_4", since=since)


def test_esc_report_in_a_hover_and_a_lost_rotor(start_vehicle, gcs: Gcs) -> None:
    start_vehicle("--speedup", "10", outs=[gcs.port])
    gcs.wait_heartbeat()
    no_idle_disarm(gcs)
    assert gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4,
                       100_000).result == ACCEPTED
    gcs.take_off(1.5)
    sim_window(gcs, 3.0)  # settle
    hover = sim_window(gcs, 5.0)
    escs = [m for m in hover if m.get_type() == "ESC_TELEMETRY_1_TO_4"]
    assert len(escs) >= 40  # 10 Hz over 5 s, less the schedule's phase
    rpm = [statistics.fmean(m.rpm[i] for m in escs) for i in range(4)]
    # hover: a quarter of 1.42 kg each on a 10-inch propeller, ~5000 rpm; alike within 10 %
    assert all(4000 < r < 6000 for r in rpm) and max(rpm) / min(rpm) < 1.1
    battery = statistics.fmean(m.current_battery for m in hover
                               if m.get_type() == "BATTERY_STATUS")  # cA
    rotors = statistics.fmean(sum(m.current) for m in escs)  # cA
    assert 0.7 * battery < rotors < battery  # the rest is the avionics' idle draw

    since = gcs.mark()
    assert gcs.command(M.MAV_CMD_INJECT_FAILURE, M.FAILURE_UNIT_SYSTEM_MOTOR,
                       M.FAILURE_TYPE_OFF, 3).result == ACCEPTED
    lost = gcs.wait("ESC_TELEMETRY_1_TO_4", lambda m: m.rpm[2] == 0, since=since,
                    timeout_s=60.0)
    assert lost.current[2] == 0 and min(lost.rpm[i] for i in (0, 1, 3)) > 0
