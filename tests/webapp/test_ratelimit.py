"""The sliding-window rate limiter behind the scan and publish limits."""

from __future__ import annotations

import pytest

from webapp.ratelimit import RateLimiter


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
