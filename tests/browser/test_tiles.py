"""The demo wall in real Chromium: every tile follows the server, in step."""

from __future__ import annotations

from playwright.sync_api import Browser, Page

from tests.browser.conftest import open_tiles, version_of
from webapp.testing import ServerProcess, wait_until

DEMO_TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]


def canvas_image(page: Page) -> str:
    return str(page.evaluate("document.getElementById('scene').toDataURL()"))


def all_at(pages: list[Page], version: int) -> bool:
    return all(version_of(page) == version for page in pages)


def test_a_state_change_shows_on_every_demo_tile(browser: Browser, server: ServerProcess) -> None:
    pages = open_tiles(browser, server, "demo", DEMO_TILES)
    wait_until(lambda: all_at(pages, 0), what="every tile to draw version 0")
    before = [canvas_image(page) for page in pages]
    assert len(set(before)) == len(DEMO_TILES), "each tile draws its own part of the scene"

    version = server.change("demo", {"layers": {"grid": False}})

    wait_until(lambda: all_at(pages, version), what=f"every tile to reach version {version}")
    after = [canvas_image(page) for page in pages]
    assert all(old != new for old, new in zip(before, after, strict=True))
    for page in pages:
        assert page.evaluate("document.body.dataset.online") == "true"
        assert page.evaluate("document.documentElement.scrollHeight") <= 270
        page.context.close()


def test_tiles_reconnect_after_a_server_restart_with_the_same_state(
    browser: Browser, server: ServerProcess
) -> None:
    pages = open_tiles(browser, server, "demo", DEMO_TILES[:3])
    wait_until(lambda: all_at(pages, 0), what="tiles to start")
    version = server.change("demo", {"layers": {"diagonals": False}, "mode": "setup"})
    wait_until(lambda: all_at(pages, version), what="tiles to apply the change")
    drawn = [canvas_image(page) for page in pages]

    server.stop()
    wait_until(
        lambda: all(page.evaluate("document.body.dataset.online") == "false" for page in pages),
        what="tiles to notice the server is gone",
    )
    assert all(page.locator("#offline").is_visible() for page in pages)
    server.start()

    wait_until(
        lambda: all(page.evaluate("document.body.dataset.online") == "true" for page in pages),
        timeout=40,
        what="tiles to reconnect",
    )
    assert all_at(pages, version)
    assert [canvas_image(page) for page in pages] == drawn
    assert not any(page.locator("#offline").is_visible() for page in pages)

    later = server.change("demo", {"layers": {"diagonals": True}})
    wait_until(lambda: all_at(pages, later), what="tiles to follow changes after the restart")
    for page in pages:
        page.context.close()


def test_skewed_tile_clocks_still_apply_a_change_within_5_ms(
    browser: Browser, server: ServerProcess
) -> None:
    skews = [-500, 500, -250, 250, 0, 400]
    pages = open_tiles(browser, server, "demo", DEMO_TILES, skews_ms=skews)
    wait_until(lambda: all_at(pages, 0), what="tiles to start")
    assert {page.evaluate("Date.now() - performance.timeOrigin - performance.now()") // 100
            for page in pages} != {0}, "the init script skews the page clocks"
    # Clock sync converges within a few ping round trips; give it those.
    wait_until(
        lambda: all(page.evaluate("window.performance.now()") > 3000 for page in pages),
        what="clock samples",
    )

    spreads = []
    for patch in ({"layers": {"labels": False}}, {"layers": {"labels": True}}):
        version = server.change("demo", patch)
        wait_until(lambda v=version: all_at(pages, v), what=f"version {version} everywhere")

        def reported(v: int = version) -> list[float] | None:
            tiles = server.status("demo")["tiles"]
            assert isinstance(tiles, list)
            times = [t["applied_at"] for t in tiles if t["version"] == v]
            return times if len(times) == len(DEMO_TILES) else None

        wait_until(lambda: reported() is not None, what="applied reports")
        times = reported()
        assert times is not None
        spreads.append(max(times) - min(times))
    assert max(spreads) <= 5.0, f"tiles applied {spreads} ms apart"
    for page in pages:
        page.context.close()


def test_the_overview_follows_the_wall_live(browser: Browser, server: ServerProcess) -> None:
    page = browser.new_page(viewport={"width": 1200, "height": 700})
    page.goto(f"{server.url}/wall/demo/overview")
    wait_until(lambda: version_of(page) == 0, what="the overview to draw")
    before = canvas_image(page)
    assert page.locator("header").inner_text().count("6 displays") == 1

    version = server.change("demo", {"layers": {"grid": False}})

    wait_until(lambda: version_of(page) == version, what="the overview to follow")
    assert canvas_image(page) != before
    page.close()
