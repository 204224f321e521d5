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


class Backoff:
    """Growing delays after failures (sign-in attempts): ``free`` failures cost
    nothing, each further one doubles the wait, up to ``max_s``; success forgets.
    """

    def __init__(
        self, free: int, base_s: float = 1.0, max_s: float = 300.0, max_keys: int = 100_000
    ) -> None:
        self.free = free
        self.base_s = base_s
        self.max_s = max_s
        self.max_keys = max_keys
        self._failures: OrderedDict[str, tuple[int, float]] = OrderedDict()

    def wait(self, key: str, now: float | None = None) -> float | None:
        """None when ``key`` may try now, else the seconds until it may."""
        now = time.monotonic() if now is None else now
        count, last = self._failures.get(key, (0, now))
        if count < self.free:
            return None
        delay = min(self.base_s * 2 ** (count - self.free), self.max_s)
        remaining = last + delay - now
        return remaining if remaining > 0 else None

    def failed(self, key: str, now: float | None = None) -> None:
        now = time.monotonic() if now is None else now
        count, _ = self._failures.pop(key, (0, now))
        self._failures[key] = (count + 1, now)
        if len(self._failures) > self.max_keys:
            self._failures.popitem(last=False)

    def succeeded(self, key: str) -> None:
        self._failures.pop(key, None)
