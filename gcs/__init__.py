"""The ground station: drives a vehicle over MAVLink with pymavlink only (never fcu or sim).

Modules: :mod:`gcs.mavlink` (dialect and wire version, .tlog reading), :mod:`gcs.link` (the
link: heartbeat, receiving and recording, replies, commands and their ACKs; with
:mod:`gcs.reply_inbox`, :mod:`gcs.round_trips` and :mod:`gcs.signing_check`),
:mod:`gcs.station` (the ground station on it: streams, arming, modes, the mission start;
built on :mod:`gcs.parameters`, :mod:`gcs.mission_upload` and :mod:`gcs.injection`),
:mod:`gcs.flight` (the whole flight), :mod:`gcs.telemetry` (packets to the
vehicle clock, dated events, samples and records), :mod:`gcs.analysis` (those to the thesis
table and a flight series), :mod:`gcs.alignment` (truth and references on the SIM_STATE
samples), :mod:`gcs.table` (the table and its text),
:mod:`gcs.report` (the Markdown report), :mod:`gcs.mission`, :mod:`gcs.faults`,
:mod:`gcs.records` (.tlog and event log), :mod:`gcs.spawn` (a vehicle child process),
:mod:`gcs.cli` (``ftc-gcs``), :mod:`gcs.pytest_plugin` (the ``vehicle_link`` fixture).
Figures, recordings and metrics are the shared toolkit's (:mod:`flightdata`).
"""
