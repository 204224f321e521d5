"""The census map as KML: schema-valid, and saying what the wall shows."""

from __future__ import annotations

import io
import re
import zipfile
from pathlib import Path

import pytest
import simplekml
from lxml import etree
from shapely import MultiPolygon, Point, Polygon, box

from tests.webapp.apps.census_map.conftest import sacramento as shipped_dataset
from tests.webapp.apps.census_map.kml_schema import assert_valid_kml
from webapp.apps.census_map.dataset import (
    Attribute,
    DataSet,
    DataSetSettings,
    Grouping,
    Tract,
    Value,
    county_of,
    tract_label,
)
from webapp.apps.census_map.kml import (
    census_kml,
    census_kmz,
    label_point,
    network_link_kml,
    valid_kml,
)

CENSUS = Path(__file__).parents[4] / "content" / "census"
NS = {"k": "http://www.opengis.net/kml/2.2", "gx": "http://www.google.com/kml/ext/2.2"}
NONE: frozenset[str] = frozenset()

# Tract outlines in longitude/latitude: one with a hole, one in two parts, a triangle.
HOLED = Polygon(
    [(-121.50, 38.50), (-121.49, 38.50), (-121.49, 38.51), (-121.50, 38.51)],
    [[(-121.496, 38.504), (-121.494, 38.504), (-121.494, 38.506), (-121.496, 38.506)]],
)
SPLIT = MultiPolygon([box(-121.48, 38.50, -121.479, 38.501), box(-121.47, 38.50, -121.46, 38.51)])
PLAIN = Polygon([(-121.45, 38.50), (-121.44, 38.50), (-121.445, 38.51)])


def make_settings() -> DataSetSettings:
    return DataSetSettings(
        title="Test <tracts>",
        source="Made up & small",
        headline=["POP", "OLD", "INC", "DENS"],
        attributes=[
            Attribute(key="POP", label="People"),
            Attribute(key="OLD", label="Aged <65> & over"),
            Attribute(key="INC", label="Income", kind="money"),
            Attribute(key="DENS", label="Density", kind="number"),
            Attribute(key="SECRET", label="Only for class 5", info_class=5),
        ],
        groups=Grouping(by="county"),
        counties={"06001": "A <&> B", "06002": "Plain"},
    )


def make_tract(geoid: str, outline: Polygon | MultiPolygon, population: float) -> Tract:
    values: dict[str, Value] = {
        "POP": population,
        "OLD": 12.0,
        "INC": 51234.0,
        "DENS": 2.5,
        "SECRET": 7.0,
    }
    return Tract(geoid, tract_label(geoid), county_of(geoid), outline, values)


def small_dataset() -> DataSet:
    # Not in GEOID order: the KML must keep the data set's order within a group.
    tracts = (
        make_tract("06001000200", SPLIT, 2000),
        make_tract("06001000101", HOLED, 1101),
        make_tract("06002000300", PLAIN, 3000),
    )
    return DataSet(id=7, name="t", settings=make_settings(), tracts=tracts)


def parse(text: str | bytes) -> etree._Element:
    data = text.encode() if isinstance(text, str) else text
    return etree.fromstring(data)


def placemarks(root: etree._Element) -> dict[str, etree._Element]:
    return {p.get("id"): p for p in root.iterfind(".//k:Placemark", NS)}


@pytest.fixture(scope="module")
def sacramento() -> DataSet:
    return shipped_dataset()


# --- the schema check itself -------------------------------------------------------

VALID = """<kml xmlns="http://www.opengis.net/kml/2.2"><Document id="d">{}</Document></kml>"""


def test_the_schema_check_accepts_valid_kml() -> None:
    assert_valid_kml(VALID.format("<name>x</name>"))
    assert_valid_kml(VALID.format("<name>x</name>").encode())


CONTROL = "<NetworkLinkControl><minRefreshPeriod>5</minRefreshPeriod></NetworkLinkControl>"


@pytest.mark.parametrize(
    ("text", "error"),
    [
        pytest.param(
            VALID.replace('id="d"', 'id="1"').format(""),
            "'1' is not a valid value of the atomic type 'xs:ID'",
            id="id-starts-with-digit",
        ),
        pytest.param(
            VALID.format("").replace("</kml>", f"{CONTROL}</kml>"),
            "NetworkLinkControl': This element is not expected",
            id="network-link-control-after-document",
        ),
        pytest.param(
            VALID.format("<colour>red</colour>"),
            "colour': This element is not expected",
            id="unknown-element",
        ),
        pytest.param(
            VALID.format("<Style/><name>x</name>"),
            "name': This element is not expected",
            id="style-before-name",
        ),
        pytest.param(
            VALID.format('<Folder id="d"/>'),
            "'d' is not a valid value of the atomic type 'xs:ID'",
            id="duplicate-id",
        ),
    ],
)
def test_the_schema_check_rejects_invalid_kml(text: str, error: str) -> None:
    with pytest.raises(AssertionError, match=re.escape(error)):
        assert_valid_kml(text)


# --- valid_kml: what simplekml gets wrong ------------------------------------------


def test_valid_kml_fixes_what_simplekml_gets_wrong() -> None:
    kml = simplekml.Kml(name="doc", description="about")
    kml.networklinkcontrol.minrefreshperiod = 5
    style = simplekml.Style()
    style.polystyle.color = "9919457a"
    kml.document.style = style
    point = kml.newpoint(name="p", coords=[(1.0, 2.0)])
    point.style = style
    raw = kml.kml()
    for error in ["xs:ID", "NetworkLinkControl': This", "name': This"]:
        with pytest.raises(AssertionError, match=error):
            assert_valid_kml(raw)

    fixed = valid_kml(raw)

    assert_valid_kml(fixed)
    root = parse(fixed)
    assert etree.QName(root[0]).localname == "NetworkLinkControl"
    ids = [element.get("id") for element in root.iter() if element.get("id") is not None]
    assert ids and all(re.fullmatch(r"[a-z]+-\d+", i) for i in ids)
    style_id = root.find(".//k:Style", NS).get("id")
    urls = [url.text for url in root.iterfind(".//k:styleUrl", NS)]
    assert urls and set(urls) == {f"#{style_id}"}


def test_valid_kml_puts_a_features_children_in_schema_order() -> None:
    kml = simplekml.Kml()
    point = kml.newpoint(name="p", description="d", coords=[(1.0, 2.0)])
    point.snippet.content = "short"
    point.region.latlonaltbox.north = 1
    point.style.labelstyle.scale = 2
    with pytest.raises(AssertionError, match="Snippet': This"):
        assert_valid_kml(kml.kml())

    fixed = valid_kml(kml.kml())

    assert_valid_kml(fixed)
    placemark = parse(fixed).find(".//k:Placemark", NS)
    assert [etree.QName(child).localname for child in placemark] == [
        *("name", "Snippet", "description", "styleUrl", "Region", "Point")
    ]


def test_valid_kml_uses_the_ids_it_is_given_and_styles_follow() -> None:
    kml = simplekml.Kml()
    style = simplekml.Style()
    point = kml.newpoint(name="p", coords=[(1.0, 2.0)])
    point.style = style

    fixed = valid_kml(kml.kml(format=False), {style.id: "shared", point.placemark.id: "here"})

    assert_valid_kml(fixed)
    root = parse(fixed)
    assert root.find(".//k:Style", NS).get("id") == "shared"
    assert root.find(".//k:Placemark", NS).get("id") == "here"
    assert root.findtext(".//k:styleUrl", namespaces=NS) == "#shared"


def test_valid_kml_gives_each_hole_its_own_boundary() -> None:
    kml = simplekml.Kml()
    holes = [[(0.1, 0.1), (0.2, 0.1), (0.2, 0.2), (0.1, 0.1)], [(0.5, 0.5), (0.6, 0.5), (0.5, 0.6)]]
    kml.newpolygon(outerboundaryis=[(0, 0), (1, 0), (1, 1), (0, 0)], innerboundaryis=holes)
    with pytest.raises(AssertionError, match="LinearRing"):
        assert_valid_kml(kml.kml())

    fixed = valid_kml(kml.kml())

    assert_valid_kml(fixed)
    boundaries = parse(fixed).findall(".//k:Polygon/k:innerBoundaryIs", NS)
    assert [len(boundary) for boundary in boundaries] == [1, 1]


# --- census_kml ---------------------------------------------------------------------


def test_census_kml_is_valid_with_a_folder_per_group_and_a_placemark_per_tract() -> None:
    dataset = small_dataset()
    text = census_kml(dataset, hidden=NONE, open_balloons=NONE)

    assert_valid_kml(text)
    folders = parse(text).findall("k:Document/k:Folder", NS)
    assert [f.findtext("k:name", namespaces=NS) for f in folders] == ["A <&> B", "Plain"]
    ids = [f.get("id") for f in folders]
    assert ids == ["group-tracts-county-06001", "group-tracts-county-06002"]
    assert [
        [p.findtext("k:name", namespaces=NS) for p in f.iterfind("k:Placemark", NS)]
        for f in folders
    ] == [["2", "1.01"], ["3"]]
    assert list(placemarks(parse(text))) == [
        "tract-06001000200",
        "tract-06001000101",
        "tract-06002000300",
    ]


def test_hidden_groups_are_unticked() -> None:
    dataset = small_dataset()
    text = census_kml(dataset, hidden=frozenset({"tracts-county-06002"}), open_balloons=NONE)
    folders = parse(text).findall("k:Document/k:Folder", NS)
    assert [f.findtext("k:visibility", namespaces=NS) for f in folders] == ["1", "0"]


def test_open_balloons_are_open_and_no_others() -> None:
    dataset = small_dataset()
    open_ = frozenset({"06001000101", "06002000300"})
    text = census_kml(dataset, hidden=NONE, open_balloons=open_)

    assert_valid_kml(text)
    shown = {
        geoid.removeprefix("tract-")
        for geoid, placemark in placemarks(parse(text)).items()
        if placemark.findtext("gx:balloonVisibility", namespaces=NS) == "1"
    }
    assert shown == open_
    assert text.count("balloonVisibility>") == 2 * len(open_)


def test_balloons_show_the_title_and_headline_values_escaped() -> None:
    dataset = small_dataset()
    root = parse(census_kml(dataset, hidden=NONE, open_balloons=NONE))
    balloon = placemarks(root)["tract-06001000101"].findtext("k:description", namespaces=NS)

    assert balloon is not None
    assert balloon.startswith("<h3>Tract 1.01, A &lt;&amp;&gt; B</h3><table>")
    cells = re.findall(r">([^<]*)</t[hd]>", balloon)
    assert cells == [
        *("People", "1,101"),
        *("Aged &lt;65&gt; &amp; over", "12"),
        *("Income", "$51,234"),
        *("Density", "2.5"),
    ]
    assert "Only for class 5" not in balloon  # only headline values go to Google Earth
    assert etree.fromstring(f"<div>{balloon}</div>").tag == "div"  # well-formed


def test_tracts_are_outlines_and_a_label_point_inside() -> None:
    dataset = small_dataset()
    found = placemarks(parse(census_kml(dataset, hidden=NONE, open_balloons=NONE)))

    def rings(placemark: etree._Element, path: str) -> list[list[tuple[float, float]]]:
        return [
            [(float(x), float(y)) for x, y, _ in (c.split(",") for c in text.split())]
            for text in placemark.xpath(f"{path}/k:LinearRing/k:coordinates/text()", namespaces=NS)
        ]

    holed = found["tract-06001000101"]
    (outer,) = rings(holed, ".//k:outerBoundaryIs")
    (hole,) = rings(holed, ".//k:innerBoundaryIs")
    assert outer[0] == outer[-1] and hole[0] == hole[-1]
    assert Polygon(outer, [hole]).equals(HOLED)

    split = found["tract-06001000200"]
    assert len(split.findall("k:MultiGeometry/k:Polygon", NS)) == 2
    assert MultiPolygon([Polygon(r) for r in rings(split, ".//k:outerBoundaryIs")]).equals(SPLIT)

    shapes = {"06001000101": HOLED, "06001000200": SPLIT, "06002000300": PLAIN}
    for geoid, tract_shape in shapes.items():
        (point,) = found[f"tract-{geoid}"].findall("k:MultiGeometry/k:Point", NS)
        x, y, _ = map(float, point.findtext("k:coordinates", namespaces=NS).split(","))
        assert tract_shape.contains(Point(x, y))
    assert SPLIT.geoms[1].contains(label_point(SPLIT))  # on the larger part


def test_one_shared_brown_style_with_visible_labels_and_description_balloons() -> None:
    root = parse(census_kml(small_dataset(), hidden=NONE, open_balloons=NONE))
    (style,) = root.findall(".//k:Style", NS)
    assert style.getparent().tag == f"{{{NS['k']}}}Document"
    assert style.get("id") == "style-tract"
    assert style.findtext("k:PolyStyle/k:color", namespaces=NS) == "9919457a"
    assert style.findtext("k:LineStyle/k:color", namespaces=NS) == "ff0f2a4a"
    assert style.findtext("k:LabelStyle/k:scale", namespaces=NS) == "1"
    # no pin, and none fetched: an Icon without href (Google Earth and CesiumJS draw
    # none), scale 0 for a client that would draw its own default anyway (issue 33)
    assert style.findtext("k:IconStyle/k:scale", namespaces=NS) == "0"
    [icon] = style.findall("k:IconStyle/k:Icon", NS)
    assert len(icon) == 0 and not (icon.text or "").strip()
    assert style.findtext("k:BalloonStyle/k:text", namespaces=NS) == "$[description]"
    assert root.find("k:Document/k:styleUrl", NS) is None
    urls = [p.findtext("k:styleUrl", namespaces=NS) for p in placemarks(root).values()]
    assert urls == ["#style-tract"] * 3


def test_the_document_is_named_and_names_its_source() -> None:
    dataset = small_dataset()
    root = parse(census_kml(dataset, hidden=NONE, open_balloons=NONE))
    assert root.findtext("k:Document/k:name", namespaces=NS) == "Test <tracts>"
    assert "Source: Made up & small" in root.findtext("k:Document/k:description", namespaces=NS)

    named = parse(census_kml(dataset, hidden=NONE, open_balloons=NONE, name="Wall <1>"))
    assert named.findtext("k:Document/k:name", namespaces=NS) == "Wall <1>"


def test_keys_that_are_not_names_still_make_distinct_valid_ids() -> None:
    tracts = (
        make_tract("x 1", PLAIN, 1),
        make_tract("x_1", HOLED, 2),
        make_tract("9:1", SPLIT, 3),
    )
    dataset = DataSet(id=1, name="t", settings=make_settings(), tracts=tracts)
    text = census_kml(dataset, hidden=NONE, open_balloons=NONE)
    assert_valid_kml(text)
    assert list(placemarks(parse(text))) == ["tract-x_20_1", "tract-x_5f_1", "tract-9_3a_1"]


def test_the_same_data_gives_the_same_kml() -> None:
    dataset = small_dataset()
    first = census_kml(dataset, hidden=NONE, open_balloons=NONE)
    assert census_kml(dataset, hidden=NONE, open_balloons=NONE) == first
    assert census_kmz(dataset, hidden=NONE, open_balloons=NONE) == census_kmz(
        dataset, hidden=NONE, open_balloons=NONE
    )


def test_census_kmz_holds_the_kml_as_its_first_entry() -> None:
    dataset = small_dataset()
    hidden, open_ = frozenset({"tracts-county-06001"}), frozenset({"06002000300"})
    kmz_bytes = census_kmz(dataset, hidden=hidden, open_balloons=open_)
    with zipfile.ZipFile(io.BytesIO(kmz_bytes)) as kmz:
        first = kmz.infolist()[0]
        assert first.filename == "doc.kml"
        assert first.compress_type == zipfile.ZIP_DEFLATED
        document = kmz.read(first)
    assert document.decode() == census_kml(dataset, hidden=hidden, open_balloons=open_)


# --- the network link ---------------------------------------------------------------


def test_network_link_refreshes_the_census_kml_without_moving_the_view() -> None:
    url = "http://wall.example:8000/apps/census/census.kml?a=1&b=2"
    text = network_link_kml(url, refresh_seconds=4, name="Census <wall>")

    assert_valid_kml(text)
    link = parse(text).find("k:Document/k:NetworkLink", NS)
    assert link is not None
    assert link.findtext("k:name", namespaces=NS) == "Census <wall>"
    assert link.findtext("k:flyToView", namespaces=NS) == "0"
    assert link.findtext("k:Link/k:href", namespaces=NS) == url
    assert link.findtext("k:Link/k:refreshMode", namespaces=NS) == "onInterval"
    assert link.findtext("k:Link/k:refreshInterval", namespaces=NS) == "4"
    assert link.findtext("k:Link/k:viewRefreshMode", namespaces=NS) == "never"


def test_network_link_needs_a_positive_interval() -> None:
    with pytest.raises(ValueError, match="refresh_seconds"):
        network_link_kml("http://wall.example/census.kml", refresh_seconds=0, name="n")


# --- the shipped data ---------------------------------------------------------------


def test_the_shipped_census_kml_is_valid(sacramento: DataSet) -> None:
    hidden = frozenset({sacramento.groups[2].id})
    open_ = frozenset({sacramento.tracts[0].geoid})
    text = census_kml(sacramento, hidden=hidden, open_balloons=open_)

    assert_valid_kml(text)
    root = parse(text)
    folders = root.findall("k:Document/k:Folder", NS)
    assert len(folders) == 10
    visibility = [f.findtext("k:visibility", namespaces=NS) for f in folders]
    assert visibility == ["1", "1", "0", *["1"] * 7]
    found = placemarks(root)
    assert len(found) == 403
    tract = sacramento.tracts[0]
    balloon = found[f"tract-{tract.geoid}"].findtext("k:description", namespaces=NS)
    assert all(f">{value}</td>" in balloon for _, value in sacramento.headline(tract))
    opened = [
        geoid
        for geoid, placemark in found.items()
        if placemark.find("gx:balloonVisibility", NS) is not None
    ]
    assert opened == [f"tract-{tract.geoid}"]
    for tract in sacramento.tracts:
        point = found[f"tract-{tract.geoid}"].findtext(".//k:Point/k:coordinates", namespaces=NS)
        x, y, _ = map(float, point.split(","))
        assert tract.shape.contains(Point(x, y)), tract.geoid


def test_the_shipped_census_kmz_is_valid(sacramento: DataSet) -> None:
    kmz_bytes = census_kmz(sacramento, hidden=NONE, open_balloons=NONE)
    with zipfile.ZipFile(io.BytesIO(kmz_bytes)) as kmz:
        assert kmz.namelist() == ["doc.kml"]
        document = kmz.read("doc.kml")
    assert_valid_kml(document)
    assert len(parse(document).findall(".//k:Placemark", NS)) == 403
