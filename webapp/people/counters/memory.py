"""Counters kept in this process: the limits of one server process."""

from __future__ import annotations

import time
from collections import OrderedDict, defaultdict, deque
from collections.abc import Sequence

from webapp.people.counters.base import (
    Backoff,
    Hit,
    SlidingWindow,
    Strike,
    conditions_of,
)


class MemoryCounters:
    """The counters of one server process.

    Memory stays bounded: a window forgets the keys whose hits have all left it (a
    phone that came and went counts nothing), and beyond ``max_keys`` per window or
    back-off the least recently seen keys are forgotten (they could only have been
    throttled more, never less, by staying). No ``await`` comes between a check and its
    count.
    """

    def __init__(self, max_keys: int = 100_000) -> None:
        self.max_keys = max_keys
        self._hits: defaultdict[str, OrderedDict[str, deque[float]]] = defaultdict(OrderedDict)
        self._failures: defaultdict[str, OrderedDict[str, tuple[int, float]]] = defaultdict(
            OrderedDict
        )

    async def hit(self, hits: Sequence[Hit], now: float | None = None) -> float | None:
        now = time.monotonic() if now is None else now
        for window, _ in hits:
            self._forget_past(window, now)
        waits = [
            w for window, key in hits if (w := self._window_wait(window, key, now)) is not None
        ]
        if waits:
            return max(waits)
        for window, key in hits:
            table = self._hits[window.name]
            held = table.get(key)
            if held is None:
                held = table[key] = deque()
                if len(table) > self.max_keys:
                    table.popitem(last=False)
            held.append(now)
        return None

    def _forget_past(self, window: SlidingWindow, now: float) -> None:
        """Forget the keys whose hits have all left the window. Keys are in the order
        they were last seen and a key is seen whenever it is hit, so once the least
        recently seen key still holds a hit, every key behind it was seen within the
        window: what is kept is what was seen in the last ``window_s``."""
        table = self._hits[window.name]
        while table:
            key, held = next(iter(table.items()))
            if held and held[-1] > now - window.window_s:
                return
            del table[key]

    def _window_wait(self, window: SlidingWindow, key: str, now: float) -> float | None:
        table = self._hits[window.name]
        held = table.get(key)
        if held is None:
            return None
        table.move_to_end(key)  # seen: the last to be forgotten
        while held and held[0] <= now - window.window_s:
            held.popleft()
        if len(held) < window.limit:
            return None
        return held[-window.limit] + window.window_s - now  # when that hit leaves the window

    async def fail(
        self, strikes: Sequence[Strike], now: float | None = None
    ) -> float | tuple[Strike, ...]:
        now = time.monotonic() if now is None else now
        conditions = conditions_of(strikes)
        held = [self._held(strike.backoff, strike.key, now) for strike in strikes]
        waits = [
            w
            for strike, (failures, last) in zip(strikes, held, strict=True)
            if (w := strike.backoff.wait(failures, last, now)) is not None
        ]
        if waits:
            return max(waits)
        counted = tuple(
            strike
            for strike, condition in zip(strikes, conditions, strict=True)
            if condition == 0 or held[condition - 1][0] == 0
        )
        for strike in counted:
            table = self._failures[strike.backoff.name]
            failures, _ = table.pop(strike.key, (0, now))
            table[strike.key] = (failures + 1, now)
            if len(table) > self.max_keys:
                table.popitem(last=False)
        return counted

    def _held(self, backoff: Backoff, key: str, now: float) -> tuple[int, float]:
        """The failures of ``key`` and the time of the last (forgotten when old)."""
        table = self._failures[backoff.name]
        failures, last = table.get(key, (0, now))
        if failures and now - last >= backoff.remembered_s:
            del table[key]
            return 0, now
        return failures, last

    async def forgive(self, counted: Sequence[Strike], forget: Sequence[Strike]) -> None:
        for strike in counted:
            table = self._failures[strike.backoff.name]
            failures, last = table.get(strike.key, (0, 0.0))
            if failures <= 1:
                table.pop(strike.key, None)
            else:
                table[strike.key] = (failures - 1, last)
        for strike in forget:
            self._failures[strike.backoff.name].pop(strike.key, None)
