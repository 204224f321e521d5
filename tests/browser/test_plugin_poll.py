"""A live poll from outside tagwall: ``tests/plugins/poll_app``, the worked example of
docs/apps.md, installed beside it (``pip install --target``) into a folder that only the
test's server sees.

Its table is made by ``tagwall serve``'s migrations; an instructor asks a question from
the poll's dashboard panel; the six tiles of the demo wall draw a bar per choice, clear
of the choices' codes; two phones vote with codes read off the tiles' screenshots; the
counts reach every tile; a second vote is refused; the votes export as CSV with the
question's text.
"""

from __future__ import annotations

import csv
import io
import shutil
from pathlib import Path

import pytest
from PIL import Image
from playwright.sync_api import Browser, Page, expect
from sqlalchemy import inspect

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles, serve
from tests.browser.phone_audit import SERIOUS, axe_violations, fits
from tests.browser.test_plugin_lifecycle import pip_install
from webapp.cli.check import fetch_layout
from webapp.cli.testing import wait_until
from webapp.core.settings import PROJECT_ROOT
from webapp.database.connection import make_engine
from webapp.people.security import operator_token

PLUGIN = PROJECT_ROOT / "tests" / "plugins" / "poll_app"
TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
STAGE = ["r2c2", "r2c3"]  # the demo's stage: where the bars and codes stand
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
CLASS = {"title": "Cell biology"}
QUESTION = "Which organelle should we review first?"
CHOICES = ["Mitochondria", "Ribosomes", "Golgi apparatus"]  # three: the middle one at a bezel
BACKGROUND = (0x12, 0x20, 0x3A)  # the poll layer's
BARS = [(0x4E, 0x79, 0xA7), (0xF2, 0x8E, 0x2B), (0xE1, 0x57, 0x59)]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The poll installed into a folder of its own, as pip leaves an app."""
    source = tmp_path_factory.mktemp("source") / "poll_app"
    shutil.copytree(PLUGIN, source)  # building writes beside the sources: not in the checkout
    target = tmp_path_factory.mktemp("site")
    pip_install(source, target)
    return target


def marks(tile: Page) -> str | None:
    """The poll on the tile, as its layer marks it: ``round:count,count,...``."""
    value: str | None = tile.evaluate("document.body.dataset.poll")
    return value


def screenshot(tile: Page, path: Path) -> Image.Image:
    tile.screenshot(path=path)
    return Image.open(path).convert("RGB")


def test_a_poll_asked_on_the_dashboard_is_voted_on_by_phones_and_exported(
    browser: Browser, site: Path, tmp_path: Path, database_url: str
) -> None:
    server = serve(tmp_path, database_url, PYTHONPATH=str(site), TAGWALL_FIRST_APP="poll")
    try:
        engine = make_engine(database_url)
        assert "poll_questions" in inspect(engine).get_table_names()  # serve's migrations
        engine.dispose()
        tiles = dict(
            zip(TILES, open_tiles(browser, server, "demo", TILES, native=True), strict=True)
        )

        started = server.http.post("/api/walls/demo/class", json=CLASS, headers=server.operator())
        assert started.status_code == 200, started.text
        dashboard = browser.new_page(viewport={"width": 1280, "height": 900})
        dashboard.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
        panel = dashboard.locator("#poll-panel")
        panel.get_by_label("Question").fill(QUESTION)
        for number, choice in enumerate(CHOICES, start=1):
            panel.get_by_label(f"Choice {number}").fill(choice)
        panel.get_by_role("button", name="Ask the room").click()
        expect(panel.locator("#poll-ask-status")).to_have_text("poll 1 is on the wall")
        wait_until(lambda: all(marks(t) == "1:0,0,0" for t in tiles.values()), what="the poll")

        # each choice's code under its bar, read off the stage's tiles as a camera reads it
        layout = fetch_layout(server.url, "demo", operator_token(server.secret))[1]
        codes = {c.label: c for c in layout.placed if c.label in CHOICES}
        assert set(codes) == set(CHOICES) and all(c.display in STAGE for c in codes.values())
        assert not any(c.leader for c in codes.values()), "each code right under its bar"
        pictures = {t: screenshot(tiles[t], tmp_path / f"{t}-asked.png") for t in STAGE}
        read = {d.payload for p in pictures.values() for d in decode_image(p)}
        scanned = {label: code.payload for label, code in codes.items() if code.payload in read}
        assert set(scanned) == set(CHOICES)

        phones = [browser.new_context(**PHONE).new_page() for _ in range(2)]
        phones[0].goto(scanned["Mitochondria"])
        expect(phones[0].locator("#said")).to_have_text("Your vote for Mitochondria is in.")
        phones[1].goto(scanned["Ribosomes"])
        expect(phones[1].locator("#said")).to_have_text("Your vote for Ribosomes is in.")
        wait_until(lambda: all(marks(t) == "1:1,1,0" for t in tiles.values()), what="the votes")

        phones[0].goto(scanned["Golgi apparatus"])  # a second vote: refused politely
        expect(phones[0].locator("#said")).to_have_text(
            "You have voted for Mitochondria: one vote per phone."
        )
        expect(phones[0].locator("#counts th")).to_have_text(CHOICES)
        expect(phones[0].locator("#counts td:last-child")).to_have_text(["1", "1", "0"])
        phones[0].screenshot(path=tmp_path / "phone.png", full_page=True)
        for width, fit in fits(phones[0]).items():  # 360 to 430 px: nothing wider, all legible
            assert not fit.problems, (width, fit.problems)
        assert [v for v in axe_violations(phones[0]) if v["impact"] in SERIOUS] == []
        assert all(marks(t) == "1:1,1,0" for t in tiles.values())  # nothing more counted

        pictures = {t: screenshot(tiles[t], tmp_path / f"{t}-voted.png") for t in STAGE}
        for code in codes.values():  # a bar over each code, stopping short of it
            picture = pictures[code.display]
            x, y, side = code.pixels
            colour = BARS[CHOICES.index(code.label)]
            above = [picture.getpixel((x + side // 2, y - dy)) for dy in range(1, 120)]
            assert colour not in above[:20], f"{code.label}'s bar reaches its code"
            if code.label != "Golgi apparatus":  # no votes, no bar beyond its foot
                assert colour in above[20:], f"no bar over {code.label}"
        for picture in pictures.values():  # nothing drawn across a bezel
            edges = [picture.getpixel((x, y)) for x in (0, 1919) for y in range(0, 1080, 4)]
            assert set(edges) == {BACKGROUND}

        expect(panel.locator("#poll-counts td")).to_have_text(["1", "1", "0"])  # the panel too
        with dashboard.expect_download() as download:
            panel.get_by_role("link", name="Votes (CSV)").click()
        rows = list(csv.DictReader(io.StringIO(download.value.path().read_text())))
        assert sorted((r["question"], r["answer"], r["correct"], r["class"]) for r in rows) == [
            (QUESTION, "Mitochondria", "n/a", "Cell biology"),
            (QUESTION, "Ribosomes", "n/a", "Cell biology"),
        ]
        assert download.value.suggested_filename.startswith("demo-cell-biology-round-1-")

        # the class ends: the poll closes with it, and its votes are the class's download
        ended = server.http.post("/api/walls/demo/class/end", headers=server.operator())
        url = "/api/apps/poll/walls/demo/polls/1/answers.csv"
        assert ended.json()["exports"] == [{"label": f"{QUESTION} (CSV)", "url": url}]
        phones[1].goto(scanned["Golgi apparatus"])
        expect(phones[1].locator("#closed")).to_have_text(
            "This poll is closed: these are its final counts."
        )
    finally:
        server.stop()
