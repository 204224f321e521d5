"""The census map as KML, so Google Earth can show what the wall shows.

Built with simplekml and then made valid against the OGC KML 2.2 schema (and Google's
``gx`` extensions) by :func:`valid_kml`: Google Earth forgives simplekml's mistakes,
other KML clients and validators do not.

The post-processing uses the standard library's ElementTree, not lxml, so that
serving KML needs no dependency beyond simplekml.
"""

from __future__ import annotations

import io
import re
import threading
import zipfile
from collections.abc import Iterator, Mapping
from html import escape
from typing import Literal
from xml.etree import ElementTree

import simplekml
from shapely import LinearRing, MultiPolygon, Point, Polygon, get_coordinates
from shapely.ops import polylabel

from webapp.apps.census_map.dataset import DataSet, Tract
from webapp.apps.census_map.theme import Shading
from webapp.choropleth.classes import MISSING_FILL, outline_for
from webapp.choropleth.palettes import MAX_CLASSES

NAMESPACES = {
    "": "http://www.opengis.net/kml/2.2",  # the default namespace, as in every KML file
    "gx": "http://www.google.com/kml/ext/2.2",
    "atom": "http://www.w3.org/2005/Atom",
    "xal": "urn:oasis:names:tc:ciq:xsdschema:xAL:2.0",
}
for _prefix, _uri in NAMESPACES.items():
    ElementTree.register_namespace(_prefix, _uri)


def _tag(name: str) -> str:
    """ElementTree's name for a KML tag: ``"styleUrl"`` -> ``"{<kml ns>}styleUrl"``."""
    prefix, _, local = name.rpartition(":")
    return f"{{{NAMESPACES[prefix]}}}{local}"


XML_DECLARATION = '<?xml version="1.0" encoding="UTF-8"?>\n'

# Brown tracts (KML colours are aabbggrr): a see-through fill, a darker solid outline.
FILL_COLOR = "9919457a"
LINE_COLOR = "ff0f2a4a"
CLASS_ALPHA = "e6"  # a class's fill, nearly opaque: the colour must read as on the wall
PLAIN_STYLE_ID = "style-tract"
LABEL_TOLERANCE = 1e-4  # degrees (about 10 m): a hundredth of the smallest shipped tract

# simplekml keeps its id counter and the document being written in class attributes,
# so two threads building KML at once would mix them up.
_SIMPLEKML = threading.Lock()

FEATURES = {
    _tag(name)
    for name in (
        "Document",
        "Folder",
        "Placemark",
        "NetworkLink",
        "GroundOverlay",
        "ScreenOverlay",
        "PhotoOverlay",
    )
}
# The order of a feature's own children in the schema (AbstractFeatureType). simplekml
# writes styles first and Snippet and Region out of place; whatever is not listed here
# (geometry, child features, extensions, a NetworkLink's Link) keeps its place after these.
FEATURE_CHILD_ORDER = (
    ("name",),
    ("visibility",),
    ("open",),
    ("atom:author",),
    ("atom:link",),
    ("address",),
    ("xal:AddressDetails",),
    ("phoneNumber",),
    ("Snippet", "snippet"),
    ("description",),
    ("Camera", "LookAt"),
    ("TimeStamp", "TimeSpan"),
    ("styleUrl",),
    ("Style", "StyleMap"),
    ("Region",),
    ("Metadata", "ExtendedData"),
)
FEATURE_CHILD_RANK = {
    _tag(name): rank for rank, names in enumerate(FEATURE_CHILD_ORDER) for name in names
}
NAME_START = re.compile(r"[A-Za-z_]")
NOT_NAME_CHAR = re.compile(r"[^A-Za-z0-9.-]")


def census_kml(
    dataset: DataSet,
    *,
    hidden: frozenset[str],
    open_balloons: frozenset[str],
    name: str | None = None,
    shading: Shading | None = None,
    all_classes: bool = False,
) -> str:
    """The data set as one KML document: a folder per tract group (hidden groups
    unticked), each tract an outline labelled with its number and a balloon with its
    headline values; the balloons in ``open_balloons`` open in Google Earth. Tracts
    are brown, or with ``shading`` in their class's colour (a shared style per class,
    the legend in the document's description), as on the wall. ``all_classes`` writes
    a style for every class any theme can have (see :func:`class_colours`), so that an
    ``Update`` can colour the map by another theme without loading it again."""
    ids: dict[str, str] = {}
    with _SIMPLEKML:
        simplekml.Kml.resetidcounter()  # the same data gives the same bytes
        kml = simplekml.Kml(name=name or dataset.title, description=_about(dataset, shading))
        ids[kml.document.id] = f"dataset-{dataset.id}"
        style = _tract_style()
        ids[style.id] = PLAIN_STYLE_ID
        # Setting a style on the Document makes it a shared style, but also the
        # Document's own styleUrl, which only the tracts should have.
        kml.document.style = style
        kml.document.styleurl = None
        colours = class_colours(shading, all_classes=all_classes)
        for index, (fill, line) in enumerate(colours):
            class_style = _tract_style(fill, line)
            ids[class_style.id] = class_style_id(index)
            ids[class_style.polystyle.id] = class_style_id(index, "poly")
            ids[class_style.linestyle.id] = class_style_id(index, "line")
            kml.document.style = class_style
        kml.document.styleurl = None
        order = {tract.geoid: index for index, tract in enumerate(dataset.tracts)}
        for group in dataset.groups:
            folder = kml.newfolder(name=group.name, visibility=0 if group.id in hidden else 1)
            ids[folder.id] = f"group-{_id_part(group.id)}"
            for geoid in sorted(group.geoids, key=order.__getitem__):
                tract = dataset.tracts[order[geoid]]
                multi = folder.newmultigeometry(
                    name=tract.label, description=_balloon(dataset, tract)
                )
                ids[multi.placemark.id] = f"tract-{_id_part(tract.geoid)}"
                multi.placemark.styleurl = f"#{tract_style_id(geoid, shading, len(colours))}"
                if geoid in open_balloons:
                    multi.gxballoonvisibility = 1
                for polygon in _parts(tract.shape):
                    multi.newpolygon(
                        outerboundaryis=_ring(polygon.exterior),
                        innerboundaryis=[_ring(hole) for hole in polygon.interiors],
                        tessellate=1,
                    )
                label = label_point(tract.shape)
                multi.newpoint(coords=[(round(label.x, 6), round(label.y, 6))])
        text = kml.kml(format=False)
    return valid_kml(text, ids)


def census_kmz(
    dataset: DataSet,
    *,
    hidden: frozenset[str],
    open_balloons: frozenset[str],
    name: str | None = None,
    shading: Shading | None = None,
    all_classes: bool = False,
) -> bytes:
    """:func:`census_kml` zipped, as Google Earth expects a KMZ: ``doc.kml`` first."""
    text = census_kml(
        dataset,
        hidden=hidden,
        open_balloons=open_balloons,
        name=name,
        shading=shading,
        all_classes=all_classes,
    )
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as kmz:
        # A fixed timestamp keeps the archive the same for the same document.
        entry = zipfile.ZipInfo("doc.kml", date_time=(1980, 1, 1, 0, 0, 0))
        kmz.writestr(entry, text.encode(), compress_type=zipfile.ZIP_DEFLATED)
    return buffer.getvalue()


def network_link_kml(url: str, *, refresh_seconds: int, name: str) -> str:
    """A KML file to open once in Google Earth: it fetches ``url`` again every
    ``refresh_seconds`` without moving the view, so Earth follows the wall."""
    if refresh_seconds < 1:
        raise ValueError("refresh_seconds must be at least 1")
    with _SIMPLEKML:
        simplekml.Kml.resetidcounter()
        kml = simplekml.Kml(name=name)
        link = kml.newnetworklink(name=name, flytoview=0)
        link.link.href = url
        link.link.refreshmode = simplekml.RefreshMode.oninterval
        link.link.refreshinterval = refresh_seconds
        link.link.viewrefreshmode = simplekml.ViewRefreshMode.never
        text = kml.kml(format=False)
    return valid_kml(text)


def group_feature_id(group_id: str) -> str:
    """The id of a group's Folder in :func:`census_kml`: what an ``Update`` targets."""
    return f"group-{_id_part(group_id)}"


def tract_feature_id(geoid: str) -> str:
    """The id of a tract's Placemark in :func:`census_kml`: what an ``Update`` targets."""
    return f"tract-{_id_part(geoid)}"


def class_style_id(index: int, part: Literal["", "poly", "line"] = "") -> str:
    """The id of class ``index``'s shared Style in :func:`census_kml`, or of its
    PolyStyle or LineStyle: what an ``Update`` changes to recolour a class."""
    return f"style-class-{index}-{part}" if part else f"style-class-{index}"


def tract_style_id(geoid: str, shading: Shading | None, styles: int) -> str:
    """The style a tract points at, among ``styles`` class styles ("no value" last)."""
    if shading is None:
        return PLAIN_STYLE_ID
    band = shading.band_of.get(geoid)
    return class_style_id(styles - 1 if band is None else band)


def class_colours(shading: Shading | None, *, all_classes: bool = False) -> list[tuple[str, str]]:
    """KML colours (fill, line) of each class, then of "no value"; none when plain.
    With ``all_classes`` there are always ``MAX_CLASSES`` class slots, then "no value",
    whatever the theme: slots it does not use, and all of them when plain, brown."""
    brown = (FILL_COLOR, LINE_COLOR)
    if shading is None:
        return [brown] * (MAX_CLASSES + 1) if all_classes else []
    colours = [_kml_pair(band.colour, band.line) for band in shading.bands]
    unused = MAX_CLASSES - len(colours) if all_classes else 0
    return [*colours, *[brown] * unused, _kml_pair(MISSING_FILL, outline_for(MISSING_FILL))]


def valid_kml(text: str, ids: Mapping[str, str] | None = None) -> str:
    """simplekml's output made valid against the KML 2.2 schema.

    simplekml numbers its ids (``id="3"``), which XML does not allow (an id is a name,
    so it cannot start with a digit); it writes a NetworkLinkControl after the Document
    although it must come first; it writes a feature's styles before its name; and it
    puts all holes of a polygon in one ``innerBoundaryIs``, which holds one ring.
    Ids found in ``ids`` are renamed to the value given there, every other id that is
    not a name gets its element's name as a prefix (``style-3``); ``styleUrl``
    references follow the renaming.
    """
    root = ElementTree.fromstring(text)
    control = root.find(_tag("NetworkLinkControl"))
    if control is not None:
        root.remove(control)
        root.insert(0, control)
    for polygon in root.iter(_tag("Polygon")):
        polygon[:] = [part for child in polygon for part in _one_ring_each(child)]
    names = ids or {}
    renamed: dict[str, str] = {}
    for element in root.iter():
        if element.tag in FEATURES:
            element[:] = sorted(element, key=_feature_child_rank)
        old = element.get("id")
        if old is None:
            continue
        new = names.get(old, old)
        if not NAME_START.match(new):
            new = f"{_local_name(element.tag).lower()}-{new}"
        if new != old:
            element.set("id", new)
            renamed[old] = new
    for url in root.iter(_tag("styleUrl")):
        target = (url.text or "").strip()
        if target.startswith("#") and target[1:] in renamed:
            url.text = f"#{renamed[target[1:]]}"
    return XML_DECLARATION + ElementTree.tostring(root, encoding="unicode")


def label_point(shape: Polygon | MultiPolygon) -> Point:
    """Where Google Earth writes a tract's number: the point of its largest part that
    lies farthest from the outline, so the label sits well inside."""
    largest = max(_parts(shape), key=lambda polygon: polygon.area)
    point: Point = polylabel(largest, tolerance=LABEL_TOLERANCE)
    return point


def _tract_style(fill: str = FILL_COLOR, line: str = LINE_COLOR) -> simplekml.Style:
    style = simplekml.Style()
    style.polystyle.color = fill
    style.linestyle.color = line
    style.linestyle.width = 1.5
    style.labelstyle.scale = 1
    # No pin, the label alone marks the tract: an Icon without href, so neither Google
    # Earth nor CesiumJS draws one or fetches one (simplekml's default pushpin is on
    # maps.google.com, out of reach offline and from a page of another site); scale 0
    # for a client that would draw its own default anyway.
    style.iconstyle.scale = 0
    style.iconstyle.icon.href = None
    style.balloonstyle.text = "$[description]"
    return style


def _about(dataset: DataSet, shading: Shading | None) -> str:
    about = f"{len(dataset.tracts)} census tracts in {len(dataset.groups)} groups."
    source = dataset.settings.source
    about = f"{about} Source: {source}" if source else about
    if shading is None:
        return about
    rows = [
        f"{shading.band_range(i)}: {band.count} ({band.colour})"
        for i, band in enumerate(shading.bands)
    ]
    rows += [f"no value: {shading.missing} (grey)"] if shading.missing else []
    return f"{about} Coloured by {shading.title}: {'; '.join(rows)}."


def _kml_pair(fill: str, line: str) -> tuple[str, str]:
    return kml_colour(fill, CLASS_ALPHA), kml_colour(line, "ff")


def kml_colour(rgb: str, alpha: str) -> str:
    """``#rrggbb`` as KML writes colours: ``aabbggrr``."""
    return f"{alpha}{rgb[5:7]}{rgb[3:5]}{rgb[1:3]}"


def _balloon(dataset: DataSet, tract: Tract) -> str:
    """The balloon as HTML; the values come from imported files, so all is escaped."""
    rows = "".join(
        f'<tr><th align="left">{escape(label)}</th><td align="right">{escape(value)}</td></tr>'
        for label, value in dataset.headline(tract)
    )
    return f"<h3>{escape(dataset.tract_title(tract))}</h3><table>{rows}</table>"


def _parts(shape: Polygon | MultiPolygon) -> Iterator[Polygon]:
    if isinstance(shape, MultiPolygon):
        yield from shape.geoms
    else:
        yield shape


def _ring(ring: LinearRing) -> list[list[float]]:
    """A ring's corners in longitude/latitude; shapely keeps the ring closed, as KML
    requires (the last corner repeats the first)."""
    corners: list[list[float]] = get_coordinates(ring).tolist()
    return corners


def _id_part(text: str) -> str:
    """``text`` as part of an XML id: characters an id cannot hold (and ``_``, the
    escape) become ``_hex_``, so different keys stay different ids."""
    return NOT_NAME_CHAR.sub(lambda match: f"_{ord(match[0]):x}_", text)


def _one_ring_each(child: ElementTree.Element) -> list[ElementTree.Element]:
    """``child`` as it is, or, for an ``innerBoundaryIs`` holding several rings, one
    ``innerBoundaryIs`` per ring."""
    if child.tag != _tag("innerBoundaryIs") or len(child) < 2:
        return [child]
    boundaries = []
    for ring in child:
        boundary = ElementTree.Element(child.tag)
        boundary.append(ring)
        boundaries.append(boundary)
    return boundaries


def _feature_child_rank(child: ElementTree.Element) -> int:
    return FEATURE_CHILD_RANK.get(child.tag, len(FEATURE_CHILD_RANK))


def _local_name(tag: str) -> str:
    return tag.rpartition("}")[2]
