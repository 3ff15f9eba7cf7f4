"""The time series of one flight, whoever recorded it: :class:`FlightSeries`.

Two sources fill it. The headless runner (``sim.runner.fly``) has every autopilot tick with
simulator truth, the position estimate and the wind. The ground station
(``gcs.analysis.FlightAnalyzer.series``) has the telemetry, aligned on the SIM_STATE samples:
no estimate and no wind (those fields are None), motor commands and effectiveness estimates
at their own message times. Metrics (:mod:`flightdata.metrics`), figures
(:mod:`flightdata.figures`) and recordings (:mod:`flightdata.recording`) read only this, and
skip what a source lacks.

Units are SI, positions NED about the origin, attitudes ZYX Euler angles (body FRD to NED).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flightdata.geometry import wrap_pi_array

__all__ = ["FlightEvent", "FlightSeries", "hold_index"]


@dataclass(frozen=True)
class FlightEvent:
    """Something that happened during a flight, for event logs and recordings.

    Attributes
    ----------
    time_s : float or None
        Simulated time, s (None: not dated yet).
    kind : str
        Who or what: the runner's sources ``"autopilot"``, ``"sim"``, ``"runner"``; the
        ground station's kinds ACK, PARAM, STATUS, MODE, ARM, MISSION, LANDED, INJECT,
        DETECT, CRASH.
    text : str
    """

    time_s: float | None
    kind: str
    text: str


@dataclass(frozen=True, kw_only=True, eq=False)
class FlightSeries:
    """Per-sample arrays of one flight (n samples of truth; motor data at its own times).

    Reference fields only mean something on the ``flying`` samples; elsewhere they hold NaN
    (the ground station: no fresh reference) or the truth (the runner), and every consumer
    ignores them there.
    """

    time_s: np.ndarray  # (n,) s, sample times on the vehicle's simulated clock, increasing
    flying: np.ndarray  # (n,) bool, a reference was tracked and the vehicle was off the ground
    pos_ned: np.ndarray  # (n, 3) m, true position
    euler_rad: np.ndarray  # (n, 3) rad, true roll, pitch, yaw
    ref_pos_ned: np.ndarray  # (n, 3) m, position reference
    ref_euler_rad: np.ndarray  # (n, 3) rad, attitude reference tracked
    pwm_time_s: np.ndarray  # (m,) s, times of the motor commands
    pwm: np.ndarray  # (m, 4) unit duty 0..pwm_max, commands of motors 1..4
    pwm_max: float  # unit duty, the command at full power
    loe_estimate_time_s: tuple[np.ndarray, ...]  # four (k_j,) arrays, s, per motor
    loe_estimate: tuple[np.ndarray, ...]  # four (k_j,) arrays, -, estimated LOE of motor j+1
    loe_injected: np.ndarray  # (n, 4) -, LOE in force (NaN: a lock or hard-over, no gamma)
    free_flight: np.ndarray | None = None  # (n,) bool, in the air between take-off and landing
    est_pos_ned: np.ndarray | None = None  # (n, 3) m, the estimate fed to the controllers
    wind_ned: np.ndarray | None = None  # (n, 3) m/s, wind velocity at the vehicle
    fault_times_s: tuple[float, ...] | None = None  # s, onsets of injected faults (None:
    # unknown; then the changes of ``loe_injected`` stand for them)
    events: tuple[FlightEvent, ...] = ()  # in the order they happened

    def position_error(self) -> np.ndarray:
        """Reference minus truth on the flying samples, (k, 3), m (what the tables use)."""
        return self.ref_pos_ned[self.flying] - self.pos_ned[self.flying]

    def attitude_error_deg(self) -> np.ndarray:
        """Reference minus truth on the flying samples, wrapped to +-180 deg, (k, 3)."""
        return np.degrees(wrap_pi_array(self.ref_euler_rad[self.flying]
                                        - self.euler_rad[self.flying]))

    def fault_onsets_s(self) -> list[float]:
        """Times (s) at which injected faults started acting, for markers on plots.

        :attr:`fault_times_s` when known, else every change of the injected LOE.
        """
        if self.fault_times_s is not None:
            return list(self.fault_times_s)
        truth = np.nan_to_num(self.loe_injected, nan=-1.0)
        if len(truth) < 2:
            return []
        changed = np.any(np.abs(np.diff(truth, axis=0)) > 1e-9, axis=1)
        return [float(t) for t in self.time_s[1:][changed]]

    def loe_estimate_held(self) -> np.ndarray:
        """The LOE estimates held on :attr:`time_s` (sample-and-hold), (n, 4); NaN before
        a motor's first estimate."""
        out = np.full((len(self.time_s), 4), np.nan)
        index: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # by time array (often shared)
        for j, (t_est, est) in enumerate(zip(self.loe_estimate_time_s, self.loe_estimate,
                                             strict=True)):
            if id(t_est) not in index:
                idx = hold_index(t_est, self.time_s)
                index[id(t_est)] = (idx, idx >= 0)
            idx, have = index[id(t_est)]
            out[have, j] = est[idx[have]]
        return out

    def pwm_held(self, time_s: np.ndarray) -> np.ndarray:
        """Motor commands held at ``time_s`` (sample-and-hold), (len(time_s), 4); 0 before
        the first command."""
        if len(self.pwm_time_s) == 0:
            return np.zeros((len(time_s), 4))
        idx = hold_index(self.pwm_time_s, time_s)
        return np.where((idx >= 0)[:, None], self.pwm[np.maximum(idx, 0)], 0.0)


def hold_index(t_src: np.ndarray, t_query: np.ndarray) -> np.ndarray:
    """Index of the latest source time at or before each query time (-1: none), 1 ns slack.

    Parameters
    ----------
    t_src : (k,) s, non-decreasing
    t_query : (n,) s
    """
    if t_src is t_query and (len(t_src) < 2 or bool(np.all(np.diff(t_src) > 1e-9))):
        return np.arange(len(t_src))  # (a series held on its own, strictly rising, times)
    return np.searchsorted(t_src, np.asarray(t_query) + 1e-9, side="right") - 1
