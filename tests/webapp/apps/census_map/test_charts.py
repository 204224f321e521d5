"""The phone page's charts: right numbers, never a value above the reader's class,
well-formed escaped SVG that reads on a phone."""

from __future__ import annotations

import json
import re
import statistics
import tomllib
import xml.etree.ElementTree as ET
from typing import Any

import pytest
from shapely.geometry import box, shape

from webapp.apps.census_map.charts import (
    BACKGROUND,
    INNER,
    MUTED,
    PALETTE,
    TEXT,
    WIDTH,
    ChartStats,
    Spread,
    charts_for,
)
from webapp.apps.census_map.dataset import (
    Attribute,
    Chart,
    DataSet,
    DataSetSettings,
    Part,
    Tract,
    Value,
    county_of,
    tract_label,
)
from webapp.core.settings import CONTENT_DIR

SVG = "{http://www.w3.org/2000/svg}"
SHIPPED = CONTENT_DIR / "census" / "sacramento-2000"


def tract(geoid: str, values: dict[str, Value], x: float = 0) -> Tract:
    return Tract(geoid, geoid, "", box(x, 0, x + 1, 1), values)


def dataset(charts: list[Chart], tracts: list[Tract], **labels: str) -> DataSet:
    """A data set whose attributes are every key the charts use, all in class 1."""
    keys = sorted({k for c in charts for k in c.keys_used()} | {"N"})
    attributes = [Attribute(key=k, label=labels.get(k, k)) for k in keys]
    settings = DataSetSettings(title="t", headline=["N"], attributes=attributes, charts=charts)
    return DataSet(id=1, name="t", settings=settings, tracts=tuple(tracts))


def parts_chart(*parts: Part, title: str = "Ages") -> Chart:
    return Chart(title=title, total="N", parts=list(parts))


def render(data: DataSet, which: int = 0, info_class: int = 1) -> str:
    svgs = charts_for(data, data.tracts[which], info_class, ChartStats())
    assert len(svgs) == 1
    return svgs[0]


def texts(svg: str) -> list[str]:
    return [t.text or "" for t in ET.fromstring(svg).iter(f"{SVG}text")]


def data_keys(svg: str) -> set[str]:
    return {
        key for element in ET.fromstring(svg).iter() for key in element.get("data-key", "").split()
    }


def segment_widths(svg: str) -> dict[str, float]:
    return {
        rect.attrib["data-key"]: float(rect.attrib["width"])
        for rect in ET.fromstring(svg).iter(f"{SVG}rect")
        if "data-key" in rect.attrib
    }


def test_parts_shares_and_the_rest() -> None:
    chart = parts_chart(
        Part(label="Young", keys=["A"]),
        Part(label="Middle", keys=["B1", "B2"]),
        Part(label="Rest"),
    )
    svg = render(dataset([chart], [tract("1", {"N": 200, "A": 60, "B1": 40, "B2": 20})]))

    lines = texts(svg)
    assert "N: 200" in lines
    assert "Young · 60 · 30.0%" in lines
    assert "Middle · 60 · 30.0%" in lines
    assert "Rest · 80 · 40.0%" in lines
    assert not any("overlap" in line for line in lines)
    widths = segment_widths(svg)
    assert widths["A"] == pytest.approx(INNER * 0.3, abs=0.1)
    assert widths["B1 B2"] == pytest.approx(INNER * 0.3, abs=0.1)
    assert widths["N A B1 B2"] == pytest.approx(INNER * 0.4, abs=0.1)  # the rest's inputs


def test_parts_that_overlap_are_shares_of_the_parts_shown() -> None:
    chart = parts_chart(
        Part(label="White", keys=["W"]),
        Part(label="Hispanic", keys=["H"]),
        Part(label="Other"),
    )
    svg = render(dataset([chart], [tract("1", {"N": 100, "W": 90, "H": 30})]))

    lines = texts(svg)
    assert "White · 90 · 75.0%" in lines
    assert "Hispanic · 30 · 25.0%" in lines
    assert "Other · 0 · 0.0%" in lines  # the rest is clamped at 0
    assert any("shares of the parts shown" in line.lower() for line in lines)
    assert sum(segment_widths(svg).values()) == pytest.approx(INNER, abs=0.1)


def test_parts_without_a_rest_leave_the_bar_short_of_the_total() -> None:
    chart = parts_chart(Part(label="A", keys=["A"]), Part(label="B", keys=["B"]))
    svg = render(dataset([chart], [tract("1", {"N": 10, "A": 2, "B": 3})]))

    assert "A · 2 · 20.0%" in texts(svg)
    assert sum(segment_widths(svg).values()) == pytest.approx(INNER * 0.5, abs=0.1)


@pytest.mark.parametrize(
    "values",
    [
        {"N": 100, "A": None, "B": 3},  # a part's value
        {"N": None, "A": 2, "B": 3},  # the total
        {"N": 100, "B": 3},  # a value the file did not have
    ],
)
def test_a_missing_value_shows_not_available_instead_of_bars(values: dict[str, Value]) -> None:
    chart = parts_chart(Part(label="A", keys=["A"]), Part(label="B", keys=["B"]))
    svg = render(dataset([chart], [tract("1", values)]))

    assert "Not available for this tract." in texts(svg)
    assert segment_widths(svg) == {}
    assert not any("·" in line for line in texts(svg))


def test_a_total_of_zero_says_no_people_counted() -> None:
    chart = parts_chart(Part(label="A", keys=["A"]), Part(label="Rest"))
    svg = render(dataset([chart], [tract("1", {"N": 0, "A": 0})]))

    assert "No people counted." in texts(svg)
    assert segment_widths(svg) == {}


@pytest.mark.parametrize(
    "values",
    [[50, 10, 40, 20, 30], [4, 1, 3, 2], [7], [1, 2, 3, 4, 5, 6, 7, 100]],
)
def test_compare_spread_is_range_quartiles_and_median(values: list[float]) -> None:
    tracts = [tract(str(i), {"V": v}, x=i) for i, v in enumerate(values)]
    tracts.append(tract("missing", {"V": None}, x=-2))
    data = dataset([Chart(title="Values", kind="compare", keys=["V"])], tracts)

    spread = ChartStats().spread(data, "V")

    q1, median, q3 = (
        statistics.quantiles(values, n=4, method="inclusive") if len(values) > 1 else values * 3
    )
    assert spread == Spread(min(values), q1, median, q3, max(values))


def test_compare_draws_this_tract_against_all_tracts() -> None:
    values = [100_000, 200_000, 300_000, 400_000, 500_000]
    tracts = [tract(str(i), {"V": v}, x=i) for i, v in enumerate(values)]
    tracts.append(tract("missing", {"V": None}, x=-2))
    chart = Chart(title="Values", kind="compare", keys=["V"])
    attributes = [Attribute(key="V", label="Home value", kind="money")]
    settings = DataSetSettings(title="t", headline=["V"], attributes=attributes, charts=[chart])
    data = DataSet(id=7, name="t", settings=settings, tracts=tuple(tracts))
    stats = ChartStats()

    svg = charts_for(data, tracts[1], 1, stats)[0]

    lines = texts(svg)
    assert "Home value" in lines
    assert "This tract: $200,000" in lines
    assert "Median of all tracts: $300,000" in lines
    ends = [line for line in lines if line.startswith(("lowest", "highest"))]
    assert ends == ["lowest $100,000", "highest $500,000"]
    root = ET.fromstring(svg)
    (dot,) = [c for c in root.iter(f"{SVG}circle") if c.get("class") == "tract"]
    (tick,) = [line for line in root.iter(f"{SVG}line") if line.get("class") == "median"]
    left, right = 16, WIDTH - 16  # the scale inside the margins
    assert float(dot.attrib["cx"]) == pytest.approx(left + (right - left) * 0.25, abs=0.1)
    assert float(tick.attrib["x1"]) == pytest.approx((left + right) / 2, abs=0.1)
    assert data_keys(svg) == {"V"}
    assert stats.spread(data, "V") is stats.spread(data, "V")  # computed once

    missing = charts_for(data, tracts[-1], 1, stats)[0]
    assert "This tract: not available" in texts(missing)
    assert not [c for c in ET.fromstring(missing).iter(f"{SVG}circle") if c.get("class")]


def test_range_ends_that_would_meet_go_on_two_lines() -> None:
    """At 16 units, "lowest $14,400" and "highest $10,000,000" do not fit one line."""
    values = [14_400, 200_000, 10_000_000]
    tracts = [tract(str(i), {"V": v}, x=i) for i, v in enumerate(values)]
    chart = Chart(title="Values", kind="compare", keys=["V"])
    attributes = [Attribute(key="V", label="Home value", kind="money")]
    settings = DataSetSettings(title="t", headline=["V"], attributes=attributes, charts=[chart])
    data = DataSet(id=8, name="t", settings=settings, tracts=tuple(tracts))

    root = ET.fromstring(charts_for(data, tracts[0], 1, ChartStats())[0])

    ends = {t.text: t for t in root.iter(f"{SVG}text") if (t.text or "").startswith(("low", "hi"))}
    low, high = ends["lowest $14,400"], ends["highest $10,000,000"]
    assert float(high.attrib["y"]) > float(low.attrib["y"])  # the next line, not on top
    assert high.attrib["text-anchor"] == "end"


def test_compare_with_no_values_anywhere_is_not_available() -> None:
    data = dataset(
        [Chart(title="Values", kind="compare", keys=["V"])],
        [tract("1", {"V": None}), tract("2", {}, x=2)],
    )
    assert "Not available for any tract." in texts(render(data))


def test_labels_and_keys_are_escaped() -> None:
    nasty = 'a <b>&amp; "c" </svg><script>'
    chart = parts_chart(
        Part(label=nasty, keys=['K"<&>']), Part(label="Rest"), title=f"Title {nasty}"
    )
    data = dataset(
        [chart, Chart(title=nasty, kind="compare", keys=['K"<&>'])],
        [tract("1", {"N": 10, 'K"<&>': 4})],
        **{'K"<&>': nasty, "N": nasty},
    )
    first, second = charts_for(data, data.tracts[0], 1, ChartStats())

    assert "<script" not in first + second
    root = ET.fromstring(first)
    assert root.findtext(f"{SVG}title") == f"Title {nasty}"
    assert f"{nasty}: 10" in " ".join(texts(first))
    assert f"{nasty} · 4 · 40.0%" in " ".join(texts(first))
    assert data_keys(first) == {'K"<&>', "N"}
    assert nasty in " ".join(texts(second))


def test_a_long_label_wraps_onto_more_lines() -> None:
    short = parts_chart(Part(label="A", keys=["A"]), Part(label="Rest"))
    long = parts_chart(Part(label="word " * 12, keys=["A"]), Part(label="Rest"))
    values: dict[str, Value] = {"N": 10, "A": 4}

    one = render(dataset([short], [tract("1", values)]))
    two = render(dataset([long], [tract("1", values)]))

    assert len(texts(two)) > len(texts(one))
    assert view_height(two) > view_height(one)


def view_height(svg: str) -> int:
    return int(ET.fromstring(svg).attrib["viewBox"].split()[3])


def test_colours_have_enough_contrast_against_the_card() -> None:
    assert contrast(TEXT, BACKGROUND) >= 7
    assert contrast(MUTED, BACKGROUND) >= 4.5
    assert all(contrast(colour, BACKGROUND) >= 3 for colour in PALETTE)


def contrast(one: str, other: str) -> float:
    """WCAG 2 contrast ratio."""

    def luminance(colour: str) -> float:
        channels = [int(colour[i : i + 2], 16) / 255 for i in (1, 3, 5)]
        r, g, b = [c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4 for c in channels]
        return 0.2126 * r + 0.7152 * g + 0.0722 * b

    light, dark = sorted([luminance(one), luminance(other)], reverse=True)
    return (light + 0.05) / (dark + 0.05)


@pytest.fixture(scope="module")
def sacramento() -> DataSet:
    features: list[dict[str, Any]] = json.loads(SHIPPED.with_suffix(".geojson").read_text())[
        "features"
    ]
    settings = DataSetSettings.model_validate(
        tomllib.loads(SHIPPED.with_suffix(".toml").read_text())
    )
    tracts = []
    for feature in features:
        properties = dict(feature["properties"])
        geoid = str(properties.pop("GEOID"))
        values = {k: None if v is None else float(v) for k, v in properties.items()}
        tracts.append(
            Tract(geoid, tract_label(geoid), county_of(geoid), shape(feature["geometry"]), values)
        )
    return DataSet(id=1, name="sacramento", settings=settings, tracts=tuple(tracts))


@pytest.mark.parametrize("info_class", [1, 2, 3, 4, 5])
def test_charts_never_show_a_value_above_the_readers_class(
    sacramento: DataSet, info_class: int
) -> None:
    settings = sacramento.settings
    visible = {a.key for a in settings.visible(info_class)}
    expected = [c for c in settings.charts if c.keys_used() <= visible]
    stats = ChartStats()

    for tract_ in sacramento.tracts[:25]:
        svgs = charts_for(sacramento, tract_, info_class, stats)

        titles = [ET.fromstring(svg).findtext(f"{SVG}title") for svg in svgs]
        assert titles == [c.title for c in expected]
        for svg, chart in zip(svgs, expected, strict=True):
            assert data_keys(svg) <= visible
            if "not available" not in svg.lower():
                assert data_keys(svg) == chart.keys_used()
    if info_class == 5:
        assert expected == settings.charts
    if info_class == 1:
        assert [c.kind for c in expected] == ["compare"]


def test_the_shipped_charts_for_the_first_tract(sacramento: DataSet) -> None:
    svgs = charts_for(sacramento, sacramento.tracts[0], 5, ChartStats())

    assert "Under 16 · 1,077 · 19.6%" in texts(svgs[0])
    assert "Other · 62 · 1.1%" in texts(svgs[1])  # 5,501 less the named races


def test_every_shipped_chart_is_well_formed_phone_readable_svg(sacramento: DataSet) -> None:
    stats = ChartStats()
    for tract_ in sacramento.tracts:
        svgs = charts_for(sacramento, tract_, 5, stats)
        page_ids: list[str] = []
        for svg in svgs:
            root = ET.fromstring(svg)  # well-formed XML, as the page inlines it with |safe
            assert root.tag == f"{SVG}svg"
            assert root.attrib["viewBox"].startswith("0 0 320 ")
            assert root.attrib["width"] == "100%"
            assert root.attrib["role"] == "img"
            ids = [e.attrib["id"] for e in root.iter() if "id" in e.attrib]
            assert root.attrib["aria-labelledby"] in ids
            page_ids += ids
            # drawn at least 328 px wide on a 360 px phone: 16 units read at 16 px or more
            assert all(int(t.attrib["font-size"]) >= 16 for t in root.iter(f"{SVG}text"))
            assert not re.search(r"<script|href|url\(|@import|\son\w+=", svg)
        assert len(page_ids) == len(set(page_ids))
