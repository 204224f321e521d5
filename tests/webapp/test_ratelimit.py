"""The sliding-window rate limiter behind the scan and publish limits, and the sign-in backoff."""

from __future__ import annotations

import pytest

from webapp.ratelimit import Backoff, RateLimiter


def test_allows_the_limit_then_says_how_long_to_wait() -> None:
    limiter = RateLimiter(limit=3, window_s=10.0)
    assert [limiter.hit("phone", now=t) for t in (0.0, 1.0, 2.0)] == [None, None, None]
    assert limiter.hit("phone", now=4.0) == pytest.approx(6.0)
    assert limiter.hit("other", now=4.0) is None, "keys are counted apart"


def test_the_window_slides() -> None:
    limiter = RateLimiter(limit=2, window_s=10.0)
    limiter.hit("phone", now=0.0)
    limiter.hit("phone", now=5.0)
    assert limiter.hit("phone", now=9.0) is not None
    assert limiter.hit("phone", now=10.0) is None, "the first hit left the window"
    assert limiter.hit("phone", now=11.0) is not None


def test_refused_hits_do_not_count() -> None:
    limiter = RateLimiter(limit=1, window_s=10.0)
    limiter.hit("phone", now=0.0)
    for t in range(1, 10):
        limiter.hit("phone", now=float(t))
    assert limiter.hit("phone", now=10.0) is None


def test_memory_is_bounded_by_forgetting_the_least_recent_keys() -> None:
    limiter = RateLimiter(limit=1, window_s=60.0, max_keys=2)
    limiter.hit("a", now=0.0)
    limiter.hit("b", now=0.0)
    limiter.hit("a", now=1.0)  # refused; "a" is now the most recently seen
    limiter.hit("c", now=2.0)  # forgets "b"
    assert limiter.hit("a", now=3.0) is not None
    assert limiter.hit("b", now=3.0) is None


# --- Backoff: the growing delays after failed sign-ins -----------------------------


def fail(backoff: Backoff, key: str, times: int, now: float = 0.0) -> None:
    for _ in range(times):
        backoff.failed(key, now=now)


def test_a_key_never_seen_may_try() -> None:
    assert Backoff(free=3).wait("account:ines", now=0.0) is None


def test_the_free_attempts_cost_nothing() -> None:
    backoff = Backoff(free=3)
    for _ in range(3):
        assert backoff.wait("phone", now=0.0) is None
        backoff.failed("phone", now=0.0)
    assert backoff.wait("phone", now=0.0) is not None, "delays start after the free ones"


def test_each_further_failure_doubles_the_delay() -> None:
    backoff = Backoff(free=3, base_s=1.0)
    fail(backoff, "phone", 3)
    waits = []
    for _ in range(4):
        waits.append(backoff.wait("phone", now=0.0))
        backoff.failed("phone", now=0.0)
    assert waits == [pytest.approx(1.0), pytest.approx(2.0), pytest.approx(4.0), pytest.approx(8.0)]


def test_the_base_scales_the_delays() -> None:
    backoff = Backoff(free=1, base_s=0.5)
    fail(backoff, "phone", 1)
    assert backoff.wait("phone", now=0.0) == pytest.approx(0.5)
    backoff.failed("phone", now=0.0)
    assert backoff.wait("phone", now=0.0) == pytest.approx(1.0)


def test_the_delay_is_capped() -> None:
    backoff = Backoff(free=1, base_s=1.0, max_s=5.0)
    waits = []
    for _ in range(6):
        backoff.failed("phone", now=0.0)
        waits.append(backoff.wait("phone", now=0.0))
    assert waits == [1.0, 2.0, 4.0, 5.0, 5.0, 5.0]


def test_the_wait_runs_from_the_last_failure_and_passes_with_time() -> None:
    backoff = Backoff(free=1, base_s=1.0)
    backoff.failed("phone", now=100.0)
    backoff.failed("phone", now=100.0)  # a 2 s delay from t=100
    assert backoff.wait("phone", now=100.0) == pytest.approx(2.0)
    assert backoff.wait("phone", now=101.5) == pytest.approx(0.5)
    assert backoff.wait("phone", now=102.0) is None
    assert backoff.wait("phone", now=500.0) is None
    backoff.failed("phone", now=500.0)  # failures are remembered: now 4 s from t=500
    assert backoff.wait("phone", now=501.0) == pytest.approx(3.0)


def test_success_forgets_the_failures() -> None:
    backoff = Backoff(free=2, base_s=1.0)
    fail(backoff, "phone", 5)
    assert backoff.wait("phone", now=0.0) is not None
    backoff.succeeded("phone")
    assert backoff.wait("phone", now=0.0) is None
    backoff.failed("phone", now=0.0)
    assert backoff.wait("phone", now=0.0) is None, "free attempts again"
    backoff.failed("phone", now=0.0)
    assert backoff.wait("phone", now=0.0) == pytest.approx(1.0), "and the delays start over"
    backoff.succeeded("never-failed")  # forgetting an unknown key is harmless


def test_keys_are_independent() -> None:
    backoff = Backoff(free=1, base_s=1.0)
    fail(backoff, "account:ines", 3)
    fail(backoff, "client:10.0.0.1", 1)
    assert backoff.wait("account:ines", now=0.0) == pytest.approx(4.0)
    assert backoff.wait("client:10.0.0.1", now=0.0) == pytest.approx(1.0)
    assert backoff.wait("account:other", now=0.0) is None
    backoff.succeeded("account:ines")
    assert backoff.wait("client:10.0.0.1", now=0.0) == pytest.approx(1.0)


def test_memory_is_bounded_by_forgetting_the_least_recently_failed() -> None:
    backoff = Backoff(free=1, base_s=10.0, max_keys=2)
    backoff.failed("a", now=0.0)
    backoff.failed("b", now=0.0)
    backoff.failed("a", now=1.0)  # "a" is now the most recent
    backoff.failed("c", now=2.0)  # forgets "b"
    assert backoff.wait("a", now=2.0) is not None
    assert backoff.wait("b", now=2.0) is None
    assert backoff.wait("c", now=2.0) is not None
