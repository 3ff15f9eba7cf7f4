"""Fault injection from the ground station, timed on the vehicle's clock.

:class:`FaultInjector` is the injection half of :class:`gcs.station.GroundStation`: motor
faults scheduled on the vehicle's clock (MAV_CMD_INJECT_FAILURE with the target time),
parameter faults sent as PARAM_SET ahead of time by the measured command lag
(:meth:`FaultInjector.lead_s`) and sent again when their echo is lost, each injection paired
with the event that shows it took effect (:class:`InjectionTiming`), and everything undone
after the flight (:meth:`FaultInjector.clear_injected_faults`).

Clocks: wall-clock seconds for resends' bookkeeping, the vehicle's simulated seconds for
fault times and lags; the two never mix.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from flightdata.series import FlightEvent
from gcs.faults import FaultSpec
from gcs.mavlink import mavlink2
from gcs.parameters import ParameterClient, same_float32
from gcs.records import EventLog, TlogWriter

__all__ = ["FaultInjector", "InjectionTiming"]

_M = mavlink2


@dataclass(frozen=True)
class InjectionTiming:
    """Where an injection landed against its target (vehicle simulated time, s).

    Attributes
    ----------
    fault : FaultSpec
    target_s : float
        Vehicle time the schedule asked for (mission start + ``fault.at_s``).
    sent_at_s : float
        Vehicle clock when the command left.
    achieved_s : float or None
        Vehicle time the fault took effect (None: never confirmed).
    """

    fault: FaultSpec
    target_s: float
    sent_at_s: float
    achieved_s: float | None

    @property
    def error_s(self) -> float | None:
        """Achieved minus target, s."""
        return None if self.achieved_s is None else self.achieved_s - self.target_s


@dataclass
class _InFlight:
    """An injection sent and not yet seen taking effect."""

    fault: FaultSpec
    target_s: float  # s, vehicle time it is meant for
    sent_s: float  # s, vehicle clock when it first left
    scheduled: bool  # on the vehicle's clock (no lag to learn from)
    by_param: bool  # it travels as a PARAM_SET, effective on arrival
    last_sent_wall_s: float  # s, wall clock (time.time) when it last left
    # s, vehicle clock when it last left: that of the first message received after it left
    # (None until one is); a station behind on its messages still handles older ones, whose
    # clock is earlier than the vehicle's when the PARAM_SET reached it
    last_sent_s: float | None = None
    received: bool = False  # the vehicle echoed its PARAM_SET
    attempts: int = 1

    def param_name(self) -> str | None:
        """The parameter it sets when it travels as a PARAM_SET (else None)."""
        if not self.by_param:
            return None
        return self.fault.param or f"SIM_MOT{self.fault.motor}_LOE"

    def param_value(self) -> float:
        return self.fault.value if self.fault.param is not None else self.fault.loe


_RESEND_AFTER_S = 0.5  # s of vehicle time without an echo (at least 3 link lags) to resend
_MAX_SENDS = 5  # a PARAM_SET injection is sent this many times at most



class FaultInjector(ParameterClient):
    """Injects faults over one link and tracks when they took effect (module docstring);
    arguments as :class:`gcs.link.Link`.

    Attributes
    ----------
    injection_timing : list of InjectionTiming
        Every injection confirmed so far, in the order confirmed.
    """

    def __init__(self, conn: Any, url: str, *, tlog: TlogWriter | None = None,
                 events: EventLog | None = None, signing_key: bytes | None = None) -> None:
        super().__init__(conn, url, tlog=tlog, events=events, signing_key=signing_key)
        self.injection_timing: list[InjectionTiming] = []
        self._inflight: list[_InFlight] = []
        self._lag_samples_s: list[float] = []
        # what the injections changed, to undo after the flight: parameter -> value before
        self._restore_params: dict[str, float] = {}
        self._motor_faults_commanded = False  # INJECT_FAILURE motor faults were sent

    def _note_event(self, event: FlightEvent) -> None:
        if event.kind == "INJECT":
            self._match_injection(event)

    def _note_lag(self, effect_s: float) -> None:
        """A command that left at the last command's clock took effect at ``effect_s``
        (vehicle time, s): one more sample of the link's lag (:meth:`lead_s`)."""
        sent = self._sent_clock
        if sent is not None:
            self._lag_samples_s.append(max(0.0, effect_s - sent))


    def lead_s(self) -> float:
        """How early (vehicle seconds) a command must leave to take effect on time.

        The median of the measured lags between the clock when a command left and the time it
        took effect (parameters, mission start), at least one telemetry tick (10 ms).
        """
        if not self._lag_samples_s:
            return 0.01
        return max(0.01, float(np.median(self._lag_samples_s[-9:])))

    def inject(self, fault: FaultSpec, target_s: float, *, via: str = "command") -> None:
        """Inject ``fault`` at vehicle time ``target_s``.

        Parameters
        ----------
        fault : FaultSpec
        target_s : float
            Vehicle (simulated) time it is meant for.
        via : {"command", "param"}
            ``command`` (motor faults): PARAM_SET SIM_FI_LOE = loe (echo awaited), then
            MAV_CMD_INJECT_FAILURE (unit MOTOR 101, type WRONG 4, instance = motor; type OK
            0 when loe = 0) with param4 = ``target_s``: the vehicle schedules the fault on its
            own clock, so it takes effect at ``target_s`` exactly whatever the link's delay
            or load; this blocks until the vehicle acknowledges (send it ahead of time).
            ``param``: PARAM_SET SIM_MOTn_LOE = loe now (ArduPilot-SITL style, effective
            when it arrives), with a TIMESYNC request in the same datagram dating it; send
            it :meth:`lead_s` ahead. Parameter faults (SIM_BARO_GLITCH...) are always a
            PARAM_SET of the second kind; one whose echo does not come back is sent again
            (:meth:`resend_lost_injections`).
        """
        sysid, compid = self.target
        clock = self.analyzer.clock_s if self.analyzer.clock_s is not None else math.nan
        scheduled = via == "command" and fault.motor is not None and fault.loe > 0
        flight = _InFlight(fault, target_s, clock, scheduled,
                           by_param=fault.param is not None or via == "param",
                           last_sent_wall_s=time.time())
        self._inflight.append(flight)
        start = self.analyzer.mission_start_s
        rel = f" (mission +{target_s - start:.3f} s)" if start is not None else ""
        self.log("INJECT", f"{'scheduling' if scheduled else 'sending'} {fault.describe()} "
                 f"for t = {target_s:.3f} s{rel}"
                 + ("" if scheduled else f", lead {self.lead_s():.3f} s"))

        if scheduled:
            self._note_change("SIM_FI_LOE")
            self._motor_faults_commanded = True
            self.set_param("SIM_FI_LOE", fault.loe)
            self.command(_M.MAV_CMD_INJECT_FAILURE,
                         (101.0, 4.0, float(fault.motor or 0), float(target_s)),
                         what=f"INJECT_FAILURE motor {fault.motor}")
        elif not flight.by_param:  # a clear (loe 0): effective when it arrives
            self.send(_M.MAVLink_command_long_message(
                sysid, compid, _M.MAV_CMD_INJECT_FAILURE, 0, 101.0, 0.0,
                float(fault.motor or 0), 0.0, 0.0, 0.0, 0.0), with_timesync=True)
        else:
            name = flight.param_name()
            assert name is not None
            self._note_change(name)
            self._send_param_injection(flight)

    def _note_change(self, name: str) -> None:
        """Remember the value ``name`` had before an injection first changed it (0 when it
        was never read: the fault parameters' value when no fault is in force)."""
        if name not in self._restore_params:
            before = self.param_names.get(name, self.analyzer.params.get(name, 0.0))
            self._restore_params[name] = float(before)

    def clear_injected_faults(self) -> None:
        """Undo this flight's injections: motor faults sent as INJECT_FAILURE are cleared
        (type OK, all motors: also those scheduled and not yet due), and every parameter an
        injection changed (SIM_MOTn_LOE, SIM_BARO_GLITCH, SIM_FI_LOE...) goes back to its
        value before the flight, so the next flight starts healthy.

        Raises
        ------
        FlightError
            A command or parameter the vehicle refused or never answered.
        """
        if self._motor_faults_commanded:
            self.command(_M.MAV_CMD_INJECT_FAILURE, (101.0, 0.0, 0.0),
                         what="INJECT_FAILURE motor all OK (clear)")
            self._motor_faults_commanded = False
        for name, before in list(self._restore_params.items()):
            self.set_param(name, before)
            del self._restore_params[name]
        self.log("INJECT", "the flight's injected faults cleared")

    @property
    def injected_anything(self) -> bool:
        """Faults were sent in this flight and not yet cleared."""
        return self._motor_faults_commanded or bool(self._restore_params)

    def _send_param_injection(self, flight: _InFlight) -> None:
        """PARAM_SET of an injection, with a TIMESYNC request in the same datagram dating it."""
        name = flight.param_name()
        assert name is not None
        sysid, compid = self.target
        self.send(_M.MAVLink_param_set_message(sysid, compid, name.encode("ascii"),
                                               float(flight.param_value()),
                                               _M.MAV_PARAM_TYPE_REAL32), with_timesync=True)

    def resend_lost_injections(self, clock_s: float) -> None:
        """Send again each PARAM_SET injection whose echo has not come back
        ``_RESEND_AFTER_S`` (or three link lags) of vehicle time after it left, up to
        ``_MAX_SENDS`` times: on a lossy link a lost PARAM_SET would be a lost fault. A
        repeat is harmless (the vehicle keeps a parameter fault it already holds).

        The wait counts from the clock of the first message received after the PARAM_SET
        left, not from the clock the station had then: a station behind on its messages
        (a loaded machine, a fast simulation) would otherwise count time the PARAM_SET spent
        waiting for nothing and send it again before its echo could arrive."""
        waiting = [f for f in self._inflight if f.by_param and not f.received]
        if not waiting:  # the usual case, on every clock update
            return
        wait_s = max(_RESEND_AFTER_S, 3.0 * self.lead_s())
        for flight in waiting:
            name = flight.param_name()
            assert name is not None  # by_param
            echoed = self.analyzer.params.get(name)
            if echoed is not None and same_float32(echoed, flight.param_value()):
                flight.received = True
            elif flight.last_sent_s is None:
                received = self.received_wall_s
                if received is None or received >= flight.last_sent_wall_s:
                    flight.last_sent_s = clock_s  # the vehicle's clock once it could have it
            elif clock_s - flight.last_sent_s > wait_s and flight.attempts < _MAX_SENDS:
                flight.attempts += 1
                flight.last_sent_s, flight.last_sent_wall_s = None, time.time()
                self.log("INJECT", f"no echo of {name} = {flight.param_value():g} after "
                         f"{wait_s:.2f} s: sending it again (attempt {flight.attempts})")
                self._send_param_injection(flight)

    def _match_injection(self, event: FlightEvent) -> None:
        """An INJECT event from the analyzer: pair it with the oldest in-flight motor fault."""
        for i, flight in enumerate(self._inflight):
            fault = flight.fault
            if fault.motor is not None and f"motor {fault.motor} " in event.text:
                del self._inflight[i]
                achieved = event.time_s
                timing = InjectionTiming(fault, flight.target_s, flight.sent_s, achieved)
                self.injection_timing.append(timing)
                if achieved is not None:
                    # the link's delay, to send the next one ahead of time (a resent one
                    # says nothing of it)
                    if not flight.scheduled and flight.attempts == 1:
                        self._lag_samples_s.append(max(0.0, achieved - flight.sent_s))
                    self.log("INJECT", f"motor {fault.motor} took effect at t = "
                             f"{achieved:.3f} s, timing error {timing.error_s:+.3f} s")
                return

    def confirm_param_faults(self) -> None:
        """Pair parameter faults (SIM_BARO_GLITCH...) with their PARAM_VALUE echoes."""
        still = []
        for flight in self._inflight:
            fault = flight.fault
            value = None if fault.param is None else self.analyzer.params.get(fault.param)
            if value is not None and same_float32(value, fault.value):
                self.injection_timing.append(
                    InjectionTiming(fault, flight.target_s, flight.sent_s, None))
            else:
                still.append(flight)
        self._inflight = still

    def pending_injections(self) -> list[FaultSpec]:
        """Faults sent but not yet confirmed."""
        return [flight.fault for flight in self._inflight]
