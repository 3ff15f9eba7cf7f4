"""The two records of a flight: a .tlog of every packet, and a readable event log.

Both are flushed to the operating system as they are written, so a flight that is
interrupted (Ctrl-C, a killed vehicle, a killed ground station) keeps everything up to the
interruption: a .tlog ends at a whole record, or with one partial record that every reader
(pymavlink, :func:`gcs.mavlink.read_tlog`) stops at.

.tlog format (MAVProxy's): for every packet sent or received, the wall-clock UNIX time in
microseconds as a big-endian uint64, then the raw MAVLink packet. As MAVProxy does, both
directions are logged, so the log shows the commands next to the vehicle's answers.

Event log format: one line per event::

    2025-01-01T12:00:00.123  t=  38.012 s  INJECT    motor 1 loss of effectiveness 0.30 ...

(wall-clock local time, the vehicle's simulated time when known, a kind, the text).
"""

from __future__ import annotations

import struct
import time
from datetime import datetime
from pathlib import Path
from typing import IO

__all__ = ["EventLog", "TlogWriter"]

_TLOG_TIME = struct.Struct(">Q")


class TlogWriter:
    """Appends packets to a .tlog, flushing each one.

    Parameters
    ----------
    path : str or Path
        File to create (parent folders are created; an existing file is replaced).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._file: IO[bytes] | None = None
        self.packets = 0

    def open(self) -> None:
        """Create the file (idempotent)."""
        if self._file is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "wb")

    def write(self, packet: bytes, unix_time_s: float | None = None) -> None:
        """Log one raw packet with its wall-clock time (now when None)."""
        self.open()
        assert self._file is not None
        stamp_us = int((time.time() if unix_time_s is None else unix_time_s) * 1e6)
        self._file.write(_TLOG_TIME.pack(stamp_us) + bytes(packet))
        self._file.flush()
        self.packets += 1

    def close(self) -> None:
        """Flush and close."""
        if self._file is not None:
            self._file.close()
            self._file = None


class EventLog:
    """A readable log of what happened, one flushed line per event.

    Parameters
    ----------
    path : str or Path or None
        File to write (None: no file).
    echo : IO[str] or None
        Also write each line there (e.g. ``sys.stderr``), or nowhere when None.
    """

    def __init__(self, path: str | Path | None, echo: IO[str] | None = None) -> None:
        self.path = None if path is None else Path(path)
        self._echo = echo
        self._file: IO[str] | None = None
        self.lines: list[str] = []

    def open(self) -> None:
        """Create the file (idempotent)."""
        if self._file is None and self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "w", encoding="utf-8")

    def write(self, kind: str, text: str, sim_time_s: float | None = None) -> str:
        """Log one event and return the line written.

        Parameters
        ----------
        kind : str
            Short upper-case category (LINK, PARAM, MISSION, ACK, MODE, STATUS, INJECT,
            DETECT, PROGRESS, FLIGHT, RESULT).
        text : str
            What happened.
        sim_time_s : float or None
            The vehicle's simulated time, s, when known.
        """
        self.open()
        wall = datetime.now().isoformat(timespec="milliseconds")
        when = "t=   ---- s" if sim_time_s is None else f"t={sim_time_s:8.3f} s"
        line = f"{wall}  {when}  {kind:<9} {text}"
        self.lines.append(line)
        if self._file is not None:
            self._file.write(line + "\n")
            self._file.flush()
        if self._echo is not None:
            self._echo.write(line + "\n")
            self._echo.flush()
        return line

    def close(self) -> None:
        """Close the file."""
        if self._file is not None:
            self._file.close()
            self._file = None
