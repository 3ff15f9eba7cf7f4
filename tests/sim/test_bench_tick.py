"""``ftc-bench tick``: every compiled call of the tick is found, timed and put back.

What it prints is a measurement (never asserted here); that it measures the calls the stack
really makes, and leaves the stack as it found it, is."""

from __future__ import annotations

import importlib
import re

import pytest

from sim import bench


def test_the_tick_breakdown_times_every_compiled_call_and_puts_them_back(
        capsys: pytest.CaptureFixture[str]) -> None:
    before = {(m, n): getattr(importlib.import_module(m), n) for m, n, _ in bench.TICK_KERNELS}
    assert bench.main(["tick", "--repeat", "1"]) == 0
    out = capsys.readouterr().out
    for module_name, name, label in bench.TICK_KERNELS:
        # every call was made by the flight (a renamed or unused kernel would show 0 calls)
        line = next(line for line in out.splitlines() if line.strip().startswith(label))
        calls = float(re.search(r"\(([\d.]+) calls\)", line).group(1))  # type: ignore[union-attr]
        assert calls > 0.5, line
        assert getattr(importlib.import_module(module_name), name) is before[
            (module_name, name)]
    assert "compiled calls in all" in out


def test_a_kernel_gone_from_its_module_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bench, "TICK_KERNELS",
                        (*bench.TICK_KERNELS, ("sim.world.world", "no_such_kernel", "gone")))
    with pytest.raises(RuntimeError, match=r"sim\.world\.world\.no_such_kernel"):
        bench.main(["tick", "--repeat", "1"])
    # the kernels wrapped before the error are back
    import sim.world.world as world_module
    from sim.world.stepping import world_steps
    assert world_module.world_steps is world_steps
