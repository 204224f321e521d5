"""The legend of the wall's colouring: where it stands and what tiles are sent."""

from __future__ import annotations

import pytest

from tests.webapp.apps.census_map.conftest import sacramento
from wall_client.config import load_walls
from wall_client.layout import Rect, Wall
from webapp.apps.census_map.legend import LEGEND_SCALES, legend_rect, theme_view
from webapp.apps.census_map.mapview import label_mm
from webapp.apps.census_map.theme import shade
from webapp.choropleth.classes import Theme
from webapp.core.settings import CONTENT_DIR


@pytest.fixture(scope="module")
def walls() -> dict[str, Wall]:
    return load_walls([CONTENT_DIR / "walls"])


def covering(wall: Wall, *display_ids: str) -> list[Rect]:
    """Codes filling these displays."""
    return [wall.display(d).rect for d in display_ids]


def on_display(wall: Wall, rect: tuple[float, float, float, float]) -> str:
    box = Rect(*rect)
    [display] = [d for d in wall.displays if d.rect.intersects(box)]
    assert display.rect.x <= box.x and box.right <= display.rect.right
    assert display.rect.y <= box.y and box.bottom <= display.rect.bottom
    return display.id


def test_the_legend_stands_on_the_menu_screen_as_large_as_it_fits(walls: dict[str, Wall]) -> None:
    wall = walls["demo"]
    found = legend_rect(wall, [(600.0, 400.0), (300.0, 200.0)], [])
    assert found is not None
    rect, size = found
    assert on_display(wall, rect) == "r1c3" and size == 0
    menu = wall.display("r1c3").rect
    assert rect[0] - menu.x < 20 and menu.bottom - (rect[1] + rect[3]) < 20, "bottom left"


def test_a_full_menu_screen_sends_the_legend_to_the_registration_screen(
    walls: dict[str, Wall],
) -> None:
    wall = walls["demo"]
    found = legend_rect(wall, [(300.0, 200.0)], covering(wall, "r1c3"))
    assert found is not None and on_display(wall, found[0]) == "r2c1"


def test_then_over_the_map_but_never_on_the_public_screen(walls: dict[str, Wall]) -> None:
    wall = walls["demo"]
    found = legend_rect(wall, [(300.0, 200.0)], covering(wall, "r1c3", "r2c1"))
    assert found is not None and on_display(wall, found[0]) not in {"r1c2", "r1c3", "r2c1"}
    everything = covering(wall, *(d.id for d in wall.displays if d.id != "r1c2"))
    assert legend_rect(wall, [(300.0, 200.0)], everything) is None


def test_over_the_map_only_where_no_other_display_has_room(walls: dict[str, Wall]) -> None:
    wall = walls["demo"]
    full_panels = covering(wall, "r1c3", "r2c1")
    found = legend_rect(wall, [(300.0, 200.0)], full_panels, covering(wall, "r1c1", "r2c2"))
    assert found is not None and on_display(wall, found[0]) == "r2c3", "off the map"
    everywhere = covering(wall, "r1c1", "r2c2", "r2c3")
    found = legend_rect(wall, [(300.0, 200.0)], full_panels, everywhere)
    assert found is not None and on_display(wall, found[0]) == "r1c1", "over it, but shown"


@pytest.mark.parametrize("wall_id", ["demo", "hiperwall", "kl-3x3", "irregular"])
def test_tiles_get_every_tract_s_class_and_a_legend_clear_of_codes(
    walls: dict[str, Wall], wall_id: str
) -> None:
    wall = walls[wall_id]
    dataset = sacramento()
    shading = shade(dataset, Theme(attribute="HSG_VAL", classes=7))
    codes = covering(wall, *(d.id for d in wall.screen("menu")))
    view = theme_view(shading, dataset.id, [t.geoid for t in dataset.tracts], wall, codes)
    assert len(view.tracts) == 403 and list(view.tracts.values()).count(-1) == 3
    assert [row.fill for row in view.classes] == [band.colour for band in shading.bands]
    assert (
        view.legend.rows[-1].stripe is not None
        and "no value · 3 tracts" in view.legend.rows[-1].text
    )
    assert view.legend.rect is not None
    assert on_display(wall, view.legend.rect) not in {d.id for d in wall.screen("public")}
    assert not any(Rect(*view.legend.rect).intersects(code) for code in codes)
    assert view.legend.font_mm in {label_mm(wall) * scale for scale in LEGEND_SCALES}
