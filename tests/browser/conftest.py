"""Browser fixtures: a real server process and Debian's Chromium driven by Playwright.

The server runs as a subprocess (``tagwall serve``) so a test can stop and restart
it the way an operator would; its database comes from the shared ``database_url``
fixture (SQLite, or a fresh PostgreSQL database when one is configured).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator, Sequence
from pathlib import Path

import pytest
from playwright.sync_api import Browser, Page, expect, sync_playwright

from tests.conftest import TEST_SECRET, server_port, wall_files, walls_of
from webapp.cli.testing import CHROMIUM_ARGS, ServerProcess, skewed_clock

# Playwright's assertions wait 5 s by default; with a test beside it on each core a tile
# can take longer to draw what it was sent (a dashboard colouring check missed 5 s under
# load). Slow, not wrong: every assertion still fails when the page never gets there.
expect.set_options(timeout=15_000)


def serve(
    tmp_path: Path,
    database_url: str,
    walls: Sequence[str] = ("demo",),
    port: int | None = None,
    **extra_env: str,
) -> ServerProcess:
    """A started server on the shipped ``walls`` (each costs its codes' placement at
    start), on ``port`` when its URLs must be known before (a provider's redirect URI);
    ``extra_env`` adds ``TAGWALL_*`` settings."""
    process = ServerProcess(
        var_dir=tmp_path / "var",
        database_url=database_url,
        secret=TEST_SECRET,
        port=port or server_port(),
        extra_env={
            "TAGWALL_WALL_CONFIGS": os.pathsep.join(str(path) for path in wall_files(*walls)),
            "TAGWALL_APPLY_LEAD_MS": "400",
            "TAGWALL_VISITOR_SETTLE_S": "0",  # test phones act faster than people
            **extra_env,
        },
    )
    process.start()
    return process


@pytest.fixture
def server(
    tmp_path: Path, database_url: str, request: pytest.FixtureRequest
) -> Iterator[ServerProcess]:
    process = serve(tmp_path, database_url, walls_of(request))
    yield process
    process.stop()


# Module scope: Playwright's sync API holds an event loop in this thread while it runs,
# which must be gone before the async tests of other modules start.
@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    executable = shutil.which("chromium")
    if executable is None:
        pytest.fail("Debian chromium is not installed: run `make test` (it installs it as root)")
    with sync_playwright() as playwright:
        launched = playwright.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS)
        yield launched
        launched.close()


def open_tiles(
    browser: Browser,
    server: ServerProcess,
    wall: str,
    tiles: list[str],
    skews_ms: list[int] | None = None,
    native: bool = False,
) -> list[Page]:
    """One page per tile, each in its own context (its own clock when skewed).

    Tiles are small windows unless ``native``: then 1920 x 1080 CSS pixels at a device
    scale of 1, as a kiosk shows them, so screenshots carry codes pixel for pixel.
    """
    viewport = {"width": 1920, "height": 1080} if native else {"width": 480, "height": 270}
    pages = []
    for index, tile in enumerate(tiles):
        context = browser.new_context(viewport=viewport, device_scale_factor=1)
        if skews_ms:
            context.add_init_script(skewed_clock(skews_ms[index]))
        page = context.new_page()
        page.goto(server.tile_url(wall, tile))
        pages.append(page)
    return pages


# One change, one instant: tiles apply a change at the wall clock's moment, not as it
# reaches them (hundreds of ms apart). How close together (a few ms) test_tiles measures
# over many changes, and `make bench`; one change on a loaded two-core machine can find a
# tile still drawing its frame (98 ms seen in CI), so a single change is held to this.
ONE_INSTANT_MS = 200.0


def assert_applied_at_one_instant(
    server: ServerProcess, wall_id: str, version: int, tiles: int
) -> None:
    """Every one of ``tiles`` tiles reported applying ``version`` at one instant."""
    status = server.status(wall_id)["tiles"]
    applied = [t["applied_at"] for t in status if t["version"] == version]
    assert len(applied) == tiles and max(applied) - min(applied) < ONE_INSTANT_MS, applied


def version_of(page: Page) -> int | None:
    value = page.evaluate("document.body.dataset.version")
    return None if value is None else int(value)
