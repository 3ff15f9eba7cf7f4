"""The slow-step lines: one plain line per step off a terminal, a live counter on one."""

from __future__ import annotations

import io

import pytest

from flightdata.steps import Steps


class Clock:
    def __init__(self) -> None:
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s


def test_off_a_terminal_each_step_is_one_plain_line_when_it_starts() -> None:
    out = io.StringIO()
    steps = Steps(out, prog="ftc-gcs")
    assert not steps.live  # a StringIO is no terminal
    with steps.step("writing figures (5 kinds)", total=5) as step:
        for _ in range(5):
            step.advance()
    with steps.step("writing the recording f.rrd"):
        pass
    assert out.getvalue() == ("ftc-gcs: writing figures (5 kinds)...\n"
                              "ftc-gcs: writing the recording f.rrd...\n")


def test_on_a_terminal_the_line_counts_and_ends_with_the_duration() -> None:
    out, clock = io.StringIO(), Clock()
    steps = Steps(out, prog="ftc-scenario", live=True, min_interval_s=0.2, clock=clock)
    with steps.step("writing figures (5 kinds)", total=5) as step:
        for _ in range(5):
            clock.now_s += 1.0
            step.advance()
    text = out.getvalue()
    assert text.startswith("\rftc-scenario: writing figures (5 kinds)... 0/5")
    for k in range(1, 6):
        assert f"writing figures (5 kinds)... {k}/5\x1b[K" in text
    assert text.endswith("\rftc-scenario: writing figures (5 kinds)... done, 5.0 s\x1b[K\n")
    assert text.count("\n") == 1  # one line on the screen


def test_a_failing_step_says_so_and_the_error_goes_on() -> None:
    out = io.StringIO()
    steps = Steps(out, live=True, clock=Clock())
    with pytest.raises(OSError), steps.step("writing the report"):
        raise OSError("disk full")
    assert out.getvalue().endswith("writing the report... failed, 0.0 s\x1b[K\n")


def test_no_stream_says_nothing() -> None:
    steps = Steps(None, live=True)
    with steps.step("anything", total=3) as step:
        step.advance(3)
    assert step.done == 3
