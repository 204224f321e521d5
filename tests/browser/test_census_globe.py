"""The census map on a globe (CesiumJS under Chromium's software GL): two neighbouring
tiles of the demo wall, screenshot at native size, show one continuous globe across the
bezel between them, with their codes still decoding."""

from __future__ import annotations

import io
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles, serve, version_of
from webapp.apps.census_map.mapview import COLOURS
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, wait_until
from webapp.people.security import operator_token

TILES = ["r2c2", "r2c3"]  # side by side, a 7 mm bezel between them, both on the map


@pytest.fixture
def globe(tmp_path: Path, database_url: str) -> Iterator[ServerProcess]:
    process = serve(tmp_path, database_url, ("demo",))
    process.change("demo", {"app": "census"})
    answer = httpx.post(
        f"{process.url}/api/census/walls/demo/surface",
        json={"surface": "globe"},
        headers=process.operator(),
        timeout=60,
    )
    assert answer.status_code == 200, answer.text
    yield process
    process.stop()


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
        lambda: all(
            version_of(p) == version
            and p.evaluate("document.body.dataset.censusSurface") == "globe"
            for p in pages
        ),
        timeout=120,
        what="both tiles to show the globe",
    )
    first_frame_s = time.monotonic() - started
    shots = [
        np.asarray(Image.open(io.BytesIO(p.screenshot(type="png"))).convert("RGB")) for p in pages
    ]
    # Not blank: Natural Earth around the county, the county's tracts on it.
    for shot in shots:
        assert shot.std() > 20 and fill_mask(shot).mean() > 0.02
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
