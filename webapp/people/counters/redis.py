"""Counters kept in Redis, one Lua script per operation: every process of a wall
shares one budget."""

from __future__ import annotations

import secrets
from collections.abc import Sequence

from redis.asyncio import Redis

from webapp.database.redis import redis_key
from webapp.people.counters.base import (
    Hit,
    Strike,
    conditions_of,
)

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
    the app answers 503 (``webapp.server.app``).
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
        for strike, condition in zip(strikes, conditions_of(strikes), strict=True):
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
