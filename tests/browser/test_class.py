"""A class in Chromium, as an instructor and a room of phones run it: Start class on
the dashboard, three students join with their roster ids and answer, one of them
offline mid-answer, End class, and the export carries every id and answer."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

from playwright.sync_api import Browser, Page, expect

from tests.browser.conftest import serve
from tests.browser.phone_audit import SERIOUS, axe_violations, fits
from webapp.cli.check import fetch_layout
from webapp.people.security import operator_token

PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
ROSTER = ["A-0017", "B-0042", "C-0101"]
SHOTS = os.environ.get("TAGWALL_SHOTS")  # a folder to keep screenshots in, to look at


def answer(phone: Page, pin_url: str, text: str) -> None:
    phone.goto(pin_url)
    phone.locator("#answer").fill(text)
    phone.get_by_role("button", name="Send").click()


def test_a_class_from_start_to_end_with_roster_ids(
    browser: Browser, tmp_path: Path, database_url: str
) -> None:
    server = serve(tmp_path, database_url)
    try:
        dashboard = browser.new_page(viewport={"width": 1280, "height": 900})
        dashboard.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
        panel = dashboard.locator("#class-panel")
        panel.get_by_label("Title").fill("Anatomy B")
        panel.get_by_label("App").select_option("brain")
        panel.get_by_label("Mode").select_option("quiz")
        panel.get_by_label("Students' names").select_option("roster")
        started = "/api/walls/demo/class"
        with dashboard.expect_response(lambda r: r.url.endswith(started), timeout=60_000):
            panel.get_by_role("button", name="Start class").click()  # the wall is ready
        expect(dashboard.locator("#class-title")).to_have_text("Anatomy B", timeout=60_000)
        expect(dashboard.locator("#class-joined")).to_have_text("0")
        expect(dashboard.locator("#app")).to_have_text("brain")

        layout = fetch_layout(server.url, "demo", operator_token(server.secret))[1]
        student_url = next(c.payload for c in layout.placed if c.label == "Student")
        pins = [c.payload for c in layout.placed if c.label.startswith("Pin ")]
        assert len(pins) >= 2

        phones = [browser.new_context(**PHONE).new_page() for _ in ROSTER]
        for phone, roster_id in zip(phones, ROSTER, strict=True):
            phone.goto(student_url)
            expect(phone.locator("h1")).to_have_text("Anatomy B")
            if roster_id == ROSTER[0]:
                assert not [p for f in fits(phone).values() for p in f.problems]
                assert not [v for v in axe_violations(phone) if v["impact"] in SERIOUS]
                if SHOTS:
                    phone.set_viewport_size({"width": 360, "height": 800})
                    phone.screenshot(path=f"{SHOTS}/join-360.png", full_page=True)
                    phone.set_viewport_size(PHONE["viewport"])  # type: ignore[arg-type]
                phone.get_by_label("A roster id").fill("   ")  # blank: asked again
                phone.get_by_role("button", name="Join").click()
                expect(phone.get_by_role("alert")).to_contain_text("Please type your roster id")
            phone.get_by_label("A roster id").fill(roster_id)
            phone.get_by_role("button", name="Join").click()
            expect(phone.locator("#role")).to_have_text("student")
        expect(dashboard.locator("#class-joined")).to_have_text("3")

        answer(phones[0], pins[0], "thalamus")
        expect(phones[0].locator("#answered")).to_be_visible()
        answer(phones[1], pins[0], "hippocampus")
        expect(phones[1].locator("#answered")).to_be_visible()

        # the third phone loses its connection as it sends: the answer stays, goes later
        late = phones[2]
        late.goto(pins[1])
        late.locator("#answer").fill("amygdala")
        late.context.set_offline(True)
        late.get_by_role("button", name="Send").click()
        expect(late.locator("#kept-notice")).to_contain_text("kept on this phone")
        expect(late.locator("#answer")).to_have_value("amygdala")
        if SHOTS:
            late.screenshot(path=f"{SHOTS}/kept-390.png", full_page=True)
        late.context.set_offline(False)
        expect(late.locator("#answered")).to_contain_text("1 of")
        expect(late.locator("#kept-sent")).to_have_text(  # the phone says it went
            "Sent: what you typed while offline has arrived."
        )
        late.reload()  # the same student, the same score
        expect(late.locator("#answered")).to_contain_text("1 of")

        # the scan feed survives a reload of the dashboard
        dashboard.reload()
        expect(dashboard.locator("#scans li").first).to_be_visible()
        assert dashboard.locator("#scans li").count() >= 6
        if SHOTS:
            dashboard.screenshot(path=f"{SHOTS}/dashboard-class.png")

        dashboard.get_by_role("button", name="End class").click()
        expect(dashboard.locator("#class-ended-joined")).to_have_text("3 students")
        export = dashboard.locator("#class-exports").get_by_role("link", name="answers (CSV)")
        expect(export).to_have_count(1)
        with dashboard.expect_download() as download:
            export.click()
        saved = download.value
        assert saved.suggested_filename.startswith("demo-anatomy-b-round-")
        rows = list(csv.DictReader(io.StringIO(Path(saved.path()).read_text())))
        assert sorted((r["name"], r["answer"]) for r in rows) == [
            ("A-0017", "thalamus"),
            ("B-0042", "hippocampus"),
            ("C-0101", "amygdala"),
        ]
        phones[0].reload()  # the round closed: names for everyone
        expect(phones[0].locator("#score")).to_be_visible()
        for phone in phones:
            phone.context.close()
        dashboard.close()
    finally:
        server.stop()
