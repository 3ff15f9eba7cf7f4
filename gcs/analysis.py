"""The thesis table from telemetry: what a ground station can compute from the MAVLink stream.

:class:`FlightAnalyzer` is fed every packet of a flight in order (live from the link, or
from a .tlog) and produces a :class:`gcs.table.FlightReport` (:meth:`FlightAnalyzer.report`)
and the aligned arrays behind it as a :class:`flightdata.series.FlightSeries`
(:meth:`FlightAnalyzer.series`, for figures and recordings). ``ftc-gcs fly`` and
``ftc-gcs report`` run the same code over the same packets, so a report recomputed from a
flight's .tlog equals the table printed at the end of that flight.

Sources (vehicle messages; docs: fcu/mavlink/telemetry/messages.py)
---------------------------------------------------------
=========================  ==================================================================
reference position         POSITION_TARGET_LOCAL_NED x, y, z (m, NED about the origin)
reference attitude         ATTITUDE_TARGET q -> ZYX roll, pitch, yaw
true attitude              SIM_STATE roll, pitch, yaw (simulator truth)
true position              SIM_STATE lat_int, lon_int (degE7; the float32 lat, lon where
                           finer) and alt (m AMSL), turned into NED about the origin with the
                           vehicle's flat-earth mapping (the origin from HOME_POSITION: home
                           latitude/longitude/altitude minus home's local x, y, z). degE7
                           resolves only ~1 cm horizontally, so north and east are the
                           integral of SIM_STATE's true velocity vn, ve anchored to the mean
                           geodetic position (:func:`gcs.alignment.truth_ned`)
motor commands             SERVO_OUTPUT_RAW servo1..4 = motors 1..4,
                           u = pwm_max (PWM_us - 1000) / 1000
LOE estimates              NAMED_VALUE_FLOAT LOE1..LOE4 (TSKF)
spin                       ATTITUDE yawspeed: the stretch where |r| exceeds
                           :data:`SPIN_RATE_RAD_S` (a vehicle that lost a rotor and gave up
                           yaw; normal flight stays far below it)
detections, injections,    DEBUG_FLOAT_ARRAY ``FTC_REC`` records (fault, detection, outcome;
outcome                    :mod:`flightdata.records`), whatever the route of an injection
                           (a SIM_* parameter, MAV_CMD_INJECT_FAILURE, a scenario's schedule);
                           repeats dropped by sequence number. STATUSTEXT is for people only.
=========================  ==================================================================

Time: packets are dated with the vehicle's simulated clock as :mod:`gcs.telemetry` says
(``time_boot_ms``, TIMESYNC answers; an event between ticks takes the next clock value).

Which samples count (mirrors ``sim.runner.flight_metrics``)
-----------------------------------------------------------
The runner takes the ticks where a reference was tracked and the vehicle was off the
ground. Here: each SIM_STATE sample at which a POSITION_TARGET_LOCAL_NED and an
ATTITUDE_TARGET younger than their own period exist (a reference that stops coming means an
idle controller), and the true altitude above home exceeds ``airborne_alt_m``
(0.1 mm: the plant holds it at exactly 0 while on the ground, so this is the runner's "not
on the ground" up to SIM_STATE's float32 resolution). References, truth and motor commands
are aligned by sample-and-hold on the vehicle's time stamps. Stream all five at the
autopilot's 100 Hz for a one-to-one match with the runner's ticks (``ftc-gcs fly`` asks for
that).

Lost packets (a lossy radio, an overflowing socket): errors are taken only over the samples
whose truth and both references arrived, a random subset, so they stay unbiased; a
reference missing for at most :data:`gcs.alignment.BRIDGE_S` (0.5 s) between two that
arrived was lost, not stopped, and is interpolated for the figures; the flight time counts
every airborne, tracked stretch across lost samples (:func:`gcs.alignment.covered_time_s`),
so at 30 % loss it is still the real one.

Errors are reference minus truth: RMS and maximum of |error| in x, y, z (m) and roll, pitch,
yaw (deg, wrapped to +-180); control effort is the mean over those samples of the sum of
the four motor commands (thesis Table 7.2: 0.0796 at hover), computed by
:mod:`flightdata.metrics` as the runner's are.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from flightdata.metrics import control_effort, tracking_errors
from flightdata.series import FlightEvent, FlightSeries
from flightdata.thesis import AXES
from gcs.alignment import Aligned, align, hold, truth_ned
from gcs.mavlink import read_tlog
from gcs.table import FlightReport
from gcs.telemetry import PWM_MAX, TelemetryReader

__all__ = ["SPIN_RATE_RAD_S", "FlightAnalyzer", "analyze_tlog", "replay_tlog"]

SPIN_RATE_RAD_S = 3.0  # rad/s of |yaw rate| that marks a spin (normal flight: < 1 rad/s)


class FlightAnalyzer(TelemetryReader):
    """Turns the packets of a flight, in order, into events and a :class:`FlightReport`.

    A :class:`gcs.telemetry.TelemetryReader` (same parameters: ``pwm_max``,
    ``airborne_alt_m``, ``on_event``) that computes the table (:meth:`report`) and the
    aligned series behind it (:meth:`series`) from what it has read so far.
    """

    # ------------------------------------------------------------------ results
    def truth_ned(self, rows: np.ndarray) -> np.ndarray | None:
        """True NED positions (m) of SIM_STATE rows; None until HOME_POSITION is known
        (:func:`gcs.alignment.truth_ned`)."""
        return None if self.home is None else truth_ned(rows, self.home)

    def _aligned(self) -> Aligned | None:
        """Truth, references and the flying mask on the SIM_STATE samples (None: no data)."""
        truth = np.array(self._truth, dtype=float).reshape(-1, 11)
        if self.home is None or not len(truth) or not self._pos_ref or not self._att_ref:
            return None
        return align(truth, np.array(self._pos_ref), np.array(self._att_ref), self.home,
                     self.airborne_alt_m)

    def _servo_sorted(self) -> np.ndarray:
        servo = np.array(self._servo, dtype=float).reshape(-1, 5)
        return servo[np.argsort(servo[:, 0], kind="stable")]

    def series(self) -> FlightSeries:
        """The aligned time series behind the table, for plots and recordings.

        The same alignment as :meth:`report` (sample-and-hold of the references on the
        SIM_STATE samples, the same flying mask), so errors over ``flying`` rows are exactly
        the ones the table's RMS and maximum are taken over. Motor commands and LOE
        estimates keep their own message times; telemetry carries no wind, no position
        estimate and no take-off/landing phase (those fields are None). Fault onsets are
        the injections that took effect (not the clearings).
        """
        al = self._aligned()
        servo = self._servo_sorted()
        loe_t = tuple(np.array([e[0] for e in self._loe_est[m]], dtype=float)
                      for m in (1, 2, 3, 4))
        loe_v = tuple(np.array([e[1] for e in self._loe_est[m]], dtype=float)
                      for m in (1, 2, 3, 4))
        if al is None:
            t = np.zeros(0)
            pos = euler = ref_pos = ref_euler = np.zeros((0, 3))
            flying = np.zeros(0, dtype=bool)
        else:
            t = al.truth[:, 0]
            pos, euler = al.pos, al.truth[:, 1:4]
            ref_pos, ref_euler = al.ref_pos, al.ref_att
            flying = al.flying
        return FlightSeries(
            time_s=t, flying=flying, pos_ned=pos, euler_rad=euler, ref_pos_ned=ref_pos,
            ref_euler_rad=ref_euler, pwm_time_s=servo[:, 0], pwm=servo[:, 1:5],
            pwm_max=self.pwm_max, loe_estimate_time_s=loe_t, loe_estimate=loe_v,
            loe_injected=self.injected_loe_at(t),
            fault_times_s=tuple(sorted({i.time_s for i in self.injections if i.loe != 0.0})),
            events=tuple(self.events))

    def injected_loe_at(self, time_s: np.ndarray) -> np.ndarray:
        """The loss of effectiveness in force on motors 1..4 at each time, shape (n, 4).

        From the simulator's announcements (:attr:`injections`), held until the next change;
        NaN where the fault in force has no constant effectiveness (lock, hard-over).
        """
        out = np.zeros((len(time_s), 4))
        for inj in sorted(self.injections, key=lambda i: i.time_s):
            out[np.asarray(time_s) >= inj.time_s - 1e-9, inj.motor - 1] = inj.loe
        return out

    def report(self) -> FlightReport:
        """The table over the flight so far."""
        al = self._aligned()
        if al is None:
            return self._make_report()
        truth, pos, flying = al.truth, al.pos, al.flying
        t = truth[:, 0]
        n = int(np.count_nonzero(flying))
        if n == 0:
            return self._make_report()
        errors = tracking_errors(al.ref_pos[flying], pos[flying], al.ref_att[flying],
                                 truth[flying, 1:4])
        rms: dict[str, float | None] = {axis: fig.rms for axis, fig in errors.items()}
        mx: dict[str, float | None] = {axis: fig.max for axis, fig in errors.items()}
        effort = None
        if self._servo:
            servo = self._servo_sorted()
            i_srv, have = hold(servo[:, 0], t[flying], fresh_s=None)
            if np.all(have):
                effort = control_effort(servo[i_srv, 1:5])
        t_end = float(t[flying][-1])
        return self._make_report(rms=rms, mx=mx, effort=effort, flight_s=al.flight_s(),
                                 samples=n, t_end=t_end)

    def _make_report(self, *, rms: dict[str, float | None] | None = None,
                     mx: dict[str, float | None] | None = None, effort: float | None = None,
                     flight_s: float = 0.0, samples: int = 0,
                     t_end: float | None = None) -> FlightReport:
        empty: dict[str, float | None] = {axis: None for axis, _ in AXES}
        return FlightReport(rms=dict(empty) if rms is None else rms,
                            max=dict(empty) if mx is None else mx, control_effort=effort,
                            flight_s=flight_s, samples=samples,
                            mission_start_s=self.mission_start_s, loe=self._loe_table(t_end),
                            injections=list(self.injections), detections=list(self.detections),
                            crashed=self.crashed, vehicle_time_s=self.clock_s,
                            params=dict(self.params if self.params_at_end is None
                                        else self.params_at_end),
                            outcome=self.outcome,
                            faults=list(self.faults), spin=self._spin())

    def _spin(self) -> dict[str, float] | None:
        """The spin phase (module docstring): first and last sample above the threshold,
        the mean yaw rate over the second half of that stretch, the peak |yaw rate|."""
        if not self._yaw_rate:
            return None
        rate = np.array(self._yaw_rate)
        above = np.flatnonzero(np.abs(rate[:, 1]) > SPIN_RATE_RAD_S)
        if above.size == 0:
            return None
        start, end = float(rate[above[0], 0]), float(rate[above[-1], 0])
        phase = rate[above[0]:above[-1] + 1]
        late = phase[phase[:, 0] >= 0.5 * (start + end), 1]
        return {"start_s": start, "end_s": end, "yaw_rate_rad_s": float(np.mean(late)),
                "peak_rad_s": float(np.max(np.abs(phase[:, 1])))}

    def _loe_table(self, t_end: float | None) -> list[dict[str, Any]]:
        rows = []
        for motor in (1, 2, 3, 4):
            inj = [i for i in self.injections if i.motor == motor]
            est = self._loe_est[motor]
            if t_end is not None:
                est = [e for e in est if e[0] <= t_end + 1e-9] or est
                # what was in force in flight: not the clearing after the landing
                inj = [i for i in inj if i.time_s <= t_end + 1e-9]
            dets = [d for d in self.detections
                    if d.motor == motor and d.record.action == "detected"]
            rows.append({
                "motor": motor,
                "injected": inj[-1].loe if inj else 0.0,
                "injected_at_s": inj[-1].time_s if inj else None,
                "estimated": est[-1][1] if est else None,
                "detected_at_s": dets[0].time_s if dets else None,
                "latency_s": dets[0].latency_s if dets else None,
            })
        return rows


def replay_tlog(path: str | Path, *, pwm_max: float = PWM_MAX,
                on_event: Callable[[FlightEvent], None] | None = None,
                on_packet: Callable[[], None] | None = None) -> FlightAnalyzer:
    """A :class:`FlightAnalyzer` fed with every packet of a recorded flight.

    ``on_packet`` is called after each packet (a progress counter).
    """
    analyzer = FlightAnalyzer(pwm_max=pwm_max, on_event=on_event)
    for record in read_tlog(path):
        analyzer.feed(record.message, record.unix_time_us)
        if on_packet is not None:
            on_packet()
    return analyzer


def analyze_tlog(path: str | Path, *, pwm_max: float = PWM_MAX) -> FlightReport:
    """The :class:`FlightReport` of a recorded flight (what ``ftc-gcs report`` prints)."""
    return replay_tlog(path, pwm_max=pwm_max).report()
