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

import secrets
import time
from collections import OrderedDict, defaultdict, deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from redis.asyncio import Redis

from webapp.database.redis import redis_key

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


def _conditions(strikes: Sequence[Strike]) -> list[int]:
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
        conditions = _conditions(strikes)
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


# The scripts read ARGV[1] as the time in seconds, or take the server's clock when it is
# empty: every process then agrees on the time, whatever its host's clock says.
_NOW = """
local now = tonumber(ARGV[1])
if not now then
  local clock = redis.call('TIME')
  now = tonumber(clock[1]) + tonumber(clock[2]) / 1000000
end
"""

# KEYS: one sorted set of hit times per (window, key). ARGV: now, a member unique to
# this call, then window_s and limit for each key. Returns the longest wait (a string)
# or nil when every key took the hit.
_HIT = (
    _NOW
    + """
local longest = nil
for i, key in ipairs(KEYS) do
  local window, limit = tonumber(ARGV[1 + 2 * i]), tonumber(ARGV[2 + 2 * i])
  redis.call('ZREMRANGEBYSCORE', key, '-inf', now - window)
  local held = redis.call('ZCARD', key)
  if held >= limit then
    local leaving = redis.call('ZRANGE', key, held - limit, held - limit, 'WITHSCORES')
    local wait = tonumber(leaving[2]) + window - now
    if not longest or wait > longest then longest = wait end
  end
end
if longest then return tostring(longest) end
for i, key in ipairs(KEYS) do
  redis.call('ZADD', key, now, ARGV[2] .. ':' .. i)
  redis.call('PEXPIRE', key, math.ceil(tonumber(ARGV[1 + 2 * i]) * 1000))
end
return nil
"""
)

# KEYS: one hash per (back-off, key): the failures 'n' and the last one's time 't'.
# ARGV: now, then for each key free, base_s, max_s, remembered_s and the position of
# its once_per (0: none). Returns the longest wait (a string), or the positions counted.
_FAIL = (
    _NOW
    + """
local held, longest = {}, nil
for i, key in ipairs(KEYS) do
  local at = 2 + 5 * (i - 1)
  local free, base, cap = tonumber(ARGV[at]), tonumber(ARGV[at + 1]), tonumber(ARGV[at + 2])
  local stored = redis.call('HMGET', key, 'n', 't')
  local failures, last = tonumber(stored[1]) or 0, tonumber(stored[2]) or now
  if failures > 0 and now - last >= tonumber(ARGV[at + 3]) then
    redis.call('DEL', key)
    failures = 0
  end
  held[i] = failures
  if failures >= free then
    local wait = last + math.min(base * 2 ^ (failures - free), cap) - now
    if wait > 0 and (not longest or wait > longest) then longest = wait end
  end
end
if longest then return tostring(longest) end
local counted = {}
for i, key in ipairs(KEYS) do
  local at = 2 + 5 * (i - 1)
  local once_per = tonumber(ARGV[at + 4])
  if once_per == 0 or held[once_per] == 0 then
    redis.call('HINCRBY', key, 'n', 1)
    redis.call('HSET', key, 't', now)
    redis.call('PEXPIRE', key, math.ceil(tonumber(ARGV[at + 3]) * 1000))
    table.insert(counted, i)
  end
end
return counted
"""
)

# KEYS: the hashes of the strikes to take back one failure of (the first ARGV[1]), then
# those to forget.
_FORGIVE = """
local taken = tonumber(ARGV[1])
for i, key in ipairs(KEYS) do
  if i <= taken and (tonumber(redis.call('HGET', key, 'n')) or 0) > 1 then
    redis.call('HINCRBY', key, 'n', -1)
  else
    redis.call('DEL', key)
  end
end
return 1
"""


class RedisCounters:
    """The counters in Redis, shared by every process (and host) of a wall.

    Keys are ``<prefix>:limit:<window or back-off>:<key>`` and expire on their own (a
    window after its last hit, failures ``remembered_s`` after the last), so Redis holds
    only what still counts. A Redis that does not answer raises ``redis.RedisError``:
    the app answers 503 (``webapp.app``).
    """

    def __init__(self, redis: Redis, prefix: str) -> None:
        self.redis = redis
        self.prefix = prefix
        self._hit = redis.register_script(_HIT)
        self._fail = redis.register_script(_FAIL)
        self._forgive = redis.register_script(_FORGIVE)

    def key(self, name: str, key: str) -> str:
        """The Redis key of ``key`` in the window or back-off called ``name``."""
        return redis_key(self.prefix, "limit", name, key)

    async def hit(self, hits: Sequence[Hit], now: float | None = None) -> float | None:
        if not hits:
            return None
        args: list[str | float] = [_clock(now), secrets.token_hex(8)]
        for window, _ in hits:
            args += [window.window_s, window.limit]
        wait = await self._hit(keys=[self.key(w.name, key) for w, key in hits], args=args)
        return None if wait is None else float(wait)

    async def fail(
        self, strikes: Sequence[Strike], now: float | None = None
    ) -> float | tuple[Strike, ...]:
        args: list[str | float] = [_clock(now)]
        for strike, condition in zip(strikes, _conditions(strikes), strict=True):
            backoff = strike.backoff
            args += [backoff.free, backoff.base_s, backoff.max_s, backoff.remembered_s, condition]
        keys = [self.key(s.backoff.name, s.key) for s in strikes]
        reply = await self._fail(keys=keys, args=args)
        if isinstance(reply, list):
            return tuple(strikes[position - 1] for position in reply)
        return float(reply)

    async def forgive(self, counted: Sequence[Strike], forget: Sequence[Strike]) -> None:
        keys = [self.key(s.backoff.name, s.key) for s in (*counted, *forget)]
        if keys:
            await self._forgive(keys=keys, args=[len(counted)])


def _clock(now: float | None) -> str:
    """``now`` for a script: exact (``repr``), or empty for the server's clock."""
    return "" if now is None else repr(now)
