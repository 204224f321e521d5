"""The counter stores: sliding windows and failure back-off, the same in this process's
memory and in Redis; on Redis, several processes share one budget, never take the same
last slot, and leave nothing behind that no longer counts."""

from __future__ import annotations

import asyncio

import pytest

from webapp.people.counters.base import Backoff, Counters, SlidingWindow, Strike
from webapp.people.counters.memory import MemoryCounters
from webapp.people.counters.redis import RedisCounters

# --- sliding windows: at most so many hits a window --------------------------------


async def hits(counters: Counters, window: SlidingWindow, key: str, *times: float) -> list[bool]:
    """Which of the hits on ``key`` at ``times`` were allowed."""
    return [await counters.hit([(window, key)], now=t) is None for t in times]


async def test_allows_the_limit_then_says_how_long_to_wait(counters: Counters) -> None:
    window = SlidingWindow("scan:visitor", limit=3, window_s=10.0)
    assert await hits(counters, window, "phone", 0.0, 1.0, 2.0) == [True, True, True]
    assert await counters.hit([(window, "phone")], now=4.0) == pytest.approx(6.0)
    assert await hits(counters, window, "other", 4.0) == [True], "keys are counted apart"
    other_window = SlidingWindow("balloon:visitor", limit=1, window_s=10.0)
    assert await hits(counters, other_window, "phone", 4.0) == [True], "windows too"


async def test_the_window_slides(counters: Counters) -> None:
    window = SlidingWindow("w", limit=2, window_s=10.0)
    assert await hits(counters, window, "phone", 0.0, 5.0, 9.0) == [True, True, False]
    assert await hits(counters, window, "phone", 10.0) == [True], "the first hit left the window"
    assert await counters.hit([(window, "phone")], now=11.0) == pytest.approx(4.0)


async def test_refused_hits_do_not_count(counters: Counters) -> None:
    window = SlidingWindow("w", limit=1, window_s=10.0)
    assert await hits(counters, window, "phone", *range(10)) == [True] + [False] * 9
    assert await hits(counters, window, "phone", 10.0) == [True]


async def test_several_windows_take_a_hit_together_or_not_at_all(counters: Counters) -> None:
    """The longest wait is given, and a hit refused by one window uses up no other."""
    own = SlidingWindow("balloon:visitor", limit=1, window_s=60.0)
    wall = SlidingWindow("balloon:wall", limit=2, window_s=60.0)
    assert await counters.hit([(own, "a"), (wall, "demo")], now=0.0) is None
    assert await counters.hit([(own, "b"), (wall, "demo")], now=10.0) is None
    # b's own window (free at 70) outlasts the wall's (free at 60)
    assert await counters.hit([(own, "b"), (wall, "demo")], now=20.0) == pytest.approx(50.0)
    assert await counters.hit([(own, "c"), (wall, "demo")], now=20.0) == pytest.approx(40.0)
    assert await counters.hit([(own, "c"), (wall, "demo")], now=60.0) is None, (
        "the refusals counted nothing: the wall's window freed when a's hit left it"
    )


async def test_no_windows_means_allowed(counters: Counters) -> None:
    assert await counters.hit([], now=0.0) is None


async def test_memory_is_bounded_by_forgetting_the_least_recent_keys() -> None:
    counters = MemoryCounters(max_keys=2)
    window = SlidingWindow("w", limit=1, window_s=60.0)
    await counters.hit([(window, "a")], now=0.0)
    await counters.hit([(window, "b")], now=0.0)
    await counters.hit([(window, "a")], now=1.0)  # refused; "a" is now the most recently seen
    await counters.hit([(window, "c")], now=2.0)  # forgets "b"
    assert await hits(counters, window, "a", 3.0) == [False]
    assert await hits(counters, window, "b", 3.0) == [True]


async def test_keys_are_forgotten_once_their_hits_left_the_window() -> None:
    """Phones that came and went leave nothing behind, however many came."""
    counters = MemoryCounters()
    window = SlidingWindow("w", limit=2, window_s=60.0)
    for phone in range(1000):
        assert await hits(counters, window, f"phone {phone}", phone / 10) == [True]
    await counters.hit([(window, "late")], now=130.0)  # phones 0-700 hit at 70 or before
    assert len(counters._hits["w"]) == 300  # phones 701-999 and "late"
    assert await hits(counters, window, "phone 999", 130.0, 130.0) == [True, False]
    await counters.hit([(window, "later")], now=1000.0)
    assert list(counters._hits["w"]) == ["later"]


# --- back-off: growing delays after failures ---------------------------------------


async def fail(counters: Counters, backoff: Backoff, key: str, now: float = 0.0) -> float | None:
    """One failure of ``key`` counted at ``now`` (None), or the wait that refused it."""
    counted = await counters.fail([Strike(backoff, key)], now=now)
    return counted if isinstance(counted, float) else None


async def fail_times(counters: Counters, backoff: Backoff, key: str, times: int) -> None:
    """``times`` failures of ``key`` at 0, each when its wait is over."""
    now = 0.0
    for _ in range(times):
        while (wait := await fail(counters, backoff, key, now)) is not None:
            now += wait


async def test_the_free_failures_cost_nothing(counters: Counters) -> None:
    backoff = Backoff("signin:client", free=3)
    assert [await fail(counters, backoff, "phone") for _ in range(3)] == [None] * 3
    assert await fail(counters, backoff, "phone") is not None, "delays start after the free ones"


async def test_each_further_failure_doubles_the_delay(counters: Counters) -> None:
    backoff = Backoff("b", free=3, base_s=1.0)
    await fail_times(counters, backoff, "phone", 3)
    waits, now = [], 0.0
    for _ in range(4):
        wait = await fail(counters, backoff, "phone", now)
        assert wait is not None
        waits.append(wait)
        now += wait
        assert await fail(counters, backoff, "phone", now) is None, "counted once the wait is over"
    assert waits == [pytest.approx(w) for w in (1.0, 2.0, 4.0, 8.0)]


async def test_the_base_scales_and_the_cap_bounds_the_delays(counters: Counters) -> None:
    backoff = Backoff("b", free=1, base_s=0.5, max_s=3.0)
    await fail_times(counters, backoff, "phone", 1)
    waits, now = [], 0.0
    for _ in range(6):
        wait = await fail(counters, backoff, "phone", now)
        assert wait is not None
        waits.append(wait)
        now += wait
        await fail(counters, backoff, "phone", now)
    assert waits == [pytest.approx(w) for w in (0.5, 1.0, 2.0, 3.0, 3.0, 3.0)]


async def test_the_wait_runs_from_the_last_failure_and_passes_with_time(
    counters: Counters,
) -> None:
    backoff = Backoff("b", free=1, base_s=1.0)
    assert await fail(counters, backoff, "phone", now=100.0) is None
    assert await fail(counters, backoff, "phone", now=100.0) == pytest.approx(1.0)
    assert await fail(counters, backoff, "phone", now=100.5) == pytest.approx(0.5)
    assert await fail(counters, backoff, "phone", now=101.0) is None  # a 2 s delay from 101
    assert await fail(counters, backoff, "phone", now=102.5) == pytest.approx(0.5)
    assert await fail(counters, backoff, "phone", now=500.0) is None, "the failures are kept"
    assert await fail(counters, backoff, "phone", now=501.0) == pytest.approx(3.0)


async def test_failures_are_forgotten_a_while_after_the_last(counters: Counters) -> None:
    backoff = Backoff("b", free=1, base_s=1.0, max_s=10.0, forget_s=3_600.0)
    await fail_times(counters, backoff, "phone", 4)  # the last at 7.0, with 8 s to wait
    assert await fail(counters, backoff, "phone", now=3_000.0) is None
    assert await fail(counters, backoff, "phone", now=3_000.0) is not None, "still remembered"
    assert await fail(counters, backoff, "phone", now=6_600.0) is None
    assert await fail(counters, backoff, "phone", now=6_600.0) == pytest.approx(1.0), (
        "an hour after the last failure the count started over"
    )


def test_failures_are_remembered_at_least_as_long_as_the_longest_delay() -> None:
    assert Backoff("b", free=1, max_s=300.0, forget_s=60.0).remembered_s == 300.0


async def test_success_takes_back_the_attempt_and_forgets_the_failures(
    counters: Counters,
) -> None:
    backoff = Backoff("b", free=2, base_s=1.0)
    await fail_times(counters, backoff, "phone", 5)
    assert await fail(counters, backoff, "phone", now=100.0) is None
    assert await fail(counters, backoff, "phone", now=100.0) is not None
    strike = Strike(backoff, "phone")
    await counters.forgive([], [strike])
    assert [await fail(counters, backoff, "phone", 100.0) for _ in range(2)] == [None, None], (
        "free failures again"
    )
    assert await fail(counters, backoff, "phone", 100.0) == pytest.approx(1.0), "delays start over"
    await counters.forgive([Strike(backoff, "never-failed")], [Strike(backoff, "nor-this")])


async def test_taking_back_undoes_one_failure(counters: Counters) -> None:
    backoff = Backoff("b", free=2, base_s=1.0)
    await fail_times(counters, backoff, "phone", 2)
    assert await fail(counters, backoff, "phone", now=0.0) == pytest.approx(1.0)
    await counters.forgive([Strike(backoff, "phone")], [])
    assert await fail(counters, backoff, "phone", now=0.0) is None, "one free failure again"
    await counters.forgive([Strike(backoff, "phone")] * 3, [])  # taking back past none is none
    assert await fail(counters, backoff, "phone", now=0.0) is None


async def test_keys_and_back_offs_are_independent(counters: Counters) -> None:
    accounts = Backoff("signin:account", free=1, base_s=1.0)
    clients = Backoff("signin:client", free=1, base_s=1.0)
    await fail_times(counters, accounts, "ines", 3)  # the third at 3.0: 4 s to wait
    await fail_times(counters, clients, "ines", 1)  # at 0.0: 1 s to wait
    assert await fail(counters, accounts, "ines", now=3.0) == pytest.approx(4.0)
    assert await fail(counters, clients, "ines", now=0.0) == pytest.approx(1.0)
    assert await fail(counters, accounts, "other", now=3.0) is None
    await counters.forgive([], [Strike(accounts, "ines")])
    assert await fail(counters, accounts, "ines", now=3.0) is None
    assert await fail(counters, clients, "ines", now=0.0) == pytest.approx(1.0), (
        "forgetting a key of one back-off leaves the other's"
    )


async def test_an_attempt_counts_on_every_strike_or_none(counters: Counters) -> None:
    pair = Backoff("pair", free=1, base_s=10.0)
    client = Backoff("client", free=5, base_s=10.0)
    await fail_times(counters, pair, "ines|a", 1)
    attempt = [Strike(pair, "ines|a"), Strike(client, "a")]
    assert await counters.fail(attempt, now=0.0) == pytest.approx(10.0)
    counted = await counters.fail([Strike(client, "a")] * 5, now=0.0)
    assert counted == (Strike(client, "a"),) * 5, "the refused attempt counted nothing on a"
    assert await counters.fail([Strike(client, "a")], now=0.0) == pytest.approx(10.0)


async def test_a_strike_once_per_another_counts_only_while_that_one_is_clean(
    counters: Counters,
) -> None:
    """An account counts each client address once: while the address has no failures."""
    pair, account = Backoff("pair", free=5), Backoff("account", free=2, base_s=1.0)

    def attempt(address: str) -> list[Strike]:
        first = Strike(pair, f"ines|{address}")
        return [first, Strike(account, "ines", once_per=first)]

    counted = await counters.fail(attempt("a"), now=0.0)
    assert counted == tuple(attempt("a"))
    assert await counters.fail(attempt("a"), now=0.0) == (attempt("a")[0],), "a counts once"
    assert await counters.fail(attempt("a"), now=0.0) == (attempt("a")[0],)
    assert await counters.fail(attempt("b"), now=0.0) == tuple(attempt("b"))
    assert await counters.fail(attempt("c"), now=0.0) == pytest.approx(1.0), (
        "two addresses failed: the account waits, even for a new one"
    )
    with pytest.raises(ValueError, match="outside its attempt"):
        await counters.fail(attempt("d")[1:], now=0.0)


async def test_memory_is_bounded_by_forgetting_the_least_recently_failed() -> None:
    counters = MemoryCounters(max_keys=2)
    backoff = Backoff("b", free=1, base_s=10.0)
    await fail(counters, backoff, "a", now=0.0)
    await fail(counters, backoff, "b", now=0.0)
    await fail(counters, backoff, "a", now=20.0)  # "a" fails again: the most recent
    await fail(counters, backoff, "c", now=20.0)  # forgets "b"
    assert await fail(counters, backoff, "a", now=20.0) is not None
    assert await fail(counters, backoff, "b", now=20.0) is None
    assert await fail(counters, backoff, "c", now=20.0) is not None


# --- Redis: what several processes share ---------------------------------------------


async def test_two_processes_share_one_window(processes: list[RedisCounters]) -> None:
    """A wall's budget of 6: three hits through each process, the seventh refused on either."""
    first, second = processes
    wall = SlidingWindow("balloon:wall", limit=6, window_s=60.0)
    for _ in range(3):
        assert await first.hit([(wall, "demo")]) is None
        assert await second.hit([(wall, "demo")]) is None
    for process in processes:
        wait = await process.hit([(wall, "demo")])
        assert wait is not None and 0 < wait <= 60.0


async def test_two_processes_never_both_take_the_last_slot(
    processes: list[RedisCounters],
) -> None:
    """200 hits at once, half through each process (each on its own connections):
    exactly the limit get through."""
    wall = SlidingWindow("balloon:wall", limit=10, window_s=60.0)
    answers = await asyncio.gather(*(processes[n % 2].hit([(wall, "demo")]) for n in range(200)))
    assert sum(answer is None for answer in answers) == 10


async def test_two_processes_share_the_failures(processes: list[RedisCounters]) -> None:
    first, second = processes
    backoff = Backoff("signin:account-at-client", free=3, base_s=1.0)
    for _ in range(3):
        assert await fail(first, backoff, "ines|203.0.113.9") is None
    wait = await fail(second, backoff, "ines|203.0.113.9")
    assert wait is not None and 0 < wait <= 1.0


async def test_a_burst_of_failures_counts_no_more_than_the_free_ones(
    processes: list[RedisCounters],
) -> None:
    """Thirty attempts at once through two processes: three are counted (and checked)."""
    backoff = Backoff("signin:account-at-client", free=3, base_s=1.0)
    strikes = [Strike(backoff, "ines|203.0.113.9")]
    answers = await asyncio.gather(*(processes[n % 2].fail(strikes) for n in range(30)))
    assert sum(not isinstance(answer, float) for answer in answers) == 3


async def test_keys_are_named_under_the_prefix_and_expire(
    processes: list[RedisCounters], redis_prefix: str
) -> None:
    """Nothing stays in Redis that no longer counts: windows expire a window after their
    last hit, failures ``remembered_s`` after the last; refused hits add nothing."""
    counters = processes[0]
    window = SlidingWindow("scan:visitor", limit=2, window_s=60.0)
    for _ in range(5):
        await counters.hit([(window, "phone")])
    backoff = Backoff("signin:client", free=1, max_s=300.0, forget_s=3_600.0)
    await fail(counters, backoff, "203.0.113.9")
    redis = counters.redis
    assert sorted(await redis.keys(f"{redis_prefix}:*")) == [
        f"{redis_prefix}:limit:scan:visitor:phone".encode(),
        f"{redis_prefix}:limit:signin:client:203.0.113.9".encode(),
    ]
    assert await redis.zcard(counters.key("scan:visitor", "phone")) == 2
    assert 0 < await redis.pttl(counters.key("scan:visitor", "phone")) <= 60_000
    assert 3_000_000 < await redis.pttl(counters.key("signin:client", "203.0.113.9")) <= 3_600_000
    await counters.forgive([], [Strike(backoff, "203.0.113.9")])
    assert await redis.exists(counters.key("signin:client", "203.0.113.9")) == 0
