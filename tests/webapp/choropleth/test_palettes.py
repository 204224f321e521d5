"""ColorBrewer's schemes as shipped, and WCAG's contrast ratio."""

from __future__ import annotations

import re

import pytest

from webapp.choropleth.palettes import MAX_CLASSES, MIN_CLASSES, SCHEMES, colours, contrast_ratio


def test_the_contrast_ratio_is_wcags() -> None:
    assert contrast_ratio("#000000", "#ffffff") == pytest.approx(21)
    assert contrast_ratio("#777777", "#ffffff") == pytest.approx(4.48, abs=0.01)
    assert contrast_ratio((255, 0, 0), "#ff0000") == 1


@pytest.mark.parametrize("scheme", sorted(SCHEMES))
def test_every_scheme_has_a_colour_per_class_from_three_to_seven(scheme: str) -> None:
    for count in range(MIN_CLASSES, MAX_CLASSES + 1):
        shades = colours(scheme, count)  # type: ignore[arg-type]
        assert len(shades) == count and len(set(shades)) == count
        assert all(re.fullmatch(r"#[0-9a-f]{6}", colour) for colour in shades)


def test_sequential_schemes_run_light_to_dark() -> None:
    for name, (kind, lists) in SCHEMES.items():
        if kind != "sequential":
            continue
        for shades in lists:
            light = [contrast_ratio(colour, "#000000") for colour in shades]
            assert light == sorted(light, reverse=True), name
