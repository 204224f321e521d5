"""The census map in Chromium: tracts across the demo wall, a group toggled by scanning
its code off the menu tile, and a balloon opened from a phone that closes by itself."""

from __future__ import annotations

import io
import itertools
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page, expect

from tag_service.verify import decode_image, module_boxes, symbol_damage
from tests.browser.conftest import (
    assert_applied_at_one_instant,
    open_tiles,
    serve,
    version_of,
)
from tests.conftest import walls_of
from wall_client.config import load_wall
from wall_client.layout import Rect, Wall, apply_affine
from webapp.apps.census_map.mapview import COLOURS
from webapp.choropleth.palettes import contrast_ratio
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, wait_until
from webapp.core.settings import CONTENT_DIR
from webapp.people.security import operator_token
from webapp.tags.schemas import LayoutInfo

DEMO = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
BALLOON_SECONDS = 5


@pytest.fixture
def census(
    tmp_path: Path, database_url: str, request: pytest.FixtureRequest
) -> Iterator[ServerProcess]:
    """A server whose demo wall shows the census map, balloons closing after 5 s."""
    process = serve(
        tmp_path,
        database_url,
        walls_of(request),
        TAGWALL_BALLOON_SECONDS=str(BALLOON_SECONDS),
    )
    process.change("demo", {"app": "census"})
    yield process
    process.stop()


def screenshot(page: Page) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(page.screenshot(type="png"))).convert("RGB"))


def brown_share(page: Page) -> float:
    """The share of the tile covered by tract fill (brown over the dark background)."""
    picture = screenshot(page).astype(int)
    r, g, b = picture[..., 0], picture[..., 1], picture[..., 2]
    return float(((r > g + 15) & (g > b) & (r > 60)).mean())


def light_share(page: Page) -> float:
    """The share of the tile that is near white: codes, and balloons' boxes."""
    return float((screenshot(page).min(axis=2) > 235).mean())


def tract_codes(layout: LayoutInfo) -> set[str]:
    """The codes standing on the map (not on the menu or registration screen)."""
    return {c.code for c in layout.placed if c.display not in ("r1c3", "r2c1")}


def map_query(state: dict[str, Any]) -> dict[str, Any]:
    """What a tile asks for its share of the map (and its colouring) in ``state``."""
    cx, cy = state["view"]["center"]
    zoom = state["view"]["zoom"]
    return {
        "dataset": state["apps"]["census"]["dataset"],
        "layout": state["tag_layout"],
        "cx": cx,
        "cy": cy,
        "zoom": zoom,
    }


def shown(page: Page, key: str) -> str:
    return str(page.evaluate(f"document.body.dataset.{key} || ''"))


def test_a_scanned_toggle_hides_its_group_on_every_tile_at_once(
    browser: Browser, census: ServerProcess
) -> None:
    tiles = dict(zip(DEMO, open_tiles(browser, census, "demo", DEMO, native=True), strict=True))
    version = census.version("demo")
    wait_until(
        lambda: all(version_of(t) == version and shown(t, "census") for t in tiles.values()),
        what="every tile to draw its share of the map",
    )
    assert brown_share(tiles["r2c2"]) > 0.02, "tracts are drawn"
    _, layout = fetch_layout(census.url, "demo", operator_token(census.secret))
    toggles = {c.payload: c.label for c in layout.placed if c.display == "r1c3"}
    decoded = {d.payload for d in decode_image(Image.fromarray(screenshot(tiles["r1c3"])))}
    assert len(toggles) == 10 and set(toggles) <= decoded, "the menu tile shows its codes"
    # the group holding the most tracts of the middle of the map: downtown Sacramento
    toggle = next(p for p, label in toggles.items() if label.startswith("0001"))
    before = {tile: brown_share(page) for tile, page in tiles.items()}

    phone = browser.new_context(**PHONE).new_page()
    phone.goto(toggle)
    expect(phone.locator("#outcome")).to_have_text("Hidden on the wall now.")

    changed = census.version("demo")
    assert changed > version
    wait_until(
        lambda: all(version_of(t) == changed for t in tiles.values()), what="tiles to apply it"
    )
    group = shown(tiles["r1c1"], "hiddenGroups")
    assert group.startswith("tracts-0001-") and all(
        shown(t, "hiddenGroups") == group for t in tiles.values()
    )
    assert_applied_at_one_instant(census, "demo", changed, 6)
    after = {tile: brown_share(page) for tile, page in tiles.items()}
    assert sum(after.values()) < sum(before.values()), "its tracts are gone from the wall"

    phone.goto(toggle)
    expect(phone.locator("#outcome")).to_have_text("Shown on the wall now.")
    wait_until(lambda: all(shown(t, "hiddenGroups") == "" for t in tiles.values()), what="back")
    phone.context.close()
    for page in tiles.values():
        page.context.close()


def test_a_balloon_opened_from_a_phone_shows_and_closes_by_itself(
    browser: Browser, census: ServerProcess
) -> None:
    tiles = dict(zip(DEMO, open_tiles(browser, census, "demo", DEMO), strict=True))
    version = census.version("demo")
    wait_until(lambda: all(version_of(t) == version for t in tiles.values()), what="tiles up")
    light = {tile: light_share(page) for tile, page in tiles.items()}  # codes are white too
    phone = browser.new_context(**PHONE).new_page()
    phone.goto(f"{census.url}/apps/census/demo/tracts")
    phone.locator("details.tract-group").first.locator("summary").click()
    phone.locator("ul.tract-list a").first.click()
    expect(phone.locator("#show-on-wall")).to_be_visible()
    phone.locator("#show-on-wall").click()
    expect(phone.locator("#outcome")).to_contain_text(f"on the wall for {BALLOON_SECONDS} seconds")

    [balloon] = census.status("demo")["state"]["balloons"]
    wait_until(
        lambda: all(shown(t, "balloons") == balloon["id"] for t in tiles.values()),
        what="every tile to show the balloon",
    )
    x, y, w, h = balloon["rect"]
    wall = census.status("demo")
    assert wall["state"]["balloons"][0]["title"].startswith("Tract ")
    holder = next(
        tile
        for tile in DEMO
        if tiles[tile].evaluate(
            "([x, y]) => { const v = JSON.parse(document.body.dataset.viewport);"
            " const [sx, sy, sw, sh] = v.scene_rect;"
            " return x >= sx && x < sx + sw && y >= sy && y < sy + sh; }",
            [x + w / 2, y + h / 2],
        )
    )
    assert light_share(tiles[holder]) > light[holder] + 0.005, "the balloon's box is on its tile"

    wait_until(
        lambda: all(shown(t, "balloons") == "" for t in tiles.values()),
        timeout=BALLOON_SECONDS + 10,
        what="the balloon to close on every tile",
    )
    assert light_share(tiles[holder]) == pytest.approx(light[holder], abs=0.001), "it is gone"
    phone.context.close()
    for page in tiles.values():
        page.context.close()


def test_the_instructor_zooms_from_the_dashboard_and_codes_follow(
    browser: Browser, census: ServerProcess
) -> None:
    tiles = dict(zip(DEMO, open_tiles(browser, census, "demo", DEMO), strict=True))
    version = census.version("demo")
    wait_until(lambda: all(version_of(t) == version for t in tiles.values()), what="tiles up")
    _, before = fetch_layout(census.url, "demo", operator_token(census.secret))
    dashboard = browser.new_page()
    dashboard.goto(f"{census.url}/login/operator?token={operator_token(census.secret)}")
    expect(dashboard.locator("#census-groups li")).to_have_count(10)

    for step in (1, 2):  # each step from the view the dashboard was last told of
        dashboard.locator('#census-panel [data-zoom="1.5"]').click()
        wait_until(
            lambda step=step: census.status("demo")["state"]["view"]["zoom"] == 1.5**step,
            what=f"zoom step {step}",
        )
        wait_until(
            lambda: dashboard.locator("#version").inner_text() == str(census.version("demo")),
            what="the dashboard to see the change",
        )

    assert census.status("demo")["state"]["view"]["zoom"] == 2.25
    zoomed = census.version("demo")
    wait_until(lambda: all(version_of(t) == zoomed for t in tiles.values()), what="tiles to follow")
    assert_applied_at_one_instant(census, "demo", zoomed, 6)
    _, after = fetch_layout(census.url, "demo", operator_token(census.secret))
    assert len(tract_codes(after)) > len(tract_codes(before)), "more tracts carry codes"
    dashboard.close()
    for page in tiles.values():
        page.context.close()


def intact_codes(page: Page, layout: LayoutInfo, wall: Wall, tile: str) -> dict[str, str]:
    """Each code on ``tile`` whose pixels differ from its symbol, with how (none: every
    code intact, quiet zone included)."""
    picture = screenshot(page)
    to_pixels = wall.viewport(tile).to_pixels
    damaged = {}
    for code in (c for c in layout.placed if c.display == tile):
        damage = symbol_damage(
            picture, module_boxes(to_pixels, code.rect, code.modules), code.matrix
        )
        if not damage.intact:
            damaged[code.label] = f"{damage.damaged} modules, quiet zone {damage.dirty_quiet}"
    return damaged


def test_balloons_leave_every_code_on_the_wall_intact(
    browser: Browser, tmp_path: Path, database_url: str
) -> None:
    """Zoomed in, tracts carry their own codes on their label points; their balloons
    point at the tract beside the code, and box, pointer and dot leave every code's
    modules, quiet zone and caption as they were (the tiles' pixels, module by module)."""
    server = serve(tmp_path, database_url, TAGWALL_BALLOON_SECONDS="600")
    try:
        server.change("demo", {"app": "census"})
        server.change("demo", {"view": {"center": [0.5, 0.5], "zoom": 3}})
        _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
        tags = httpx.get(f"{server.url}/api/walls/demo/tags", headers=server.operator()).json()
        on_wall = {c.code for c in layout.placed}
        geoids = sorted(
            t["params"]["geoid"] for t in tags if t["action"] == "tract" and t["code"] in on_wall
        )
        assert len(geoids) >= 4
        phone = browser.new_context(**PHONE).new_page()
        for geoid in geoids[:4]:
            phone.goto(f"{server.url}/apps/census/demo/tracts/{geoid}")
            phone.locator("#show-on-wall").click()
            expect(phone.locator("#outcome")).to_contain_text("on the wall for 600 seconds")
        phone.context.close()
        version = server.version("demo")
        balloons = server.status("demo")["state"]["balloons"]
        assert len(balloons) == 4
        tiles = dict(zip(DEMO, open_tiles(browser, server, "demo", DEMO, native=True), strict=True))
        wait_until(
            lambda: all(
                version_of(t) == version and len(shown(t, "balloons").split()) == 4
                for t in tiles.values()
            ),
            what="every tile to show the four balloons",
        )
        wall = load_wall(CONTENT_DIR / "walls" / "demo.toml")
        damaged = {tile: intact_codes(page, layout, wall, tile) for tile, page in tiles.items()}
        assert damaged == {tile: {} for tile in DEMO}
        for balloon in balloons:  # and the balloons are there: their boxes are light
            x, y, w, h = balloon["rect"]
            viewport = next(
                v
                for d in wall.displays
                if (v := wall.viewport(d.id)).scene_rect.contains(Rect(x, y, w, h))
            )
            left, top = (round(v) + 4 for v in apply_affine(viewport.to_pixels, x, y))
            right, bottom = (round(v) - 4 for v in apply_affine(viewport.to_pixels, x + w, y + h))
            inside = screenshot(tiles[viewport.display_id])[top:bottom, left:right]
            assert (inside.min(axis=2) > 200).mean() > 0.7, balloon["id"]
        for page in tiles.values():
            page.context.close()
    finally:
        server.stop()


def test_tract_outlines_stand_out_from_the_fill_on_a_tile(
    browser: Browser, census: ServerProcess
) -> None:
    """On a tile as people see it: the pixels on tract outlines against the fill a few
    pixels to either side, at the middle of every outline edge long enough to measure,
    reach WCAG's 3:1 for non-text contrast (the median; most edges well above)."""
    [tile] = open_tiles(browser, census, "demo", ["r2c2"], native=True)
    version = census.version("demo")
    wait_until(lambda: version_of(tile) == version and shown(tile, "census"), what="the map")
    picture = screenshot(tile).astype(float)
    state = census.status("demo")["state"]
    view = httpx.get(
        f"{census.url}/api/apps/census/walls/demo/tiles/r2c2", params=map_query(state)
    ).json()
    fill = np.array([int(COLOURS["fill"][i : i + 2], 16) for i in (1, 3, 5)])
    height, width = picture.shape[:2]
    ratios = []
    for tract in view["tracts"]:
        for ring in tract["rings"]:
            points = np.reshape(ring, (-1, 2)).astype(float)
            for a, b in itertools.pairwise(points):
                length = float(np.hypot(*(b - a)))
                if length < 12:
                    continue
                middle, normal = (a + b) / 2, np.array([a[1] - b[1], b[0] - a[0]]) / length
                x, y = np.rint(middle).astype(int)
                sides = [np.rint(middle + s * 6 * normal).astype(int) for s in (-1, 1)]
                if not all(0 <= px < width and 0 <= py < height for px, py in [(x, y), *sides]):
                    continue
                for sx, sy in sides:
                    beside = picture[sy, sx]
                    if np.abs(beside - fill).max() < 12:  # a tract's fill, not a code or label
                        ratios.append(contrast_ratio(picture[y, x], beside))
    assert len(ratios) > 200
    assert float(np.median(ratios)) >= 3.0, np.percentile(ratios, [10, 50, 90])
    tile.context.close()


@pytest.mark.walls("demo", "kl-3x3")
def test_menu_labels_leave_the_toggle_codes_intact_on_kl_3x3(
    browser: Browser, census: ServerProcess
) -> None:
    """The KL wall's menu screens hold the group toggles two rows deep; each toggle's
    label ("0072-0080 · shown") stands in its caption strip and never over the code
    below or beside it, in every census view and with groups hidden."""
    census.change("kl-3x3", {"app": "census"})
    wall = load_wall(CONTENT_DIR / "walls" / "kl-3x3.toml")
    menus = [d.id for d in wall.screen("menu")]
    tiles = dict(zip(menus, open_tiles(browser, census, "kl-3x3", menus), strict=True))
    for page, display in zip(tiles.values(), menus, strict=True):
        width, height = wall.display(display).resolution
        page.set_viewport_size({"width": width, "height": height})
    views = [
        {},
        {"view": {"center": [0.4, 0.6], "zoom": 2}},
        {"layers": {"tracts-0072-0080": False, "tracts-0001-0038": False}},
    ]
    for patch in views:
        version = census.change("kl-3x3", patch) if patch else census.version("kl-3x3")
        wait_until(lambda v=version: all(version_of(t) == v for t in tiles.values()), what="tiles")
        _, layout = fetch_layout(census.url, "kl-3x3", operator_token(census.secret))
        toggles = [c for c in layout.placed if c.display in menus]
        assert len(toggles) == 10
        damaged = {tile: intact_codes(page, layout, wall, tile) for tile, page in tiles.items()}
        assert damaged == {tile: {} for tile in menus}, patch
    for page in tiles.values():
        page.context.close()


LABEL = np.array([0xF5, 0xE6, 0xD0])  # tract numbers (census_map/static/census.js)
PORTRAIT_VIEW = {"center": [1.7, 0.45], "zoom": 1.5}  # the map across the portrait panel


def best_overlap(seen: np.ndarray, expected: np.ndarray) -> float:
    """How well a mask matches ``expected`` (intersection over union) at the best of
    the shifts of up to 2 px the 4 px larger ``seen`` allows (text lands on whole
    pixels differently)."""
    h, w = expected.shape
    return max(
        float((part & expected).sum() / (part | expected).sum())
        for dy in range(5)
        for dx in range(5)
        if (part := seen[dy : dy + h, dx : dx + w]) is not None
    )


def test_tract_numbers_and_captions_read_upright_as_the_portrait_panel_hangs(
    browser: Browser, tmp_path: Path, database_url: str
) -> None:
    """The irregular wall's portrait panel is turned 90 degrees: its screenshot, turned
    the way the panel hangs, shows each tract number and each code's caption
    ("Student", "Instructor", "Tract index") as the same text written upright (not
    sideways, not upside down)."""
    server = serve(tmp_path, database_url, ("demo", "irregular"))
    try:
        server.change("irregular", {"app": "census"})
        version = server.change("irregular", {"view": PORTRAIT_VIEW})
        [tile] = open_tiles(browser, server, "irregular", ["portrait"], native=True)
        wait_until(lambda: version_of(tile) == version and shown(tile, "census"), what="the map")
        state = server.status("irregular")["state"]
        (cx, cy), zoom = PORTRAIT_VIEW["center"], PORTRAIT_VIEW["zoom"]
        query = {"dataset": state["apps"]["census"]["dataset"], "layout": state["tag_layout"]}
        share = httpx.get(
            f"{server.url}/api/apps/census/walls/irregular/tiles/portrait",
            params={**query, "cx": cx, "cy": cy, "zoom": zoom},
        ).json()
        labels = [
            t for t in share["tracts"] if not t["code"] and t["label_clear"] and len(t["label"]) > 3
        ]
        # each number written upright in the tile's font, as a mask
        references = tile.evaluate(
            """([labels, size]) => labels.map(([text, room]) => {
              const probe = new OffscreenCanvas(1, 1).getContext("2d");
              probe.font = `bold ${Math.round(size)}px sans-serif`;
              const width = Math.ceil(probe.measureText(text).width);
              if (width > 2 * room) return null;  // the tile leaves it out
              const [w, h] = [width + 8, Math.ceil(size * 1.6)];
              const ctx = new OffscreenCanvas(w, h).getContext("2d");
              ctx.font = probe.font;
              ctx.textAlign = "center";
              ctx.textBaseline = "middle";
              ctx.fillText(text, w / 2, h / 2);
              const alpha = ctx.getImageData(0, 0, w, h).data.filter((_, i) => i % 4 === 3);
              return [w, h, Array.from(alpha, (a) => (a > 128 ? 1 : 0))];
            })""",
            [[[t["label"], t["room"]] for t in labels], share["label_px"]],
        )
        framebuffer = screenshot(tile).astype(int)
        height = framebuffer.shape[0]
        hung = np.rot90(framebuffer, k=-1)  # turned clockwise: the panel as it hangs
        scores = []
        for tract, reference in zip(labels, references, strict=True):
            if reference is None:
                continue
            w, h, bits = reference
            expected = np.array(bits, dtype=bool).reshape(h, w)
            x, y = tract["at"]
            hx, hy = height - 1 - round(y), round(x)  # where the framebuffer point hangs
            top, left = hy - h // 2 - 2, hx - w // 2 - 2
            crop = hung[top : top + h + 4, left : left + w + 4]
            if top < 0 or left < 0 or crop.shape[:2] != (h + 4, w + 4):
                continue  # cut by the display's edge
            seen = np.abs(crop - LABEL).sum(axis=2) < 120
            upright = best_overlap(seen, expected)
            upside_down = best_overlap(seen[::-1, ::-1], expected)
            scores.append((tract["label"], round(upright, 2), round(upside_down, 2)))
        assert len(scores) >= 5, f"tract numbers on the portrait panel: {scores}"
        assert all(up > 0.6 and up > down + 0.2 for _, up, down in scores), scores

        # the codes' captions, each as the tile's own drawCaption writes it upright
        _, layout = fetch_layout(server.url, "irregular", operator_token(server.secret))
        captioned = [c for c in layout.placed if c.display == "portrait" and c.caption]
        assert {"Student", "Instructor", "Tract index"} <= {c.label for c in captioned}
        to_pixels = (
            load_wall(CONTENT_DIR / "walls" / "irregular.toml").viewport("portrait").to_pixels
        )
        framed = np.pad(hung.min(axis=2) > 200, 2)  # white text; strips reach the edges
        scores = []
        for code in captioned:
            assert code.caption is not None
            x, y, w, h = code.caption
            (x0, y0), (x1, y1) = (apply_affine(to_pixels, *p) for p in ((x, y), (x + w, y + h)))
            left, top = round(min(x0, x1)), round(min(y0, y1))
            width, tall = round(max(x0, x1)) - left, round(max(y0, y1)) - top
            # the strip as it hangs: framebuffer (x, y) hangs at (height - 1 - y, x)
            hx, hy, hw, hh = height - top - tall, left, tall, width
            bits = tile.evaluate(
                """async ([text, w, h]) => {
                  const {drawCaption} = await import("/static/js/codes.js");
                  const ctx = new OffscreenCanvas(w, h).getContext("2d");
                  drawCaption(ctx, text, [0, 0, w, h], 0);
                  const data = ctx.getImageData(0, 0, w, h).data;
                  return Array.from(data.filter((_, i) => i % 4 === 1), (g) => (g > 200 ? 1 : 0));
                }""",
                [code.label, hw, hh],
            )
            expected = np.array(bits, dtype=bool).reshape(hh, hw)
            seen = framed[hy : hy + hh + 4, hx : hx + hw + 4]
            upright = best_overlap(seen, expected)
            upside_down = best_overlap(seen[::-1, ::-1], expected)
            scores.append((code.label, round(upright, 2), round(upside_down, 2)))
        assert all(up > 0.6 and up > down + 0.2 for _, up, down in scores), scores
        tile.context.close()
    finally:
        server.stop()


def colour_share(picture: np.ndarray, hex_colour: str, within: int = 24) -> float:
    target = np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)])
    return float((np.abs(picture.astype(int) - target).sum(axis=2) <= within).mean())


def colour_wall(server: ServerProcess, theme: dict[str, object] | None) -> None:
    httpx.post(
        f"{server.url}/api/apps/census/walls/demo/theme",
        json={"theme": theme},
        headers=server.operator(),
    ).raise_for_status()


def legend_picture(server: ServerProcess, tiles: dict[str, Page], wall: Wall) -> np.ndarray:
    """The legend as its tile shows it, cut out of the tile's screenshot."""
    state = server.status("demo")["state"]
    body = httpx.get(
        f"{server.url}/api/apps/census/walls/demo/tiles/r1c1/theme",
        params={**map_query(state), **state["apps"]["census"]["theme"]},
    ).json()
    x, y, w, h = body["legend"]["rect"]
    [display] = [d for d in wall.displays if d.rect.intersects(Rect(x, y, w, h))]
    to_pixels = wall.viewport(display.id).to_pixels
    (left, top), (right, bottom) = (
        apply_affine(to_pixels, x, y),
        apply_affine(to_pixels, x + w, y + h),
    )
    picture = screenshot(tiles[display.id])
    return picture[round(top) : round(bottom), round(left) : round(right)]


def test_colouring_the_wall_by_a_value_reaches_every_tile_in_the_same_frame(
    browser: Browser, census: ServerProcess
) -> None:
    """The instructor colours the map by household income, then by housing value: each
    time every tile swaps in the same frame, the tracts take the classes' colours and
    the legend stands on the registration screen; back to plain, the brown returns."""
    wall = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    tiles = dict(zip(DEMO, open_tiles(browser, census, "demo", DEMO, native=True), strict=True))
    version = census.version("demo")
    wait_until(
        lambda: all(version_of(t) == version and shown(t, "census") for t in tiles.values()),
        what="every tile to draw its share of the map",
    )
    assert colour_share(screenshot(tiles["r2c2"]), COLOURS["fill"], 8) > 0.02

    income = {"attribute": "HH_INC", "scheme": "YlOrRd", "method": "quantiles", "classes": 5}
    housing = {"attribute": "HSG_VAL", "scheme": "PuOr", "method": "natural", "classes": 7}
    # the classes' colours; on the map, those of classes holding many tracts (the one
    # tract valued at a million or more may lie off these two displays)
    for theme, mark, colours, on_map in (
        (income, "HH_INC 5", ["#ffffb2", "#fecc5c", "#fd8d3c", "#f03b20", "#bd0026"], 5),
        (housing, "HSG_VAL 7", ["#b35806", "#f1a340", "#fee0b6", "#998ec3", "#542788"], 4),
    ):
        colour_wall(census, theme)
        changed = census.version("demo")
        wait_until(
            lambda: all(version_of(t) == changed for t in tiles.values()),  # noqa: B023
            what="every tile to apply the colouring",
        )
        assert all(shown(t, "censusTheme") == mark for t in tiles.values())
        assert_applied_at_one_instant(census, "demo", changed, 6)
        map_tiles = [screenshot(tiles[t]) for t in ("r2c2", "r2c3")]
        assert colour_share(map_tiles[0], COLOURS["fill"], 8) < 0.0005, "no tract is left brown"
        for hex_colour in colours[:on_map]:
            assert any(colour_share(p, hex_colour) > 0.0005 for p in map_tiles), hex_colour
        legend = legend_picture(census, tiles, wall)
        assert legend.size and colour_share(legend, "#e6e6e6", 60) > 0.01, "its text"
        for hex_colour in colours:
            assert colour_share(legend, hex_colour, 8) > 0.002, f"a swatch of {hex_colour}"

    colour_wall(census, None)
    plain = census.version("demo")
    wait_until(lambda: all(version_of(t) == plain for t in tiles.values()), what="plain again")
    assert colour_share(screenshot(tiles["r2c2"]), COLOURS["fill"], 8) > 0.02
    assert all(shown(t, "censusTheme") == "" for t in tiles.values())
    for page in tiles.values():
        page.context.close()
