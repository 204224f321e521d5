"""The census map on a globe across whole walls (CesiumJS under Chromium's software GL):
every tile of the demo wall and of the irregular wall (a panel turned to portrait,
displays of two pixel pitches) at its native size, each held against one reference
picture of the whole wall drawn with the wall's one camera. Tract edges continue across
every bezel within 2 px, the codes decode from the screenshots, and a colouring, a
flight and a tour's steps reach every tile at one instant.

The reference is the tiles' own globe (``static/globe.js``) on a page whose one
"display" is the wall's whole scene at the finest tiles' pixels per mm: one frustum,
so one continuous picture, the bezels' share left out as the tiles leave it out. Each
tile's tract edges, put into the scene by the wall's geometry (the server's viewports,
as test_wall_composite.py composites the flat scene), must lie on the reference's along
both sides of every seam. Imagery is left out (its level of detail differs between a
tile and the reference): only the tract outlines are compared, read by their colour
between the fill and the outline's (the outlines are 1 px lines; the fill itself is one
flat colour), and codes, captions and pins are masked out.
"""

from __future__ import annotations

import base64
import io
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import numpy.typing as npt
import pytest
from PIL import Image, ImageDraw, ImageFilter
from playwright.sync_api import Browser, Page, expect

from tag_service.verify import decode_image
from tests.browser.conftest import (
    ONE_INSTANT_MS,
    assert_applied_at_one_instant,
    serve,
)
from tests.browser.test_census_globe import post, shows_globe
from tests.conftest import wall_files
from tests.webapp.apps.census_map.conftest import sacramento
from tests.webapp.apps.census_map.test_globe import neighbours
from wall_client.config import load_wall
from wall_client.layout import Affine, Wall, invert_affine
from webapp.apps.census_map.mapview import COLOURS
from webapp.cli.check import fetch_layout
from webapp.cli.testing import RECORD_SHOWN, ServerProcess, wait_until
from webapp.people.security import operator_token
from webapp.tags.schemas import PlacedCode

Mask = npt.NDArray[np.bool_]
Picture = npt.NDArray[np.uint8]

WITHIN_PX = 2.0  # the bound: a tile's tract edge from the one camera's, in tile pixels
SHARE = 0.97  # of a seam side's edge pixels within it (measured: 99-100 %)
BAND_PX = 160  # tile pixels along each side of a seam whose edges are compared
LEAST_EDGE_PX = 60  # a side of a seam with fewer outline pixels than this shows no tract
SEARCH_PX = 8  # how far an edge pixel's nearest counterpart is looked for
MASK_PX = 6  # around codes, captions and pins


@dataclass(frozen=True)
class Look:
    """Where the wall looks for the check (``POST .../fly``): a place and zoom at which
    tracts cross every seam of the wall (the fitted map at zoom 1 covers two displays
    of the demo wall, the other seams see only imagery)."""

    longitude: float
    latitude: float
    zoom: float


# The demo last: the colouring, flight and tour test that follows keeps its tiles open
# (a wall's six first globe frames are a minute of software GL).
LOOKS = {"irregular": Look(-121.4, 38.65, 4), "demo": Look(-121.15, 38.65, 5)}
# One server and its open tiles serve every test of the module: one worker runs them.
pytestmark = pytest.mark.xdist_group("census-globe-wall")


@dataclass
class GlobeWall:
    wall: Wall
    tiles: dict[str, Page]


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ServerProcess]:
    """Both walls on the census map's globe. Software GL prepares a globe picture in
    seconds, six at once in tens: the wall waits a minute for every tile's ready (a
    GPU's kiosk needs far less than the 3 s default), so changes swap at one instant."""
    tmp = tmp_path_factory.mktemp("globe-wall")
    process = serve(
        tmp, f"sqlite:///{tmp / 'tagwall.db'}", tuple(LOOKS), TAGWALL_SWAP_TIMEOUT_MS="60000"
    )
    for wall in LOOKS:
        process.change(wall, {"app": "census"})
        post(process, wall, "surface", {"surface": "globe"})
    yield process
    process.stop()


@pytest.fixture(scope="module")
def globe_walls(browser: Browser, server: ServerProcess) -> Iterator[Callable[[str], GlobeWall]]:
    """A wall's tiles, each in a window of its native resolution, opened on first use
    and kept for the tests of that wall."""
    opened: dict[str, GlobeWall] = {}

    def close() -> None:
        for globe_wall in opened.values():
            for page in globe_wall.tiles.values():
                page.context.close()
        opened.clear()

    def get(wall_id: str) -> GlobeWall:
        if wall_id not in opened:
            close()
            wall = load_wall(wall_files(wall_id)[0])
            tiles = {}
            for display in wall.displays:
                width, height = display.resolution
                context = browser.new_context(
                    viewport={"width": width, "height": height}, device_scale_factor=1
                )
                tiles[display.id] = page = context.new_page()
                page.goto(server.tile_url(wall_id, display.id))
                page.evaluate(RECORD_SHOWN)
            opened[wall_id] = GlobeWall(wall, tiles)
        return opened[wall_id]

    yield get
    close()


def on_globe(server: ServerProcess, wall: str) -> None:
    """The wall as the check wants it: on the globe at its look, plain, straight down
    (nothing changes when it already is)."""
    look = LOOKS[wall]
    post(server, wall, "camera", {"heading": 0, "tilt": 0})
    post(server, wall, "theme", {"theme": None})
    post(
        server,
        wall,
        "fly",
        {"longitude": look.longitude, "latitude": look.latitude, "zoom": look.zoom},
    )


def wait_shown(server: ServerProcess, globe_wall: GlobeWall, wall: str) -> int:
    """Every tile shows the wall's version on the globe; returns the version."""
    version = server.version(wall)
    wait_until(
        lambda: all(shows_globe(page, version) for page in globe_wall.tiles.values()),
        timeout=300,  # software GL, six tiles at once: a minute when loaded
        what=f"every tile of {wall} to show version {version} on the globe",
    )
    return version


def shoot(page: Page) -> Picture:
    return np.asarray(Image.open(io.BytesIO(page.screenshot(type="png"))).convert("RGB"))


def hex_rgb(name: str) -> npt.NDArray[np.float64]:
    return np.array([int(COLOURS[name][i : i + 2], 16) for i in (1, 3, 5)], dtype=float)


def outlines(picture: Picture) -> Mask:
    """The tract outlines: pixels whose colour lies between the fill and the outline's
    (a 1 px line covers a pixel by a quarter to all of it, multisampled), a quarter of
    the way or more; the imagery's colours lie off that line."""
    fill, line = hex_rgb("fill"), hex_rgb("outline")
    towards = line - fill
    offset = picture.astype(float) - fill
    along = (offset @ towards) / (towards @ towards)
    off = np.linalg.norm(offset - along[..., None] * towards, axis=2)
    return np.asarray((along >= 0.2) & (along <= 1.2) & (off <= 20))


def apply(affine: Affine, xs: npt.NDArray[Any], ys: npt.NDArray[Any]) -> tuple[Any, Any]:
    a, b, c, d, e, f = affine
    return a * xs + c * ys + e, b * xs + d * ys + f


def nearest(marks: Mask, xs: npt.NDArray[Any], ys: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """How far (pixels of ``marks``) each point (pixel coordinates, centres at .5) lies
    from the nearest marked pixel's centre; inf beyond SEARCH_PX."""
    found = np.full(len(xs), np.inf)
    height, width = marks.shape
    column, row = np.floor(xs).astype(int), np.floor(ys).astype(int)
    offsets = sorted(
        (
            (dx, dy)
            for dx in range(-SEARCH_PX, SEARCH_PX + 1)
            for dy in range(-SEARCH_PX, SEARCH_PX + 1)
        ),
        key=lambda o: o[0] ** 2 + o[1] ** 2,
    )
    for dx, dy in offsets:
        x, y = column + dx, row + dy
        open_ = np.isinf(found) & (x >= 0) & (y >= 0) & (x < width) & (y < height)
        hit = np.zeros(len(xs), dtype=bool)
        hit[open_] = marks[y[open_], x[open_]]
        found[hit] = np.hypot(x[hit] + 0.5 - xs[hit], y[hit] + 0.5 - ys[hit])
    return found


def covered(wall: Wall, display_id: str, placed: list[PlacedCode], shot: Picture) -> Mask:
    """Where codes, their captions and pins stand on a display (its native pixels), and
    what else is drawn light over the globe (the menu screen's caption)."""
    light = Image.fromarray(((shot.min(axis=2) >= 200) * 255).astype(np.uint8))
    image = light.filter(ImageFilter.MaxFilter(2 * MASK_PX + 1))
    draw = ImageDraw.Draw(image)
    to_pixels = wall.viewport(display_id).to_pixels
    for code in placed:
        if code.display == display_id:
            x, y, side = code.pixels
            draw.rectangle([x - MASK_PX, y - MASK_PX, x + side + MASK_PX, y + side + MASK_PX], 255)
        for x, y, w, h in [r for r in (code.rect, code.caption) if r is not None]:
            xs, ys = apply(
                to_pixels, np.array([x, x + w, x, x + w]), np.array([y, y, y + h, y + h])
            )
            draw.rectangle(
                [xs.min() - MASK_PX, ys.min() - MASK_PX, xs.max() + MASK_PX, ys.max() + MASK_PX],
                255,
            )
        if code.leader is not None:
            (ax, ay), (bx, by) = code.leader
            xs, ys = apply(to_pixels, np.array([ax, bx]), np.array([ay, by]))
            draw.line([xs[0], ys[0], xs[1], ys[1]], 255, 2 * MASK_PX)
            for x, y in zip(xs, ys, strict=True):
                draw.ellipse(
                    [x - 2 * MASK_PX, y - 2 * MASK_PX, x + 2 * MASK_PX, y + 2 * MASK_PX], 255
                )
    return np.asarray(image) > 0


@dataclass(frozen=True)
class Reference:
    """The whole wall's scene through the one camera: ``picture``, its pixels from
    scene mm by ``to_pixels``."""

    picture: Picture
    to_pixels: Affine
    px_per_mm: float


# The tiles' own globe, on a page of the server's origin, its one display the whole
# scene; coloured plain, every tract shown (as the wall is for the check).
DRAW_REFERENCE = """async ({wall, query, display, fill, line}) => {
  const {Globe} = await import("/static/apps/census/globe.js");
  const globe = await Globe.create(display);
  const answer = await fetch(`/api/apps/census/walls/${wall}/globe?${query}`);
  globe.show(await answer.json(), () => ({fill, line, shown: true}));
  await globe.settle();
  return globe.canvas.toDataURL("image/png");
}"""


def px_per_mm(wall: Wall, display_id: str) -> float:
    a, b, _, _, _, _ = wall.viewport(display_id).to_pixels
    return math.hypot(a, b)


def draw_reference(browser: Browser, server: ServerProcess, wall: Wall) -> Reference:
    density = max(px_per_mm(wall, d.id) for d in wall.displays)
    rects = [wall.viewport(d.id).scene_rect for d in wall.displays]
    x0, y0 = min(r.x for r in rects), min(r.y for r in rects)
    x1, y1 = max(r.right for r in rects), max(r.bottom for r in rects)
    size = [math.ceil((x1 - x0) * density), math.ceil((y1 - y0) * density)]
    to_pixels: Affine = (density, 0.0, 0.0, density, -density * x0, -density * y0)
    state = server.status(wall.id)["state"]
    census = state["apps"]["census"]
    query = httpx.QueryParams(
        {
            "dataset": census["dataset"],
            "cx": state["view"]["center"][0],
            "cy": state["view"]["center"][1],
            "zoom": state["view"]["zoom"],
            "heading": census["heading"],
            "tilt": census["tilt"],
        }
    )
    # bypass_csp: the check's own script evaluates in the page; what it imports is the
    # tiles' module from the server's origin, under the tiles' usual policy
    context = browser.new_context(
        viewport={"width": 800, "height": 600}, device_scale_factor=1, bypass_csp=True
    )
    page = context.new_page()
    page.goto(f"{server.url}/healthz")
    url = page.evaluate(
        DRAW_REFERENCE,
        {
            "wall": wall.id,
            "query": str(query),
            "display": {"resolution": size, "to_pixels": list(to_pixels)},
            "fill": COLOURS["fill"],
            "line": COLOURS["outline"],
        },
    )
    context.close()
    picture = Image.open(io.BytesIO(base64.b64decode(str(url).split(",", 1)[1]))).convert("RGB")
    assert list(picture.size) == size
    return Reference(np.asarray(picture), to_pixels, density)


@dataclass(frozen=True)
class Side:
    """One side of a seam, compared: its edge pixels both ways, in tile pixels."""

    display: str
    tile_edges: int  # the tile's edge pixels in the band
    tile_within: float  # their share within WITHIN_PX of the reference's
    reference_edges: int
    reference_within: float  # the reference's edges' share within WITHIN_PX of the tile's
    shifted_within: float  # the tile's share when the tile is WITHIN_PX * 2 off along the seam

    @property
    def holds(self) -> bool:
        return (
            min(self.tile_edges, self.reference_edges) >= LEAST_EDGE_PX
            and min(self.tile_within, self.reference_within) >= SHARE
        )


def compare_side(
    wall: Wall,
    display_id: str,
    band: tuple[float, float, float, float],
    along: tuple[float, float],
    shot: Picture,
    mask: Mask,
    reference: Reference,
    reference_edges: Mask,
) -> Side:
    """The tile's outlines against the reference's within ``band`` (scene mm)."""
    bx, by, bw, bh = band
    to_pixels = wall.viewport(display_id).to_pixels
    to_scene = invert_affine(to_pixels)
    density = px_per_mm(wall, display_id)
    mine = outlines(shot) & ~mask
    rows, columns = np.nonzero(mine)
    sx, sy = apply(to_scene, columns + 0.5, rows + 0.5)
    inside = (sx >= bx) & (sx <= bx + bw) & (sy >= by) & (sy <= by + bh)
    sx, sy = sx[inside], sy[inside]

    def tile_to_reference(shift_mm: float) -> npt.NDArray[Any]:
        rx, ry = apply(reference.to_pixels, sx + along[0] * shift_mm, sy + along[1] * shift_mm)
        return nearest(reference_edges, rx, ry) * density / reference.px_per_mm

    distances = tile_to_reference(0.0)
    shifted = tile_to_reference(2 * WITHIN_PX / density)
    # the reference's edges in the band, where the tile shows the map (not under a code)
    rows, columns = np.nonzero(reference_edges)
    to_ref_scene = invert_affine(reference.to_pixels)
    qx, qy = apply(to_ref_scene, columns + 0.5, rows + 0.5)
    inside = (qx >= bx) & (qx <= bx + bw) & (qy >= by) & (qy <= by + bh)
    tx, ty = apply(to_pixels, qx[inside], qy[inside])
    height, width = mask.shape
    x, y = np.floor(tx).astype(int), np.floor(ty).astype(int)
    on_tile = (x >= 0) & (y >= 0) & (x < width) & (y < height)
    clear = on_tile.copy()
    clear[on_tile] = ~mask[y[on_tile], x[on_tile]]
    back = nearest(mine, tx[clear], ty[clear])

    def share(d: npt.NDArray[Any]) -> float:
        return float((d <= WITHIN_PX).mean()) if len(d) else 0.0

    return Side(
        display_id, len(distances), share(distances), len(back), share(back), share(shifted)
    )


def seam_bands(
    wall: Wall, a: str, b: str, axis: str
) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, float]]:
    """The bands (scene mm) of ``a`` and ``b`` along their seam, BAND_PX of each
    display's pixels deep, and the seam's direction."""
    ra, rb = wall.viewport(a).scene_rect, wall.viewport(b).scene_rect
    da, db = BAND_PX / px_per_mm(wall, a), BAND_PX / px_per_mm(wall, b)
    if axis == "x":  # b right of a
        top, bottom = max(ra.y, rb.y), min(ra.bottom, rb.bottom)
        return (ra.right - da, top, da, bottom - top), (rb.x, top, db, bottom - top), (0.0, 1.0)
    left, right = max(ra.x, rb.x), min(ra.right, rb.right)
    return (left, ra.bottom - da, right - left, da), (left, rb.y, right - left, db), (1.0, 0.0)


def composite(wall: Wall, shots: dict[str, Picture], scale: float = 0.25) -> Image.Image:
    """The tiles' screenshots in their places on the wall (magenta: the bezels)."""
    canvas = Image.new("RGB", (math.ceil(wall.width * scale), math.ceil(wall.height * scale)))
    canvas.paste((255, 0, 255), (0, 0, *canvas.size))
    for display in wall.displays:
        x, y, w, h = display.rect.xywh
        picture = Image.fromarray(shots[display.id])
        if display.rotation:
            picture = picture.rotate(-display.rotation, expand=True)
        canvas.paste(
            picture.resize((round(w * scale), round(h * scale))),
            (round(x * scale), round(y * scale)),
        )
    return canvas


@pytest.mark.parametrize("wall_id", list(LOOKS))
def test_the_globe_runs_on_across_every_bezel_within_2_px_and_its_codes_scan(
    browser: Browser,
    server: ServerProcess,
    globe_walls: Callable[[str], GlobeWall],
    wall_id: str,
    tmp_path: Path,
) -> None:
    started = time.monotonic()
    globe_wall = globe_walls(wall_id)
    on_globe(server, wall_id)
    wait_shown(server, globe_wall, wall_id)
    shown_s = time.monotonic() - started
    wall = globe_wall.wall
    shots = {tile: shoot(page) for tile, page in globe_wall.tiles.items()}
    _, layout = fetch_layout(server.url, wall_id, operator_token(server.secret))
    for tile, shot in shots.items():
        # not blank: the Earth around the county, on every display
        assert shot.std() > 12, (tile, shot.std())
        placed = {c.code for c in layout.placed if c.display == tile}
        found = {d.payload.rsplit("/", 1)[-1] for d in decode_image(Image.fromarray(shot))}
        assert placed <= found, (tile, placed - found)
    assert len(layout.placed) > 10, "codes on the tracts, straight down"

    drawn = time.monotonic()
    reference = draw_reference(browser, server, wall)
    reference_s = time.monotonic() - drawn
    reference_edges = outlines(reference.picture)
    masks = {tile: covered(wall, tile, layout.placed, shot) for tile, shot in shots.items()}
    Image.fromarray(reference.picture).resize(
        (reference.picture.shape[1] // 4, reference.picture.shape[0] // 4)
    ).save(tmp_path / "reference.png")
    composite(wall, shots).save(tmp_path / "tiles.png")
    for tile, shot in shots.items():
        Image.fromarray(shot).save(tmp_path / f"{tile}.png")
    print(f"{wall_id}: globe on every tile after {shown_s:.0f} s, reference {reference_s:.0f} s;")
    print(f"  pictures: {tmp_path}")

    failed = []
    seams = neighbours(wall)
    assert len(seams) == {"demo": 7, "irregular": 6}[wall_id]
    for a, b, axis in seams:
        band_a, band_b, along = seam_bands(wall, a, b, axis)
        sides = [
            compare_side(
                wall, tile, band, along, shots[tile], masks[tile], reference, reference_edges
            )
            for tile, band in ((a, band_a), (b, band_b))
        ]
        print(
            f"  {a}|{b}: "
            + "; ".join(
                f"{s.display} {s.tile_edges} px {s.tile_within:.1%} within {WITHIN_PX:g} px"
                f" (back {s.reference_edges} px {s.reference_within:.1%},"
                f" {2 * WITHIN_PX:g} px off {s.shifted_within:.1%})"
                for s in sides
            )
        )
        failed += [(a, b, s) for s in sides if not s.holds]
        # the measure sees an error of twice the bound
        assert all(s.shifted_within < SHARE for s in sides), (a, b, sides)
    assert not failed, failed


def shown_at(page: Page, version: int) -> float:
    """The true time (ms) a tile showed ``version`` (RECORD_SHOWN)."""
    return float(page.evaluate(f"window.__shown['{version}']"))


def assert_shown_at_one_instant(globe_wall: GlobeWall, version: int) -> list[float]:
    times = [shown_at(page, version) for page in globe_wall.tiles.values()]
    assert max(times) - min(times) < ONE_INSTANT_MS, times
    return times


def fill_share(picture: Picture) -> float:
    return float((np.abs(picture.astype(float) - hex_rgb("fill")).max(axis=2) <= 12).mean())


def test_a_colouring_a_flight_and_a_tour_reach_every_tile_of_the_globe_at_one_instant(
    browser: Browser,
    server: ServerProcess,
    globe_walls: Callable[[str], GlobeWall],
    tmp_path: Path,
) -> None:
    wall_id = "demo"
    globe_wall = globe_walls(wall_id)
    tiles = len(globe_wall.tiles)
    on_globe(server, wall_id)
    wait_shown(server, globe_wall, wall_id)
    plain = {tile: shoot(page) for tile, page in globe_wall.tiles.items()}

    # A colouring: every tile's tracts change colour in the same frame.
    started = time.monotonic()
    post(
        server,
        wall_id,
        "theme",
        {"theme": {"attribute": "HH_INC", "scheme": "YlOrRd", "method": "quantiles", "classes": 5}},
    )
    version = wait_shown(server, globe_wall, wall_id)
    coloured_s = time.monotonic() - started
    assert_applied_at_one_instant(server, wall_id, version, tiles)
    assert_shown_at_one_instant(globe_wall, version)
    coloured = {tile: shoot(page) for tile, page in globe_wall.tiles.items()}
    for tile in plain:
        before, after = fill_share(plain[tile]), fill_share(coloured[tile])
        if before > 0.01:  # the county on it: its brown gone into the classes' colours
            assert after < 0.1 * before, (tile, before, after)

    # A flight to a tract in the south of the county: the whole wall looks elsewhere.
    tracts = sacramento().tracts
    south = min(tracts, key=lambda t: t.shape.centroid.y)
    started = time.monotonic()
    post(server, wall_id, "fly", {"tract": south.geoid})
    version = wait_shown(server, globe_wall, wall_id)
    flown_s = time.monotonic() - started
    assert_applied_at_one_instant(server, wall_id, version, tiles)
    assert_shown_at_one_instant(globe_wall, version)
    flown = {tile: shoot(page) for tile, page in globe_wall.tiles.items()}
    for tile in plain:
        moved = (
            np.abs(coloured[tile].astype(int) - flown[tile].astype(int)).max(axis=2) > 30
        ).mean()
        assert moved > 0.1, (tile, moved)
    composite(globe_wall.wall, plain).save(tmp_path / "1-plain.png")
    composite(globe_wall.wall, coloured).save(tmp_path / "2-coloured.png")
    composite(globe_wall.wall, flown).save(tmp_path / "3-flown.png")

    # A tour, played and stopped from the dashboard: each step on every tile at one
    # instant, each staying at least its dwell from the instant it shows.
    view = server.status(wall_id)["state"]["view"]
    here = {"center": view["center"], "zoom": view["zoom"]}
    steps = [
        {**here, "heading": 30, "tilt": 20, "dwell_s": 2},
        {**here, "zoom": view["zoom"] / 2, "heading": 0, "tilt": 0, "dwell_s": 600},
        {**here, "dwell_s": 2},
    ]
    answer = httpx.put(
        f"{server.url}/api/apps/census/walls/{wall_id}/tour",
        json={"steps": steps},
        headers=server.operator(),
        timeout=60,
    )
    assert answer.status_code == 200, answer.text
    dashboard = browser.new_page()
    dashboard.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    said = dashboard.locator("#census-tour-shown")
    expect(said).to_have_text("Not playing.")
    started = time.monotonic()
    dashboard.locator("#census-tour-play").click()
    versions = []
    for step in (0, 1):
        wait_until(
            lambda step=step: (
                (tour := census_of(server, wall_id)["tour"])["playing"] and tour["step"] == step
            ),
            timeout=300,
            what=f"the tour's step {step + 1}",
        )
        versions.append(wait_shown(server, globe_wall, wall_id))
        expect(said).to_have_text(f"Playing: step {step + 1} of 3.")
    toured_s = time.monotonic() - started
    first, second = (assert_shown_at_one_instant(globe_wall, v) for v in versions)
    assert min(second) - max(first) >= steps[0]["dwell_s"] * 1000, "the first step dwelt"
    toured = {tile: shoot(page) for tile, page in globe_wall.tiles.items()}
    composite(globe_wall.wall, toured).save(tmp_path / "4-toured.png")

    dashboard.locator("#census-tour-stop").click()
    expect(said).to_have_text("Not playing: stopped at step 2 of 3: the instructor stopped it.")
    state = server.status(wall_id)["state"]
    assert (state["view"]["zoom"], state["apps"]["census"]["tour"]["step"]) == (
        steps[1]["zoom"],
        1,
    ), "stopped where it was"
    dashboard.close()
    print(
        f"colouring shown on every tile after {coloured_s:.0f} s, flight {flown_s:.0f} s,"
        f" two tour steps {toured_s:.0f} s; pictures: {tmp_path}"
    )


def census_of(server: ServerProcess, wall: str) -> dict[str, Any]:
    census: dict[str, Any] = server.status(wall)["state"]["apps"]["census"]
    return census
