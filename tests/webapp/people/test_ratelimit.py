"""The sliding-window rate limiter, the limits on what phones do to a wall, and the
sign-in backoff."""

from __future__ import annotations

import pytest

from webapp.people.ratelimit import ActionLimits, ActionPolicy, Actor, Backoff, RateLimiter


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


# --- ActionLimits: what phones do to a shared wall ---------------------------------


def limits(
    per_visitor: int = 100,
    per_new_address: int | None = 100,
    per_address: int | None = 100,
    per_wall: int | None = 100,
    settle_s: float = 10.0,
) -> ActionLimits:
    """Balloons limited as given (every other budget roomy), scans as the server does:
    per visitor and per address for new visitors only."""
    return ActionLimits(
        {
            "balloon": ActionPolicy(per_visitor, per_new_address, per_address, per_wall, settle_s),
            "scan": ActionPolicy(3, 5, None, None, 0.0),
        },
        window_s=60.0,
    )


SETTLED = 60.0  # seconds since the cookie was issued: past the settle time
NEW = 1.0  # a cookie issued a moment ago
NO_COOKIE = None  # the request brought no valid cookie


def balloons(
    action_limits: ActionLimits, actors: list[Actor], wall: str = "demo", now: float = 0.0
) -> list[bool]:
    """Which of the actors' balloons (one each, in order) are allowed."""
    return [action_limits.hit("balloon", actor, wall, now=now) is None for actor in actors]


def test_a_visitor_has_its_own_budget() -> None:
    action_limits = limits(per_visitor=2)
    phone = Actor("phone", "10.0.0.1", SETTLED)
    assert balloons(action_limits, [phone] * 3) == [True, True, False]
    assert balloons(action_limits, [Actor("other", "10.0.0.1", SETTLED)]) == [True]


def test_new_and_cookieless_visitors_of_one_address_share_a_small_budget() -> None:
    action_limits = limits(per_new_address=3)
    fresh = [Actor(f"fresh-{n}", "10.0.0.1", NEW if n % 2 else NO_COOKIE) for n in range(4)]
    assert balloons(action_limits, fresh) == [True, True, True, False]
    assert balloons(action_limits, [Actor("fresh-x", "10.0.0.2", NO_COOKIE)]) == [True], (
        "another address has its own"
    )
    assert balloons(action_limits, [Actor("settled", "10.0.0.1", SETTLED)]) == [True], (
        "a settled visitor is not held by the new ones' budget"
    )


def test_a_visitor_settles_when_its_cookie_is_old_enough() -> None:
    action_limits = limits(per_new_address=1, settle_s=10.0)
    assert balloons(action_limits, [Actor("a", "10.0.0.1", 9.9), Actor("b", "10.0.0.1", 9.9)]) == [
        True,
        False,
    ]
    assert balloons(action_limits, [Actor("b", "10.0.0.1", 10.0)]) == [True]


def test_one_address_has_one_budget_for_all_its_visitors() -> None:
    action_limits = limits(per_address=3)
    room = [Actor(f"phone-{n}", "10.0.0.1", SETTLED) for n in range(4)]
    assert balloons(action_limits, room) == [True, True, True, False]
    assert balloons(action_limits, [Actor("phone-0", "10.0.0.2", SETTLED)]) == [True]


def test_one_wall_has_one_budget_for_everyone() -> None:
    action_limits = limits(per_wall=3)
    everyone = [Actor(f"phone-{n}", f"10.0.0.{n}", SETTLED) for n in range(4)]
    assert balloons(action_limits, everyone) == [True, True, True, False]
    assert balloons(action_limits, everyone[:1], wall="lobby") == [True], "walls are apart"


def test_the_window_slides_for_every_budget() -> None:
    action_limits = limits(per_visitor=1, per_new_address=1, per_address=1, per_wall=1)
    phone = Actor("phone", "10.0.0.1", NO_COOKIE)
    assert action_limits.hit("balloon", phone, "demo", now=0.0) is None
    assert action_limits.hit("balloon", phone, "demo", now=45.0) == pytest.approx(15.0)
    assert action_limits.hit("balloon", phone, "demo", now=60.0) is None


def test_the_longest_wait_is_given_and_a_refused_action_uses_up_no_budget() -> None:
    action_limits = limits(per_visitor=1, per_wall=2)
    first, second = Actor("a", "10.0.0.1", SETTLED), Actor("b", "10.0.0.2", SETTLED)
    assert action_limits.hit("balloon", first, "demo", now=0.0) is None
    assert action_limits.hit("balloon", second, "demo", now=10.0) is None
    # the second visitor's own budget (free at 70) outlasts the wall's (free at 60)
    assert action_limits.hit("balloon", second, "demo", now=20.0) == pytest.approx(50.0)
    third = Actor("c", "10.0.0.3", SETTLED)
    assert action_limits.hit("balloon", third, "demo", now=20.0) == pytest.approx(40.0)
    # the refusals counted nothing: the wall's budget frees when the first balloon leaves
    assert action_limits.hit("balloon", third, "demo", now=60.0) is None


def test_no_limit_of_a_kind_means_none_is_kept() -> None:
    action_limits = limits(per_visitor=1000, per_new_address=None, per_address=None, per_wall=None)
    crowd = [Actor(f"phone-{n}", "10.0.0.1", NO_COOKIE) for n in range(500)]
    assert all(balloons(action_limits, crowd))


def test_kinds_of_action_are_counted_apart() -> None:
    """Scans (the server's policy: no address or wall budget for settled phones) do not
    use up balloons, and balloons do not use up scans."""
    action_limits = limits(per_visitor=1)
    phone = Actor("phone", "10.0.0.1", SETTLED)
    assert balloons(action_limits, [phone]) == [True]
    scans = [action_limits.hit("scan", phone, "demo", now=0.0) is None for _ in range(4)]
    assert scans == [True, True, True, False]
    cookieless = [Actor(f"x-{n}", "10.0.0.9", NO_COOKIE) for n in range(6)]
    assert [action_limits.hit("scan", a, "", now=0.0) is None for a in cookieless] == [True] * 5 + [
        False
    ]
