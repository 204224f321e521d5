"""Colour schemes for thematic maps: ColorBrewer's, those its authors mark safe for
colour-blind readers, for three to seven classes.

This product includes colour specifications and designs developed by Cynthia Brewer
(http://colorbrewer.org/), under the Apache License 2.0.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

SchemeName = Literal[
    "YlOrRd",
    "YlGnBu",
    "OrRd",
    "PuBuGn",
    "Blues",
    "Greens",
    "Purples",
    "RdBu",
    "PuOr",
    "BrBG",
    "PiYG",
    "PRGn",
]
Kind = Literal["sequential", "diverging"]
MIN_CLASSES = 3
MAX_CLASSES = 7

# scheme -> (kind, colours for 3, 4, 5, 6 and 7 classes), lightest (sequential) or the
# low end (diverging) first.
SCHEMES: dict[SchemeName, tuple[Kind, tuple[tuple[str, ...], ...]]] = {
    "YlOrRd": (
        "sequential",
        (
            ("#ffeda0", "#feb24c", "#f03b20"),
            ("#ffffb2", "#fecc5c", "#fd8d3c", "#e31a1c"),
            ("#ffffb2", "#fecc5c", "#fd8d3c", "#f03b20", "#bd0026"),
            ("#ffffb2", "#fed976", "#feb24c", "#fd8d3c", "#f03b20", "#bd0026"),
            ("#ffffb2", "#fed976", "#feb24c", "#fd8d3c", "#fc4e2a", "#e31a1c", "#b10026"),
        ),
    ),
    "YlGnBu": (
        "sequential",
        (
            ("#edf8b1", "#7fcdbb", "#2c7fb8"),
            ("#ffffcc", "#a1dab4", "#41b6c4", "#225ea8"),
            ("#ffffcc", "#a1dab4", "#41b6c4", "#2c7fb8", "#253494"),
            ("#ffffcc", "#c7e9b4", "#7fcdbb", "#41b6c4", "#2c7fb8", "#253494"),
            ("#ffffcc", "#c7e9b4", "#7fcdbb", "#41b6c4", "#1d91c0", "#225ea8", "#0c2c84"),
        ),
    ),
    "OrRd": (
        "sequential",
        (
            ("#fee8c8", "#fdbb84", "#e34a33"),
            ("#fef0d9", "#fdcc8a", "#fc8d59", "#d7301f"),
            ("#fef0d9", "#fdcc8a", "#fc8d59", "#e34a33", "#b30000"),
            ("#fef0d9", "#fdd49e", "#fdbb84", "#fc8d59", "#e34a33", "#b30000"),
            ("#fef0d9", "#fdd49e", "#fdbb84", "#fc8d59", "#ef6548", "#d7301f", "#990000"),
        ),
    ),
    "PuBuGn": (
        "sequential",
        (
            ("#ece2f0", "#a6bddb", "#1c9099"),
            ("#f6eff7", "#bdc9e1", "#67a9cf", "#02818a"),
            ("#f6eff7", "#bdc9e1", "#67a9cf", "#1c9099", "#016c59"),
            ("#f6eff7", "#d0d1e6", "#a6bddb", "#67a9cf", "#1c9099", "#016c59"),
            ("#f6eff7", "#d0d1e6", "#a6bddb", "#67a9cf", "#3690c0", "#02818a", "#016450"),
        ),
    ),
    "Blues": (
        "sequential",
        (
            ("#deebf7", "#9ecae1", "#3182bd"),
            ("#eff3ff", "#bdd7e7", "#6baed6", "#2171b5"),
            ("#eff3ff", "#bdd7e7", "#6baed6", "#3182bd", "#08519c"),
            ("#eff3ff", "#c6dbef", "#9ecae1", "#6baed6", "#3182bd", "#08519c"),
            ("#eff3ff", "#c6dbef", "#9ecae1", "#6baed6", "#4292c6", "#2171b5", "#084594"),
        ),
    ),
    "Greens": (
        "sequential",
        (
            ("#e5f5e0", "#a1d99b", "#31a354"),
            ("#edf8e9", "#bae4b3", "#74c476", "#238b45"),
            ("#edf8e9", "#bae4b3", "#74c476", "#31a354", "#006d2c"),
            ("#edf8e9", "#c7e9c0", "#a1d99b", "#74c476", "#31a354", "#006d2c"),
            ("#edf8e9", "#c7e9c0", "#a1d99b", "#74c476", "#41ab5d", "#238b45", "#005a32"),
        ),
    ),
    "Purples": (
        "sequential",
        (
            ("#efedf5", "#bcbddc", "#756bb1"),
            ("#f2f0f7", "#cbc9e2", "#9e9ac8", "#6a51a3"),
            ("#f2f0f7", "#cbc9e2", "#9e9ac8", "#756bb1", "#54278f"),
            ("#f2f0f7", "#dadaeb", "#bcbddc", "#9e9ac8", "#756bb1", "#54278f"),
            ("#f2f0f7", "#dadaeb", "#bcbddc", "#9e9ac8", "#807dba", "#6a51a3", "#4a1486"),
        ),
    ),
    "RdBu": (
        "diverging",
        (
            ("#ef8a62", "#f7f7f7", "#67a9cf"),
            ("#ca0020", "#f4a582", "#92c5de", "#0571b0"),
            ("#ca0020", "#f4a582", "#f7f7f7", "#92c5de", "#0571b0"),
            ("#b2182b", "#ef8a62", "#fddbc7", "#d1e5f0", "#67a9cf", "#2166ac"),
            ("#b2182b", "#ef8a62", "#fddbc7", "#f7f7f7", "#d1e5f0", "#67a9cf", "#2166ac"),
        ),
    ),
    "PuOr": (
        "diverging",
        (
            ("#f1a340", "#f7f7f7", "#998ec3"),
            ("#e66101", "#fdb863", "#b2abd2", "#5e3c99"),
            ("#e66101", "#fdb863", "#f7f7f7", "#b2abd2", "#5e3c99"),
            ("#b35806", "#f1a340", "#fee0b6", "#d8daeb", "#998ec3", "#542788"),
            ("#b35806", "#f1a340", "#fee0b6", "#f7f7f7", "#d8daeb", "#998ec3", "#542788"),
        ),
    ),
    "BrBG": (
        "diverging",
        (
            ("#d8b365", "#f5f5f5", "#5ab4ac"),
            ("#a6611a", "#dfc27d", "#80cdc1", "#018571"),
            ("#a6611a", "#dfc27d", "#f5f5f5", "#80cdc1", "#018571"),
            ("#8c510a", "#d8b365", "#f6e8c3", "#c7eae5", "#5ab4ac", "#01665e"),
            ("#8c510a", "#d8b365", "#f6e8c3", "#f5f5f5", "#c7eae5", "#5ab4ac", "#01665e"),
        ),
    ),
    "PiYG": (
        "diverging",
        (
            ("#e9a3c9", "#f7f7f7", "#a1d76a"),
            ("#d01c8b", "#f1b6da", "#b8e186", "#4dac26"),
            ("#d01c8b", "#f1b6da", "#f7f7f7", "#b8e186", "#4dac26"),
            ("#c51b7d", "#e9a3c9", "#fde0ef", "#e6f5d0", "#a1d76a", "#4d9221"),
            ("#c51b7d", "#e9a3c9", "#fde0ef", "#f7f7f7", "#e6f5d0", "#a1d76a", "#4d9221"),
        ),
    ),
    "PRGn": (
        "diverging",
        (
            ("#af8dc3", "#f7f7f7", "#7fbf7b"),
            ("#7b3294", "#c2a5cf", "#a6dba0", "#008837"),
            ("#7b3294", "#c2a5cf", "#f7f7f7", "#a6dba0", "#008837"),
            ("#762a83", "#af8dc3", "#e7d4e8", "#d9f0d3", "#7fbf7b", "#1b7837"),
            ("#762a83", "#af8dc3", "#e7d4e8", "#f7f7f7", "#d9f0d3", "#7fbf7b", "#1b7837"),
        ),
    ),
}


def colours(scheme: SchemeName, classes: int) -> tuple[str, ...]:
    """The scheme's colours for ``classes`` classes, low to high."""
    return SCHEMES[scheme][1][classes - MIN_CLASSES]


def kind(scheme: SchemeName) -> Kind:
    return SCHEMES[scheme][0]


def contrast_ratio(a: str | Sequence[float], b: str | Sequence[float]) -> float:
    """WCAG 2's contrast ratio of two sRGB colours (``#rrggbb`` or 0-255 triples):
    from 1 (the same) to 21 (black on white); non-text parts need 3."""

    def luminance(colour: str | Sequence[float]) -> float:
        rgb = (
            [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
            if isinstance(colour, str)
            else list(colour)
        )
        linear = [
            c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4
            for c in (v / 255 for v in rgb)
        ]
        return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]

    dark, light = sorted((luminance(a), luminance(b)))
    return (light + 0.05) / (dark + 0.05)
