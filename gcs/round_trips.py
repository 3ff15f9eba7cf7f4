"""How long to wait for a reply before asking again, from the link's measured round trips.

A request over MAVLink may be lost on the way out or its reply on the way back; the only
remedy is to ask again. :class:`RoundTrips` keeps the latest round trips measured (a request
to the reply that answered it, only where no earlier copy of the request can have drawn the
reply: Karn's rule, which the caller keeps) and sets the wait before asking again from them:
over loopback a lost request is asked again within 0.2 s, over a radio link as late as its
replies take. Times are wall-clock seconds.
"""

from __future__ import annotations

import time
from collections import deque

__all__ = ["RETRY_FLOOR_S", "RoundTrips"]

RETRY_FLOOR_S = 0.2  # s wall, the shortest wait before a request is sent again


class RoundTrips:
    """The latest eight round trips of one link (module docstring).

    Attributes
    ----------
    samples_s : collections.deque of float
        The round trips measured, s wall, oldest first (eight at the most).
    """

    def __init__(self) -> None:
        self.samples_s: deque[float] = deque(maxlen=8)

    def note(self, sent_at: float) -> None:
        """A reply came to a request sent at ``time.monotonic()`` = ``sent_at``; the caller
        makes sure no earlier copy of the request can have drawn it (Karn's rule)."""
        self.samples_s.append(time.monotonic() - sent_at)

    def retry_wait_s(self, longest_s: float) -> float:
        """Wall seconds to wait for a reply before asking again: four times the slowest of
        the last eight measured round trips, at least :data:`RETRY_FLOOR_S` and at most
        ``longest_s`` (``longest_s`` before any is measured)."""
        if not self.samples_s:
            return longest_s
        return min(longest_s, max(RETRY_FLOOR_S, 4.0 * max(self.samples_s)))
