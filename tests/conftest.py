"""Repository-wide pytest configuration.

``gcs.pytest_plugin`` provides the ``vehicle_link`` fixture (a started ``ftc-vehicle`` and a
connected ground-station link) and the ``vehicle`` marker; see its docstring and the README.
"""

pytest_plugins = ["gcs.pytest_plugin"]
