"""The brain across the demo wall in Chromium: chosen and turned from the dashboard,
every tile showing its part, first coarse then refined, all changing together."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image
from playwright.sync_api import Browser, Page, expect

from tests.browser.conftest import assert_applied_at_one_instant, open_tiles, version_of
from webapp.cli.testing import ServerProcess, wait_until
from webapp.core.settings import CONTENT_DIR
from webapp.people.security import operator_token
from webapp.volume.build import build_store, open_source

MNI = CONTENT_DIR / "brain_atlas" / "mni_icbm152_t1_tal_nlin_sym_09a.nii.gz"
DEMO = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]


def bright_share(page: Page) -> float:
    """The share of the tile's pixels that are clearly not black."""
    picture = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("L"))
    return float((picture > 60).mean())


def grey_share(page: Page) -> float:
    """The share of the page's right half, around the demo's stage (the lower right
    displays), that is light neutral grey (the brain)."""
    picture = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)
    height, width, _ = picture.shape
    stage = picture[height // 4 :, width // 2 :]
    r, g, b = stage[..., 0], stage[..., 1], stage[..., 2]
    neutral = (abs(r - g) < 10) & (abs(g - b) < 10) & (g > 90) & (g < 245)
    return float(neutral.mean())


def shows(page: Page) -> str:
    return str(page.evaluate("document.body.dataset.volume || ''"))


def test_the_dashboard_puts_the_brain_on_every_tile_and_turns_it(
    browser: Browser, server: ServerProcess
) -> None:
    build_store(open_source(MNI), server.var_dir / "volumes" / "mni152", name="mni152")
    tiles = dict(zip(DEMO, open_tiles(browser, server, "demo", DEMO), strict=True))
    start = server.version("demo")
    wait_until(lambda: all(version_of(t) == start for t in tiles.values()), what="tiles up")
    dashboard = browser.new_page()
    dashboard.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    expect(dashboard.locator("#volume-choice option[value=mni152]")).to_have_count(1)

    dashboard.locator("#volume-choice").select_option("mni152")

    wait_until(
        lambda: all(shows(t) == "refined 0" for t in tiles.values()),
        timeout=30,
        what="every tile to show its refined part of the brain",
    )
    shown = server.version("demo")
    assert all(version_of(t) == shown for t in tiles.values())
    # The brain stands on the stage (r2c2 and r2c3, clear of the designated screens);
    # the others show only their codes.
    assert bright_share(tiles["r2c2"]) > 0.05
    assert bright_share(tiles["r2c3"]) > 0.05
    assert bright_share(tiles["r1c1"]) < 0.08
    assert bright_share(tiles["r1c2"]) < 0.08
    # The level-of-detail map lists every tile with its level.
    expect(dashboard.locator("#lod-list li")).to_have_count(len(DEMO))
    expect(dashboard.locator("#lod-list li[data-tile=r2c2]")).to_contain_text("level 0")

    before = tiles["r2c2"].screenshot()
    dashboard.get_by_role("button", name="turn right ⟳").click()

    wait_until(lambda: server.version("demo") == shown + 1, what="the turn to be stored")
    wait_until(
        lambda: all(version_of(t) == shown + 1 for t in tiles.values()),
        timeout=15,
        what="every tile to swap to the turned view",
    )
    # One swap for the whole wall: the tiles applied the new view at the same instant.
    assert_applied_at_one_instant(server, "demo", shown + 1, len(DEMO))
    status = server.status("demo")
    assert status["state"]["view"]["yaw"] == 30
    wait_until(
        lambda: all(shows(t) == "refined 0" for t in tiles.values()),
        timeout=30,
        what="the turned view to refine",
    )
    assert tiles["r2c2"].screenshot() != before
    expect(dashboard.locator("#view-yaw")).to_have_text("30")

    dashboard.locator("#volume-choice").select_option("")
    wait_until(lambda: all(shows(t) == "" for t in tiles.values()), what="the volume to go")
    for tile in tiles.values():
        tile.context.close()
    dashboard.close()


def test_the_overview_shows_the_quick_image_of_each_display(
    browser: Browser, server: ServerProcess
) -> None:
    build_store(open_source(MNI), server.var_dir / "volumes" / "mni152", name="mni152")
    overview = browser.new_page(viewport={"width": 960, "height": 400})
    overview.goto(f"{server.url}/wall/demo/overview")
    start = server.version("demo")
    wait_until(lambda: version_of(overview) == start, what="the overview to start")
    assert grey_share(overview) < 0.01  # the test pattern is blue and yellow

    server.change("demo", {"volume": {"volume": "mni152"}})

    wait_until(lambda: version_of(overview) == start + 1, what="the overview to follow")
    wait_until(lambda: grey_share(overview) > 0.025, what="the grey brain on the overview")
    overview.close()
