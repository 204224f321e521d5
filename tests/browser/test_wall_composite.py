"""One scene on every tile: each tile's screenshot at native size, put into wall
coordinates (rotation and bezels as the server's viewports say), against the overview
drawn at the same scale. Every pin head and line, code, caption, balloon, label,
class colour and legend on one must be on the other, for every app and view preset
(and the census map coloured by a value), on the demo wall, the
irregular wall (a portrait panel) and a block of HIPerWall tiles.

The volume raster may differ in detail (the overview gets the quick fallback image), so
the comparison looks at the overlay's distinctive colours only: masks per colour,
counted on a grid of small cells, each cell on one side needing a marked cell within
one cell on the other side.
"""

from __future__ import annotations

import io
import json
import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import numpy.typing as npt
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page

from tests.browser.conftest import serve, version_of
from wall_client.layout import Affine, compose_affine, invert_affine
from webapp.apps.brain_atlas.views import load_views
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, wait_until
from webapp.people.security import operator_token

Mask = npt.NDArray[np.bool_]
RGB = npt.NDArray[np.int16]

CELL = 6  # overview px: a feature counts where it marks a cell
EDGE = 5  # overview px along each display's edge where a mark need not be matched: a
# sliver of a line, a head or a number there renders unequally at the overview's scale
# (which draws pins at least 2 px wide, so a pin just off a display peeks in)


@dataclass(frozen=True)
class Feature:
    mask: Callable[[RGB], Mask]
    least: int = 2  # overview px of it that mark a cell
    least_tile: int = 6  # native tile px that do (about one overview px at these scales)
    near_share: float = 1.0  # of those, what counts as the nearby mark a mark needs
    on_panels: bool = True  # compared on the designated screens too


@dataclass(frozen=True)
class WallCase:
    wall: str
    tiles: tuple[str, ...] | None  # None: every display
    scale: float  # overview px per wall mm (roughly: the page fits the wall)
    zoomed: tuple[tuple[float, float], float] = ((0.5, 0.5), 2.25)  # a census view: centre, zoom


WALLS = (
    WallCase("demo", None, 0.4),
    WallCase("irregular", None, 0.4, zoomed=((1.7, 0.45), 1.5)),  # the map on the portrait
    # the middle of the stage, where the brain's pins stand, and the east of the census
    # map (fitted to the free displays, it stands left of the stage's middle)
    WallCase("hiperwall", ("r3c4", "r3c5", "r3c6", "r4c4", "r4c5", "r4c6"), 0.3),
)
# Every case shares the module's one server and tile pages: one worker runs them all.
pytestmark = pytest.mark.xdist_group("wall-composite")

PRESETS = [preset.id for preset in load_views()]
WHOLE = {"center": [0.5, 0.5], "zoom": 1.0}
SCENES = [
    "pattern",
    "census",
    "census-zoomed-balloon",
    "census-coloured",
    *(f"brain-{preset}" for preset in PRESETS),
    "brain-left-side-k5",
]


def colour(hex_colour: str) -> npt.NDArray[np.int16]:
    return np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)], dtype=np.int16)


def near(rgb: RGB, hex_colour: str, within: int) -> Mask:
    return np.asarray(np.abs(rgb - colour(hex_colour)).sum(axis=2) <= within)


def tract_label(rgb: RGB) -> Mask:
    """Tract numbers (#f5e6d0), also where small text blends them with the map's brown:
    light, warm, neither white nor grey (codes' edges) nor the brain's tissue."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return np.asarray(
        (r > 140) & (g > 0.84 * r) & (b > 0.68 * r) & (r - b > 25) & (rgb.min(axis=2) < 235)
    )


# The overlay's colours (static/js/codes.js, census.js, balloons.js, scene.js).
FEATURES = {
    "pin": Feature(lambda rgb: near(rgb, "#e63946", 45), least=1),
    "caption backing": Feature(lambda rgb: near(rgb, "#10161f", 4)),
    # codes' light modules and quiet zones, caption text, balloons, the pattern's labels
    "light": Feature(lambda rgb: np.asarray(rgb.min(axis=2) >= 235)),
}
# Tract numbers are compared where the map is shown: on a designated screen the panel's
# text (the menu's caption) crosses tract outlines over the zoomed map, and at the
# overview's scale their blend takes a tract number's colour.
CENSUS_FEATURES = {
    **FEATURES,
    "tract label": Feature(tract_label, least_tile=16, on_panels=False),
}
# The coloured map (YlOrRd, five classes): its lightest and darkest classes where they
# cover much of a cell (a sixth of the overview's, 400 native px: most of a demo cell, a
# sixth of a HIPerWall one), near a cell they cover at least a little on the other side
# (the overview blends the smallest tracts with their outlines), and the legend, on the
# captions' backing.
THEME = {"attribute": "HH_INC", "scheme": "YlOrRd", "method": "quantiles", "classes": 5}
COLOURED_FEATURES = {
    **{name: feature for name, feature in FEATURES.items() if name != "pin"},  # red classes
    "lightest class": Feature(lambda rgb: near(rgb, "#ffffb2", 30), 6, 400, near_share=0.25),
    "darkest class": Feature(lambda rgb: near(rgb, "#bd0026", 30), 6, 400, near_share=0.25),
}


@dataclass
class WallPages:
    info: dict[str, Any]  # the server's WallInfo: rects, to_wall, to_pixels
    tiles: dict[str, Page]
    overview: Page


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ServerProcess]:
    """One server for every wall (their states are separate); balloons stay open."""
    tmp = tmp_path_factory.mktemp("composite")
    process = serve(
        tmp,
        f"sqlite:///{tmp / 'tagwall.db'}",
        [case.wall for case in WALLS],
        TAGWALL_BALLOON_SECONDS="3600",
    )
    yield process
    process.stop()


@pytest.fixture(scope="module")
def walls(browser: Browser, server: ServerProcess) -> Iterator[Callable[[WallCase], WallPages]]:
    """A wall's tiles, in windows of their native resolution, and its overview at
    about the case's scale, opened on first use and kept for its scenes (the scenes
    of one wall run one after another)."""
    opened: dict[str, WallPages] = {}

    def open_wall(case: WallCase) -> WallPages:
        overview = browser.new_context(viewport={"width": 400, "height": 300}).new_page()
        overview.goto(f"{server.url}/wall/{case.wall}/overview")
        info = json.loads(str(overview.evaluate("document.body.dataset.wallInfo")))
        bar = int(overview.evaluate("document.querySelector('.bar').offsetHeight"))
        overview.set_viewport_size(
            {
                "width": round(info["width"] * case.scale),
                "height": round(info["height"] * case.scale) + bar,
            }
        )
        tiles = {}
        for display in info["displays"]:
            if case.tiles is not None and display["id"] not in case.tiles:
                continue
            width, height = display["resolution"]
            context = browser.new_context(
                viewport={"width": width, "height": height}, device_scale_factor=1
            )
            tiles[display["id"]] = page = context.new_page()
            page.goto(server.tile_url(case.wall, display["id"]))
        return WallPages(info, tiles, overview)

    def close() -> None:
        for pages in opened.values():
            for page in (*pages.tiles.values(), pages.overview):
                page.context.close()
        opened.clear()

    def get(case: WallCase) -> WallPages:
        if case.wall not in opened:
            close()
            opened[case.wall] = open_wall(case)
        return opened[case.wall]

    yield get
    close()


def brain(server: ServerProcess, wall: str, **choice: str) -> None:
    response = httpx.post(
        f"{server.url}/api/apps/brain/walls/{wall}",
        json=choice,
        headers=server.operator(),
        timeout=120,
    )
    response.raise_for_status()


def open_balloon(browser: Browser, server: ServerProcess, wall: str) -> str:
    """A phone opens the balloon of a tract that carries its own code on the wall now."""
    _, layout = fetch_layout(server.url, wall, operator_token(server.secret))
    tract = next(c for c in layout.placed if re.fullmatch(r"\d+(\.\d+)?", c.label))
    phone = browser.new_context(viewport={"width": 390, "height": 844}).new_page()
    phone.goto(tract.payload)
    phone.locator("#show-on-wall").click()
    phone.locator("#outcome").wait_for()
    phone.context.close()
    [balloon] = server.status(wall)["state"]["balloons"]
    return str(balloon["id"])


def show(browser: Browser, server: ServerProcess, case: WallCase, scene: str) -> str | None:
    """Put the scene up; returns the id of the balloon it opens (or None)."""
    wall = case.wall
    if scene == "pattern":
        server.change(wall, {"app": "pattern", "view": WHOLE, "balloons": []})
    elif scene.startswith("census"):
        zoomed = scene == "census-zoomed-balloon"
        centre, zoom = case.zoomed
        view = {"center": list(centre), "zoom": zoom} if zoomed else WHOLE
        server.change(wall, {"app": "census", "view": view, "balloons": []})
        theme = THEME if scene == "census-coloured" else None
        httpx.post(
            f"{server.url}/api/apps/census/walls/{wall}/theme",
            json={"theme": theme},
            headers=server.operator(),
        ).raise_for_status()
        return open_balloon(browser, server, wall) if zoomed else None
    else:
        server.change(wall, {"app": "brain", "balloons": []})
        preset = scene.removeprefix("brain-").removesuffix("-k5")
        brain(server, wall, preset=preset, tag_set="k5" if scene.endswith("-k5") else "full")
    return None


def map_to_overview(display: dict[str, Any], scale: float) -> Affine:
    """A tile's native pixels -> the overview canvas's pixels: back to scene mm, placed
    on the wall by to_wall, at the overview's scale."""
    to_scene = invert_affine(tuple(display["to_pixels"]))  # type: ignore[arg-type]
    on_wall = compose_affine(tuple(display["to_wall"]), to_scene)  # type: ignore[arg-type]
    return compose_affine((scale, 0.0, 0.0, scale, 0.0, 0.0), on_wall)


def cells_of_tile(mask: Mask, to_overview: Affine, grid: tuple[int, int]) -> npt.NDArray[Any]:
    """Per overview cell, how many native pixels of the tile's mask land in it."""
    counts = np.zeros(grid, dtype=np.int64)
    ys, xs = np.nonzero(mask)
    a, b, c, d, e, f = to_overview
    ox = (a * (xs + 0.5) + c * (ys + 0.5) + e) // CELL
    oy = (b * (xs + 0.5) + d * (ys + 0.5) + f) // CELL
    inside = (ox >= 0) & (oy >= 0) & (ox < grid[1]) & (oy < grid[0])
    np.add.at(counts, (oy[inside].astype(int), ox[inside].astype(int)), 1)
    return counts


def cells_of_overview(mask: Mask, grid: tuple[int, int]) -> npt.NDArray[Any]:
    h, w = grid
    padded = np.zeros((h * CELL, w * CELL), dtype=np.int64)
    part = mask[: h * CELL, : w * CELL]
    padded[: part.shape[0], : part.shape[1]] = part
    return padded.reshape(h, CELL, w, CELL).sum(axis=(1, 3))


def grown(cells: Mask) -> Mask:
    """The cells and their eight neighbours."""
    padded = np.pad(cells, 1)
    h, w = cells.shape
    out = np.zeros_like(cells)
    for dy in range(3):
        for dx in range(3):
            out |= padded[dy : dy + h, dx : dx + w]
    return out


def screenshot(page: Page, selector: str | None = None) -> RGB:
    target = page.locator(selector) if selector else page
    image = Image.open(io.BytesIO(target.screenshot(type="png"))).convert("RGB")
    return np.asarray(image).astype(np.int16)


@pytest.mark.parametrize(
    ("case", "scene"),
    [(case, scene) for case in WALLS for scene in SCENES],
    ids=[f"{case.wall}-{scene}" for case in WALLS for scene in SCENES],
)
def test_every_tile_shows_its_part_of_the_one_scene(
    browser: Browser,
    server: ServerProcess,
    walls: Callable[[WallCase], WallPages],
    case: WallCase,
    scene: str,
    tmp_path: Path,
) -> None:
    pages = walls(case)
    balloon = show(browser, server, case, scene)
    version = server.version(case.wall)
    everyone = [*pages.tiles.values(), pages.overview]
    wait_until(
        lambda: all(version_of(page) == version for page in everyone),
        timeout=120,
        what=f"{case.wall}: every tile and the overview to show version {version}",
    )
    if balloon is not None:
        wait_until(
            lambda: all(
                balloon in str(page.evaluate("document.body.dataset.balloons"))
                for page in pages.tiles.values()
            ),
            what="every tile to show the balloon",
        )

    overview = screenshot(pages.overview, "#scene canvas:not([hidden])")
    height, width, _ = overview.shape
    scale = min(width / pages.info["width"], height / pages.info["height"])
    grid = (height // CELL, width // CELL)
    # only the displays whose tiles are open take part (a block of the HIPerWall)
    shown = [d for d in pages.info["displays"] if d["id"] in pages.tiles]

    def on_displays(displays: list[dict[str, Any]], edge: int) -> Mask:
        """The overview's pixels on ``displays``, ``edge`` px in."""
        inside = np.zeros((height, width), dtype=bool)
        for display in displays:
            x, y, w, h = (round(v * scale) for v in display["rect"])
            inside[y + edge : y + h - edge, x + edge : x + w - edge] = True
        return inside

    shots = {tile: screenshot(page) for tile, page in pages.tiles.items()}

    def marks(feature: Feature, edge: int, share: float = 1.0) -> tuple[Mask, Mask]:
        """The cells the feature marks (``share`` of its least amounts) on the tiles and
        on the overview, leaving out ``edge`` overview px along each display's edges."""
        on_tiles = np.zeros(grid, dtype=np.int64)
        compared = [d for d in shown if feature.on_panels or not d["roles"]]
        for display in compared:
            _, _, w, h = display["rect"]
            native = math.ceil(edge / scale * math.sqrt(math.prod(display["resolution"]) / (w * h)))
            mask = feature.mask(shots[display["id"]])
            inner = np.zeros_like(mask)
            inner[native : mask.shape[0] - native, native : mask.shape[1] - native] = True
            on_tiles += cells_of_tile(mask & inner, map_to_overview(display, scale), grid)
        on_overview = cells_of_overview(feature.mask(overview) & on_displays(compared, edge), grid)
        return on_tiles >= feature.least_tile * share, on_overview >= feature.least * share

    problems = []
    features = {"census": CENSUS_FEATURES, "census-coloured": COLOURED_FEATURES}.get(
        scene.removesuffix("-zoomed-balloon"), FEATURES
    )
    for name, feature in features.items():
        # a mark well inside a display must be near a mark on the other side, anywhere
        tiles_inside, overview_inside = marks(feature, EDGE)
        tiles_any, overview_any = marks(feature, 0, feature.near_share)
        for where, missing in (
            ("the tiles", overview_inside & ~grown(tiles_any)),
            ("the overview", tiles_inside & ~grown(overview_any)),
        ):
            if missing.any():
                ys, xs = np.nonzero(missing)
                at = [
                    (round(x * CELL / scale), round(y * CELL / scale))
                    for y, x in zip(ys, xs, strict=True)
                ]
                problems.append(f"{name}: {len(at)} cells missing on {where}, at mm {at[:6]}")
    if problems:
        Image.fromarray(overview.astype(np.uint8)).save(tmp_path / "overview.png")
        for tile, shot in shots.items():
            Image.fromarray(shot.astype(np.uint8)).save(tmp_path / f"{tile}.png")
    assert not problems, f"{case.wall} {scene}: " + "; ".join(problems) + f" (images: {tmp_path})"
