"""The brain atlas in Chromium: a child registers from the tile's code, picks the K-5
group off the menu tile (the wall's pins change), scans every K-5 pin photographed off
the tiles while the instructor turns the brain through its views, answers, finishes
and reads the results."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page, expect

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles, serve, version_of
from webapp.apps.brain_atlas.content import load_content
from webapp.apps.brain_atlas.views import load_views
from webapp.check import fetch_layout
from webapp.schemas import LayoutInfo
from webapp.security import operator_token
from webapp.testing import ServerProcess, wait_until

DEMO = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
FREE = ["r1c1", "r2c2", "r2c3"]  # the displays that are no designated screen
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}


@pytest.fixture
def atlas(tmp_path: Path, database_url: str) -> Iterator[ServerProcess]:
    process = serve(tmp_path, database_url)
    process.change("demo", {"app": "brain"})
    yield process
    process.stop()


def decoded(page: Page) -> set[str]:
    image = Image.open(io.BytesIO(page.screenshot(type="png")))
    return {code.payload for code in decode_image(image)}


def layout_of(server: ServerProcess) -> LayoutInfo:
    return fetch_layout(server.url, "demo", operator_token(server.secret))[1]


def settle(server: ServerProcess, tiles: dict[str, Page]) -> None:
    version = server.version("demo")
    wait_until(
        lambda: all(
            version_of(t) == version and t.evaluate("document.body.dataset.volume")
            for t in tiles.values()
        ),
        what=f"every tile to draw the brain at version {version}",
    )


def control(server: ServerProcess, **choice: Any) -> None:
    response = httpx.post(
        f"{server.url}/api/walls/demo/brain", json=choice, headers=server.operator()
    )
    response.raise_for_status()


def test_a_child_answers_every_k5_pin_off_the_tiles_and_sees_the_results(
    browser: Browser, atlas: ServerProcess
) -> None:
    tiles = dict(zip(DEMO, open_tiles(browser, atlas, "demo", DEMO, native=True), strict=True))
    settle(atlas, tiles)
    phone = browser.new_context(**PHONE).new_page()

    # register as a student from the code photographed off the registration tile
    layout = layout_of(atlas)
    student = next(c.payload for c in layout.placed if c.label == "Student")
    assert student in decoded(tiles["r2c1"])
    phone.goto(student)
    expect(phone.locator("#role")).to_have_text("student")

    # the K-5 code off the menu tile: the visitor's group and the wall's pins change
    full_pins = {c.payload for c in layout.placed if c.label.startswith("Pin ")}
    k5 = next(c.payload for c in layout.placed if c.label == "K-5")
    assert k5 in decoded(tiles["r1c3"])
    phone.goto(k5)
    expect(phone.locator("#outcome")).to_contain_text("K-5 group")
    settle(atlas, tiles)
    k5_layout = layout_of(atlas)
    k5_pins = {c.payload for c in k5_layout.placed if c.label.startswith("Pin ")}
    assert k5_pins and not k5_pins & full_pins
    shown = set().union(*(decoded(tiles[t]) for t in FREE))
    assert k5_pins <= shown and not full_pins & shown, "the tiles show the K-5 pins only"

    # turn the brain through the views; answer each pin read off the tiles, half right
    names = [r.name for r in load_content().in_set("k5")]
    answered: set[int] = set()
    for preset in load_views():
        control(atlas, preset=preset.id)
        settle(atlas, tiles)
        labels = {c.payload: c.label for c in layout_of(atlas).placed}
        for payload in set().union(*(decoded(tiles[t]) for t in FREE)):
            label = labels.get(payload, "")
            number = int(label.removeprefix("Pin ")) if label.startswith("Pin ") else 0
            if not number or number in answered:
                continue
            phone.goto(payload)
            expect(phone.locator("h1")).to_have_text(label)
            text = names[number - 1] if number % 2 else "no idea"
            phone.locator("#answer").fill(text)
            phone.get_by_role("button", name="Send").click()
            expect(phone.locator("#answered")).to_contain_text(f"{len(answered) + 1} of 11")
            answered.add(number)
    assert answered == set(range(1, 12))

    phone.locator("#finish").click()
    expect(phone.locator("#score")).to_have_text("6 of 11 right")
    results = phone.locator("#pins").inner_text()
    assert all(name in results for name in names)
    phone.context.close()
    for page in tiles.values():
        page.context.close()


def test_the_instructor_turns_the_brain_and_follows_the_class_from_the_dashboard(
    browser: Browser, atlas: ServerProcess
) -> None:
    [tile] = open_tiles(browser, atlas, "demo", ["r2c2"])
    settle(atlas, {"r2c2": tile})
    dashboard = browser.new_page()
    dashboard.goto(f"{atlas.url}/login/operator?token={operator_token(atlas.secret)}")
    panel = dashboard.locator("#brain-panel")
    expect(panel.locator("#brain-now")).to_contain_text("quiz, full pins")
    before = version_of(tile)

    panel.get_by_role("button", name="Deep structures, axial slice").click()

    wait_until(lambda: (version_of(tile) or 0) > (before or 0), what="the tile to turn")
    assert atlas.status("demo")["state"]["view"]["pitch"] == 90
    # a student answers a pin; the panel's table counts it
    pin = next(c for c in layout_of(atlas).placed if c.label.startswith("Pin "))
    phone = browser.new_context(**PHONE).new_page()
    phone.goto(pin.payload)
    phone.locator("#answer").fill("the wrong thing")
    phone.get_by_role("button", name="Send").click()
    number = pin.label.removeprefix("Pin ")
    row = panel.locator("#brain-stats tbody tr").nth(int(number) - 1)
    expect(row).to_contain_text("the wrong thing (1)", timeout=10_000)
    expect(panel.locator("#brain-participants")).to_contain_text("1 taking part")

    panel.get_by_role("button", name="Tutor").click()
    expect(panel.locator("#brain-now")).to_contain_text("tutor")
    phone.goto(pin.payload)
    expect(phone.locator("#tutor-text")).to_be_visible()
    phone.context.close()
    tile.context.close()
    dashboard.close()
