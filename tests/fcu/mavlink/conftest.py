"""The MAVLink tests, in subfolders that mirror ``fcu/mavlink/`` (transport, protocols,
telemetry), share one test kit beside this file (``mavlink_testkit``, imported by name).

pytest puts the folder of a ``conftest.py`` that has no ``__init__.py`` on ``sys.path`` (its
default ``prepend`` import mode), as ``tests/conftest.py`` makes ``tests/rrd_reading.py``
importable by name; this file does that for the test kit, whichever subfolder's tests run.
"""
