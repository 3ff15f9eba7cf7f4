"""What the autopilot, the simulator and the ground station share, defined once.

It imports none of ``fcu``, ``sim`` or ``gcs`` (tests/test_import_boundaries.py):

- :mod:`flightdata.vocabulary`: motor numbering, sensor names, configuration choices and the
  parameter values that select them, fault, detection and outcome kinds;
- :mod:`flightdata.records`: fault, detection and outcome records (JSON and MAVLink forms);
- :mod:`flightdata.mission`: mission items and the thesis's mission;
- :mod:`flightdata.thesis`: the thesis's tables, fault schedule and runs;
- :mod:`flightdata.config`: validated configuration dataclasses loaded from TOML;

and the flight-data toolkit, the one implementation both the headless runner and the ground
station use to look at a flight:

- :mod:`flightdata.series`: :class:`~flightdata.series.FlightSeries`, the per-sample arrays of
  a flight (from the runner's ticks or the ground station's telemetry), and its events;
- :mod:`flightdata.metrics`: tracking errors, control effort, LOE convergence, detection
  latency (the thesis's figures of merit);
- :mod:`flightdata.figures`: the thesis-style figures, one registry (matplotlib, lazily);
- :mod:`flightdata.recording`: rerun recordings, live or afterwards (rerun, lazily);
- :mod:`flightdata.report`: Markdown tables and embedded figures of the reports;
- :mod:`flightdata.geometry`: angle wrapping, Euler angles and quaternions, body rates.
"""
