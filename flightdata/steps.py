"""Saying what a command is doing during its slow steps (reading a log, drawing figures...).

A flight's figures, recording and report can take a minute after the flight itself, which
should not be a silent minute. :class:`Steps` writes one line per step on a stream (standard
error): on a terminal the line is rewritten in place with a live counter and ends with the
step's duration; elsewhere (a pipe, a log file, CI) it is a plain line written when the step
starts, so logs stay readable::

    ftc-gcs: writing figures (5 kinds, PNG and PDF) in figs/... 3/5        (terminal, live)
    ftc-gcs: writing figures (5 kinds, PNG and PDF) in figs/... done, 11.8 s
    ftc-gcs: writing figures (5 kinds, PNG and PDF) in figs/...            (elsewhere)

Usage::

    steps = Steps(sys.stderr, prog="ftc-gcs")
    with steps.step("writing figures (5 kinds)", total=5) as step:
        save_figures(series, out, on_figure=lambda kind: step.advance())

The headless runner's own live line (simulated time, real-time factor, flight phase) is
:class:`sim.progress.ProgressLine`; this is for the work around a flight.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from types import TracebackType
from typing import IO

__all__ = ["Step", "Steps"]

_CLEAR_TO_EOL = "\x1b[K"


class Step:
    """One step in progress (made by :meth:`Steps.step`); count its work with :meth:`advance`.

    Attributes
    ----------
    done : int
        Units of work done so far.
    total : int or None
        Units expected (None: unknown; the counter then shows ``done`` alone).
    """

    def __init__(self, steps: Steps, what: str, total: int | None) -> None:
        self._steps = steps
        self.what = what
        self.total = total
        self.done = 0
        self._start_s = steps.clock()
        self._next_s = self._start_s + steps.min_interval_s

    def advance(self, n: int = 1) -> None:
        """``n`` more units of work done; the live line is rewritten when due."""
        self.done += n
        now = self._steps.clock()
        if now >= self._next_s:
            self._next_s = now + self._steps.min_interval_s
            self._steps.show(self, self.counter())

    def counter(self) -> str:
        """``"3/5"``, or ``"3"`` when the total is unknown."""
        return f"{self.done}/{self.total}" if self.total is not None else f"{self.done}"

    def elapsed_s(self) -> float:
        """Wall seconds since the step started."""
        return self._steps.clock() - self._start_s

    def __enter__(self) -> Step:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._steps.finish(self, failed=kind is not None)


class Steps:
    """Announces the slow steps of a command (see the module docstring).

    Parameters
    ----------
    stream : text stream or None
        Where the lines go (``sys.stderr``); None says nothing (``--quiet``).
    prog : str
        The command's name, first on each line.
    live : bool or None
        Rewrite the line in place with a counter (a terminal); None: when ``stream`` is a
        terminal.
    min_interval_s : float
        Wall seconds between two rewrites of a live line.
    clock : callable
        Wall clock, s (``time.perf_counter``; injectable for tests).
    """

    def __init__(self, stream: IO[str] | None, *, prog: str = "", live: bool | None = None,
                 min_interval_s: float = 0.2,
                 clock: Callable[[], float] = time.perf_counter) -> None:
        self.stream = stream
        self.prog = prog
        if live is None:
            isatty = getattr(stream, "isatty", None)
            live = bool(isatty()) if callable(isatty) else False
        self.live = live
        self.min_interval_s = min_interval_s
        self.clock = clock

    def step(self, what: str, total: int | None = None) -> Step:
        """Start a step (a context manager): says ``<prog>: <what>...`` at once."""
        step = Step(self, what, total)
        if self.stream is not None:
            if self.live:
                self._write("\r" + self._head(step) + (" 0/" + str(total) if total else ""))
            else:
                self._write(self._head(step) + "\n")
        return step

    def _head(self, step: Step) -> str:
        prefix = f"{self.prog}: " if self.prog else ""
        return f"{prefix}{step.what}..."

    def show(self, step: Step, counter: str) -> None:
        """Rewrite the live line of ``step`` with ``counter`` (nothing when not live)."""
        if self.stream is not None and self.live:
            self._write("\r" + self._head(step) + " " + counter + _CLEAR_TO_EOL)

    def finish(self, step: Step, *, failed: bool = False) -> None:
        """End ``step``: the live line gets its outcome and duration (nothing when not live)."""
        if self.stream is None or not self.live:
            return
        outcome = "failed" if failed else "done"
        self._write("\r" + self._head(step) + f" {outcome}, {step.elapsed_s():.1f} s"
                    + _CLEAR_TO_EOL + "\n")

    def _write(self, text: str) -> None:
        assert self.stream is not None
        self.stream.write(text)
        self.stream.flush()
