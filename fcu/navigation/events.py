"""What the navigator tells its caller: command results and events (for STATUSTEXT)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


@dataclass(frozen=True)
class CommandResult:
    """Outcome of a command: ACCEPTED or DENIED, with a reason for STATUSTEXT."""

    accepted: bool
    reason: str = ""


Severity = Literal["info", "notice", "warning", "critical"]


@dataclass(frozen=True)
class NavEvent:
    """A human-readable record of something the navigator did or refused.

    Attributes
    ----------
    time_s : float
        Simulated time, s (a command's event carries the latest step time).
    kind : str
        ``mode``, ``arm``, ``disarm``, ``takeoff``, ``takeoff_complete``, ``target_reached``,
        ``mission``, ``item_reached``, ``mission_complete``, ``landing``, ``landed``,
        ``speed``, ``home``, ``failsafe`` or ``refused``.
    text : str
        Message suitable for STATUSTEXT (at most ~50 characters is not guaranteed).
    severity : {"info", "notice", "warning", "critical"}
        MAV_SEVERITY to use.
    seq : int or None
        Mission seq for ``item_reached`` (and ``mission``) events.
    """

    time_s: float
    kind: str
    text: str
    severity: Severity = "info"
    seq: int | None = None

    def __str__(self) -> str:
        return f"[{self.time_s:8.2f} s] {self.text}"
