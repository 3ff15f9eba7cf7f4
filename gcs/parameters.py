"""Parameters over MAVLink as a ground station handles them: download, read, set and check.

:class:`ParameterClient` is the parameter half of :class:`gcs.station.GroundStation`: the
PARAM_REQUEST_LIST download completed by index over a lossy link, PARAM_REQUEST_READ by name,
and PARAM_SET confirmed by its PARAM_VALUE echo (or a read-back), with the vehicle's reason
when it refuses. Times are wall-clock seconds.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from gcs.errors import CommandRefused, FlightTimeout
from gcs.link import ACK_TIMEOUTS_S, Link
from gcs.mavlink import MAVLinkMessage, mavlink2
from gcs.records import EventLog, TlogWriter
from gcs.telemetry import mavlink_text

__all__ = ["ParameterClient", "same_float32"]

_M = mavlink2
_PARAM_LIST_QUIET_S = 1.0  # s wall without PARAM_VALUE that ends a parameter download
# PARAM_REQUEST_READ rounds for the indices a download missed: of 1 s each at most (shorter
# on a fast link, RoundTrips.retry_wait_s), for this many seconds in all
_PARAM_READ_ROUNDS = 12
_REASON_WAIT_S = 0.3  # s wall, how long a refusal's STATUSTEXT may trail its PARAM_VALUE
_FLOAT32_TOL = 1e-6  # relative: PARAM_VALUE is REAL32


def same_float32(a: float, b: float) -> bool:
    """Equal as REAL32 parameter values (what PARAM_VALUE carries)."""
    return float(np.float32(a)) == float(np.float32(b)) or math.isclose(
        a, b, rel_tol=_FLOAT32_TOL, abs_tol=1e-12)


class ParameterClient(Link):
    """The vehicle's parameters over one link (module docstring); arguments as
    :class:`gcs.link.Link`.

    Attributes
    ----------
    param_names : dict
        Name -> the last value the vehicle reported.
    param_count : int or None
        How many parameters the vehicle announced.
    """

    def __init__(self, conn: Any, url: str, *, tlog: TlogWriter | None = None,
                 events: EventLog | None = None, signing_key: bytes | None = None) -> None:
        super().__init__(conn, url, tlog=tlog, events=events, signing_key=signing_key)
        self.param_names: dict[str, float] = {}
        self.param_count: int | None = None

    def fetch_params(self, quiet_s: float = _PARAM_LIST_QUIET_S,
                     timeout_s: float = 20.0) -> dict[str, float]:
        """PARAM_REQUEST_LIST; every PARAM_VALUE until all indices arrived (or a quiet spell),
        then PARAM_REQUEST_READ for each index that did not (a lossy link), in rounds as long
        as the link's round trips need (:meth:`gcs.round_trips.RoundTrips.retry_wait_s`)."""
        sysid, compid = self.target
        self.inbox.take_all("PARAM_VALUE", lambda m: True)
        self.send(_M.MAVLink_param_request_list_message(sysid, compid))
        seen: dict[int, str] = {}
        deadline = time.monotonic() + timeout_s
        last = time.monotonic()
        while time.monotonic() < deadline:
            msg = self._wait_reply(["PARAM_VALUE"], lambda m: True, 0.05)
            if msg is None:
                if time.monotonic() - last > quiet_s:
                    if seen:
                        break
                    last = time.monotonic()  # the request (or every answer) was lost
                    self.send(_M.MAVLink_param_request_list_message(sysid, compid))
                continue
            last = time.monotonic()
            self._note_param(msg, seen)
            if self.param_count and len(seen) >= self.param_count:
                break
        if not self.param_names:
            raise FlightTimeout("no PARAM_VALUE in answer to PARAM_REQUEST_LIST")
        asked = 0
        give_up = time.monotonic() + _PARAM_READ_ROUNDS * ACK_TIMEOUTS_S[0]
        first = True
        while time.monotonic() < give_up:
            missing = [i for i in range(self.param_count or 0) if i not in seen]
            if not missing:
                break
            asked += len(missing)
            for index in missing:
                self.send(_M.MAVLink_param_request_read_message(sysid, compid, b"", index))
            sent_at = time.monotonic()
            round_end = sent_at + self.round_trips.retry_wait_s(ACK_TIMEOUTS_S[0])
            while len(seen) < (self.param_count or 0) and time.monotonic() < round_end:
                msg = self._wait_reply(["PARAM_VALUE"], lambda m: True, 0.05)
                if msg is not None:
                    if first and int(msg.param_index) in missing:
                        # one sample, from the first round only (Karn's rule); the other
                        # answers queue behind it
                        self.round_trips.note(sent_at)
                        first = False
                    self._note_param(msg, seen)
            first = False
        self.log("PARAM", f"{len(self.param_names)} parameters"
                 + ("" if self.param_count in (None, len(seen)) else
                    f" of {self.param_count} announced")
                 + (f" ({asked} asked for again)" if asked else ""))
        return dict(self.param_names)

    def _note_param(self, msg: MAVLinkMessage, seen: dict[int, str]) -> None:
        name = mavlink_text(msg.param_id)
        self.param_names[name] = float(msg.param_value)
        self.param_count = int(msg.param_count)
        if 0 <= int(msg.param_index) < 0xFFFF:
            seen[int(msg.param_index)] = name

    def read_param(self, name: str) -> float | None:
        """PARAM_REQUEST_READ by name (retried); None when the vehicle never answers."""
        sysid, compid = self.target

        def named(m: MAVLinkMessage) -> bool:
            return mavlink_text(m.param_id) == name

        for timeout_s in ACK_TIMEOUTS_S[:4]:
            self.inbox.take_all("PARAM_VALUE", named)
            self.send(_M.MAVLink_param_request_read_message(sysid, compid,
                                                            name.encode("ascii"), -1))
            msg = self._wait_reply(["PARAM_VALUE"], named, timeout_s)
            if msg is not None:
                self.param_names[name] = float(msg.param_value)
                return float(msg.param_value)
        return None

    def set_param(self, name: str, value: float) -> float:
        """PARAM_SET and check the PARAM_VALUE echo (the value read back).

        Retried with back-off (:data:`gcs.link.ACK_TIMEOUTS_S`); each retry sends the
        PARAM_SET again and a PARAM_REQUEST_READ, and either answer showing the new value
        confirms it.

        Returns
        -------
        float
            The value now in force.

        Raises
        ------
        CommandRefused
            The vehicle kept another value, or does not know ``name``.
        FlightTimeout
            No echo after every attempt.
        """
        sysid, compid = self.target

        def about_it(m: MAVLinkMessage) -> bool:
            """The vehicle's words on this parameter: "NAME: ..." or "... parameter NAME"."""
            text = mavlink_text(m.text)
            return text.startswith(f"{name}:") or f"parameter {name}".lower() in text.lower()

        def answer(m: MAVLinkMessage) -> bool:
            if m.get_type() == "PARAM_VALUE":
                return mavlink_text(m.param_id) == name
            return about_it(m)

        kept: float | None = None  # a value read back that is not ours yet
        for attempt, timeout_s in enumerate(ACK_TIMEOUTS_S):
            self.inbox.take_all("PARAM_VALUE", lambda m: mavlink_text(m.param_id) == name)
            self.inbox.take_all("STATUSTEXT", lambda m: True)
            self.send(_M.MAVLink_param_set_message(sysid, compid, name.encode("ascii"),
                                                   float(value), _M.MAV_PARAM_TYPE_REAL32))
            if attempt:
                self.send(_M.MAVLink_param_request_read_message(sysid, compid,
                                                                name.encode("ascii"), -1))
            self._sent_clock = self.analyzer.clock_s
            deadline = time.monotonic() + timeout_s
            while (left := deadline - time.monotonic()) > 0:
                echo = self._wait_reply(["PARAM_VALUE", "STATUSTEXT"], answer, left)
                if echo is None:
                    break
                if echo.get_type() == "STATUSTEXT":  # the reason came before the echo
                    late = self._wait_reply(["PARAM_VALUE"], lambda m: mavlink_text(
                        m.param_id) == name, _REASON_WAIT_S)
                    still = "" if late is None else f", still {float(late.param_value):g}"
                    raise CommandRefused(f"parameter {name} = {value:g} refused{still}: "
                                         f"{mavlink_text(echo.text)}")
                now = float(echo.param_value)
                self.param_names[name] = now
                if same_float32(now, value):
                    return now
                # the old value: the echo of a refusal (its reason follows at once), or a
                # read-back (or a late answer) from before our PARAM_SET arrived
                kept = now
                reason = self._wait_reply(["STATUSTEXT"], about_it, _REASON_WAIT_S)
                if reason is not None:
                    raise CommandRefused(f"parameter {name} = {value:g} refused, still {now:g}"
                                         f": {mavlink_text(reason.text)}")
        if kept is not None:
            raise CommandRefused(f"parameter {name} = {value:g} refused, still {kept:g}")
        raise FlightTimeout(f"no PARAM_VALUE echo for {name} after {len(ACK_TIMEOUTS_S)} "
                            "attempts")
