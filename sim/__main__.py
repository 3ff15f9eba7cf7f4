"""``python -m sim``: the vehicle process, the same as ``ftc-vehicle``."""

import sys

from sim.vehicle_cli import main

sys.exit(main())
