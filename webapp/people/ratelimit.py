"""Rate limits and sign-in delays, kept in memory by the process that serves the request.

Every check and its count happen together, with no ``await`` between them, so
requests that arrive at once cannot all pass a check before any of them is counted.
"""

from __future__ import annotations

import time
from collections import OrderedDict, deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from webapp.people.visitors import Visitor


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

    def wait(self, key: str, now: float | None = None) -> float | None:
        """None when ``key`` may hit now, else the seconds until it may; counts nothing."""
        now = time.monotonic() if now is None else now
        hits = self._hits.get(key)
        if hits is None:
            return None
        self._hits.move_to_end(key)  # seen: the last to be forgotten
        while hits and hits[0] <= now - self.window_s:
            hits.popleft()
        return hits[0] + self.window_s - now if len(hits) >= self.limit else None

    def count(self, key: str, now: float | None = None) -> None:
        """Count one hit, allowed or not (callers check :meth:`wait` first)."""
        now = time.monotonic() if now is None else now
        hits = self._hits.get(key)
        if hits is None:
            hits = self._hits[key] = deque()
            if len(self._hits) > self.max_keys:
                self._hits.popitem(last=False)
        hits.append(now)

    def hit(self, key: str, now: float | None = None) -> float | None:
        """Count one hit; None when allowed, else the seconds to wait before retrying."""
        now = time.monotonic() if now is None else now
        wait = self.wait(key, now)
        if wait is None:
            self.count(key, now)
        return wait


def hit_all(limits: Sequence[tuple[RateLimiter, str]], now: float | None = None) -> float | None:
    """One hit on every (limiter, key) when all allow it, else none and the longest wait:
    a request refused by one limit uses up no other."""
    now = time.monotonic() if now is None else now
    waits = [w for limiter, key in limits if (w := limiter.wait(key, now)) is not None]
    if waits:
        return max(waits)
    for limiter, key in limits:
        limiter.count(key, now)
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

    def failures(self, key: str) -> int:
        return self._failures.get(key, (0, 0.0))[0]

    def failed(self, key: str, now: float | None = None) -> None:
        now = time.monotonic() if now is None else now
        count, _ = self._failures.pop(key, (0, now))
        self._failures[key] = (count + 1, now)
        if len(self._failures) > self.max_keys:
            self._failures.popitem(last=False)

    def take_back(self, key: str) -> None:
        """Undo one failure counted in advance for an attempt that succeeded."""
        count, last = self._failures.get(key, (0, 0.0))
        if count <= 1:
            self._failures.pop(key, None)
        else:
            self._failures[key] = (count - 1, last)

    def succeeded(self, key: str) -> None:
        self._failures.pop(key, None)


# --- what phones do to a shared wall ---------------------------------------------------

WallAction = Literal["scan", "publish", "balloon", "toggle", "group"]


@dataclass(frozen=True)
class Actor:
    """Who acts, as the abuse limits see them: a visitor (one phone session) at a
    client address; ``age_s`` is how long ago its session cookie was issued (None:
    the request brought no valid cookie)."""

    visitor_id: str
    address: str
    age_s: float | None

    @classmethod
    def of(cls, visitor: Visitor, address: str) -> Actor:
        return cls(visitor.id, address, visitor.age_s())


@dataclass(frozen=True)
class ActionPolicy:
    """How often one kind of action may happen per minute, each limit on its own key:
    per visitor, per client address for visitors not yet settled (a phone whose cookie
    is younger than ``settle_s``, or that brought none), per client address for
    everyone, and per wall. None: no limit of that kind."""

    per_visitor: int
    per_new_address: int | None
    per_address: int | None
    per_wall: int | None
    settle_s: float


class ActionLimits:
    """The limits on what phones do to a wall, one home for every kind of action.

    A phone that drops its cookie is a new visitor at every request: it escapes its
    per-visitor limit but not the small budget that new visitors of one address share.
    A lecture hall behind one NAT address is many settled visitors: each is limited as
    the one phone it is, and only the hall-sized per-address and the wall's own limits
    hold them together.
    """

    def __init__(self, policies: Mapping[WallAction, ActionPolicy], window_s: float = 60.0):
        self.policies = dict(policies)
        self._limiters: dict[tuple[WallAction, str], RateLimiter] = {}
        for kind, policy in self.policies.items():
            for scope, limit in (
                ("visitor", policy.per_visitor),
                ("new", policy.per_new_address),
                ("address", policy.per_address),
                ("wall", policy.per_wall),
            ):
                if limit is not None:
                    self._limiters[kind, scope] = RateLimiter(limit, window_s)

    def hit(
        self, kind: WallAction, actor: Actor, wall_id: str, now: float | None = None
    ) -> float | None:
        """Count one action; None when allowed, else the seconds to wait."""
        policy = self.policies[kind]
        settled = actor.age_s is not None and actor.age_s >= policy.settle_s
        keys = {
            "visitor": actor.visitor_id,
            "new": None if settled else actor.address,
            "address": actor.address,
            "wall": wall_id,
        }
        return hit_all(
            [
                (limiter, key)
                for (action, scope), limiter in self._limiters.items()
                if action == kind and (key := keys[scope]) is not None
            ],
            now,
        )
