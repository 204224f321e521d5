"""The memory benchmark's arithmetic: the soak's trend and its limit, and the cost per
tile or phone (the runs themselves are ``make bench``)."""

from __future__ import annotations

import pytest

from benchmarks.memory import bounded, growth_limit_mb_per_min, per_item_kb, trend


def test_a_trend_is_the_least_squares_slope_with_its_standard_error() -> None:
    assert trend([(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]) == (pytest.approx(2.0), 0.0)
    slope, error = trend([(0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (3.0, 1.0)])
    assert slope == pytest.approx(0.2)
    assert error == pytest.approx(0.2828, abs=1e-4)
    assert trend([(0.0, 1.0), (2.0, 2.0)]) == (0.5, 0.0)  # no error from two points
    with pytest.raises(ValueError):
        trend([(0.0, 1.0)])


def test_the_growth_limit_is_a_tenth_of_a_kilobyte_per_phone_that_came() -> None:
    assert growth_limit_mb_per_min(10.0) == pytest.approx(0.1 * 600 / 1024)


def test_the_cost_of_an_item_is_its_share_of_what_memory_grew() -> None:
    before = {"rss": 1000, "anon": 800, "file": 200, "peak": 1000}
    after = {"rss": 1300, "anon": 1050, "file": 250, "peak": 1400}
    assert per_item_kb(before, after, 100) == {"rss": 3.0, "anon": 2.5}


def test_growth_is_told_only_beyond_the_limit_and_the_noise() -> None:
    assert bounded(0.05, 0.0, limit=0.06)
    assert not bounded(0.10, 0.01, limit=0.06)
    assert bounded(0.10, 0.03, limit=0.06), "within twice its standard error"
