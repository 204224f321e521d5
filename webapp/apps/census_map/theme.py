"""Thematic maps: the tracts coloured by one of the data set's values (a choropleth).

The wall state names the theme (:class:`Theme`: which value, which ColorBrewer scheme,
how the values are cut into classes); :func:`shade` applies it to a data set, and
everything that shows the map reads that one :class:`Shading`: the tiles' fills and
legend, the KML's styles, and each tract page's "where this tract stands".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from webapp.apps.census_map.dataset import Attribute, DataSet, Tract, format_value, large_margin
from webapp.choropleth.classes import (
    METHOD_NAMES,
    Band,
    Floats,
    Theme,
    class_uppers,
    spread,
)
from webapp.choropleth.palettes import MIN_CLASSES, colours


@dataclass(frozen=True)
class Standing:
    """Where one tract's value stands among all tracts with a value."""

    value: float
    band: int  # 0-based, low to high
    bands: int
    rank: int  # 1: the highest value
    below: int  # tracts with a lower value
    of: int  # tracts with a value
    median: float
    margin_bands: tuple[int, int] | None  # the classes value ± margin reaches


@dataclass(frozen=True)
class Shading:
    """A theme applied to one data set."""

    theme: Theme
    attribute: Attribute
    bands: tuple[Band, ...]
    band_of: dict[str, int]  # GEOID -> band, for the tracts with a value
    missing: int  # tracts without a value
    values: Floats  # every value, sorted
    uppers: Floats  # each band's upper bound (the last: the largest value)

    @property
    def title(self) -> str:
        return self.attribute.label

    @property
    def median(self) -> float:
        return float(np.median(self.values))

    def colour(self, geoid: str) -> str | None:
        """The tract's fill (None: it has no value)."""
        band = self.band_of.get(geoid)
        return None if band is None else self.bands[band].colour

    def band_range(self, band: int) -> str:
        b = self.bands[band]
        low, high = (format_value(self.attribute, v) for v in (b.low, b.high))
        return low if low == high else f"{low} to {high}"

    def standing(self, tract: Tract) -> Standing | None:
        """Where ``tract`` stands (None: it has no value for the theme)."""
        value = tract.values.get(self.attribute.key)
        if value is None or tract.geoid not in self.band_of:
            return None
        n = len(self.values)
        below = int(np.searchsorted(self.values, value, side="left"))
        above = n - int(np.searchsorted(self.values, value, side="right"))
        margin = tract.values.get(self.attribute.margin) if self.attribute.margin else None
        reach = None
        if margin is not None and margin >= 0:
            reach = (self._band_at(value - margin), self._band_at(value + margin))
        return Standing(
            value=value,
            band=self.band_of[tract.geoid],
            bands=len(self.bands),
            rank=above + 1,
            below=below,
            of=n,
            median=self.median,
            margin_bands=reach,
        )

    def _band_at(self, value: float) -> int:
        return min(int(np.searchsorted(self.uppers, value, side="left")), len(self.bands) - 1)


def kept_theme(dataset: DataSet | None, theme: Theme | None) -> Theme | None:
    """``theme`` while ``dataset`` has its value; None (the plain map) once the wall
    shows a data set without it."""
    if dataset is None or theme is None:
        return None
    return theme if any(a.key == theme.attribute for a in dataset.settings.attributes) else None


def shade(dataset: DataSet, theme: Theme) -> Shading:
    """Cut the tracts' values of ``theme.attribute`` into classes by ``theme.method``
    and colour them by ``theme.scheme``. Ties never straddle two classes, so a data set
    with few distinct values gets fewer classes than asked."""
    attribute = dataset.settings.attribute(theme.attribute)
    known = [(t.geoid, t.values.get(attribute.key)) for t in dataset.tracts]
    present = [(geoid, value) for geoid, value in known if value is not None]
    values = np.sort(np.array([value for _, value in present], dtype=np.float64))
    uppers = class_uppers(values, theme.method, theme.classes)
    palette = spread(colours(theme.scheme, max(len(uppers), MIN_CLASSES)), len(uppers))
    index = np.searchsorted(uppers, [value for _, value in present], side="left")
    band_of = {geoid: int(i) for (geoid, _), i in zip(present, index, strict=True)}
    bands = []
    for i, upper in enumerate(uppers):
        members = values[(values <= upper) & ((values > uppers[i - 1]) if i else True)]
        if theme.method == "equal" or not len(members):
            low = float(uppers[i - 1]) if i else float(values[0])
            high = float(upper)
        else:
            low, high = float(members[0]), float(members[-1])
        bands.append(Band(low=low, high=high, colour=palette[i], count=len(members)))
    return Shading(
        theme=theme,
        attribute=attribute,
        bands=tuple(bands),
        band_of=band_of,
        missing=len(known) - len(present),
        values=values,
        uppers=uppers,
    )


def in_sentence(label: str) -> str:
    """``label`` inside a sentence: a first word written as an ordinary capitalised word
    ("Median income") starts lower-case; any other keeps its case, so a column's code
    ("ENROLL"), an acronym ("ACS estimate") or a word with capitals inside ("iPhone
    owners", "McDonald") reads as the data set names it."""
    first = label.split(maxsplit=1)[0] if label.strip() else ""
    if first[:1].isupper() and first[1:] == first[1:].lower():
        stripped = label.lstrip()
        return stripped[:1].lower() + stripped[1:]
    return label


def describe(shading: Shading, tract: Tract, info_class: int) -> list[str]:
    """Where the tract stands on the wall's colouring, in words for ``info_class``:
    groups and "more than" for the youngest, classes, ranks and the median from the
    middle classes, the percentile, the method and what the margin of error allows
    for the highest."""
    label = shading.attribute.label
    standing = shading.standing(tract)
    if standing is None:
        return [
            f"This tract has no value for {in_sentence(label)}, so the wall shows it striped grey."
        ]
    group, groups = standing.band + 1, standing.bands
    value = format_value(shading.attribute, standing.value)
    median = format_value(shading.attribute, standing.median)
    if info_class <= 1:
        return [
            f"On the wall this tract is in colour group {group} of {groups}:"
            f" group 1 has the least, group {groups} the most.",
            f"Its {in_sentence(label)} is bigger than in {standing.below}"
            f" of the {standing.of} tracts.",
        ]
    if info_class == 2:
        return [
            f"Colour group {group} of {groups} on the wall (group 1 is the lowest).",
            f"{value}: higher than {standing.below} of {standing.of} tracts.",
            f"The middle tract of the county (the median) has {median}.",
        ]
    sentences = [
        f"Class {group} of {groups}: {shading.band_range(standing.band)}.",
        f"Rank {standing.rank} of {standing.of} (1 is the highest); county median {median}.",
    ]
    if info_class >= 4:
        share = round(100 * standing.below / standing.of)
        sentences.append(f"Higher than {share}% of the tracts with a value.")
    if info_class >= 5:
        sentences.append(f"Classes by {METHOD_NAMES[shading.theme.method]}.")
        margin = tract.values.get(shading.attribute.margin) if shading.attribute.margin else None
        if standing.margin_bands is not None and margin is not None:
            first, last = (b + 1 for b in standing.margin_bands)
            plus_minus = format_value(shading.attribute, margin)
            where = f"class {first}" if first == last else f"any of classes {first} to {last}"
            care = " (uncertain)" if large_margin(standing.value, margin) else ""
            sentences.append(
                f"Within its margin of error (± {plus_minus}) it lies in {where}{care}."
            )
    return sentences
