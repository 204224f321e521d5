"""The counters behind the abuse limits and the sign-in throttle, and where they live.

Two kinds of counter: sliding windows of hits (at most ``limit`` per key in ``window_s``)
and failure counts with growing delays (sign-in back-off). Every operation checks all
the keys it names and counts on all of them or on none, atomically: requests that
arrive at once cannot all pass a check before any of them is counted.

:class:`MemoryCounters` keep them in this process (one server process);
:class:`RedisCounters` keep them in Redis, one Lua script per operation, so every
process of a wall shares one budget. Which keys and limits a request meets is decided
above the store, once (``webapp.people.ratelimit``, ``webapp.people.signin``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

# Failures are forgotten this long after the last one (never before its delay is over).
FORGET_FAILURES_S = 24 * 3600.0


@dataclass(frozen=True)
class SlidingWindow:
    """At most ``limit`` hits per key within ``window_s`` seconds; ``name`` keeps its
    keys apart from every other window's."""

    name: str
    limit: int
    window_s: float = 60.0


@dataclass(frozen=True)
class Backoff:
    """Growing delays after failures: ``free`` failures cost nothing, each further one
    doubles the wait, up to ``max_s``; ``name`` keeps its keys apart."""

    name: str
    free: int
    base_s: float = 1.0
    max_s: float = 300.0
    forget_s: float = FORGET_FAILURES_S

    @property
    def remembered_s(self) -> float:
        """How long failures are kept after the last one: never less than the longest
        delay, or a count could vanish while its wait runs."""
        return max(self.forget_s, self.max_s)

    def wait(self, failures: int, last: float, now: float) -> float | None:
        """None when a key with ``failures``, the last at ``last``, may try at ``now``,
        else the seconds until it may (Redis's script computes the same)."""
        if failures < self.free:
            return None
        remaining = last + min(self.base_s * 2 ** (failures - self.free), self.max_s) - now
        return remaining if remaining > 0 else None


@dataclass(frozen=True)
class Strike:
    """One failure an attempt counts in advance, on ``key`` of ``backoff``. With
    ``once_per`` (another strike of the same attempt) it counts only while that one has
    no failures yet: each client address counts once on an account."""

    backoff: Backoff
    key: str
    once_per: Strike | None = None


Hit = tuple[SlidingWindow, str]


class Counters(Protocol):
    """Where the counters live; ``now`` (seconds) is for tests, else the store's clock."""

    async def hit(self, hits: Sequence[Hit], now: float | None = None) -> float | None:
        """One hit on every (window, key) when all allow it, else none and the longest
        wait: a request refused by one limit uses up no other."""
        ...

    async def fail(
        self, strikes: Sequence[Strike], now: float | None = None
    ) -> float | tuple[Strike, ...]:
        """Count a failure on every strike when none must wait, and say which counted
        (``once_per``); else count none and give the longest wait."""
        ...

    async def forgive(self, counted: Sequence[Strike], forget: Sequence[Strike]) -> None:
        """An attempt succeeded: take back one failure of each ``counted`` strike, then
        forget every failure of the ``forget`` ones."""
        ...


def conditions_of(strikes: Sequence[Strike]) -> list[int]:
    """For each strike, the position (from 1) of its ``once_per`` among ``strikes``, or 0."""
    positions = []
    for strike in strikes:
        if strike.once_per is None:
            positions.append(0)
        elif strike.once_per in strikes:
            positions.append(list(strikes).index(strike.once_per) + 1)
        else:
            raise ValueError(f"{strike.key!r} counts once per a strike outside its attempt")
    return positions
