"""Codes as people meet them: photographed off real tiles, decoded, scanned by a phone."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path

import httpx
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
from wall_client.config import load_wall
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, wait_until
from webapp.core.settings import CONTENT_DIR
from webapp.people.security import operator_token
from webapp.tags.schemas import LayoutInfo

DEMO_TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}


def shown_payloads(page: Page) -> set[str]:
    """Every code the tile shows, decoded from a screenshot of it."""
    image = Image.open(io.BytesIO(page.screenshot(type="png")))
    return {decoded.payload for decoded in decode_image(image)}


def placed_payloads(layout: LayoutInfo, display: str) -> set[str]:
    return {code.payload for code in layout.placed if code.display == display}


def current_layout(server: ServerProcess) -> tuple[int, LayoutInfo]:
    return fetch_layout(server.url, "demo", operator_token(server.secret))


def test_every_tile_shows_exactly_its_placed_codes_and_a_phone_can_follow_them(
    browser: Browser, server: ServerProcess
) -> None:
    pages = open_tiles(browser, server, "demo", DEMO_TILES, native=True)
    version, layout = current_layout(server)
    wait_until(lambda: all(version_of(p) == version for p in pages), what="tiles to show the codes")
    assert layout.tag_set == "setup" and not layout.unplaced

    shown = {tile: shown_payloads(page) for tile, page in zip(DEMO_TILES, pages, strict=True)}
    for tile in DEMO_TILES:
        assert shown[tile] == placed_payloads(layout, tile), tile
    assert shown["r1c2"] == set() and shown["r1c3"] == set(), "panels stay free of codes"
    assert len(shown["r2c1"]) == 2, "the two registration codes"

    phone = browser.new_context(**PHONE).new_page()
    [display_code] = shown["r2c2"] - {c.payload for c in layout.placed if c.leader}
    phone.goto(display_code)
    expect(phone.locator("h1")).to_have_text("Display r2c2")
    expect(phone.locator("dl.facts")).to_contain_text("r2c2")
    assert phone.evaluate("document.documentElement.scrollWidth") <= 390, "fits the phone"

    student = next(c for c in layout.placed if c.display == "r2c1" and "tudent" in c.label)
    assert student.payload in shown["r2c1"]
    phone.goto(student.payload)
    expect(phone.locator("body")).to_contain_text("student")
    phone.context.close()
    for page in pages:
        page.context.close()


@pytest.fixture
def unhurried_server(tmp_path: Path, database_url: str) -> Iterator[ServerProcess]:
    """A lead long enough for six full-HD tiles to draw the frame before the instant.

    The swap is scheduled, not immediate: a tile that is still drawing when the instant
    comes shows its frame late, so on two loaded cores the default lead (400 ms) would
    measure the machine rather than the schedule.
    """
    process = serve(tmp_path, database_url, TAGWALL_APPLY_LEAD_MS="2500")
    yield process
    process.stop()


def test_switching_the_tag_set_changes_the_codes_on_every_tile_at_once(
    browser: Browser, unhurried_server: ServerProcess
) -> None:
    server = unhurried_server
    wall = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    with httpx.Client(base_url=server.url, headers=server.operator()) as client:
        for tile in ["r1c1", "r2c2", "r2c3"]:
            spec = {
                "app": "pattern",
                "action": "locate",
                "label": f"Quiz {tile}",
                "tag_set": "quiz",
                "anchor": list(wall.display(tile).rect.center),
            }
            assert client.post("/api/walls/demo/tags", json=spec).status_code == 201
        pages = open_tiles(browser, server, "demo", DEMO_TILES, native=True)
        before_version, before = current_layout(server)
        wait_until(
            lambda: all(version_of(p) == before_version for p in pages), what="tiles to start"
        )

        response = client.put("/api/walls/demo/tag-set", json={"name": "quiz"})
        assert response.status_code == 200, response.text

    version, after = current_layout(server)
    assert version > before_version and after.tag_set == "quiz"
    wait_until(lambda: all(version_of(p) == version for p in pages), what="tiles to switch sets")
    assert_applied_at_one_instant(server, "demo", version, len(DEMO_TILES))  # one swap

    quiz = {code.payload for code in after.placed if code.label.startswith("Quiz")}
    assert len(quiz) == 3
    setup = {code.payload for code in before.placed if code.label.startswith("Display")}
    everything = set().union(*(shown_payloads(page) for page in pages))
    assert quiz <= everything and not (setup & everything)
    for tile, page in zip(DEMO_TILES, pages, strict=True):
        assert shown_payloads(page) == placed_payloads(after, tile), tile
        page.context.close()
