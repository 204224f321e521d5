"""Cutting values into classes: quantiles, equal intervals, Jenks' natural breaks."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pydantic import ValidationError

from webapp.choropleth.classes import (
    MISSING_FILL,
    Theme,
    class_uppers,
    outline_for,
    spread,
)
from webapp.choropleth.palettes import MAX_CLASSES, MIN_CLASSES, SCHEMES, contrast_ratio


def classes_of(values: list[float], uppers: np.ndarray) -> list[int]:
    return [int(i) for i in np.searchsorted(uppers, values, side="left")]


def test_quantiles_hold_about_as_many_values_each() -> None:
    values = np.sort(np.random.default_rng(3).lognormal(10, 1, 400))
    counts = np.bincount(classes_of(list(values), class_uppers(values, "quantiles", 5)))
    assert len(counts) == 5 and counts.max() - counts.min() <= 1


def test_equal_intervals_are_equally_wide() -> None:
    values = np.array([0.0, 1, 2, 3, 10])
    assert class_uppers(values, "equal", 4).tolist() == [2.5, 5.0, 7.5, 10.0]


def squared_deviations(values: np.ndarray, ends: list[int]) -> float:
    parts = np.split(values, ends[:-1])
    return float(sum(((part - part.mean()) ** 2).sum() for part in parts))


def test_natural_breaks_are_the_best_cut() -> None:
    """Against every possible cut of a small sample: none has less within-class spread."""
    values = np.sort(np.random.default_rng(5).normal(50, 20, 14).round(1))
    uppers = class_uppers(values, "natural", 4)
    ends = [int(np.searchsorted(values, upper, side="right")) for upper in uppers]
    best = min(
        squared_deviations(values, [*cut, len(values)])
        for cut in itertools.combinations(range(1, len(values)), 3)
    )
    assert squared_deviations(values, ends) == pytest.approx(best)


def test_natural_breaks_find_obvious_clusters() -> None:
    values = np.array([1.0, 2, 3, 50, 51, 52, 100, 101])
    assert class_uppers(values, "natural", 3).tolist() == [3.0, 52.0, 101.0]


@pytest.mark.parametrize("method", ["quantiles", "equal", "natural"])
def test_ties_never_straddle_and_few_values_give_few_classes(method: str) -> None:
    values = np.array([5.0] * 20 + [7.0] * 3 + [9.0])
    uppers = class_uppers(values, method, 5)  # type: ignore[arg-type]
    assert uppers.tolist() == [5.0, 7.0, 9.0]
    assert class_uppers(np.array([]), method, 5).size == 0  # type: ignore[arg-type]


def test_spread_keeps_the_ends_of_a_scheme() -> None:
    palette = ("a", "b", "c", "d", "e")
    assert spread(palette, 2) == ("a", "e")
    assert spread(palette, 1) == ("c",)
    assert spread(palette, 5) == palette


def test_every_fill_gets_an_outline_that_stands_out() -> None:
    """WCAG non-text contrast (3:1) between each class's fill and the outline drawn
    inside it, for every scheme, every number of classes, and "no value"."""
    fills = {MISSING_FILL} | {
        c for _, lists in SCHEMES.values() for shades in lists for c in shades
    }
    for fill in fills:
        assert contrast_ratio(outline_for(fill), fill) >= 3, fill


@pytest.mark.parametrize(
    "fields",
    [
        {"attribute": ""},
        {"attribute": "X", "scheme": "Rainbow"},
        {"attribute": "X", "method": "kmeans"},
        {"attribute": "X", "classes": MIN_CLASSES - 1},
        {"attribute": "X", "classes": MAX_CLASSES + 1},
        {"attribute": "X", "colour": "red"},
    ],
)
def test_a_theme_outside_the_offer_is_refused(fields: dict[str, object]) -> None:
    with pytest.raises(ValidationError):
        Theme.model_validate(fields)
