"""The brain atlas in Chromium: a child registers from the tile's code, picks the K-5
group off the menu tile (the wall's pins change), scans every K-5 pin photographed off
the tiles while the instructor turns the brain through its views, answers, finishes
and reads the results."""

from __future__ import annotations

import io
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page, expect

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles, serve, version_of
from tests.browser.phone_audit import SERIOUS, axe_violations, fits
from tests.browser.test_phone_pages import all_pin_codes
from wall_client.config import load_wall
from wall_client.layout import Rect, apply_affine
from webapp.apps.brain_atlas.content import load_content
from webapp.apps.brain_atlas.views import load_views
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, wait_until
from webapp.core.settings import CONTENT_DIR
from webapp.people.security import operator_token
from webapp.tags.schemas import LayoutInfo

DEMO = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
FREE = ["r1c1", "r2c2", "r2c3"]  # the displays that are no designated screen
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}


@pytest.fixture
def atlas(tmp_path: Path, database_url: str) -> Iterator[ServerProcess]:
    process = serve(tmp_path, database_url)
    with httpx.Client(timeout=60) as client:  # the first pins take a while on a busy machine
        process.change("demo", {"app": "brain"}, client)
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
    response = server.http.post(
        "/api/apps/brain/walls/demo", json=choice, headers=server.operator(), timeout=60
    )
    response.raise_for_status()


def brain_status(server: ServerProcess) -> dict[str, Any]:
    response = server.http.get("/api/apps/brain/walls/demo", headers=server.operator())
    response.raise_for_status()
    result: dict[str, Any] = response.json()
    return result


def quiz_post(server: ServerProcess, action: str, **body: Any) -> None:
    response = server.http.post(
        f"/api/apps/brain/walls/demo/quiz/{action}",
        json=body,
        headers=server.operator(),
        timeout=60,
    )
    response.raise_for_status()


def caption_reads(
    tile: Page, image: Image.Image, caption: tuple[float, float, float, float], total: int
) -> int:
    """The pin number the caption under a code shows, read off the screenshot: the
    caption's strip is compared with every candidate drawn by the tile's own caption
    function; the one that matches best is what a person reads there."""
    # each candidate's green channel comes back as one Latin-1 string: a list of numbers
    # per pixel costs Playwright's message checks more than the rest of the test
    (px, py, pw, ph), candidates = tile.evaluate(
        """async ([caption, texts]) => {
          const {drawCaption, pixelBox} = await import("/static/js/codes.js");
          const viewport = JSON.parse(document.body.dataset.viewport);
          const [a, b] = viewport.to_pixels;
          const box = pixelBox(viewport.to_pixels, ...caption);
          const canvas = new OffscreenCanvas(1920, 1080);
          const ctx = canvas.getContext("2d");
          return [box, texts.map((text) => {
            ctx.clearRect(0, 0, canvas.width, canvas.height);
            drawCaption(ctx, text, box, Math.atan2(b, a));
            const data = ctx.getImageData(...box).data;
            let green = "";
            for (let i = 0; i < data.length; i += 4) green += String.fromCharCode(data[i + 1]);
            return green;
          })];
        }""",
        [list(caption), [f"Pin {n}" for n in range(1, total + 1)]],
    )
    seen = np.asarray(image.convert("RGB"))[py : py + ph, px : px + pw, 1].astype(int).ravel()
    scores = []
    for number, green in enumerate(candidates, start=1):
        expected = np.frombuffer(green.encode("latin-1"), dtype=np.uint8).astype(int)
        if len(seen) != len(expected):  # the strip would leave the display
            continue
        scores.append((float(np.abs(seen - expected).mean()), number))
    best, number = min(scores)
    assert best < 8, f"no caption reads as a pin number in the strip at {caption}"
    return number


def pins_seen(server: ServerProcess, tiles: dict[str, Page]) -> dict[int, str]:
    """Pin number -> payload of every pin code decoded off the free tiles now, each
    number read off the caption under its code."""
    layout = layout_of(server)
    placed = {c.payload: c for c in layout.placed}
    total = len(load_content().in_set("k5" if layout.tag_set == "brain-k5" else "full"))
    found: dict[int, str] = {}
    for tile in FREE:
        image = Image.open(io.BytesIO(tiles[tile].screenshot(type="png")))
        for code in decode_image(image):
            entry = placed.get(code.payload)
            if entry is None or not entry.label.startswith("Pin "):
                continue
            number = int(entry.label.removeprefix("Pin "))
            assert entry.caption is not None, f"pin {number} has no caption"
            assert caption_reads(tiles[tile], image, entry.caption, total) == number
            found[number] = code.payload
    return found


PIN_RED = np.array([0xE6, 0x39, 0x46])


def red_near(image: Image.Image, x: float, y: float, radius: int = 2) -> bool:
    """Whether pin red is drawn within ``radius`` px of (x, y) on a tile screenshot."""
    rgb = np.asarray(image.convert("RGB")).astype(int)
    col, row = round(x), round(y)
    patch = rgb[max(row - radius, 0) : row + radius + 1, max(col - radius, 0) : col + radius + 1]
    return bool((np.abs(patch - PIN_RED).sum(axis=2) < 40).any())


def test_a_pin_reaching_a_neighbouring_display_is_drawn_there(
    browser: Browser, atlas: ServerProcess
) -> None:
    """Left side, full set: a pin's code stands on r2c3 and its head on r2c2; the r2c2
    tile draws the head and its part of the line, as the overview does."""
    control(atlas, preset="left-side", tag_set="full")
    tiles = dict(zip(FREE, open_tiles(browser, atlas, "demo", FREE, native=True), strict=True))
    settle(atlas, tiles)
    wall = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    shots = {t: Image.open(io.BytesIO(page.screenshot(type="png"))) for t, page in tiles.items()}
    placed = layout_of(atlas).placed
    # a pin's line may pass under another code or caption (drawn over pins)
    covers = [Rect(x - 2, y - 2, w + 4, h + 4) for x, y, w, h in (c.footprint for c in placed)]
    crossing = 0
    for code in placed:
        if code.leader is None:
            continue
        start, head = code.leader
        for display in (wall.display(t) for t in FREE):
            to_pixels = wall.viewport(display.id).to_pixels
            if display.rect.contains(head):
                crossing += code.display != display.id
                assert red_near(shots[display.id], *apply_affine(to_pixels, *head)), (
                    f"{display.id} lacks the head of {code.label}"
                )
            for t in np.linspace(0.1, 0.9, 9):  # the line, wherever it crosses a tile
                point = (start[0] + t * (head[0] - start[0]), start[1] + t * (head[1] - start[1]))
                if display.rect.contains(point) and not any(r.contains(point) for r in covers):
                    assert red_near(shots[display.id], *apply_affine(to_pixels, *point)), (
                        f"{display.id} lacks the line of {code.label}"
                    )
    assert crossing, "some pin's head stands on another display than its code"
    for page in tiles.values():
        page.context.close()


def shares(image: Image.Image) -> tuple[float, float]:
    """The share of a tile that is brain (the tissue colours: warm, light) and that is
    the setup pattern's display background (#182030)."""
    rgb = np.asarray(image.convert("RGB")).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    # the tissue colours: light and warm, blue about 0.8 of green (not the pattern's
    # yellow diagonals, 0.4, nor its orange circle, 0.7)
    tissue = (r > 150) & (r > g + 20) & (b > 0.76 * g) & (b < 0.9 * g)
    pattern = np.abs(rgb - [0x18, 0x20, 0x30]).sum(axis=2) < 12
    return float(tissue.mean()), float(pattern.mean())


def test_back_to_the_pattern_no_brain_is_left_on_the_tiles(
    browser: Browser, atlas: ServerProcess
) -> None:
    """Switching from the brain atlas back to the setup pattern shows the pattern on
    every stage tile, and nothing of the brain, without clearing the volume by hand."""
    tiles = dict(zip(FREE, open_tiles(browser, atlas, "demo", FREE, native=True), strict=True))
    settle(atlas, tiles)
    shots = {t: Image.open(io.BytesIO(p.screenshot(type="png"))) for t, p in tiles.items()}
    assert max(shares(shot)[0] for shot in shots.values()) > 0.05, "the brain is up"
    version = atlas.change("demo", {"app": "pattern"})
    wait_until(lambda: all(version_of(t) == version for t in tiles.values()), what="the switch")
    for tile, page in tiles.items():
        image = Image.open(io.BytesIO(page.screenshot(type="png")))
        brain, pattern = shares(image)
        assert brain < 0.002 and pattern > 0.5, f"{tile}: brain {brain:.3f}, pattern {pattern:.3f}"
        assert page.evaluate("document.body.dataset.volume") == ""
        assert f"Display {tile}" in {c.label for c in layout_of(atlas).placed}
    assert atlas.status("demo")["state"]["volume"] is None
    for page in tiles.values():
        page.context.close()


def test_a_class_meets_the_quiz_off_the_tiles(browser: Browser, atlas: ServerProcess) -> None:
    """Students on 390 px phones, every code decoded from native tile screenshots: a
    child's K-5 scan changes the child's pages, not the wall; the pins' numbers are read
    off their captions; My quiz sends the child only to views whose tiles show the pin;
    a throw-away private tab that answers "x" everywhere and finishes learns nothing
    while answers count; closing the round shows everyone the names and takes no more
    answers; twenty alternating audience scans swap the wall once; a new round puts
    new codes and numbers on the tiles and an old code says so."""
    tiles = dict(zip(DEMO, open_tiles(browser, atlas, "demo", DEMO, native=True), strict=True))
    settle(atlas, tiles)
    child = browser.new_context(**PHONE).new_page()

    # register as a student from the code photographed off the registration tile
    layout = layout_of(atlas)
    student = next(c.payload for c in layout.placed if c.label == "Student")
    assert student in decoded(tiles["r2c1"])
    child.goto(student)
    expect(child.locator("#role")).to_have_text("student")

    # K-5 off the menu tile, mid-round: the child's group changes, the wall's pins do not
    version = atlas.version("demo")
    full_pins = {c.payload for c in layout.placed if c.label.startswith("Pin ")}
    k5 = next(c.payload for c in layout.placed if c.label == "K-5")
    assert k5 in decoded(tiles["r1c3"])
    child.goto(k5)
    expect(child.locator("#outcome")).to_contain_text("K-5 group")
    expect(child.locator("#wall-pins")).to_contain_text("your instructor chooses")
    assert atlas.version("demo") == version
    assert full_pins & set().union(*(decoded(tiles[t]) for t in FREE))

    # the instructor puts up the K-5 pins and turns the brain through the views
    control(atlas, tag_set="k5")
    shown_in: dict[str, set[int]] = {}
    codes: dict[int, str] = {}
    for preset in load_views():
        control(atlas, preset=preset.id)
        settle(atlas, tiles)
        seen = pins_seen(atlas, tiles)
        shown_in[preset.name] = set(seen)
        codes |= seen
    assert sorted(codes) == list(range(1, 12))

    # My quiz names, per view, only pins whose codes those views put on the tiles
    child.goto(f"{atlas.url}/apps/brain/demo/quiz/k5")
    hints = child.locator("#open-by-view li").all_inner_texts()
    assert hints
    for hint in hints:
        view, _, pins = hint.partition(": ")
        numbers = {int(p.removeprefix("pin ")) for p in pins.split(", ")}
        assert numbers <= shown_in[view], f"{view}: {numbers - shown_in[view]} not on the tiles"

    # a throw-away private tab answers "x" to every pin and finishes
    key = {r["pin"]: r["name"] for r in brain_status(atlas)["quiz"]["k5"]["regions"]}
    cheat = browser.new_context(**PHONE).new_page()
    for payload in codes.values():
        cheat.goto(payload)
        cheat.locator("#answer").fill("x")
        cheat.get_by_role("button", name="Send").click()
        expect(cheat.locator("#answered")).to_be_visible()
    cheat.locator("#finish").click()
    expect(cheat.locator("#waiting")).to_contain_text("right names at the end")
    harvest = cheat.locator("main").inner_text()
    for payload in codes.values():
        cheat.goto(payload)
        harvest += cheat.locator("main").inner_text()
    assert not [name for name in key.values() if name in harvest]
    assert "✓" not in harvest and "✗" not in harvest

    # the child answers, half right, and finishes: no names yet either
    for number, payload in sorted(codes.items()):
        child.goto(payload)
        expect(child.locator("h1")).to_have_text(f"Pin {number}")
        child.locator("#answer").fill(key[number] if number % 2 else "no idea")
        child.get_by_role("button", name="Send").click()
        expect(child.locator("#answered")).to_contain_text("of 11")
    child.locator("#finish").click()
    expect(child.locator("#waiting")).to_be_visible()

    # the instructor closes the round: names for everyone, no more answers
    quiz_post(atlas, "close")
    child.reload()
    expect(child.locator("#score")).to_have_text("6 of 11 right")
    results = child.locator("#pins").inner_text()
    assert all(name in results for name in key.values())
    cheat.goto(codes[1])
    expect(cheat.locator("#round-state")).to_contain_text("over")
    expect(cheat.locator("#answer")).to_have_count(0)

    # the audience may switch now: twenty alternating menu scans in half a second
    control(atlas, audience_switches=True)
    menu = {c.label: c.payload for c in layout_of(atlas).placed}
    other = next(menu[g] for g in ("Medical", "Undergraduate", "Research") if g in menu)
    storm = [menu["K-5"] if n % 2 else other for n in range(20)]
    before = atlas.version("demo")
    with ThreadPoolExecutor(max_workers=20) as pool:
        answers = list(pool.map(lambda url: httpx.get(url, timeout=30), storm))
    assert all(a.status_code == 200 for a in answers)
    assert atlas.version("demo") - before == 1, "one swap, to the full set"
    settle(atlas, tiles)
    assert atlas.status("demo")["state"]["tag_set"] == "brain-full"

    # a new round: new codes and numbers on the tiles, and an old code says so
    quiz_post(atlas, "reset")
    control(atlas, tag_set="k5")
    settle(atlas, tiles)
    fresh = pins_seen(atlas, tiles)
    assert fresh and not set(fresh.values()) & set(codes.values())
    child.goto(codes[1])
    expect(child.locator("h1")).to_have_text("A new round has started")
    child.context.close()
    cheat.context.close()
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

    # tutor pages name every pin: the panel asks before closing the running round
    dashboard.once("dialog", lambda dialog: dialog.accept())
    panel.get_by_role("button", name="Tutor").click()
    expect(panel.locator("#brain-now")).to_contain_text("tutor")
    expect(panel.locator("#brain-round-state")).to_contain_text("closed")
    phone.goto(pin.payload)
    expect(phone.locator("#tutor-text")).to_be_visible()
    phone.context.close()
    tile.context.close()
    dashboard.close()


def test_the_class_results_on_the_dashboard_fit_an_instructors_phone(
    browser: Browser, atlas: ServerProcess, tmp_path: Path
) -> None:
    """Issue 31: the brain's results table on the dashboard ran off the right of a
    390 px phone (it scrolled sideways in its box): on a phone each pin's row stacks,
    every column named, within 360-430 px."""
    pins = all_pin_codes(atlas)
    student = browser.new_context(**PHONE).new_page()
    student.goto(next(c.payload for c in layout_of(atlas).placed if c.label == "Student"))
    student.goto(next(iter(pins.values())))
    csrf = student.locator("input[name=csrf]").first.get_attribute("value") or ""
    for pin, payload in list(pins.items())[:6]:
        response = student.request.post(
            f"{atlas.url}/apps/brain/demo/pins/{payload.rsplit('/', 1)[1]}/answer",
            form={"csrf": csrf, "answer": f"the superior temporal gyrus near region {pin}"},
            max_redirects=0,
        )
        assert response.status == 303, response.text()
    phone = browser.new_context(**PHONE).new_page()
    phone.goto(f"{atlas.url}/login/operator?token={operator_token(atlas.secret)}")
    stats = phone.locator("#brain-stats")
    expect(stats.locator("tbody tr").first).to_be_visible()
    expect(stats).to_contain_text("the superior temporal gyrus near region")
    for width in (360, 390, 430):
        phone.set_viewport_size({"width": width, "height": 844})
        box = stats.bounding_box()
        assert box is not None and box["x"] >= 0 and box["x"] + box["width"] <= width, (
            f"{width} px: the table spans {box}"
        )
        overflow = stats.evaluate(
            """(table) => [...table.querySelectorAll("td")].filter((td) =>
                 td.scrollWidth > td.clientWidth + 1
                 || td.getBoundingClientRect().right > innerWidth + 0.5).length"""
        )
        assert overflow == 0, f"{width} px: {overflow} cells run over"
        assert stats.evaluate("(t) => t.parentElement.scrollWidth <= t.parentElement.clientWidth")
    problems = [p for fit in fits(phone, tables_scroll=True).values() for p in fit.problems]
    assert not problems, problems
    phone.set_viewport_size({"width": 390, "height": 844})
    stats.screenshot(path=tmp_path / "dashboard-results-390.png")
    violations = [v for v in axe_violations(phone) if v["impact"] in SERIOUS]
    assert not violations, violations
    phone.context.close()
    student.context.close()
