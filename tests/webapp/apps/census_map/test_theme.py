"""The census map coloured by a value: classes over the tracts, and where one tract
stands, in words for each information class."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.webapp.apps.census_map.conftest import grid_dataset, sacramento
from webapp.apps.census_map.dataset import Attribute, DataSet
from webapp.apps.census_map.theme import describe, in_sentence, kept_theme, shade
from webapp.choropleth.classes import Theme


def with_values(dataset: DataSet, values: dict[str, dict[str, float | None]]) -> DataSet:
    tracts = tuple(
        dataclasses.replace(t, values={**t.values, **values.get(t.geoid, {})})
        for t in dataset.tracts
    )
    return DataSet(id=dataset.id, name=dataset.name, settings=dataset.settings, tracts=tracts)


@pytest.mark.parametrize("method", ["quantiles", "equal", "natural"])
def test_every_tract_with_a_value_is_in_exactly_one_class(method: str) -> None:
    dataset = sacramento()
    shading = shade(dataset, Theme(attribute="HSG_VAL", method=method, classes=6))  # type: ignore[arg-type]
    assert len(shading.bands) == 6
    assert sum(b.count for b in shading.bands) + shading.missing == len(dataset.tracts)
    assert shading.missing == 3, "three tracts have no owner-occupied homes"
    for tract in dataset.tracts:
        value = tract.values["HSG_VAL"]
        band = shading.band_of.get(tract.geoid)
        if value is None:
            assert band is None and shading.colour(tract.geoid) is None
        else:
            assert band is not None
            assert shading.bands[band].low <= value <= shading.bands[band].high
    highs = [b.high for b in shading.bands]
    assert highs == sorted(highs)


def test_a_diverging_scheme_puts_its_neutral_colour_in_the_middle() -> None:
    shading = shade(sacramento(), Theme(attribute="HH_INC", scheme="RdBu", classes=5))
    assert shading.bands[2].colour == "#f7f7f7"


def test_the_standing_of_a_tract_ranks_it_among_all() -> None:
    dataset = grid_dataset(4, 3)  # POP 1000, 1001, ... by tract number
    shading = shade(dataset, Theme(attribute="POP", classes=3))
    top = shading.standing(dataset.tracts[-1])
    bottom = shading.standing(dataset.tracts[0])
    assert top is not None and bottom is not None
    assert (top.rank, top.below, top.of, top.band) == (1, 11, 12, 2)
    assert (bottom.rank, bottom.below, bottom.band) == (12, 0, 0)
    assert top.median == pytest.approx(np.median([t.values["POP"] for t in dataset.tracts]))


def test_the_words_grow_with_the_information_class() -> None:
    dataset = sacramento()
    shading = shade(dataset, Theme(attribute="HH_INC"))
    tract = dataset.tract("06061022001")
    assert tract is not None
    child = " ".join(describe(shading, tract, 1))
    assert "colour group" in child and "bigger than in" in child
    assert "Rank" not in child and "county" not in child
    student = " ".join(describe(shading, tract, 2))
    assert "(the median)" in student and "Rank" not in student
    expert = " ".join(describe(shading, tract, 3))
    assert "Class " in expert and "Rank " in expert and "county median $" in expert
    assert "%" not in expert
    researcher = " ".join(describe(shading, tract, 5))
    assert "Higher than" in researcher and "Classes by quantiles" in researcher


def test_a_label_keeps_its_case_inside_a_sentence() -> None:
    """Issue 31: a column named ENROLL read "Its eNROLL is bigger than..."."""
    base = grid_dataset(4, 3)
    settings = base.settings.model_copy(
        update={"attributes": [Attribute(key="POP", label="ENROLL"), *base.settings.attributes[1:]]}
    )
    dataset = DataSet(id=1, name="grid", settings=settings, tracts=base.tracts)
    shading = shade(dataset, Theme(attribute="POP", classes=3))
    words = " ".join(describe(shading, dataset.tracts[5], 1))
    assert "Its ENROLL is bigger than in" in words
    assert in_sentence("Median household income") == "median household income"
    assert in_sentence("ACS estimate of people") == "ACS estimate of people"
    assert in_sentence("McDonald's outlets") == "McDonald's outlets"
    assert in_sentence("iPhone owners") == "iPhone owners"


def test_a_researcher_reads_which_classes_the_margin_of_error_reaches() -> None:
    settings = grid_dataset().settings
    attributes = [
        Attribute(key="POP", label="Population", margin="POP_MOE"),
        *settings.attributes[1:],
    ]
    base = grid_dataset(4, 3)
    dataset = with_values(
        DataSet(
            id=1,
            name="grid",
            settings=settings.model_copy(update={"attributes": attributes}),
            tracts=base.tracts,
        ),
        {t.geoid: {"POP_MOE": 250.0} for t in base.tracts},
    )
    shading = shade(dataset, Theme(attribute="POP", classes=3))
    middle = dataset.tracts[5]  # 1005, in the middle class; ± 250 reaches both others
    text = describe(shading, middle, 5)[-1]
    assert "± 250" in text and "classes 1 to 3" in text and "(uncertain)" in text
    assert not any("margin" in sentence for sentence in describe(shading, middle, 4))


def test_a_tract_without_a_value_is_said_to_be_striped() -> None:
    dataset = sacramento()
    shading = shade(dataset, Theme(attribute="HSG_VAL"))
    tract = next(t for t in dataset.tracts if t.values["HSG_VAL"] is None)
    assert shading.standing(tract) is None
    assert "striped grey" in describe(shading, tract, 3)[0]


def test_a_theme_stays_only_while_the_data_set_has_its_value() -> None:
    theme = Theme(attribute="HH_INC")
    assert kept_theme(sacramento(), theme) == theme
    assert kept_theme(grid_dataset(), theme) is None
    assert kept_theme(None, theme) is None and kept_theme(sacramento(), None) is None
