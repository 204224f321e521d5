"""What tiles need to colour the map by the wall's theme: each tract's class, the
classes' colours, and the legend placed on the wall clear of every code."""

from __future__ import annotations

from collections.abc import Sequence

from pydantic import BaseModel

from tag_service.placement import place_box
from wall_client.layout import Rect, Wall
from webapp.apps.census_map.actions import CLEAR_PX, balloon_size
from webapp.apps.census_map.mapview import grown, label_mm
from webapp.apps.census_map.theme import Shading
from webapp.choropleth.classes import METHOD_NAMES, MISSING_FILL, MISSING_STRIPE, outline_for

SWATCH_CHARS = 6  # a row's swatch and the gap after it (census.js: 3 font sizes)
LEGEND_SCALES = (2.0, 1.5, 1.0)  # the legend's type, in tract-number heights, largest first


class LegendRow(BaseModel):
    fill: str
    line: str  # the outline drawn inside tracts of this fill
    stripe: str | None = None  # tracts without a value: striped
    text: str


class Legend(BaseModel):
    """The legend box (scene mm; None when the wall has no room for it) and its text,
    at the size of the tract numbers, read from the seats."""

    rect: tuple[float, float, float, float] | None
    font_mm: float
    title: str
    note: str
    rows: list[LegendRow]


class ThemeView(BaseModel):
    """``GET /api/apps/census/walls/{wall}/tiles/{tile}/theme``: the classes of the tracts
    (by GEOID; -1 for no value), how each class is drawn, and the legend."""

    dataset: int
    tracts: dict[str, int]
    classes: list[LegendRow]
    missing: LegendRow
    legend: Legend


def theme_view(
    shading: Shading,
    dataset_id: int,
    geoids: Sequence[str],
    wall: Wall,
    codes: Sequence[Rect],
    on_map: Sequence[Rect] = (),
) -> ThemeView:
    """The theme for tiles; ``codes``: the placed codes' footprints, which the legend
    keeps clear of; ``on_map``: the tracts' boxes, which it keeps off where it can."""
    classes = [
        LegendRow(
            fill=band.colour, line=band.line, text=f"{shading.band_range(i)} · {tracts(band.count)}"
        )
        for i, band in enumerate(shading.bands)
    ]
    missing = LegendRow(
        fill=MISSING_FILL,
        line=outline_for(MISSING_FILL),
        stripe=MISSING_STRIPE,
        text=f"no value · {tracts(shading.missing)}",
    )
    rows = classes + ([missing] if shading.missing else [])
    note = f"{len(shading.bands)} classes by {METHOD_NAMES[shading.theme.method]}"
    lines = [note, *(" " * SWATCH_CHARS + row.text for row in rows)]
    fonts = [label_mm(wall) * scale for scale in LEGEND_SCALES]
    sizes = [balloon_size(shading.title, lines, font) for font in fonts]
    rect, chosen = legend_rect(wall, sizes, codes, on_map) or (None, len(fonts) - 1)
    font = fonts[chosen]
    return ThemeView(
        dataset=dataset_id,
        tracts={geoid: shading.band_of.get(geoid, -1) for geoid in geoids},
        classes=classes,
        missing=missing,
        legend=Legend(rect=rect, font_mm=font, title=shading.title, note=note, rows=rows),
    )


def tracts(count: int) -> str:
    return f"{count} tract" if count == 1 else f"{count} tracts"


def legend_rect(
    wall: Wall,
    sizes: Sequence[tuple[float, float]],
    codes: Sequence[Rect],
    on_map: Sequence[Rect] = (),
) -> tuple[tuple[float, float, float, float], int] | None:
    """Where the legend stands and which of ``sizes`` (largest first) it takes: in the
    bottom-left corner of the menu screen, else of the registration screen, else of
    another display but the public screen, off the map (``on_map``: the tracts' boxes)
    where one has room, over it where none has; as large as the first display with
    room allows, clear of every code and its caption and a little inside the display's
    edge. None when no display has room even for the smallest."""
    margin = CLEAR_PX * max(d.mm_per_px for d in wall.displays)
    inset = label_mm(wall) / 2
    clear = [grown(code, margin) for code in codes]
    public = {d.id for d in wall.screen("public")}
    panels = [*wall.screen("menu"), *wall.screen("registration")]
    rest = [d for d in wall.displays if d not in panels and d.id not in public]
    tries = [(d, clear) for d in panels]
    tries += [(d, [*clear, *on_map]) for d in rest] + [(d, clear) for d in rest]
    for display, obstacles in tries:
        area = wall.viewport(display.id).scene_rect
        near = [o for o in obstacles if o.intersects(grown(area, margin))]
        for index, (width, height) in enumerate(sizes):
            padded = (width + 2 * inset, height + 2 * inset)
            box = place_box(wall, padded, (area.x, area.bottom), near, on=[display.id])
            if box is not None:
                return (box.x + inset, box.y + inset, width, height), index
    return None
