"""Data set rules: tract numbers, groups, settings, and what each class may read."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from tests.webapp.apps.census_map.conftest import grid_dataset
from webapp.apps.census_map.dataset import (
    Attribute,
    DataSet,
    DataSetSettings,
    Grouping,
    default_settings,
    similar_ranges,
    tract_label,
)


@pytest.mark.parametrize(
    ("geoid", "label"),
    [("06067001101", "11.01"), ("06067002200", "22"), ("06061022001", "220.01"), ("A7", "A7")],
)
def test_tract_numbers_as_people_write_them(geoid: str, label: str) -> None:
    assert tract_label(geoid) == label


def test_the_shipped_data_has_ten_number_groups_of_similar_size(shipped: DataSet) -> None:
    sizes = [len(g.geoids) for g in shipped.groups]
    assert len(shipped.groups) == 10
    assert sum(sizes) == len(shipped.tracts) == 403
    assert max(sizes) <= 2 * min(sizes)
    assert shipped.groups[0].name.startswith("0001-")
    every = [g for group in shipped.groups for g in group.geoids]
    assert len(every) == len(set(every)), "a tract is in exactly one group"


def test_groups_by_county_name_each_county(shipped: DataSet) -> None:
    settings = shipped.settings.model_copy(update={"groups": Grouping(by="county")})
    by_county = DataSet(id=2, name="c", settings=settings, tracts=shipped.tracts)
    assert [g.name for g in by_county.groups] == ["El Dorado", "Placer", "Sacramento", "Yolo"]
    assert sum(len(g.geoids) for g in by_county.groups) == 403


def test_given_ranges_and_the_tracts_they_leave_out() -> None:
    data = grid_dataset()
    settings = data.settings.model_copy(update={"groups": Grouping(ranges=[(1, 4), (5, 8)])})
    grouped = DataSet(id=3, name="g", settings=settings, tracts=data.tracts)
    assert [(g.name, len(g.geoids)) for g in grouped.groups] == [
        ("0001-0004", 4),
        ("0005-0008", 4),
        ("Other tracts", 4),
    ]


@given(
    st.lists(st.integers(min_value=1, max_value=9999), min_size=1, max_size=400), st.integers(1, 10)
)
def test_similar_ranges_cover_every_number_in_order(numbers: list[int], count: int) -> None:
    ranges = similar_ranges(numbers, count)
    assert 1 <= len(ranges) <= count
    assert all(low <= high for low, high in ranges)
    assert all(a[1] < b[0] for a, b in itertools.pairwise(ranges))
    assert all(any(low <= n <= high for low, high in ranges) for n in numbers)


def test_headline_values_must_be_for_everyone() -> None:
    with pytest.raises(ValidationError, match="info_class 1"):
        DataSetSettings(
            title="t",
            headline=["A"],
            attributes=[Attribute(key="A", label="A", info_class=2)],
        )


def test_settings_naming_unknown_attributes_are_refused() -> None:
    with pytest.raises(ValidationError, match="unknown attributes named: B"):
        DataSetSettings(title="t", headline=["B"], attributes=[Attribute(key="A", label="A")])


@pytest.mark.parametrize("info_class", [1, 2, 3, 4, 5])
def test_each_class_reads_exactly_its_values(shipped: DataSet, info_class: int) -> None:
    tract = shipped.tracts[0]
    labels = [f.label for f in shipped.facts(tract, info_class)]
    allowed = [a.label for a in shipped.settings.attributes if a.info_class <= info_class]
    assert sorted(labels) == sorted(allowed)
    assert labels[:4] == [label for label, _ in shipped.headline(tract)]
    if info_class == 5:
        assert len(labels) == 27, "class 5 reads every attribute"


def test_values_are_written_for_reading(shipped: DataSet) -> None:
    assert shipped.headline(shipped.tracts[0]) == [
        ("Total population", "5,501"),
        ("Population 65 and over", "518"),
        ("Median household income (1999)", "$52,941"),
        ("Median housing value", "$225,900"),
    ]
    assert shipped.tract_title(shipped.tracts[0]) == "Tract 220.01, Placer"


def test_the_shipped_labels_are_words_not_column_codes(shipped: DataSet) -> None:
    labels = [f.label for f in shipped.facts(shipped.tracts[0], 5)]
    codes = [a.key for a in shipped.settings.attributes]
    assert not [label for label in labels if any(code in label for code in codes)]
    assert "Employed civilians in production occupations" in labels


def test_default_settings_spread_the_columns_over_the_classes() -> None:
    settings = default_settings("Maricopa", [f"C{i}" for i in range(12)])
    assert settings.headline == ["C0", "C1", "C2", "C3"]
    classes = [a.info_class for a in settings.attributes]
    assert classes[:4] == [1, 1, 1, 1] and classes == sorted(classes) and classes[-1] == 5
