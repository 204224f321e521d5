"""The public screen shows any publication whole, the way the room sees it: a short
item, the long Broca's-area tutor page and a census tract at information class 5 (its
table of 27 values and its charts) published from phones onto the demo wall's public
tile at native size, and the census tract again on hiperwall, whose small 30-inch
panels seen from 2.5 m need type so large that it takes pages. On every page the title
and the byline lie inside the display, the content lies inside the display and is not
cut, all pages together show all of it, pages turn by themselves, and two public tiles
(one on a skewed local clock) show the same page at the same time. With
TAGWALL_SCREENSHOTS=DIR set, every page seen lands in DIR as a PNG."""

from __future__ import annotations

import io
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser, BrowserContext, Page, expect

from tests.browser.conftest import serve
from tests.conftest import walls_of
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, skewed_clock, wait_until
from webapp.people.security import operator_token

WALL = "demo"
# content/walls/*.toml: each wall's public display and its native resolution
PUBLIC = {"demo": ("r1c2", (1920, 1080)), "hiperwall": ("r1c5", (2560, 1600))}
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
PAGE_S = 4  # pages turn this fast here (reading time is counted in minutes in a room)
SKEW_MS = 2500  # the second public tile's local clock is this far off
# How far a page's turn may lag on a loaded machine; a tile paging by its own clock
# would be SKEW_MS off.
LATE_MS = 1000
CREAM = np.array([0xF6, 0xF3, 0xEA])
EDGE = 16  # px of the screen's border that must stay background: nothing runs off


@pytest.fixture
def server(
    tmp_path: Path, database_url: str, request: pytest.FixtureRequest
) -> Iterator[ServerProcess]:
    process = serve(
        tmp_path,
        database_url,
        walls_of(request),
        TAGWALL_PUBLIC_WORDS_PER_MINUTE="100000",  # every page lasts the minimum
        TAGWALL_PUBLIC_PAGE_MIN_S=str(PAGE_S),
        TAGWALL_PUBMED_URL="http://127.0.0.1:9/",
    )
    yield process
    process.stop()


@pytest.fixture
def contexts(browser: Browser) -> Iterator[list[BrowserContext]]:
    made: list[BrowserContext] = []
    yield made
    for context in made:
        context.close()


def public_tiles(
    browser: Browser, server: ServerProcess, made: list[BrowserContext], wall: str = WALL
) -> list[Page]:
    """The wall's public display twice at native size, as two kiosks would show it: the
    second with its local clock SKEW_MS off (the wall's clock is the server's)."""
    tile, (width, height) = PUBLIC[wall]
    tiles = []
    for skew in (0, SKEW_MS):
        context = browser.new_context(
            viewport={"width": width, "height": height}, device_scale_factor=1
        )
        made.append(context)
        if skew:
            context.add_init_script(skewed_clock(skew))
        page = context.new_page()
        page.goto(server.tile_url(wall, tile))
        tiles.append(page)
    return tiles


def phone(browser: Browser, made: list[BrowserContext]) -> Page:
    context = browser.new_context(**PHONE)  # type: ignore[arg-type]
    made.append(context)
    return context.new_page()


def publish(page: Page) -> None:
    with page.expect_navigation():
        page.get_by_role("button", name="Publish to the public screen").tap()
    expect(page.locator("#outcome")).to_contain_text("on the public screen")


class _Text(HTMLParser):
    """The text of a publication's content: everything but its title and byline."""

    def __init__(self) -> None:
        super().__init__()
        self.skip = 0
        self.parts: list[str] = []

    def handle_starttag(self, tag: str, attrs: Any) -> None:
        self.skip += tag in ("h1", "footer")

    def handle_endtag(self, tag: str) -> None:
        self.skip -= tag in ("h1", "footer")

    def handle_data(self, data: str) -> None:
        if not self.skip:
            self.parts.append(data)


def squeezed(text: str) -> str:
    return "".join(text.split())


def content_text(html: str) -> str:
    parser = _Text()
    parser.feed(html)
    return squeezed("".join(parser.parts))


# Where what the public screen draws lies, whatever builds it.
DRAWN = """() => {
  const screen = document.getElementById("public");
  const box = (e) => { const r = e.getBoundingClientRect();
    return [r.left, r.top, r.right, r.bottom]; };
  const drawn = [...screen.querySelectorAll("*")].filter((e) => {
    const r = e.getBoundingClientRect(); return r.width && r.height; });
  return {title: box(screen.querySelector("h1")), footer: box(screen.querySelector("footer")),
          drawn: drawn.map((e) => ({tag: e.tagName, text: e.innerText?.slice(0, 40),
                                    box: box(e)}))};
}"""

# What a tile shows now: the page, and where everything on it is.
LOOK = """() => {
  const screen = document.getElementById("public");
  const view = screen.querySelector(".public-view");
  const box = (e) => { const r = e.getBoundingClientRect();
    return [r.left, r.top, r.right, r.bottom]; };
  const page = view.querySelector(".public-page:not([hidden])");
  const content = [];
  for (const column of page.querySelectorAll(".public-column")) {
    for (const e of column.querySelectorAll("*")) {
      const r = e.getBoundingClientRect();
      if (r.width && r.height) content.push({tag: e.tagName, box: box(e), column: box(column)});
    }
  }
  return {
    page: Number(screen.dataset.page), pages: Number(screen.dataset.pages),
    title: box(view.querySelector("h1")), titleText: view.querySelector("h1").innerText,
    footer: box(view.querySelector("footer")), byline: view.querySelector(".byline").innerText,
    number: view.querySelector(".page-number").innerText,
    font: Number(view.dataset.fontPx), content, text: page.textContent,
  };
}"""

STATE = """() => { const s = document.getElementById("public").dataset;
  return {publication: s.publication, page: Number(s.page ?? 0), pages: Number(s.pages ?? 0),
          since: Number(s.pageSince ?? 0), until: Number(s.pageUntil ?? 0)}; }"""


@dataclass
class Watch:
    """What the public tiles showed, page by page."""

    publication: str
    pages: int = 0
    texts: dict[int, str] = field(default_factory=dict)  # page -> its text (first tile)
    looked: set[tuple[int, int]] = field(default_factory=set)  # (tile, page) inspected
    shown: dict[int, set[tuple[int, int, int]]] = field(default_factory=dict)
    turns: set[tuple[int, int]] = field(default_factory=set)  # (tile, page) seen to start


def inside(inner: list[float], outer: list[float], slack: float = 1.0) -> bool:
    return (
        inner[0] >= outer[0] - slack
        and inner[1] >= outer[1] - slack
        and inner[2] <= outer[2] + slack
        and inner[3] <= outer[3] + slack
    )


def screenshot(page: Page) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(page.screenshot(type="png"))).convert("RGB"))


def on_screen(tile: Page, where: str) -> np.ndarray:
    """As the room sees it: the title and the byline, and everything else the screen
    draws, lie inside the display (its border stays background: nothing runs off), and
    the title is drawn. Returns the screenshot."""
    seen = tile.evaluate(DRAWN)
    picture = screenshot(tile)
    size = tile.viewport_size
    assert size is not None
    display = [0, 0, size["width"], size["height"]]
    assert inside(seen["title"], display), f"{where}: title {seen['title']} off screen"
    assert inside(seen["footer"], display), f"{where}: byline {seen['footer']} off screen"
    for item in seen["drawn"]:
        assert inside(item["box"], display), f"{where}: {item} off screen"
    frame = np.concatenate(
        [picture[:EDGE].reshape(-1, 3), picture[-EDGE:].reshape(-1, 3),
         picture[:, :EDGE].reshape(-1, 3), picture[:, -EDGE:].reshape(-1, 3)]
    ).astype(int)  # fmt: skip
    off = int((np.abs(frame - CREAM).max(axis=1) > 40).sum())
    assert off == 0, f"{where}: {off} pixels of the screen's edge are not background"
    x0, y0, x1, y1 = (round(v) for v in seen["title"])
    ink = (picture[y0:y1, x0:x1].max(axis=2) < 100).mean()
    assert ink > 0.005, f"{where}: the title is not drawn ({ink:.4f} dark)"
    return picture


def inspect(tile: Page, index: int, watch: Watch, name: str) -> bool:
    """Check the page the tile shows; False when it turned meanwhile (look again later)."""
    seen = tile.evaluate(LOOK)
    picture = on_screen(tile, f"{name}, tile {index}")
    if tile.evaluate(STATE)["page"] != seen["page"]:
        return False
    page, pages = seen["page"], seen["pages"]
    where = f"{name}, tile {index}, page {page} / {pages}"
    assert seen["titleText"].strip(), where
    assert seen["byline"].startswith("Published by "), where
    assert seen["number"] == (f"{page} / {pages}" if pages > 1 else ""), where
    assert seen["content"], f"{where}: an empty page"
    body = [seen["title"][0], seen["title"][3], seen["footer"][2], seen["footer"][1]]
    for item in seen["content"]:
        assert inside(item["box"], item["column"]), f"{where}: {item} cut by its column"
        assert inside(item["box"], body), f"{where}: {item} over the title or byline"
    if index == 0:
        watch.texts[page] = seen["text"]
    folder = os.environ.get("TAGWALL_SCREENSHOTS")
    if folder:
        Path(folder).mkdir(parents=True, exist_ok=True)
        Image.fromarray(picture).save(Path(folder) / f"public-{name}-tile{index}-p{page}.png")
    return True


def watch_every_page(tiles: list[Page], publication: str, name: str) -> Watch:
    """Watch the tiles until each showed every page (inspected) and was seen turning to
    it; every sighting is checked against when the wall's clock says that page is up."""
    watch = Watch(publication)

    wait_until(
        lambda: all(t.evaluate(STATE)["publication"] == publication for t in tiles),
        timeout=60,
        what="the public tiles to show the publication",
    )
    for index, tile in enumerate(tiles):
        on_screen(tile, f"{name}, tile {index}")
    wait_until(
        lambda: all(t.evaluate(STATE)["pages"] for t in tiles),
        what="the public tiles to count its pages",
    )
    watch.pages = tiles[0].evaluate(STATE)["pages"]
    assert all(t.evaluate(STATE)["pages"] == watch.pages for t in tiles), "same pages everywhere"
    last: dict[int, int] = {}
    deadline = time.monotonic() + 60 + 3 * watch.pages * PAGE_S
    while time.monotonic() < deadline:
        for index, tile in enumerate(tiles):
            before = time.time() * 1000
            state = tile.evaluate(STATE)
            after = time.time() * 1000
            page = state["page"]
            # the tile showed this page at some instant between before and after
            assert watch.pages == 1 or (
                after >= state["since"] - LATE_MS and before <= state["until"] + LATE_MS
            ), (
                f"{name}: tile {index} shows page {page} at {before:.0f}..{after:.0f}, "
                f"the wall's clock says {state['since']}..{state['until']}"
            )
            watch.shown.setdefault(index, set()).add((page, state["since"], state["until"]))
            if index in last and last[index] != page:
                watch.turns.add((index, page))
            last[index] = page
            if (index, page) not in watch.looked and inspect(tile, index, watch, name):
                watch.looked.add((index, page))
        everything = {(i, p) for i in range(len(tiles)) for p in range(1, watch.pages + 1)}
        if watch.looked >= everything and (watch.pages == 1 or watch.turns >= everything):
            break
        time.sleep(0.1)
    else:
        raise AssertionError(f"{name}: not every page seen: {sorted(watch.looked)}")
    # each page follows the one before, and the tiles put the same page up for the same
    # span of the wall's clock
    spans = watch.shown[0] | watch.shown[1]
    for page, _, until in spans if watch.pages > 1 else ():
        for other, since, _ in spans:
            if abs(since - until) < LATE_MS:
                assert other == page % watch.pages + 1, f"{name}: page {other} after {page}"
    for page, since, until in watch.shown[0]:
        for other, other_since, other_until in watch.shown[1]:
            if abs(other_since - since) < LATE_MS:
                assert (other, abs(other_until - until) < LATE_MS) == (page, True), name
    return watch


def the_publication(server: ServerProcess, wall: str = WALL) -> dict[str, Any]:
    shown = httpx.get(f"{server.url}/api/walls/{wall}/public", headers=server.operator())
    shown.raise_for_status()
    item: dict[str, Any] = shown.json()["shown"]
    return item


def check_whole(server: ServerProcess, tiles: list[Page], name: str, wall: str = WALL) -> Watch:
    item = the_publication(server, wall)
    watch = watch_every_page(tiles, str(item["id"]), name)
    together = squeezed("".join(watch.texts[p] for p in range(1, watch.pages + 1)))
    assert together == content_text(item["html"]), f"{name}: the pages do not show it all"
    return watch


def test_a_short_publication_shows_on_one_page(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    tiles = public_tiles(browser, server, contexts)
    _, layout = fetch_layout(server.url, WALL, operator_token(server.secret))
    setup = {code.label: code.payload for code in layout.placed}
    student = phone(browser, contexts)
    student.goto(setup["Display r2c2"])
    publish(student)
    watch = check_whole(server, tiles, "short")
    assert watch.pages == 1
    assert tiles[0].evaluate(LOOK)["font"] == 32, "a short item in the largest type"


def test_the_long_brocas_area_tutor_page_shows_whole(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    server.change(WALL, {"app": "brain"})
    for change in ({"preset": "left-side"}, {"mode": "tutor"}):
        httpx.post(
            f"{server.url}/api/apps/brain/walls/{WALL}", json=change, headers=server.operator(),
            timeout=60,
        ).raise_for_status()  # fmt: skip
    tiles = public_tiles(browser, server, contexts)
    _, layout = fetch_layout(server.url, WALL, operator_token(server.secret))
    pins = [code.payload for code in layout.placed if code.label.startswith("Pin ")]
    student = phone(browser, contexts)  # an undergraduate: the default group
    for pin in pins:
        student.goto(pin)
        if student.locator("h1").inner_text() == "Broca's area":
            break
    else:
        pytest.fail("no pin of the left-side view marks Broca's area")
    expect(student.locator("body")).to_contain_text("For the Undergraduate group")
    publish(student)
    check_whole(server, tiles, "brocas-area")
    assert tiles[0].evaluate(LOOK)["byline"].startswith("Published by a student · ")


def publish_a_tract_at_class_5(browser: Browser, server: ServerProcess, wall: str,
                               made: list[BrowserContext]) -> None:  # fmt: skip
    """An instructor's phone at information class 5 publishes a tract's page."""
    instructor = phone(browser, made)
    pairing = httpx.post(f"{server.url}/api/pairing", headers=server.operator()).json()["url"]
    instructor.goto(pairing)
    with instructor.expect_navigation():
        instructor.get_by_role("button", name="Become instructor").tap()
    instructor.goto(f"{server.url}/me")
    instructor.locator("select[name=info_class]").select_option("5")
    with instructor.expect_navigation():
        instructor.get_by_role("button", name="Save").tap()
    instructor.goto(f"{server.url}/apps/census/{wall}/tracts")
    tract = instructor.locator(".tract-list a").first.get_attribute("href")
    instructor.goto(f"{server.url}{tract}/here")
    expect(instructor.locator(".hint").first).to_contain_text("information class 5")
    publish(instructor)


def every_value_and_chart(server: ServerProcess, wall: str) -> None:
    """The publication is the tract's whole class-5 page: 27 values, and charts."""
    html = the_publication(server, wall)["html"]
    assert html.count("<svg") >= 2 and html.count("<dt>") == 27


def test_a_census_tract_at_class_5_shows_its_table_and_charts_whole(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    server.change(WALL, {"app": "census"})
    tiles = public_tiles(browser, server, contexts)
    publish_a_tract_at_class_5(browser, server, WALL, contexts)
    check_whole(server, tiles, "census-class-5")
    every_value_and_chart(server, WALL)
    assert tiles[0].evaluate(LOOK)["byline"].startswith("Published by an instructor · ")


@pytest.mark.walls("demo", "hiperwall")
@pytest.mark.alone  # pages turn in step, within a second
def test_what_does_not_fit_takes_pages_that_turn_in_step_on_every_public_tile(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    server.change("hiperwall", {"app": "census"})
    tiles = public_tiles(browser, server, contexts, "hiperwall")
    publish_a_tract_at_class_5(browser, server, "hiperwall", contexts)
    watch = check_whole(server, tiles, "census-hiperwall", "hiperwall")
    every_value_and_chart(server, "hiperwall")
    assert watch.pages >= 2, "67 px type on a 2560 x 1600 screen holds no 27 rows and charts"
    assert tiles[0].evaluate(LOOK)["font"] >= 67, "never below what the seats can read"
