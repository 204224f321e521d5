"""The sign-in throttle's rules, on both counter stores: failures slow whoever fails,
each address counts once on an account, a known browser is throttled on its own, and
on Redis every process sees the same failures. (As an attacker meets it through the
login form: tests/webapp/server/routes/test_signin.py.)"""

from __future__ import annotations

import asyncio

import pytest

from webapp.people.counters.base import Counters
from webapp.people.counters.redis import RedisCounters
from webapp.people.signin import (
    ACCOUNT_FREE_CLIENTS,
    Attempt,
    SignInThrottle,
    device_cookie,
    device_of,
)

FREE, CLIENT_FREE = 3, 10


def throttle(counters: Counters) -> SignInThrottle:
    return SignInThrottle(counters, free=FREE, client_free=CLIENT_FREE, max_s=300.0)


async def tries(
    throttle: SignInThrottle,
    times: int,
    account: str = "ines",
    address: str = "203.0.113.9",
    device: str | None = None,
    now: float | None = 0.0,
) -> list[bool]:
    """Which of ``times`` wrong-password attempts were let through to the check."""
    answers = [await throttle.reserve(account, address, device, now) for _ in range(times)]
    return [isinstance(answer, Attempt) for answer in answers]


async def test_a_guesser_slows_only_itself(counters: Counters) -> None:
    guarded = throttle(counters)
    assert await tries(guarded, FREE + 2) == [True] * FREE + [False, False]
    assert await tries(guarded, 1, address="198.51.100.4") == [True], "the instructor elsewhere"
    assert await tries(guarded, 1, account="other") == [True], "other accounts from there"


async def test_each_further_failure_doubles_the_wait(counters: Counters) -> None:
    guarded = throttle(counters)
    await tries(guarded, FREE)
    waits, now = [], 0.0
    for _ in range(3):
        wait = await guarded.reserve("ines", "203.0.113.9", None, now)
        assert isinstance(wait, float)
        waits.append(wait)
        now += wait
        assert await tries(guarded, 1, now=now) == [True]
    assert waits == [pytest.approx(w) for w in (1.0, 2.0, 4.0)]


async def test_accounts_are_compared_as_they_are_signed_in(counters: Counters) -> None:
    guarded = throttle(counters)
    for account in ("Ines", " ines", "INES"):
        await guarded.reserve(account, "203.0.113.9", None, 0.0)
    assert await tries(guarded, 1, account="ines") == [False]


async def test_one_address_spraying_many_accounts_is_slowed(counters: Counters) -> None:
    guarded = throttle(counters)
    answers = [(await tries(guarded, 1, account=f"user{n}"))[0] for n in range(CLIENT_FREE + 2)]
    assert answers == [True] * CLIENT_FREE + [False, False]


async def test_an_account_guessed_from_everywhere_slows_only_unknown_browsers(
    counters: Counters,
) -> None:
    guarded = throttle(counters)
    for n in range(ACCOUNT_FREE_CLIENTS):
        assert await tries(guarded, 1, address=f"198.51.100.{n}") == [True]
    assert await tries(guarded, 1, address="192.0.2.77") == [False], "an unknown browser waits"
    assert await tries(guarded, 1, address="192.0.2.77", device="laptop") == [True], (
        "the instructor's own browser does not"
    )


async def test_an_address_counts_once_on_the_account(counters: Counters) -> None:
    """More failures from one address than the account's free addresses do not slow
    the account for everyone."""
    guarded = throttle(counters)
    failures = ACCOUNT_FREE_CLIENTS + 5
    for second in range(0, 300 * failures, 300):  # each when the address's wait is over
        assert await tries(guarded, 1, now=float(second)) == [True]
    assert await tries(guarded, 1, address="192.0.2.77", now=300.0 * failures) == [True]


async def test_a_known_browser_is_throttled_on_its_own(counters: Counters) -> None:
    guarded = throttle(counters)
    assert await tries(guarded, FREE + 1, device="stolen-laptop") == [True] * FREE + [False]
    assert await tries(guarded, 1, device="laptop") == [True]
    assert await tries(guarded, 1) == [True], "nor does it slow the address"


async def test_success_takes_the_attempt_back_and_forgets_the_failures(
    counters: Counters,
) -> None:
    guarded = throttle(counters)
    await tries(guarded, FREE - 1)
    attempt = await guarded.reserve("ines", "203.0.113.9", None, 0.0)
    assert isinstance(attempt, Attempt)
    await guarded.succeeded(attempt)
    assert await tries(guarded, FREE + 1) == [True] * FREE + [False], "free failures again"
    # the address's failures on other accounts were counted and stay, minus the success
    sprayed = [(await tries(guarded, 1, account=f"u{n}"))[0] for n in range(CLIENT_FREE)]
    assert sprayed.count(True) == CLIENT_FREE - (FREE - 1) - FREE


async def test_a_burst_gets_no_more_attempts_than_the_free_ones(counters: Counters) -> None:
    guarded = throttle(counters)
    answers = await asyncio.gather(
        *(guarded.reserve("ines", "203.0.113.9", None) for _ in range(30))
    )
    assert sum(isinstance(answer, Attempt) for answer in answers) == FREE


def test_a_device_cookie_names_its_account_and_nothing_forged_passes() -> None:
    value = device_cookie("secret", "ines").split(";")[0].split("=", 1)[1]
    assert device_of("secret", value, "ines") is not None
    assert device_of("secret", value, "other") is None
    assert device_of("another-secret", value, "ines") is None
    assert device_of("secret", "x" * 400, "ines") is None


# --- several server processes ---------------------------------------------------------


async def test_failures_through_one_process_slow_the_other(
    processes: list[RedisCounters],
) -> None:
    first, second = (throttle(process) for process in processes)
    assert await tries(first, FREE, now=None) == [True] * FREE
    wait = await second.reserve("ines", "203.0.113.9", None)
    assert isinstance(wait, float) and 0 < wait <= 1.0
    assert await tries(second, 1, address="198.51.100.4", now=None) == [True]


async def test_a_burst_through_two_processes_gets_the_free_attempts_once(
    processes: list[RedisCounters],
) -> None:
    throttles = [throttle(process) for process in processes]
    answers = await asyncio.gather(
        *(throttles[n % 2].reserve("ines", "203.0.113.9", None) for n in range(30))
    )
    assert sum(isinstance(answer, Attempt) for answer in answers) == FREE


async def test_a_success_through_one_process_forgets_on_the_other(
    processes: list[RedisCounters],
) -> None:
    first, second = (throttle(process) for process in processes)
    await tries(first, FREE - 1, now=None)
    attempt = await first.reserve("ines", "203.0.113.9", None)
    assert isinstance(attempt, Attempt)
    await first.succeeded(attempt)
    assert await tries(second, FREE, now=None) == [True] * FREE
