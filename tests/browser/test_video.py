"""The video app as an instructor uses it: a video uploaded from the dashboard (a file
that is no video refused in one line), shown on the wall, played and paused from the
phone remote at 390 px, sought and looped from the panel, its sound put on one display;
every tile at its native size, each display showing its part of the frame."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image
from playwright.sync_api import Browser, Page, expect

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles, serve
from tests.browser.phone_audit import SERIOUS, axe_violations, fits
from tests.browser.video_wall import FPS, TILES, lecture_wall, numbered_card
from webapp.apps.video.testcard import read_cell
from webapp.cli.testing import wait_until
from webapp.people.security import operator_token

PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}


def frames(tiles: list[Page], folder: Path | None = None) -> list[int | None]:
    """The frame number each tile shows (one after another: for a paused wall)."""
    shown = []
    for name, page in zip(TILES, tiles, strict=True):
        shot = page.screenshot()
        if folder is not None:
            (folder / f"tile-{name}.png").write_bytes(shot)
        shown.append(read_cell(np.asarray(Image.open(io.BytesIO(shot)).convert("RGB"))))
    return shown


def marks(tiles: list[Page]) -> list[str]:
    return [page.evaluate("document.body.dataset.video || ''") for page in tiles]


def test_an_instructor_plays_a_video_from_the_dashboard_and_the_phone_remote(
    browser: Browser, tmp_path: Path, database_url: str
) -> None:
    server = serve(tmp_path, database_url, TAGWALL_WALL_CONFIGS=str(lecture_wall(tmp_path)))
    try:
        tiles = open_tiles(browser, server, "demo", TILES, native=True)
        sign_in = f"{server.url}/login/operator?token={operator_token(server.secret)}"
        dashboard = browser.new_page(viewport={"width": 1280, "height": 1000})
        dashboard.goto(sign_in)
        dashboard.locator("#app-choice").select_option("video")
        dashboard.locator("#apply-app").click()
        panel = dashboard.locator("#video-panel")
        expect(panel).to_be_visible()
        expect(panel.locator("[data-video-title]")).to_have_text("No video on the wall")

        notes = tmp_path / "notes.mp4"
        notes.write_text("Minutes of the meeting")
        panel.locator("input[name=file]").set_input_files(notes)
        panel.get_by_role("button", name="Upload").click()
        expect(panel.locator("#video-upload-status")).to_have_text(
            "notes.mp4 is not a video (ffprobe cannot read it)."
        )
        panel.locator("input[name=file]").set_input_files(numbered_card(tmp_path, 60.0))
        panel.get_by_label("Title").fill("Sync card")
        panel.get_by_role("button", name="Upload").click()
        expect(panel.locator("#video-upload-status")).to_have_text(
            "added Sync card (1:00, 480 \u00d7 180 px)", timeout=60_000
        )
        row = panel.locator("#video-list tbody tr")
        expect(row).to_have_count(1)
        row.get_by_role("button", name="Show on the wall").click()
        expect(row.get_by_role("button", name="On the wall")).to_be_disabled()
        expect(panel.locator("[data-video-title]")).to_have_text("Sync card")
        wait_until(lambda: all(m.startswith("paused") for m in marks(tiles)), 60, what="tiles")
        assert frames(tiles) == [0] * len(TILES)

        # the phone remote: its code read off the dashboard, opened on an instructor's
        # phone (here signed in by the operator's link)
        panel.get_by_role("button", name="Phone remote").click()
        remote = f"{server.url}/apps/video/demo/remote"
        code = panel.locator("#video-remote-code")
        expect(code).to_be_visible()
        decoded = decode_image(Image.open(io.BytesIO(code.screenshot())))
        assert [d.payload for d in decoded] == [remote]
        phone = browser.new_context(**PHONE).new_page()  # type: ignore[arg-type]
        phone.goto(sign_in)
        phone.goto(remote)
        expect(phone.locator("[data-video-title]")).to_have_text("Sync card")
        expect(phone.locator("[data-video-time]")).to_have_text("0:00 / 1:00")
        assert not [p for f in fits(phone).values() for p in f.problems]
        assert not [v for v in axe_violations(phone) if v["impact"] in SERIOUS]
        phone.set_viewport_size(PHONE["viewport"])  # type: ignore[arg-type]
        phone.screenshot(path=tmp_path / "remote-390.png", full_page=True)

        phone.get_by_role("button", name="Play", exact=True).click()
        wait_until(lambda: all(m.startswith("playing") for m in marks(tiles)), 30, what="play")
        expect(phone.locator("[data-video-time]")).to_have_text("0:02 / 1:00", timeout=10_000)
        phone.get_by_role("button", name="Pause", exact=True).click()
        wait_until(lambda: all(m.startswith("paused") for m in marks(tiles)), 30, what="pause")
        paused = frames(tiles)
        assert paused == [paused[0]] * len(TILES) and paused[0] is not None, paused
        assert paused[0] >= 2 * FPS
        phone.screenshot(path=tmp_path / "remote-390-paused.png", full_page=True)

        # the panel: ten seconds on, while paused (every tile exactly there)
        panel.get_by_role("button", name="On 10 s").click()
        wait_until(lambda: frames(tiles)[0] == paused[0] + 10 * FPS, 30, what="the seek")
        moved = frames(tiles, tmp_path)
        assert moved == [paused[0] + 10 * FPS] * len(TILES), moved
        panel.get_by_label("Loop").check()
        panel.get_by_label("Sound from").select_option("r2c2")
        expect(phone.get_by_label("Loop")).to_be_checked(timeout=10_000)
        expect(phone.get_by_label("Sound from")).to_have_value("r2c2")
        panel.get_by_role("button", name="Play", exact=True).click()
        wait_until(lambda: all(m.startswith("playing") for m in marks(tiles)), 30, what="play")
        said = marks(tiles)
        assert ["sound" if m.endswith("sound") else "muted" for m in said] == [
            "muted", "muted", "muted", "muted", "sound", "muted",
        ], said  # fmt: skip
        assert server.status("demo")["tiles"][0]["notes"] == []
        dashboard.screenshot(path=tmp_path / "dashboard.png", full_page=True)

        # another app: every tile stops, and nothing sounds behind it
        dashboard.locator("#app-choice").select_option("pattern")
        dashboard.locator("#apply-app").click()
        wait_until(lambda: all(m == "" for m in marks(tiles)), 30, what="the pattern")
        assert all(page.evaluate("document.querySelector('video').paused") for page in tiles)
    finally:
        server.stop()
