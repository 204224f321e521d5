"""Google Earth walls: one Google Earth Pro per display, each showing exactly its
display's part of the census map, with the codes placed on that display, so phones
scan a code off an Earth display as off a tile (the dissertation's HIPerWall ran
Google Earth on its tiles this way).

Each Earth instance opens one small file (:func:`opener_kml`) holding two network links:

* **the map** (``map.kmz``: every tract, hidden groups unticked, no balloon open),
  fetched again every ``map_refresh`` seconds. It is the big one (0.6 MB zipped) and
  changes only with the data set, so it is fetched seldom;
* **the display's wall document** (:func:`wall_kml`, a few kB), fetched every
  ``refresh`` seconds with ``flyToView``. Its ``NetworkLinkControl`` carries the
  display's view (:func:`display_view`: the wall pans and zooms, Earth follows) and an
  ``Update`` that changes the loaded map in place by ``targetId``: group folders'
  ``visibility``, the display's balloon (``gx:balloonVisibility``) and the colouring
  (:class:`Colouring`: the class styles' colours, the tracts' ``styleUrl``). Its
  ``cookie`` names the balloon it opened and the colouring it left, which Earth sends
  back on the next fetch: the next document closes that balloon, and recolours only
  what differs from that colouring (nothing while the theme stays). The document
  itself holds the display's codes and their captions as ScreenOverlays.

The map Earth loads has a style for every class any theme can have (``all_classes``
in :func:`~webapp.apps.census_map.kml.census_kml`): an ``Update`` can ``Change`` a
Style but not ``Create`` one, so every id a theme may need is there from the start.

Google Earth applies an ``Update`` only to a file a NetworkLink loaded, found by the
exact URL in ``targetHref``: the map's URL is built in one place (:func:`map_url`), on
the base URL the opener named for both links: the public base URL
(``TAGWALL_PUBLIC_BASE_URL``), or the one ``tagwall earth --base-url`` gave, which the
opener's links carry with the server's signature (:class:`EarthBase`); never on the
Host header of a request, which whoever sends it chooses. Nothing rests on that match
alone: CesiumJS adds the opener's query to every link in it, so the usual opener has
none (:meth:`EarthOptions.query`), every route ignores a query it does not read, and the
map's own refresh brings the whole current map (groups, colouring) to an Earth whose
Update missed it.

Views: Google Earth looks straight down (heading 0, tilt 0) at the middle of the
display's rectangle of the map, from the height at which its horizontal field of view
spans the rectangle's width on the WGS84 ellipsoid, the globe Earth draws
(:func:`look_at_range`). Earth's view is a perspective of the ellipsoid, the wall's map
an equirectangular plane: at county scale they differ by well under a percent of a
display (the tests measure it), and neighbouring views meet across the bezel between
them as the tiles do.
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import asdict, dataclass
from urllib.parse import quote, urlencode
from xml.etree.ElementTree import Element, SubElement, tostring

from PIL import Image, ImageDraw, ImageFont
from pydantic import ValidationError

from tag_service.codes import content_hash
from wall_client.layout import Display, Wall
from webapp.apps.census_map.actions import group_shown
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.ellipsoid import WGS84_A, WGS84_E2
from webapp.apps.census_map.kml import (
    NAMESPACES,
    XML_DECLARATION,
    class_colours,
    class_style_id,
    group_feature_id,
    tract_feature_id,
    tract_style_id,
)
from webapp.apps.census_map.mapview import MapGeometry, projection
from webapp.apps.census_map.theme import Shading
from webapp.choropleth.classes import Theme
from webapp.database.connection import Database
from webapp.engine.wall_state import Balloon, View, WallState
from webapp.people.security import derive_token, token_matches
from webapp.tags.registry import get_layout
from webapp.tags.schemas import PlacedCode

DEFAULT_FOV = 60.0  # degrees across: Google Earth's horizontal field of view
MIN_FOV, MAX_FOV = 1.0, 150.0
DEFAULT_REFRESH_S = 2  # the wall document: view, groups, balloons, codes
DEFAULT_MAP_REFRESH_S = 60  # the map itself
MIN_REFRESH_S, MAX_REFRESH_S = 1, 3600
PREFIX = "/apps/census/earth"
# A code's caption as tiles draw it (static/js/codes.js, drawCaption): white bold text,
# as large as fits, on a dark strip.
CAPTION_BACKING = "#10161f"
CAPTION_FONT = "DejaVuSans-Bold.ttf"  # Debian's sans-serif, as Chromium draws the tiles'


@dataclass(frozen=True)
class EarthOptions:
    """How a display group's Earth instances are set up (the opener's query)."""

    fov: float = DEFAULT_FOV  # their horizontal field of view, degrees
    refresh: int = DEFAULT_REFRESH_S  # seconds between fetches of the wall document
    map_refresh: int = DEFAULT_MAP_REFRESH_S  # seconds between fetches of the map

    def __post_init__(self) -> None:
        if not MIN_FOV <= self.fov <= MAX_FOV:
            raise ValueError(f"fov must be from {MIN_FOV:g} to {MAX_FOV:g} degrees")
        for value in (self.refresh, self.map_refresh):
            if not MIN_REFRESH_S <= value <= MAX_REFRESH_S:
                raise ValueError(f"refresh intervals must be {MIN_REFRESH_S}-{MAX_REFRESH_S} s")

    def query(self) -> dict[str, str]:
        """The options that differ from the defaults, as the opener's query: the usual
        opener has none, and CesiumJS adds an opener's query to every link in it."""
        return {
            name: f"{value:g}"
            for name, value in asdict(self).items()
            if value != getattr(EarthOptions, name)
        }


# --- where things are ----------------------------------------------------------------


def earth_displays(wall: Wall) -> list[Display]:
    """The displays Google Earth can drive: those showing the map. The designated
    screens (public, menu, registration) show panels Earth cannot draw: they stay tiles."""
    designated = wall.designated()
    return [d for d in wall.displays if d.id not in designated]


def screen_role(wall: Wall, display_id: str) -> str | None:
    """The role of the designated screen ``display_id`` is (public, menu, ...), if any."""
    return next((role for role, ids in wall.screens.items() if display_id in ids), None)


@dataclass(frozen=True)
class EarthBase:
    """Where Google Earth reaches this server: ``url``, and ``signature`` when it is not
    the public base URL (``tagwall earth --base-url``): links carry the URL with its
    signature, so the server names URLs on it only where the operator chose it."""

    url: str
    signature: str | None = None

    @classmethod
    def of_request(
        cls, secret: str, public: str, url: str | None, signature: str | None
    ) -> EarthBase | None:
        """The base a link named (``url`` and ``signature`` from its query), the public
        base when it named none; None when its signature is not this server's."""
        if url is None and signature is None:
            return cls(public)
        if url is None or signature is None:
            return None
        if not token_matches(base_signature(secret, url), signature):
            return None
        return cls(url, signature)

    def query(self) -> dict[str, str]:
        return {"base": self.url, "sig": self.signature} if self.signature else {}


def base_signature(secret: str, url: str) -> str:
    """The server's signature of an Earth base ``url`` (a token derived from the secret)."""
    return derive_token(secret, f"earth-base:{url}")


def map_url(base_url: str, wall_id: str) -> str:
    return f"{base_url}{PREFIX}/{quote(wall_id)}/map.kmz"


def opener_url(base: EarthBase, wall_id: str, display_id: str, options: EarthOptions) -> str:
    path = f"{base.url}{PREFIX}/{quote(wall_id)}/{quote(display_id)}.kml"
    return _with_query(path, {**options.query(), **base.query()})


def wall_document_url(base: EarthBase, wall_id: str, display_id: str, fov: float) -> str:
    path = f"{base.url}{PREFIX}/{quote(wall_id)}/{quote(display_id)}/wall.kml"
    return _with_query(path, {**EarthOptions(fov=fov).query(), **base.query()})


def _with_query(url: str, query: Mapping[str, str]) -> str:
    return f"{url}?{urlencode(query)}" if query else url


def code_image_url(base_url: str, code: PlacedCode) -> str:
    """The code's PNG as the wall placed it: its error level, whole pixels per module."""
    name = f"{code.code}.{content_hash(code.payload, code.error)}.png"
    query = urlencode({"scale": code.px_per_module, "error": code.error})
    return f"{base_url}/codes/{name}?{query}"


def caption_url(base_url: str, wall_id: str, layout_id: int, code: str) -> str:
    return f"{base_url}{PREFIX}/{quote(wall_id)}/captions/{layout_id}/{quote(code)}.png"


@dataclass(frozen=True)
class ScreenImage:
    """An image Earth draws on top of the globe, in the display's pixels as mounted."""

    name: str
    href: str
    box: tuple[int, int, int, int]  # x, y from the top left, width, height


def screen_images(
    wall: Wall, display_id: str, codes: Sequence[PlacedCode], layout_id: int, base_url: str
) -> list[ScreenImage]:
    """The codes on ``display_id`` where the wall placed them, each with its caption
    under it, so a code reads on Earth as on a tile (the pins some codes get are not
    drawn: Earth has no lines on the screen)."""
    images = []
    for code in codes:
        if code.display != display_id:
            continue
        x, y, side = code.pixels
        images.append(ScreenImage(code.label, code_image_url(base_url, code), (x, y, side, side)))
        if code.label and code.caption:
            href = caption_url(base_url, wall.id, layout_id, code.code)
            images.append(
                ScreenImage(code.label, href, mounted_box(wall, display_id, code.caption))
            )
    return images


def mounted_box(
    wall: Wall, display_id: str, rect: tuple[float, float, float, float]
) -> tuple[int, int, int, int]:
    """A scene-mm rectangle in the display's whole pixels as mounted: Earth's window
    fills the display upright as it hangs (a turned display turns its desktop)."""
    scene = wall.viewport(display_id).scene_rect
    width, height = wall.display(display_id).mounted_resolution
    x, y, w, h = rect
    left, right = (round((value - scene.x) / scene.width * width) for value in (x, x + w))
    top, bottom = (round((value - scene.y) / scene.height * height) for value in (y, y + h))
    return (left, top, right - left, bottom - top)


def caption_png(text: str, size: tuple[int, int]) -> bytes:
    """``text`` as large as fits its strip (80 % of its height, 96 % of its width at most),
    centred, as tiles draw a code's caption."""
    width, height = size
    image = Image.new("RGB", size, CAPTION_BACKING)
    draw = ImageDraw.Draw(image)
    font_px = max(1, int(height * 0.8))
    measured = draw.textlength(text, font=_font(font_px))
    if measured > width * 0.96:
        font_px = max(1, int(font_px * width * 0.96 / measured))
    draw.text((width / 2, height / 2), text, fill="#fff", font=_font(font_px), anchor="mm")
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def _font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """The caption font, laid out by FreeType alone: Pillow's HarfBuzz layout (raqm)
    draws nothing, or a glyph run millions of pixels wide, once libvips (the image app)
    has put the system's FreeType in the process before Pillow's text engine loaded."""
    basic = ImageFont.Layout.BASIC
    try:
        return ImageFont.truetype(CAPTION_FONT, size, layout_engine=basic)
    except OSError:  # no DejaVu: Pillow's own sans-serif
        default = ImageFont.load_default(size)
        if isinstance(default, ImageFont.FreeTypeFont):
            return default.font_variant(layout_engine=basic)
        return default


# --- views ---------------------------------------------------------------------------


@dataclass(frozen=True)
class DisplayView:
    """What one display shows of the map on the globe, and the view that shows it."""

    display_id: str
    west: float  # degrees: the display's rectangle of the map
    north: float
    east: float
    south: float
    longitude: float  # the rectangle's middle, where Earth looks straight down
    latitude: float
    range_m: float  # how high above it Earth's camera stands
    fov: float  # horizontal field of view the range is for (degrees)


def display_view(
    geometry: MapGeometry, wall: Wall, view: View, display_id: str, fov: float = DEFAULT_FOV
) -> DisplayView:
    """The display's scene rectangle taken back through the wall's projection of the
    map to longitude/latitude, and the range from which Google Earth, looking straight
    down ``fov`` degrees across, sees exactly its width at its middle latitude."""
    project = projection(geometry, wall, view)
    rect = wall.viewport(display_id).scene_rect
    west, north = geometry.to_lonlat(*project.to_plane(rect.x, rect.y))
    east, south = geometry.to_lonlat(*project.to_plane(rect.right, rect.bottom))
    longitude, latitude = geometry.to_lonlat(*project.to_plane(*rect.center))
    range_m = look_at_range(latitude, (east - west) / 2, fov)
    return DisplayView(display_id, west, north, east, south, longitude, latitude, range_m, fov)


def look_at_range(latitude: float, half_width: float, fov: float) -> float:
    """The ``range`` of a LookAt straight down (tilt 0) at ``latitude`` from which a
    horizontal field of view of ``fov`` degrees spans ``half_width`` degrees of longitude
    either side of the middle, on the WGS84 ellipsoid Google Earth draws (a sphere of mean
    radius, as before, left each demo display's view 3 mm short on the wall).

    The camera stands ``range`` above the ground along the ellipsoid's normal; the plane
    of the picture's middle row (the normal and east) cuts the ellipsoid in the prime
    vertical, of radius of curvature N. The sphere of radius N centred where the normal
    meets the axis touches the ellipsoid along the whole parallel, so on it (within a
    micrometre on the wall at county scale): a camera h above the ground sees, at angle
    a off straight down, the point t = asin((N + h) / N · sin a) - a away (radians about
    that centre), and the great circle heading east meets the meridian ``half_width``
    away at tan t = tan(half_width) · cos(latitude). Solved for h with a = fov / 2."""
    phi = math.radians(latitude)
    prime_vertical = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(phi) ** 2)
    half_arc = math.atan(math.tan(math.radians(half_width)) * math.cos(phi))
    half_fov = math.radians(fov) / 2
    return prime_vertical * (math.sin(half_fov + half_arc) / math.sin(half_fov) - 1)


def display_balloon(
    wall: Wall, display_id: str, balloons: Sequence[Balloon], now: int
) -> str | None:
    """The tract whose balloon this display's Earth opens: the newest open balloon
    whose tract point lies on the display. Google Earth shows one balloon at a time,
    at its placemark, so each display opens the one the wall points at on it."""
    rect = wall.viewport(display_id).scene_rect
    for balloon in reversed(balloons):
        if balloon.open_at(now) and rect.contains(balloon.anchor):
            return balloon.id.removeprefix("tract-")
    return None


# --- colouring ------------------------------------------------------------------------


@dataclass(frozen=True)
class Colouring:
    """How an Earth's map is coloured, as ``map.kmz`` writes it and an Update changes
    it. ``key`` names it in the wall document's cookie."""

    key: str
    classes: tuple[tuple[str, str], ...]  # each class slot's KML (fill, line), "no value" last
    styles: Mapping[str, str]  # GEOID -> the id of the style the tract points at


def colouring(dataset: DataSet, shading: Shading | None) -> Colouring:
    """The map coloured by ``shading`` (None: plain brown), every class slot written."""
    colours = class_colours(shading, all_classes=True)
    return Colouring(
        key=colouring_key(dataset.id, shading.theme if shading else None),
        classes=tuple(colours),
        styles={t.geoid: tract_style_id(t.geoid, shading, len(colours)) for t in dataset.tracts},
    )


def colouring_key(dataset_id: int, theme: Theme | None) -> str:
    """``7`` (data set 7, plain) or ``7.YlOrRd.quantiles.5.POP``: short enough for a
    cookie, and enough to colour the map again (the value last: it may hold dots)."""
    if theme is None:
        return str(dataset_id)
    return f"{dataset_id}.{theme.scheme}.{theme.method}.{theme.classes}.{theme.attribute}"


def keyed_theme(key: str) -> tuple[int, Theme | None] | None:
    """The data set and theme :func:`colouring_key` wrote into ``key``; None when it
    names none (a mangled cookie)."""
    dataset_id, *rest = key.split(".", 4)
    if not (dataset_id.isascii() and dataset_id.isdigit()) or len(rest) not in (0, 4):
        return None
    if not rest:
        return int(dataset_id), None
    scheme, method, classes, attribute = rest
    fields = {"attribute": attribute, "scheme": scheme, "method": method, "classes": classes}
    try:
        return int(dataset_id), Theme.model_validate(fields)
    except ValidationError:
        return None


def earlier_colouring(
    dataset: DataSet,
    key: str | None,
    now: Colouring,
    shading_of: Callable[[Theme], Shading | None],
) -> Colouring | None:
    """What the Earth whose cookie names ``key`` shows: ``now`` when that is the
    current colouring (nothing to change); None when it cannot be known: a just-started
    Earth (no cookie yet), another data set, a value this one lacks. An Earth whose
    colouring is unknown gets every style, right whichever map it loaded."""
    if key == now.key:
        return now
    named = keyed_theme(key) if key else None
    if named is None or named[0] != dataset.id:
        return None
    theme = named[1]
    shading = None if theme is None else shading_of(theme)
    if theme is not None and shading is None:
        return None
    return colouring(dataset, shading)


# --- documents -----------------------------------------------------------------------


def display_document(
    db: Database,
    *,
    wall: Wall,
    state: WallState,
    dataset: DataSet,
    geometry: MapGeometry,
    on_wall: bool,
    shading: Shading | None,
    shading_of: Callable[[Theme], Shading | None],
    display_id: str,
    fov: float,
    opened: str | None,
    coloured: str | None,
    base_url: str,
    now: int,
) -> str:
    """:func:`wall_kml` for ``display_id`` as the wall stands: its view, groups, the
    balloon on it, its codes, the map coloured by ``shading`` (none, every group shown,
    the map's home view and plain while the census map is not on the wall). This
    display's Earth's cookie says what it shows: ``opened``, the balloon it opened last
    (closed unless still the one to show), and ``coloured``, the key of its colouring
    (``shading_of`` colours the data set by that key's theme, to change only what
    differs). ``base_url`` is the base the opener named the map by (the public base
    URL, or a signed one), so ``targetHref`` is the very URL Earth loaded the map from."""
    balloons = state.balloons if on_wall else []
    closing = {b.id.removeprefix("tract-") for b in balloons} | ({opened} if opened else set())
    record = get_layout(db, wall.id, state.tag_layout) if on_wall and state.tag_layout else None
    placed = [PlacedCode.model_validate(p) for p in record.placed] if record else []
    now_coloured = colouring(dataset, shading)
    return wall_kml(
        name=f"tagwall · {wall.name} · {display_id}",
        map_href=map_url(base_url, wall.id),
        view=display_view(geometry, wall, state.view if on_wall else View(), display_id, fov),
        groups={g.id: not on_wall or group_shown(state, g.id) for g in dataset.groups},
        balloon=display_balloon(wall, display_id, balloons, now),
        closing={geoid for geoid in closing if dataset.tract(geoid) is not None},
        colours=now_coloured,
        earlier=earlier_colouring(dataset, coloured, now_coloured, shading_of),
        images=screen_images(wall, display_id, placed, state.tag_layout, base_url),
        pixels=wall.display(display_id).mounted_resolution,
    )


def opener_kml(base: EarthBase, wall: Wall, display_id: str, options: EarthOptions) -> str:
    """What the Earth instance on ``display_id`` opens (once, by hand or at start): the
    map and the display's wall document as network links."""
    root = _kml()
    document = _add(root, "Document")
    _add(document, "name", f"tagwall · {wall.name} · {display_id}")
    _add(document, "open", 1)
    _add(
        document,
        "description",
        "Keeps this Google Earth showing its display's part of the wall's census map. "
        f"Set Earth's horizontal field of view to {options.fov:g}°.",
    )
    the_map = _add(document, "NetworkLink")
    _add(the_map, "name", "Census map")
    _add(the_map, "refreshVisibility", 1)  # the refreshed map's groups, not the user's ticks
    _add(the_map, "flyToView", 0)
    _link(the_map, map_url(base.url, wall.id), options.map_refresh)
    state = _add(document, "NetworkLink")
    _add(state, "name", "The wall: view, groups, balloon, colours, codes")
    _add(state, "flyToView", 1)  # to the NetworkLinkControl's view, on every fetch
    _link(state, wall_document_url(base, wall.id, display_id, options.fov), options.refresh)
    return _text(root)


def wall_kml(
    *,
    name: str,
    map_href: str,
    view: DisplayView,
    groups: Mapping[str, bool],
    balloon: str | None,
    closing: Collection[str],
    colours: Colouring,
    earlier: Colouring | None,
    images: Sequence[ScreenImage],
    pixels: tuple[int, int],
) -> str:
    """One display's wall document: its view, the map's group visibility (``groups``:
    group id -> shown), balloons (open ``balloon``, close those in ``closing``) and
    ``colours`` (the class styles and tracts that differ from ``earlier``, what the
    Earth shows: all when unknown) as an Update of the loaded map, and ``images`` (its
    codes and their captions) as ScreenOverlays on a window of ``pixels`` (the
    display's resolution as mounted). The cookie names the balloon and the colouring."""
    root = _kml()
    control = _add(root, "NetworkLinkControl")
    cookie = {"open": balloon} if balloon is not None else {}
    _add(control, "cookie", urlencode({**cookie, "theme": colours.key}))
    update = _add(control, "Update")
    _add(update, "targetHref", map_href)
    for index, (fill, line) in enumerate(colours.classes):
        if earlier is None or earlier.classes[index] != (fill, line):
            _change(update, "PolyStyle", class_style_id(index, "poly"), "color", fill)
            _change(update, "LineStyle", class_style_id(index, "line"), "color", line)
    for geoid, style in colours.styles.items():
        if earlier is None or earlier.styles.get(geoid) != style:
            _change(update, "Placemark", tract_feature_id(geoid), "styleUrl", f"#{style}")
    for group_id, shown in groups.items():
        _change(update, "Folder", group_feature_id(group_id), "visibility", int(shown))
    for geoid in sorted(closing):
        if geoid != balloon:
            _change(update, "Placemark", tract_feature_id(geoid), "gx:balloonVisibility", 0)
    if balloon is not None:
        _change(update, "Placemark", tract_feature_id(balloon), "gx:balloonVisibility", 1)
    look_at = _add(control, "LookAt")
    _add(look_at, "longitude", _number(view.longitude))
    _add(look_at, "latitude", _number(view.latitude))
    _add(look_at, "altitude", 0)
    _add(look_at, "heading", 0)
    _add(look_at, "tilt", 0)
    _add(look_at, "range", f"{view.range_m:.1f}")
    _add(look_at, "altitudeMode", "relativeToGround")
    document = _add(root, "Document")
    _add(document, "name", name)
    for image in images:
        _screen_overlay(document, image, pixels)
    return _text(root)


def _screen_overlay(document: Element, image: ScreenImage, pixels: tuple[int, int]) -> None:
    """An image at its pixels: its top-left corner at its position as a fraction of the
    display (KML counts y from the bottom), its size in pixels, so a code's modules
    stay whole pixels as on a tile."""
    width, height = pixels
    x, y, w, h = image.box
    overlay = _add(document, "ScreenOverlay")
    _add(overlay, "name", image.name)
    icon = _add(overlay, "Icon")
    _add(icon, "href", image.href)
    fraction = {"xunits": "fraction", "yunits": "fraction"}
    _add(overlay, "overlayXY", x="0", y="1", **fraction)
    _add(overlay, "screenXY", x=_number(x / width), y=_number(1 - y / height), **fraction)
    _add(overlay, "size", x=str(w), y=str(h), xunits="pixels", yunits="pixels")


def _change(update: Element, kind: str, target: str, field: str, value: object) -> None:
    change = _add(update, "Change")
    _add(_add(change, kind, targetId=target), field, value)


def _link(network_link: Element, href: str, seconds: int) -> None:
    link = _add(network_link, "Link")
    _add(link, "href", href)
    _add(link, "refreshMode", "onInterval")
    _add(link, "refreshInterval", seconds)
    _add(link, "viewRefreshMode", "never")


def _kml() -> Element:
    return Element(f"{{{NAMESPACES['']}}}kml")


def _add(parent: Element, name: str, text: object = None, **attributes: str) -> Element:
    """A child element ``name`` (``gx:`` for Google's extensions) holding ``text``."""
    prefix, _, local = name.rpartition(":")
    child = SubElement(parent, f"{{{NAMESPACES[prefix]}}}{local}", attributes)
    if text is not None:
        child.text = str(text)
    return child


def _number(value: float) -> str:
    """Seven decimals (a centimetre in degrees), without trailing zeros."""
    return f"{value:.7f}".rstrip("0").rstrip(".")


def _text(root: Element) -> str:
    return XML_DECLARATION + tostring(root, encoding="unicode")
