"""The limits on what phones do to a wall, on both counter stores (the stores
themselves: test_counters.py); on Redis, two processes hold one budget."""

from __future__ import annotations

import asyncio

import pytest

from webapp.people.counters.base import Counters
from webapp.people.counters.redis import RedisCounters
from webapp.people.ratelimit import ActionLimits, ActionPolicy, Actor, retry_after_s


def test_the_retry_after_is_whole_seconds_past_the_wait() -> None:
    assert [retry_after_s(w) for w in (0.001, 0.999, 1.0, 6.5, 59.99)] == [1, 1, 2, 7, 60]


# --- ActionLimits: what phones do to a shared wall ---------------------------------


def limits(
    counters: Counters,
    per_visitor: int = 100,
    per_new_address: int | None = 100,
    per_address: int | None = 100,
    per_wall: int | None = 100,
    settle_s: float = 10.0,
) -> ActionLimits:
    """Balloons limited as given (every other budget roomy), scans as the server does:
    per visitor and per address for new visitors only."""
    return ActionLimits(
        counters,
        {
            "balloon": ActionPolicy(per_visitor, per_new_address, per_address, per_wall, settle_s),
            "scan": ActionPolicy(3, 5, None, None, 0.0),
        },
        window_s=60.0,
    )


SETTLED = 60.0  # seconds since the cookie was issued: past the settle time
NEW = 1.0  # a cookie issued a moment ago
NO_COOKIE = None  # the request brought no valid cookie


async def balloons(
    action_limits: ActionLimits, actors: list[Actor], wall: str = "demo", now: float | None = 0.0
) -> list[bool]:
    """Which of the actors' balloons (one each, in order) are allowed (``now`` None: at
    the store's own time)."""
    return [await action_limits.hit("balloon", actor, wall, now=now) is None for actor in actors]


async def test_a_visitor_has_its_own_budget(counters: Counters) -> None:
    action_limits = limits(counters, per_visitor=2)
    phone = Actor("phone", "10.0.0.1", SETTLED)
    assert await balloons(action_limits, [phone] * 3) == [True, True, False]
    assert await balloons(action_limits, [Actor("other", "10.0.0.1", SETTLED)]) == [True]


async def test_new_and_cookieless_visitors_of_one_address_share_a_small_budget(
    counters: Counters,
) -> None:
    action_limits = limits(counters, per_new_address=3)
    fresh = [Actor(f"fresh-{n}", "10.0.0.1", NEW if n % 2 else NO_COOKIE) for n in range(4)]
    assert await balloons(action_limits, fresh) == [True, True, True, False]
    assert await balloons(action_limits, [Actor("fresh-x", "10.0.0.2", NO_COOKIE)]) == [True], (
        "another address has its own"
    )
    assert await balloons(action_limits, [Actor("settled", "10.0.0.1", SETTLED)]) == [True], (
        "a settled visitor is not held by the new ones' budget"
    )


async def test_a_visitor_settles_when_its_cookie_is_old_enough(counters: Counters) -> None:
    action_limits = limits(counters, per_new_address=1, settle_s=10.0)
    new_ones = [Actor("a", "10.0.0.1", 9.9), Actor("b", "10.0.0.1", 9.9)]
    assert await balloons(action_limits, new_ones) == [True, False]
    assert await balloons(action_limits, [Actor("b", "10.0.0.1", 10.0)]) == [True]


async def test_one_address_has_one_budget_for_all_its_visitors(counters: Counters) -> None:
    action_limits = limits(counters, per_address=3)
    room = [Actor(f"phone-{n}", "10.0.0.1", SETTLED) for n in range(4)]
    assert await balloons(action_limits, room) == [True, True, True, False]
    assert await balloons(action_limits, [Actor("phone-0", "10.0.0.2", SETTLED)]) == [True]


async def test_one_wall_has_one_budget_for_everyone(counters: Counters) -> None:
    action_limits = limits(counters, per_wall=3)
    everyone = [Actor(f"phone-{n}", f"10.0.0.{n}", SETTLED) for n in range(4)]
    assert await balloons(action_limits, everyone) == [True, True, True, False]
    assert await balloons(action_limits, everyone[:1], wall="lobby") == [True], "walls are apart"


async def test_the_window_slides_for_every_budget(counters: Counters) -> None:
    action_limits = limits(counters, per_visitor=1, per_new_address=1, per_address=1, per_wall=1)
    phone = Actor("phone", "10.0.0.1", NO_COOKIE)
    assert await action_limits.hit("balloon", phone, "demo", now=0.0) is None
    assert await action_limits.hit("balloon", phone, "demo", now=45.0) == pytest.approx(15.0)
    assert await action_limits.hit("balloon", phone, "demo", now=60.0) is None


async def test_the_longest_wait_is_given_and_a_refused_action_uses_up_no_budget(
    counters: Counters,
) -> None:
    action_limits = limits(counters, per_visitor=1, per_wall=2)
    first, second = Actor("a", "10.0.0.1", SETTLED), Actor("b", "10.0.0.2", SETTLED)
    assert await action_limits.hit("balloon", first, "demo", now=0.0) is None
    assert await action_limits.hit("balloon", second, "demo", now=10.0) is None
    # the second visitor's own budget (free at 70) outlasts the wall's (free at 60)
    assert await action_limits.hit("balloon", second, "demo", now=20.0) == pytest.approx(50.0)
    third = Actor("c", "10.0.0.3", SETTLED)
    assert await action_limits.hit("balloon", third, "demo", now=20.0) == pytest.approx(40.0)
    # the refusals counted nothing: the wall's budget frees when the first balloon leaves
    assert await action_limits.hit("balloon", third, "demo", now=60.0) is None


async def test_no_limit_of_a_kind_means_none_is_kept(counters: Counters) -> None:
    action_limits = limits(
        counters, per_visitor=1000, per_new_address=None, per_address=None, per_wall=None
    )
    crowd = [Actor(f"phone-{n}", "10.0.0.1", NO_COOKIE) for n in range(500)]
    assert all(await balloons(action_limits, crowd))


async def test_kinds_of_action_are_counted_apart(counters: Counters) -> None:
    """Scans (the server's policy: no address or wall budget for settled phones) do not
    use up balloons, and balloons do not use up scans."""
    action_limits = limits(counters, per_visitor=1)
    phone = Actor("phone", "10.0.0.1", SETTLED)
    assert await balloons(action_limits, [phone]) == [True]
    scans = [await action_limits.hit("scan", phone, "demo", now=0.0) is None for _ in range(4)]
    assert scans == [True, True, True, False]
    cookieless = [Actor(f"x-{n}", "10.0.0.9", NO_COOKIE) for n in range(6)]
    allowed = [await action_limits.hit("scan", a, "", now=0.0) is None for a in cookieless]
    assert allowed == [True] * 5 + [False]


# --- several server processes: one budget in Redis --------------------------------------


async def test_two_processes_hold_one_wall_budget(processes: list[RedisCounters]) -> None:
    """A wall's budget of 6 a minute: three balloons through each process, and the
    seventh is refused on either, with the wait until the first leaves the window."""
    first, second = (limits(process, per_wall=6) for process in processes)
    phones = [Actor(f"phone-{n}", f"10.0.0.{n}", SETTLED) for n in range(8)]
    assert await balloons(first, phones[0:3], now=None) == [True] * 3
    assert await balloons(second, phones[3:6], now=None) == [True] * 3
    for process, phone in zip((first, second), phones[6:], strict=True):
        wait = await process.hit("balloon", phone, "demo")
        assert wait is not None and 0 < wait <= 60.0


async def test_two_processes_never_both_take_a_visitors_last_action(
    processes: list[RedisCounters],
) -> None:
    """A burst of one phone's balloons spread over two processes: its own budget of
    three holds, and the refused ones use up none of the wall's."""
    first, second = (limits(process, per_visitor=3, per_wall=5) for process in processes)
    phone = Actor("phone", "10.0.0.1", SETTLED)
    answers = await asyncio.gather(
        *((first, second)[n % 2].hit("balloon", phone, "demo") for n in range(60))
    )
    assert sum(answer is None for answer in answers) == 3
    others = [Actor(f"other-{n}", f"10.0.0.{n + 2}", SETTLED) for n in range(3)]
    assert await balloons(second, others, now=None) == [True, True, False]
