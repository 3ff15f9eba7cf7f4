"""What the autopilot, the simulator and the ground station share, defined once.

It imports none of ``fcu``, ``sim`` or ``gcs`` (tests/test_import_boundaries.py):

- :mod:`flightdata.vocabulary`: motor numbering, sensor names, configuration choices and the
  parameter values that select them, fault, detection and outcome kinds;
- :mod:`flightdata.records`: fault, detection and outcome records (JSON and MAVLink forms);
- :mod:`flightdata.mission`: mission items and the thesis's mission;
- :mod:`flightdata.thesis`: the thesis's tables, fault schedule and runs;
- :mod:`flightdata.config`: validated configuration dataclasses loaded from TOML.
"""
