"""An image across the demo wall in Chromium: uploaded and shown from the dashboard,
each native-size tile showing exactly its region of it, fetching only its own pyramid
tiles, and zoomed and panned from the dashboard in step."""

from __future__ import annotations

import io
import re
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page, expect

from tests.browser.conftest import open_tiles, version_of
from tests.webapp.apps.image.samples import quadrants
from webapp.cli.testing import ServerProcess, wait_until
from webapp.people.security import operator_token

DEMO = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
STAGE = ["r2c2", "r2c3"]  # the demo's stage: the two displays clear of the screens
SHRINK = 8  # screenshots are compared at an eighth of their size: tolerant of filtering


def source_image(path: Path) -> np.ndarray:
    """A 4000 x 1120 px image (the stage's shape) whose colour says where it lies: red
    left to right, green top to bottom, blue in 250 px squares (a region off by a tenth
    of a square shows)."""
    pixels = quadrants(4000, 1120)
    y, x = np.mgrid[0:1120, 0:4000]
    pixels[..., 2] = np.where((x // 250 + y // 250) % 2 == 0, 40, 230)
    Image.fromarray(pixels).save(path)
    return pixels


def expected_tile(pixels: np.ndarray, display: dict, stage: list[float], view: dict) -> Image.Image:
    """What ``display`` should show, by the placement docs/image.md describes: the image
    as large as fits on the stage at zoom 1, the view's centre at the stage's middle."""
    height, width = pixels.shape[:2]
    sx, sy, sw, sh = stage
    zoom, (cx, cy) = view["zoom"], view["center"]
    fit = min(sw / width, sh / height)
    a = zoom * fit
    e = sx + sw / 2 + zoom * ((0.5 - cx) * sw - width * fit / 2)
    f = sy + sh / 2 + zoom * ((0.5 - cy) * sh - height * fit / 2)
    p = display["to_pixels"]  # scene mm -> native px
    to_pixels = np.array([[p[0], p[2], p[4]], [p[1], p[3], p[5]], [0, 0, 1]])
    to_scene = np.array([[a, 0, e], [0, a, f], [0, 0, 1]])  # image px -> scene mm
    back = np.linalg.inv(to_pixels @ to_scene)  # native px -> image px
    return Image.fromarray(pixels).transform(
        tuple(display["resolution"]),
        Image.Transform.AFFINE,
        tuple(back[:2].ravel()),
        Image.Resampling.BILINEAR,
        fillcolor=(0, 0, 0),
    )


def difference(shot: Image.Image, expected: Image.Image) -> float:
    """Mean absolute difference per channel (0-255) of the two, shrunk alike."""
    size = (shot.width // SHRINK, shot.height // SHRINK)
    ours = np.asarray(shot.convert("RGB").resize(size, Image.Resampling.BOX), dtype=float)
    theirs = np.asarray(expected.resize(size, Image.Resampling.BOX), dtype=float)
    return float(np.abs(ours - theirs).mean())


def screenshot(page: Page) -> Image.Image:
    return Image.open(io.BytesIO(page.screenshot()))


def marked(page: Page) -> str:
    return str(page.evaluate("document.body.dataset.image || ''"))


def test_an_uploaded_image_shows_its_own_region_on_every_tile_and_pans_and_zooms_in_step(
    browser: Browser, server: ServerProcess, tmp_path: Path
) -> None:
    pixels = source_image(tmp_path / "gradient.png")
    tiles = dict(zip(DEMO, open_tiles(browser, server, "demo", DEMO, native=True), strict=True))
    fetched: dict[str, list[str]] = {name: [] for name in DEMO}
    for name, page in tiles.items():
        page.on("request", lambda r, name=name: fetched[name].append(r.url))
    dashboard = browser.new_page()
    dashboard.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    dashboard.locator("#app-choice").select_option("image")
    dashboard.locator("#apply-app").click()
    panel = dashboard.locator("#image-panel")
    expect(panel).to_be_visible()

    panel.locator("input[name=file]").set_input_files(tmp_path / "gradient.png")
    panel.locator("input[name=title]").fill("Gradient")
    panel.get_by_role("button", name="Upload").click()
    expect(panel.locator("#image-upload-status")).to_have_text(
        "added Gradient (4000 \u00d7 1120 px)", timeout=30_000
    )
    panel.get_by_role("button", name="Show on the wall").click()
    expect(panel.get_by_role("button", name="On the wall")).to_be_visible()

    wall = httpx.get(f"{server.url}/api/walls/demo").json()
    displays = {d["id"]: d for d in wall["displays"]}
    state = server.status("demo")["state"]
    image = state["apps"]["image"]["image"]
    wait_until(
        lambda: all(marked(tiles[name]) == "refined 12" for name in STAGE),
        timeout=30,
        what="the stage's tiles to show the full-size level",
    )
    version = server.version("demo")
    assert all(version_of(page) == version for page in tiles.values())
    for name in STAGE:
        shot = screenshot(tiles[name])
        shot.save(tmp_path / f"{name}.png")  # to look at
        own = difference(shot, expected_tile(pixels, displays[name], wall["stage"], state["view"]))
        other = STAGE[1 - STAGE.index(name)]
        theirs = difference(
            shot, expected_tile(pixels, displays[other], wall["stage"], state["view"])
        )
        assert own < 8 < theirs, (name, own, theirs)
    # Each display fetched only the pyramid tiles it shows, each once: of level 12's 16
    # columns (256 px each), the left display columns 0-7 (up to image x 1994), the right
    # one 7-15 (from x 2006: column 7 straddles the bezel), all 5 rows; the other
    # displays none at all.
    pyramid = re.compile(rf"/apps/image/images/{image}/(\d+)/(\d+)_(\d+)\.jpg$")
    for name, columns in [("r2c2", range(8)), ("r2c3", range(7, 16))]:
        found = [m.groups() for url in fetched[name] if (m := pyramid.search(url))]
        level_12 = sorted((int(col), int(row)) for level, col, row in found if level == "12")
        assert level_12 == [(col, row) for col in columns for row in range(5)], (name, found)
    assert not any(
        pyramid.search(url) for name in DEMO if name not in STAGE for url in fetched[name]
    )

    panel.get_by_role("button", name="zoom in").click()
    expect(dashboard.locator("#version")).to_have_text(str(version + 1))  # its state is new
    panel.get_by_role("button", name="pan right").click()
    wait_until(lambda: server.version("demo") == version + 2, what="zoom and pan to be stored")
    wait_until(
        lambda: all(version_of(page) == version + 2 for page in tiles.values()),
        what="every tile to swap to the zoomed view",
    )
    zoomed = server.status("demo")["state"]["view"]
    assert zoomed["zoom"] == 1.25 and zoomed["center"] == pytest.approx([0.58, 0.5])
    wait_until(
        lambda: all(marked(tiles[name]) == "refined 12" for name in STAGE),
        timeout=30,
        what="the zoomed view to refine",
    )
    for name in STAGE:
        shot = screenshot(tiles[name])
        shot.save(tmp_path / f"{name}-zoomed.png")
        assert difference(shot, expected_tile(pixels, displays[name], wall["stage"], zoomed)) < 8
    for page in tiles.values():
        page.context.close()
    dashboard.close()
