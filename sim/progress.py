"""A progress line for long headless runs: simulated time, real-time factor and flight phase.

On a terminal the line is rewritten in place a few times per second::

    lqg_loe  t = 23.4 / 60.0 s  3.9x real time  AUTO in air, item 6/10 waypoint

Elsewhere (a pipe, a log file, CI) only the final line is written, so logs stay readable.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import IO, TYPE_CHECKING

if TYPE_CHECKING:
    from fcu.autopilot import Autopilot
    from sim.world import World

_LANDED = {0: "", 1: "on ground", 2: "in air", 3: "taking off", 4: "landing"}
_CLEAR_TO_EOL = "\x1b[K"


def flight_phase(autopilot: Autopilot) -> str:
    """Mode, landed state, current mission item and active failsafes, in a few words.

    Examples: ``"AUTO in air, item 6/10 waypoint"``, ``"LAND landing, failsafe: estimator"``.
    """
    nav = autopilot.navigator
    words = [nav.mode.name]
    landed = _LANDED.get(int(nav.landed_state), "")
    if landed:
        words.append(landed)
    text = " ".join(words)
    progress = nav.mission_progress()
    items = nav.mission_items
    if progress.state.name == "ACTIVE" and 1 <= progress.current_seq <= len(items):
        item = items[progress.current_seq - 1]
        text += f", item {progress.current_seq}/{len(items)} {item.command}"
    elif progress.state.name == "COMPLETE":
        text += ", mission complete"
    failsafes = nav.failsafe_sources
    if failsafes:
        text += ", failsafe: " + ", ".join(failsafes)
    return text


class ProgressLine:
    """Reports a run's progress on ``stream`` (pass :meth:`on_tick` to ``fly``).

    Parameters
    ----------
    stream : text stream
        Usually ``sys.stderr``.
    name : str
        What is flying (the scenario name), first on the line.
    duration_s : float
        Simulated time the run will last, s.
    live : bool
        Rewrite one line in place while flying (for a terminal); when False only
        :meth:`finish` writes.
    min_interval_s : float
        Wall-clock time between two rewrites of the live line, s.
    clock : callable
        Wall clock in seconds (``time.perf_counter``; injectable for tests).
    """

    def __init__(self, stream: IO[str], name: str, duration_s: float, *, live: bool,
                 min_interval_s: float = 0.2,
                 clock: Callable[[], float] = time.perf_counter) -> None:
        self.stream = stream
        self.name = name
        self.duration_s = duration_s
        self.live = live
        self.min_interval_s = min_interval_s
        self._clock = clock
        self._wall0 = clock()  # until the first tick: the real-time factor starts there
        self._sim0 = 0.0
        self._next_wall = math.inf
        self._sim_s = 0.0
        self._autopilot: Autopilot | None = None
        self._written = False

    def line(self, sim_s: float, rtf: float, phase: str) -> str:
        """The text of one progress line (``rtf``: simulated seconds per wall-clock second)."""
        return (f"{self.name}  t = {sim_s:5.1f} / {self.duration_s:.1f} s  "
                f"{rtf:5.1f}x real time  {phase}")

    def on_tick(self, world: World, autopilot: Autopilot) -> None:
        """Note the simulated time; rewrite the live line when due."""
        self._sim_s = world.time_s
        if self._autopilot is None:
            self._autopilot = autopilot
            self._wall0 = self._clock()
            self._sim0 = self._sim_s
            self._next_wall = self._wall0 + self.min_interval_s
        if not self.live:
            return
        now = self._clock()
        if now < self._next_wall:
            return
        self._next_wall = now + self.min_interval_s
        rtf = (self._sim_s - self._sim0) / max(now - self._wall0, 1e-9)
        self.stream.write("\r" + self.line(self._sim_s, rtf, flight_phase(autopilot))
                          + _CLEAR_TO_EOL)
        self.stream.flush()
        self._written = True

    def finish(self, sim_s: float | None = None, wall_s: float | None = None,
               note: str = "") -> None:
        """Write the final line (replacing the live one), e.g. with ``note="interrupted"``.

        ``sim_s`` and ``wall_s`` (the whole run, e.g. ``FlightResult.sim_s`` and ``wall_s``)
        default to the last tick seen and the wall time since the first; the phase is the
        autopilot's at the last tick.
        """
        if sim_s is None or wall_s is None:
            sim_s, wall_s = self._sim_s, self._clock() - self._wall0
            rtf = (sim_s - self._sim0) / max(wall_s, 1e-9)
        else:
            rtf = sim_s / max(wall_s, 1e-9)
        phase = flight_phase(self._autopilot) if self._autopilot is not None else "not started"
        text = self.line(sim_s, rtf, phase)
        if note:
            text += f"  ({note})"
        prefix = "\r" if self._written else ""
        suffix = _CLEAR_TO_EOL if self._written else ""
        self.stream.write(prefix + text + suffix + "\n")
        self.stream.flush()
