"""``make demo``: fly the thesis mission with the Table 7.3 faults and print the table.

Headless for now: the world and the autopilot in one process, as fast as the CPU allows.
"""

from __future__ import annotations

import sys

from sim.scenario_cli import main

if __name__ == "__main__":
    sys.exit(main(["run", "lqg_abdob_loe"]))
