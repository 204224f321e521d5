"""Sliding-window rate limits, kept in memory by the process that serves the request."""

from __future__ import annotations

import time
from collections import OrderedDict, deque


class RateLimiter:
    """At most ``limit`` hits per key within ``window_s`` seconds.

    Memory stays bounded: beyond ``max_keys`` the least recently seen keys are
    forgotten (they could only have been throttled more, never less, by staying).
    """

    def __init__(self, limit: int, window_s: float = 60.0, max_keys: int = 100_000) -> None:
        self.limit = limit
        self.window_s = window_s
        self.max_keys = max_keys
        self._hits: OrderedDict[str, deque[float]] = OrderedDict()

    def hit(self, key: str, now: float | None = None) -> float | None:
        """Count one hit; None when allowed, else the seconds to wait before retrying."""
        now = time.monotonic() if now is None else now
        hits = self._hits.get(key)
        if hits is None:
            hits = self._hits[key] = deque()
            if len(self._hits) > self.max_keys:
                self._hits.popitem(last=False)
        else:
            self._hits.move_to_end(key)
        while hits and hits[0] <= now - self.window_s:
            hits.popleft()
        if len(hits) >= self.limit:
            return hits[0] + self.window_s - now
        hits.append(now)
        return None
