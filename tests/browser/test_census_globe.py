"""The census map on a globe (CesiumJS under Chromium's software GL): two neighbouring
tiles of the demo wall, screenshot at native size, show one continuous globe across the
bezel between them, with their codes still decoding, straight down and turned and
tilted, each tract code over its tract; the dashboard switches the globe on and off and
names a tile that cannot show it; a site's own imagery server lies over the bundled
Natural Earth, which stays when that server (or its terrain server) fails."""

from __future__ import annotations

import base64
import io
import json
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page, expect

from tag_service.verify import decode_image
from tests.browser.conftest import (
    assert_applied_at_one_instant,
    open_tiles,
    serve,
    version_of,
)
from tests.browser.test_census import brown_share
from wall_client.config import load_wall
from wall_client.layout import apply_affine
from webapp.apps.census_map.mapview import COLOURS
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, free_port, wait_until
from webapp.core.settings import CONTENT_DIR
from webapp.people.security import operator_token

TILES = ["r2c2", "r2c3"]  # side by side, a 7 mm bezel between them, both on the map


def post(server: ServerProcess, wall: str, path: str, body: Any) -> Any:
    """The operator's POST to the census map's API of ``wall``; its JSON answer."""
    answer = httpx.post(
        f"{server.url}/api/apps/census/walls/{wall}/{path}",
        json=body,
        headers=server.operator(),
        timeout=60,
    )
    assert answer.status_code == 200, answer.text
    return answer.json()


def shows_globe(page: Page, version: int) -> bool:
    """The tile shows the wall's ``version`` on the globe (not the flat map)."""
    return (
        version_of(page) == version
        and page.evaluate("document.body.dataset.censusSurface") == "globe"
    )


def on_globe(tmp_path: Path, database_url: str, **extra_env: str) -> ServerProcess:
    """The demo wall showing the census map on the globe."""
    # Software GL prepares a globe picture in seconds (its first in tens): the wall waits
    # for every tile's ready up to a minute (a GPU's kiosk needs far less than the 3 s
    # default), so each change still swaps on both at one instant.
    process = serve(tmp_path, database_url, ("demo",), TAGWALL_SWAP_TIMEOUT_MS="60000", **extra_env)
    process.change("demo", {"app": "census"})
    post(process, "demo", "surface", {"surface": "globe"})
    return process


@pytest.fixture
def globe(tmp_path: Path, database_url: str) -> Iterator[ServerProcess]:
    process = on_globe(tmp_path, database_url)
    yield process
    process.stop()


def edge_width(picture: np.ndarray) -> float:
    """The median number of rows, down the columns, that a crossing from the fill to
    the imagery around the county takes (half-way colours in between): 1 to 2 when
    sharp. Outlines, codes and captions are not the imagery."""
    fill, line = ([int(COLOURS[k][i : i + 2], 16) for i in (1, 3, 5)] for k in ("fill", "outline"))
    distance = np.abs(picture.astype(int) - fill).max(axis=2)
    far = (
        (distance >= 60)
        & (np.abs(picture.astype(int) - line).max(axis=2) > 40)
        & (picture.max(axis=2) < 200)
    )
    widths = []
    for column in picture.shape[1] // 16 * np.arange(1, 16):
        d = distance[:, column]
        inside, outside = d <= 12, far[:, column]
        row = 0
        while row < len(d) - 1:
            if inside[row] and not inside[row + 1]:
                end = row + 1
                while end < len(d) and not inside[end] and not outside[end]:
                    end += 1
                if end < len(d) and outside[end]:
                    widths.append(end - row)
                row = end
            else:
                row += 1
    assert widths, "the fill meets something"
    return float(np.median(widths))


def fill_mask(picture: np.ndarray) -> np.ndarray:
    r, g, b = (int(COLOURS["fill"][i : i + 2], 16) for i in (1, 3, 5))
    return np.abs(picture.astype(int) - [r, g, b]).max(axis=2) <= 12


def test_the_globe_runs_on_across_the_bezel_and_its_codes_scan(
    browser: Browser, globe: ServerProcess
) -> None:
    started = time.monotonic()
    pages = open_tiles(browser, globe, "demo", TILES, native=True)
    version = globe.version("demo")
    wait_until(
        lambda: all(shows_globe(p, version) for p in pages),
        timeout=300,  # software GL: 12 s here when quiet; CI's machine runs up to twice slower
        what="both tiles to show the globe",
    )
    first_frame_s = time.monotonic() - started
    shots = [
        np.asarray(Image.open(io.BytesIO(p.screenshot(type="png"))).convert("RGB")) for p in pages
    ]
    # Not blank: Natural Earth around the county, the county's tracts on it.
    for shot in shots:
        assert shot.std() > 20 and fill_mask(shot).mean() > 0.02
    # At the display's own pixels: the county's fill meets the imagery within a few
    # pixels (a picture drawn smaller and scaled up blurs it over a dozen and more).
    for shot in shots:
        assert edge_width(shot) <= 3, edge_width(shot)
    # The codes decode from the screenshots, every one placed on these tiles.
    _, layout = fetch_layout(globe.url, "demo", operator_token(globe.secret))
    for tile, shot in zip(TILES, shots, strict=True):
        placed = {c.code for c in layout.placed if c.display == tile}
        found = {d.payload.rsplit("/", 1)[-1] for d in decode_image(Image.fromarray(shot))}
        assert placed and placed <= found, (tile, placed - found)
    # Across the bezel: the county's fill meets the seam at about the same rows on both
    # sides (rows under a code or caption left out). A coarse bound: tract outlines and
    # sloped edges move across the 11 px the bezel hides; a display seeing the wrong part
    # of the camera (the bezel ignored, a centred frustum) misses by far more.
    left, right = shots[0][:, -1], shots[1][:, 0]
    plain = (left.max(axis=1) < 200) & (right.max(axis=1) < 200)
    plain &= np.abs(left.astype(int) - [16, 22, 31]).max(axis=1) > 6  # captions' backing
    plain &= np.abs(right.astype(int) - [16, 22, 31]).max(axis=1) > 6
    on_left = fill_mask(left[None])[0] & plain
    on_right = fill_mask(right[None])[0] & plain
    assert on_left.sum() > 50, "the county reaches the seam"
    differ = np.flatnonzero(on_left != on_right)
    assert len(differ) <= 0.12 * plain.sum(), (len(differ), plain.sum())
    print(f"first globe frame on both tiles after {first_frame_s:.1f} s")
    for page in pages:
        page.context.close()


def shoot(page: Page) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(page.screenshot(type="png"))).convert("RGB"))


def test_the_dashboard_turns_and_tilts_the_globe_on_every_tile_at_one_instant(
    browser: Browser, globe: ServerProcess, tmp_path: Path
) -> None:
    pages = open_tiles(browser, globe, "demo", TILES, native=True)

    def shown(version: int) -> bool:
        return all(shows_globe(p, version) for p in pages)

    version = globe.version("demo")
    wait_until(lambda: shown(version), timeout=300, what="both tiles to show the globe")
    before = [shoot(p) for p in pages]
    _, layout = fetch_layout(globe.url, "demo", operator_token(globe.secret))
    assert any(c.display in TILES for c in layout.placed), "codes on the tracts, straight down"

    dashboard = browser.new_page()
    dashboard.goto(f"{globe.url}/login/operator?token={operator_token(globe.secret)}")
    turn = dashboard.get_by_role("button", name="turn right 15 degrees")
    tilt = dashboard.get_by_role("button", name="tilt more, 10 degrees towards the horizon")
    for button in (turn, tilt):
        box = button.bounding_box()
        assert box and box["width"] >= 44 and box["height"] >= 44, box
    shown_camera = dashboard.locator("#census-camera-shown")
    turn.click()
    expect(shown_camera).to_contain_text("Turned to 15° from north, tilted 0°")
    for degrees in (10, 20):  # reached and pressed from the keyboard
        tilt.focus()
        dashboard.keyboard.press("Enter")
        expect(shown_camera).to_contain_text(f"tilted {degrees}° from straight down")
    census = globe.status("demo")["state"]["apps"]["census"]
    assert (census["heading"], census["tilt"]) == (15, 20)
    version = globe.version("demo")
    wait_until(lambda: shown(version), timeout=300, what="both tiles to show the turned globe")
    assert_applied_at_one_instant(globe, "demo", version, len(TILES))
    after = [shoot(p) for p in pages]
    # before over after, the two tiles side by side (the bezel between them left out)
    Image.fromarray(np.vstack([np.hstack(before), np.hstack(after)])).save(
        tmp_path / "globe-turned.png"
    )
    print(f"before and after: {tmp_path / 'globe-turned.png'}")
    for tile, a, b in zip(TILES, before, after, strict=True):
        # still the globe (the county on the imagery), but seen otherwise
        assert b.std() > 20 and fill_mask(b).mean() > 0.01
        changed = np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 40
        assert changed.mean() > 0.2, (tile, changed.mean())
    # turned and tilted: the codes placed on these tiles decode from their screenshots
    # (which tract each stands on: test_codes_stand_on_their_tracts_on_a_tilted_globe)
    _, layout = fetch_layout(globe.url, "demo", operator_token(globe.secret))
    for tile, shot in zip(TILES, after, strict=True):
        placed = {c.code for c in layout.placed if c.display == tile}
        found = {d.payload.rsplit("/", 1)[-1] for d in decode_image(Image.fromarray(shot))}
        assert placed <= found, (tile, placed - found)
    dashboard.close()
    for page in pages:
        page.context.close()


def globe_picture(page: Page) -> np.ndarray:
    """The globe as CesiumJS last drew it on the tile, without the layers over it
    (codes, pins, captions): its canvas at the display's native pixels."""
    url = page.evaluate("document.querySelector('.cesium-widget canvas').toDataURL('image/png')")
    data = base64.b64decode(url.split(",", 1)[1])
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def test_codes_stand_on_their_tracts_on_a_tilted_globe(
    browser: Browser, globe: ServerProcess, tmp_path: Path
) -> None:
    """Zoomed in, coloured by a value in seven classes, turned and tilted: the codes on
    the two map tiles decode from the screenshots, and under each tract code's anchor
    (where its pin points) the globe shows that tract: its class's colour in the globe's
    own picture (the codes drawn over it left out)."""
    globe.change("demo", {"view": {"center": [0.5, 0.5], "zoom": 3}})
    theme = {"attribute": "HSG_VAL", "scheme": "PuOr", "method": "natural", "classes": 7}
    for path, body in (("theme", {"theme": theme}), ("camera", {"heading": 30, "tilt": 45})):
        post(globe, "demo", path, body)
    pages = open_tiles(browser, globe, "demo", TILES, native=True)
    version = globe.version("demo")
    wait_until(
        lambda: all(
            shows_globe(p, version)
            and p.evaluate("document.body.dataset.censusTheme") == "HSG_VAL 7"
            for p in pages
        ),
        timeout=300,  # software GL: a first globe frame takes tens of seconds
        what="both tiles to show the tilted, coloured globe",
    )
    shots = [shoot(p) for p in pages]
    pictures = [globe_picture(p) for p in pages]
    for tile, shot, picture in zip(TILES, shots, pictures, strict=True):
        Image.fromarray(shot).save(tmp_path / f"tilted-{tile}.png")
        Image.fromarray(picture).save(tmp_path / f"tilted-{tile}-globe.png")
    print(f"screenshots: {tmp_path}/tilted-*.png")

    state = globe.status("demo")["state"]
    cx, cy = state["view"]["center"]
    classes = httpx.get(
        f"{globe.url}/api/apps/census/walls/demo/tiles/r2c2/theme",
        params={
            "dataset": state["apps"]["census"]["dataset"],
            "layout": state["tag_layout"],
            "cx": cx,
            "cy": cy,
            "zoom": state["view"]["zoom"],
            **theme,
        },
    ).json()
    tags = httpx.get(f"{globe.url}/api/walls/demo/tags", headers=globe.operator()).json()
    geoid_of = {t["code"]: t["params"]["geoid"] for t in tags if t["action"] == "tract"}
    _, layout = fetch_layout(globe.url, "demo", operator_token(globe.secret))
    wall = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    checked = []
    for tile, shot, picture in zip(TILES, shots, pictures, strict=True):
        assert picture.shape == shot.shape
        found = {d.payload.rsplit("/", 1)[-1] for d in decode_image(Image.fromarray(shot))}
        placed = [c for c in layout.placed if c.display == tile]
        assert placed and {c.code for c in placed} <= found, tile
        to_pixels = wall.viewport(tile).to_pixels
        for code in placed:
            if code.code not in geoid_of:
                continue  # a cluster's code: its anchor is its tracts' middle
            x, y = (round(c) for c in apply_affine(to_pixels, *code.anchor))
            seen = np.median(picture[y - 2 : y + 3, x - 2 : x + 3].reshape(-1, 3), axis=0)
            index = classes["tracts"][geoid_of[code.code]]
            row = classes["classes"][index] if index >= 0 else classes["missing"]
            want = [int(row["fill"][i : i + 2], 16) for i in (1, 3, 5)]
            assert np.abs(seen - want).max() <= 12, (tile, code.label, seen, row["fill"])
            checked.append(code.label)
    print(f"tract codes on their tracts' colours: {checked}")
    assert len(checked) >= 4, checked
    for page in pages:
        page.context.close()


# A kiosk whose browser has no WebGL: every WebGL context it asks for is refused.
NO_WEBGL = """
const getContext = HTMLCanvasElement.prototype.getContext;
HTMLCanvasElement.prototype.getContext = function (kind, ...rest) {
  return String(kind).startsWith("webgl") || kind === "experimental-webgl"
    ? null : getContext.call(this, kind, ...rest);
};
"""


def test_the_dashboard_switches_to_the_globe_and_names_a_tile_without_webgl(
    browser: Browser, tmp_path: Path, database_url: str
) -> None:
    process = serve(tmp_path, database_url, ("demo",))
    try:
        process.change("demo", {"app": "census"})
        context = browser.new_context(viewport={"width": 480, "height": 270})
        context.add_init_script(NO_WEBGL)
        tile = context.new_page()
        tile.goto(process.tile_url("demo", "r2c2"))
        dashboard = browser.new_page()
        dashboard.goto(f"{process.url}/login/operator?token={operator_token(process.secret)}")
        flat = dashboard.locator('#census-surface [data-surface="flat"]')
        on_globe = dashboard.locator('#census-surface [data-surface="globe"]')
        expect(flat).to_have_attribute("aria-pressed", "true")
        wait_until(
            lambda: tile.evaluate("document.body.dataset.censusSurface") == "flat",
            what="the tile to show the flat map",
        )
        notes = dashboard.locator("#tiles tr", has_text="r2c2").locator("td").last
        expect(notes).to_have_text("")

        on_globe.click()
        expect(on_globe).to_have_attribute("aria-pressed", "true")
        assert process.status("demo")["state"]["apps"]["census"]["surface"] == "globe"
        wait_until(
            lambda: tile.evaluate("document.body.dataset.censusSurface") == "flat: no WebGL",
            what="the tile without WebGL to keep the flat map",
        )
        expect(notes).to_have_text("r2c2 shows the flat map: no WebGL")
        assert brown_share(tile) > 0.02  # the flat map, drawn

        flat.click()
        expect(flat).to_have_attribute("aria-pressed", "true")
        expect(notes).to_have_text("")
        assert tile.evaluate("document.body.dataset.censusSurface") == "flat"
        context.close()
        dashboard.close()
    finally:
        process.stop()


MAGENTA = (255, 0, 255)


TERRAIN_HEIGHT_M = 100
# a heightmap-1.0 terrain tileset (the simplest Cesium reads): every tile 65 x 65
# heights, all TERRAIN_HEIGHT_M, stored as (h + 1000) * 5; children down to level 7
TERRAIN_LAYER = json.dumps(
    {
        "tilejson": "2.1.0",
        "format": "heightmap-1.0",
        "version": "1.0.0",
        "scheme": "tms",
        "tiles": ["{z}/{x}/{y}.terrain"],
    }
).encode()


def heightmap(level: int) -> bytes:
    heights = np.full(65 * 65, (TERRAIN_HEIGHT_M + 1000) * 5, dtype="<u2").tobytes()
    return heights + bytes([15 if level < 7 else 0, 0])  # child tiles, no water


class TileServer:
    """A site's own tile server: every ``/{z}/{x}/{y}.png`` a solid magenta picture,
    under ``/terrain/`` a flat terrain tileset, under ``/broken/`` 500s; it counts what
    it is asked."""

    def __init__(self) -> None:
        buffer = io.BytesIO()
        Image.new("RGB", (256, 256), MAGENTA).save(buffer, format="PNG")
        picture = buffer.getvalue()
        asked: list[str] = []

        class Answer(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                asked.append(self.path)
                path = self.path.split("?")[0]
                if path.startswith("/broken/"):
                    self.send_error(500)
                    return
                if path == "/terrain/layer.json":
                    self.answer(TERRAIN_LAYER, "application/json")
                elif path.startswith("/terrain/"):
                    self.answer(heightmap(int(path.split("/")[2])), "application/octet-stream")
                else:
                    self.answer(picture, "image/png")

            def answer(self, body: bytes, media_type: str) -> None:
                self.send_response(200)
                self.send_header("Content-Type", media_type)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, format: str, *args: object) -> None:
                pass

        self.asked = asked
        self.http = ThreadingHTTPServer(("127.0.0.1", 0), Answer)
        self.url = f"http://127.0.0.1:{self.http.server_address[1]}"
        threading.Thread(target=self.http.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.http.shutdown()
        self.http.server_close()


@pytest.fixture
def tile_server() -> Iterator[TileServer]:
    server = TileServer()
    yield server
    server.close()


def globe_tile(browser: Browser, process: ServerProcess) -> tuple[Page, list[str]]:
    """r2c2 at its native size showing the globe, and every URL it asked for."""
    started = time.monotonic()
    (page,) = open_tiles(browser, process, "demo", ["r2c2"], native=True)
    asked: list[str] = []
    page.on("request", lambda request: asked.append(request.url))
    version = process.version("demo")
    wait_until(
        lambda: shows_globe(page, version),
        timeout=300,
        what="the tile to show the globe",
    )
    print(f"first globe frame after {time.monotonic() - started:.1f} s")
    return page, asked


def decodes_its_codes(process: ServerProcess, shot: np.ndarray) -> None:
    _, layout = fetch_layout(process.url, "demo", operator_token(process.secret))
    placed = {c.code for c in layout.placed if c.display == "r2c2"}
    found = {d.payload.rsplit("/", 1)[-1] for d in decode_image(Image.fromarray(shot))}
    assert placed and placed <= found, placed - found


def notes_of(process: ServerProcess) -> list[str]:
    tiles = process.status("demo")["tiles"]
    return next(t["notes"] for t in tiles if t["tile_id"] == "r2c2")


def magenta_share(shot: np.ndarray) -> float:
    return float((np.abs(shot.astype(int) - MAGENTA).max(axis=2) <= 30).mean())


def test_the_sites_own_imagery_lies_over_the_globe_through_tagwall(
    browser: Browser, tmp_path: Path, database_url: str, tile_server: TileServer
) -> None:
    process = on_globe(
        tmp_path,
        database_url,
        TAGWALL_CENSUS_IMAGERY_URL=f"{tile_server.url}/{{z}}/{{x}}/{{y}}.png",
        TAGWALL_CENSUS_TERRAIN_URL=f"{tile_server.url}/terrain/",
    )
    try:
        page, asked = globe_tile(browser, process)
        shot = shoot(page)
        Image.fromarray(shot).save(tmp_path / "site-imagery.png")
        print(f"the tile on the site's imagery: {tmp_path / 'site-imagery.png'}")
        # the site's picture around the county, the county's tracts over it (on the
        # ellipsoid, never hidden by the land 100 m above it)
        assert magenta_share(shot) > 0.3, magenta_share(shot)
        assert fill_mask(shot).mean() > 0.02
        decodes_its_codes(process, shot)
        assert notes_of(process) == []
        # the tile asked only tagwall; tagwall asked the site's server
        assert all(url.startswith(process.url) for url in asked), [
            url for url in asked if not url.startswith(process.url)
        ]
        pictures = [path for path in tile_server.asked if path.endswith(".png")]
        terrain = [path for path in tile_server.asked if path.endswith(".terrain")]
        relayed = [url for url in asked if "/apps/census/globe/" in url]
        print(
            f"the tile asked tagwall for {len(relayed)} imagery and terrain tiles, "
            f"tagwall the site's server for {len(pictures)} pictures, {len(terrain)} terrain tiles"
        )
        assert pictures and terrain
        page.context.close()
    finally:
        process.stop()


def test_a_site_server_that_fails_leaves_natural_earth_and_the_codes(
    browser: Browser, tmp_path: Path, database_url: str, tile_server: TileServer
) -> None:
    nobody = f"http://127.0.0.1:{free_port()}"  # a port nothing listens on
    process = on_globe(
        tmp_path,
        database_url,
        TAGWALL_CENSUS_IMAGERY_URL=f"{nobody}/{{z}}/{{x}}/{{y}}.png",
        TAGWALL_CENSUS_TERRAIN_URL=f"{tile_server.url}/broken/",  # answers 500
    )
    try:
        page, _ = globe_tile(browser, process)
        shot = shoot(page)
        Image.fromarray(shot).save(tmp_path / "site-failed.png")
        print(f"the tile with its site's servers failing: {tmp_path / 'site-failed.png'}")
        # Natural Earth around the county: land in colours, no blank or black tiles
        background = np.abs(shot.astype(int) - [5, 7, 10]).max(axis=2) <= 6
        assert shot.std() > 20 and background.mean() < 0.01, (shot.std(), background.mean())
        assert magenta_share(shot) < 0.001 and fill_mask(shot).mean() > 0.02
        decodes_its_codes(process, shot)
        notes = notes_of(process)
        print(f"the dashboard's notes: {notes}")
        assert any("without terrain: its server failed (HTTP 5" in n for n in notes), notes
        assert any("Natural Earth where its imagery server failed" in n for n in notes), notes
        assert tile_server.asked and all(p.startswith("/broken/") for p in tile_server.asked)
        page.context.close()
    finally:
        process.stop()
