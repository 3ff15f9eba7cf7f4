"""Compile (or load) the numba kernels before anything flies, and say how far it has got.

Every kernel is ``@njit(cache=True)``: the first call on a machine compiles it (numba's type
inference and LLVM: minutes of CPU for the whole project on a 2-core machine, most of it for
the estimators), later processes load the machine code from the cache in about a second.
This module does that first call on purpose, at a time of the user's choosing:

- :func:`precompile` first prepares what a vehicle's boot needs (the default configuration,
  which ``make demo`` flies), then flies every configuration that runs a kernel of its own
  (:data:`PRECOMPILE_FLIGHTS`): after it every kernel the project can run is in the cache.
  ``make setup`` runs it (through ``ftc-vehicle --precompile``), so a fresh clone's first
  ``ftc-vehicle``, ``ftc-scenario`` or campaign worker only loads.
- :func:`prepare_vehicle` does the same for one vehicle's own configuration at its boot,
  while its boot HEARTBEATs say ``MAV_STATE_BOOT`` (:mod:`fcu.mavlink.transport.boot_beacon`
  sends the progress lines meanwhile).

:class:`KernelProgress` counts the project's kernels compiled so far from numba's event API
(``numba.core.event``, the ``numba:compile`` events), out of every kernel the project
defines (:func:`project_kernels`): ``preparing: 37 of 131 kernels compiled, 41 s``. A kernel
loaded from the cache is not compiled and is not counted, so with a warm cache the count
stays low and the preparation ends in about a second. The count rises in steps: the
estimators' kernel alone is a third of the cold build, one step of tens of seconds.
"""

from __future__ import annotations

import gc
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["PRECOMPILE_FLIGHTS", "KernelProgress", "Progress", "precompile",
           "prepare_vehicle", "project_kernels", "reporting"]

PROJECT_PACKAGES = ("sim", "fcu", "flightdata", "jitsupport")  # whose kernels are counted
REPORT_PERIOD_S = 5.0  # s wall between progress reports


@dataclass(frozen=True)
class Progress:
    """How far a preparation has got."""

    compiled: int  # project kernels compiled so far, each once however many specialisations
    # (cache loads are not counted)
    total: int  # kernels the project defines
    elapsed_s: float  # s wall since the preparation started
    compiling: str = ""  # the outermost kernel being compiled now ("" when none)
    done: bool = False

    def line(self) -> str:
        """One line of at most 50 characters (one STATUSTEXT): ``preparing: N of M kernels
        compiled, T s`` or, at the end, ``ready: ...``."""
        head = "ready" if self.done else "preparing"
        return f"{head}: {self.compiled} of {self.total} kernels compiled, {self.elapsed_s:.0f} s"


def project_kernels() -> list[Any]:
    """Every numba kernel (dispatcher) defined in the project's modules imported so far,
    each once, in a stable order (module, then name); not those declared
    ``inline="always"``, whose code is compiled into their callers' and never on its own."""
    from numba.extending import is_jitted  # (public: a numba dispatcher)

    seen: dict[int, tuple[str, str, Any]] = {}
    for name, module in list(sys.modules.items()):
        if module is None or name.partition(".")[0] not in PROJECT_PACKAGES:
            continue
        for value in list(vars(module).values()):
            if (is_jitted(value) and id(value) not in seen
                    and value.targetoptions.get("inline") != "always"):
                func = value.py_func
                if func.__module__.partition(".")[0] in PROJECT_PACKAGES:
                    seen[id(value)] = (func.__module__, func.__qualname__, value)
    return [entry[2] for entry in sorted(seen.values(), key=lambda e: (e[0], e[1]))]


def _kernel_name(dispatcher: Any) -> str:
    func = dispatcher.py_func
    return f"{func.__module__}.{func.__qualname__}"


class KernelProgress:
    """Counts the project's kernels numba compiles while it is entered (a context manager,
    through ``numba.core.event``'s ``numba:compile`` events); thread-safe to read."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._start_s = clock()
        self._lock = threading.Lock()
        self._compiled: set[str] = set()  # kernel and signature
        self._kernels: set[str] = set()  # kernel
        self._stack: list[str] = []
        self._total = 0
        self._done = False
        self._listener: Any = None

    def __enter__(self) -> KernelProgress:
        from numba.core import event

        class Forward(event.Listener):  # numba's listener interface, to notify()
            def on_start(inner, ev: Any) -> None:  # noqa: N805
                self.notify(ev)

            def on_end(inner, ev: Any) -> None:  # noqa: N805
                self.notify(ev)

        self._start_s = self._clock()
        self._total = len(project_kernels())
        self._listener = Forward()
        event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc: object) -> None:
        from numba.core import event

        event.unregister("numba:compile", self._listener)

    def finish(self) -> Progress:
        """Mark the preparation done; returns the final progress."""
        self._total = max(self._total, len(project_kernels()))
        self._done = True
        return self.snapshot()

    def notify(self, ev: Any) -> None:
        """A ``numba:compile`` event (its start or its end)."""
        dispatcher = ev.data.get("dispatcher")
        if dispatcher is None:
            return
        name = _kernel_name(dispatcher)
        with self._lock:
            if ev.is_start:
                self._stack.append(name)
                return
            if self._stack:
                self._stack.pop()
            if name.partition(".")[0] in PROJECT_PACKAGES:
                self._compiled.add(f"{name}{ev.data.get('args')}")
                self._kernels.add(name)

    @property
    def kernel_names(self) -> list[str]:
        """The kernels (with their signatures) compiled so far, in no particular order."""
        with self._lock:
            return sorted(self._compiled)

    def snapshot(self) -> Progress:
        """The progress now."""
        with self._lock:
            compiled = len(self._kernels)
            compiling = self._stack[0] if self._stack else ""
        return Progress(compiled=compiled, total=max(self._total, compiled),
                        elapsed_s=self._clock() - self._start_s, compiling=compiling,
                        done=self._done)


@contextmanager
def reporting(report: Callable[[Progress], object] | None,
              period_s: float = REPORT_PERIOD_S) -> Iterator[KernelProgress]:
    """A :class:`KernelProgress` entered, and ``report`` called with its progress every
    ``period_s`` wall seconds from a thread (and once more at the end, ``done``)."""
    progress = KernelProgress()
    stop = threading.Event()

    def beat() -> None:
        while not stop.wait(period_s):
            assert report is not None
            report(progress.snapshot())

    with progress:
        thread = None
        if report is not None:
            report(progress.snapshot())
            thread = threading.Thread(target=beat, name="kernel-progress", daemon=True)
            thread.start()
        try:
            yield progress
        finally:
            stop.set()
            if thread is not None:
                thread.join()
    final = progress.finish()
    if report is not None:
        report(final)


def _load_telemetry_kernels() -> None:
    """The vibration filter of RAW_IMU / VIBRATION: numba code no flight of the stack runs."""
    from fcu.monitoring.vibration import VibrationMonitor

    VibrationMonitor().update(np.zeros(1), np.zeros((1, 3)))


def _load_fault_kernels() -> None:
    """The fault rules as the fault engine calls them from Python (a step the world takes in
    Python while a fault acts, :meth:`FaultEngine.true_loe`): each kernel with the argument
    types the engine gives it, whichever faults a flight has and whenever they start."""
    from sim.world.fault_types import ActuatorFault, SensorFault
    from sim.world.faults import FaultEngine

    engine = FaultEngine(np.random.default_rng(0), 0.05, 1.0)
    engine.schedule(ActuatorFault(motor=1, kind="loe", loe=0.2, profile="random"))
    engine.schedule(SensorFault(sensor="baro", kind="loss_of_accuracy", magnitude=50.0))
    engine.actuator_inputs(0.0, np.zeros(4))
    engine.true_loe_values(0.0)
    engine.corrupt("baro", 0.0, np.zeros(1), 0.01)


def prepare_vehicle(world: Any, autopilot: Any, seed: int) -> None:
    """Load (or compile) the kernels one vehicle flies: a throwaway copy of it flies a few
    ticks with an actuator and a sensor fault (:func:`sim.stack.warm_up`), then the fault
    rules as the engine calls them from Python and the telemetry filters load. Nothing of the
    real vehicle is touched."""
    from sim.stack import warm_up

    warm_up(world, autopilot, seed)
    _load_fault_kernels()
    _load_telemetry_kernels()
    gc.collect()


@dataclass(frozen=True)
class PrecompileFlight:
    """A headless flight of a shipped scenario whose configuration runs kernels of its own (a
    fault of the world, a path of the autopilot); flown in full (a fraction of a second once
    compiled)."""

    scenario: str
    why: str


PRECOMPILE_FLIGHTS: tuple[PrecompileFlight, ...] = (  # (after a vehicle's boot preparation)
    PrecompileFlight("rotor_lost_hover_m1", "EKF and TSKF with the sensor watch, LQG, AbDOB, "
                     "active FTC, a rotor lost, the motor detector, relaxed hover"),
    PrecompileFlight("tskf_pd_abdob_loe", "the TSKF flying: its own tick and the sensor watch "
                     "on its screening; PD; loss of effectiveness"),
    PrecompileFlight("case3", "height from the barometer, a barometer fault"),
    PrecompileFlight("mocap_freeze", "a motion-capture fault: a sensor excluded and "
                     "re-admitted"),
)
"""What :func:`precompile` flies: between them every kernel of the world, the estimators,
the control chain and the monitors runs at least once (``tests/integration/test_first_run.py``
flies every attitude law, estimator, observer and FTC mode after it, and checks that nothing
more compiles)."""


def precompile(report: Callable[[Progress], object] | None = None) -> KernelProgress:
    """Compile (or load) every kernel the project can run (module docstring); ``report`` is
    called with the progress every few seconds. Returns the progress counter (its
    :meth:`~KernelProgress.snapshot` is the final figure).

    Raises
    ------
    RuntimeError
        A flight did not run (a broken install): names the flight.
    """
    from sim.runner import fly
    from sim.scenario import load_scenario

    with reporting(report) as progress:
        vehicle = load_scenario("baseline")  # first what ftc-vehicle loads at its boot
        prepare_vehicle(vehicle.world, vehicle.autopilot, vehicle.seed)
        for flight in PRECOMPILE_FLIGHTS:
            scenario = load_scenario(flight.scenario)
            try:
                fly(scenario)
            except Exception as err:  # pragma: no cover - a broken install
                raise RuntimeError(f"precompile flight {flight.scenario} failed: "
                                   f"{type(err).__name__}: {err}") from err
    return progress

