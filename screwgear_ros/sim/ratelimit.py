"""Rate limiting of repeated warnings, one budget per key (e.g. per input topic)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Hashable


class RateLimiter:
    """Lets one event per key through every ``interval`` seconds and counts the rest.

    ``allow(key)`` returns ``(True, suppressed)`` when a warning may be emitted now,
    ``suppressed`` being how many were held back for that key since the last one
    emitted, and ``(False, 0)`` otherwise; ``drain(key)`` takes the count held back so
    far for a summary ("41 more reversals in the last 5 s"). Thread-safe.
    """

    def __init__(self, interval: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.interval = interval
        self._clock = clock
        self._lock = threading.Lock()
        self._last: dict[Hashable, float] = {}
        self._held: dict[Hashable, int] = {}

    def allow(self, key: Hashable) -> tuple[bool, int]:
        now = self._clock()
        with self._lock:
            last = self._last.get(key)
            if last is not None and now - last < self.interval:
                self._held[key] = self._held.get(key, 0) + 1
                return False, 0
            self._last[key] = now
            return True, self._held.pop(key, 0)

    def drain(self, key: Hashable) -> int:
        """How many events of ``key`` were held back since the last one let through;
        they count as reported from now on (for a periodic summary line)."""
        with self._lock:
            return self._held.pop(key, 0)


__all__ = ['RateLimiter']
