"""A value cut into classes, and the colours they are drawn in.

:class:`Theme` is what a wall's state says a map is coloured by; :func:`class_uppers`
cuts values into classes the three ways cartographers use most (quantiles, equal
intervals, Jenks' natural breaks), each class drawn in a ColorBrewer colour with an
outline that stands out from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field

from webapp.choropleth.palettes import MAX_CLASSES, MIN_CLASSES, SchemeName, contrast_ratio

Method = Literal["quantiles", "equal", "natural"]
METHOD_NAMES: dict[Method, str] = {
    "quantiles": "quantiles",
    "equal": "equal intervals",
    "natural": "natural breaks",
}
# Tracts without a value are striped in these (their legend row too), never coloured
# as if they had one.
MISSING_FILL = "#7a7a7a"
MISSING_STRIPE = "#b8b8b8"
DARK_LINE = "#0d1b2a"  # the map's background
LIGHT_LINE = "#e6e6e6"  # not white: codes and the legend's text are the lightest things drawn
Floats = npt.NDArray[np.float64]


class Theme(BaseModel):
    """What the wall's tracts are coloured by: one value of the data set, a colour
    scheme and how the values are cut into classes."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    attribute: str = Field(min_length=1, max_length=64)
    scheme: SchemeName = "YlOrRd"
    method: Method = "quantiles"
    classes: int = Field(default=5, ge=MIN_CLASSES, le=MAX_CLASSES)


@dataclass(frozen=True)
class Band:
    """One class of the map: the values it holds, its colour, how many tracts."""

    low: float
    high: float
    colour: str
    count: int

    @property
    def line(self) -> str:
        """The outline drawn inside a tract of this colour: whichever of dark and light
        stands out more from it (WCAG non-text contrast, at least 3:1 either way)."""
        return outline_for(self.colour)


def class_uppers(values: Floats, method: Method, classes: int) -> Floats:
    """Each class's upper bound (inclusive) for sorted ``values``: quantiles, equal
    intervals between the smallest and largest, or Fisher-Jenks natural breaks (the
    cut that makes the classes' summed squared deviations least)."""
    if not len(values):
        return np.array([], dtype=np.float64)
    distinct = np.unique(values)
    if len(distinct) <= classes:
        return distinct
    if method == "equal":
        low, high = float(values[0]), float(values[-1])
        return np.array([low + (high - low) * i / classes for i in range(1, classes + 1)])
    if method == "quantiles":
        cuts = np.quantile(
            values, [i / classes for i in range(1, classes + 1)], method="inverted_cdf"
        )
        return np.unique(cuts)
    return np.unique(values[np.array(_jenks_ends(values, classes)) - 1])


def _jenks_ends(values: Floats, classes: int) -> list[int]:
    """Where each class of the optimal cut of ``values`` (sorted) ends (exclusive
    indices), by Fisher's dynamic programme on prefix sums: O(classes · n²) numpy."""
    n = len(values)
    sums = np.concatenate(([0.0], np.cumsum(values)))
    squares = np.concatenate(([0.0], np.cumsum(values * values)))

    def spread_of(starts: npt.NDArray[np.int64], end: int) -> Floats:
        count = end - starts
        total = sums[end] - sums[starts]
        result: Floats = squares[end] - squares[starts] - total * total / count
        return result

    cost = np.full((classes + 1, n + 1), math.inf)
    start_of = np.zeros((classes + 1, n + 1), dtype=np.int64)
    cost[1, 1:] = [spread_of(np.array([0]), end)[0] for end in range(1, n + 1)]
    for k in range(2, classes + 1):
        for end in range(k, n + 1):
            starts = np.arange(k - 1, end)
            candidates = cost[k - 1, starts] + spread_of(starts, end)
            best = int(np.argmin(candidates))
            cost[k, end] = candidates[best]
            start_of[k, end] = starts[best]
    ends, end = [], n
    for k in range(classes, 0, -1):
        ends.append(end)
        end = int(start_of[k, end])
    return ends[::-1]


def spread(palette: tuple[str, ...], count: int) -> tuple[str, ...]:
    """``count`` colours from ``palette`` as far apart as it allows (all of it when
    ``count`` is its length)."""
    if count >= len(palette):
        return palette
    if count == 1:
        return (palette[len(palette) // 2],)
    step = (len(palette) - 1) / (count - 1)
    return tuple(palette[round(i * step)] for i in range(count))


def outline_for(fill: str) -> str:
    """The outline colour that stands out more from ``fill``."""
    return max((DARK_LINE, LIGHT_LINE), key=lambda line: contrast_ratio(line, fill))
