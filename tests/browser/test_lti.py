"""A class from the course, in Chromium with third-party cookies blocked (as Safari
blocks them): the instructor adds tagwall to the test LMS's course by deep linking
(the demo wall, the brain quiz), launches it in the course's frame and gets the
dashboard with the class started and the course's roster; two students launch from
their phones (390 px) and answer pins with nothing typed but answers; one student
never comes and shows as missing; End class posts both scores (the first post refused
by the gradebook, and retried), and the LMS's gradebook has them."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, Page, expect, sync_playwright

from tests.browser.conftest import serve
from tests.browser.phone_audit import SERIOUS, axe_violations, fits
from tests.lti.lms import TestLms
from webapp.cli.check import fetch_layout
from webapp.cli.testing import CHROMIUM_ARGS, wait_until
from webapp.database.connection import Database
from webapp.people.security import operator_token

PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
DESKTOP = {"viewport": {"width": 1280, "height": 900}}
SHOTS = os.environ.get("TAGWALL_SHOTS")  # a folder to keep screenshots in, to look at


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    """Chromium that blocks third-party cookies: tagwall in the LMS's frame gets none."""
    executable = shutil.which("chromium")
    assert executable, "Debian chromium is not installed: run `make test`"
    with sync_playwright() as playwright:
        launched = playwright.chromium.launch(
            executable_path=executable,
            args=[*CHROMIUM_ARGS, "--test-third-party-cookie-phaseout"],
        )
        yield launched
        launched.close()


def shot(page: Page, name: str) -> None:
    if SHOTS:
        page.screenshot(path=f"{SHOTS}/lti-{name}.png", full_page=True)


def student_joins_in_the_frame(browser: Browser, lms: TestLms, user: str, link: str) -> Page:
    """A phone's browser on the course page: the launch in the frame, then its own tab."""
    context = browser.new_context(**PHONE)  # type: ignore[arg-type]
    course = context.new_page()
    course.goto(lms.page(link, user))
    frame = course.frame_locator("#tool")
    expect(frame.locator("h1")).to_have_text("Biology 101")  # tagwall's page, not the LMS's
    with context.expect_page() as opened:
        frame.get_by_role("button", name="Join the class").click()
    return opened.value


def test_a_class_launched_from_the_course(
    browser: Browser, tmp_path: Path, database_url: str, lms: TestLms
) -> None:
    server = serve(tmp_path, database_url, TAGWALL_LTI_RETRY_FIRST_S="1")
    db = Database(server.database_url)
    try:
        lms.serve(server.url, db)
        teacher = browser.new_context(**DESKTOP)  # type: ignore[arg-type]

        # deep linking: the instructor adds tagwall to the course
        course = teacher.new_page()
        course.goto(lms.page("deep-link", "teacher"))
        tool = course.frame_locator("#tool")
        expect(tool.locator("h1")).to_have_text("Add tagwall to Biology 101")
        picker = next(f for f in course.frames if f.url.endswith("/lti/launch"))
        assert not [v for v in axe_violations(picker) if v["impact"] in SERIOUS]
        tool.get_by_label("Wall").select_option("demo")
        tool.get_by_label("Lesson").select_option("brain:quiz")
        tool.get_by_label("Title in the course").fill("Brain quiz")
        shot(course, "deep-link-picker")
        tool.get_by_role("button", name="Add to the course").click()
        expect(tool.locator("#added")).to_have_text("Brain quiz")
        links = lms.gradebook()["links"]
        assert links["link-1"]["custom"] == {"wall": "demo", "app": "brain", "mode": "quiz"}
        assert links["link-1"]["lineItem"]["scoreMaximum"] == 10

        # the instructor's launch: the dashboard opens in its own tab, the class started
        course.goto(lms.page("link-1", "teacher"))
        expect(tool.locator("h1")).to_have_text("Biology 101")
        assert teacher.cookies(server.url) == []  # deep link and launch: no cookie needed
        shot(course, "instructor-launch")
        with teacher.expect_page() as opened:
            tool.get_by_role("button", name="Open the dashboard").click()
        dashboard = opened.value
        expect(dashboard.locator("#class-title")).to_have_text("Biology 101", timeout=90_000)
        expect(dashboard.locator("#class-naming")).to_have_text("students named by the course")
        expect(dashboard.locator("#class-missing")).to_have_text(
            "Ada Lovelace, Ben Absent, Sam Student"
        )
        expect(dashboard.locator("#app")).to_have_text("brain")
        expect(dashboard.locator("header")).to_contain_text("Signed in as Ines Teacher")

        layout = fetch_layout(server.url, "demo", operator_token(server.secret))[1]
        pins = [c.payload for c in layout.placed if c.label.startswith("Pin ")]
        assert len(pins) >= 2

        # Sam's phone opens the launch itself (the LMS app): straight on to the class
        sam = browser.new_context(**PHONE).new_page()  # type: ignore[arg-type]
        sam.goto(f"{lms.url}/start?user=sam&hint=link-1")
        expect(sam.locator("#joined")).to_contain_text("You are in the class as Sam Student")
        assert not [p for f in fits(sam).values() for p in f.problems]
        assert not [v for v in axe_violations(sam) if v["impact"] in SERIOUS]
        shot(sam, "student-joined-390")
        # Ada's phone browser shows the course page: the launch in its frame, one tap
        ada = student_joins_in_the_frame(browser, lms, "ada", "link-1")
        expect(ada.locator("#joined")).to_contain_text("You are in the class as Ada Lovelace")
        expect(dashboard.locator("#class-joined-names")).to_have_text("Ada Lovelace, Sam Student")
        expect(dashboard.locator("#class-missing")).to_have_text("Ben Absent")
        shot(dashboard, "dashboard-roster")
        # the instructor opens the link again, in a window of its own (an LMS set to
        # open tools so): on to the dashboard by itself, the same class, not a new one
        again = teacher.new_page()
        again.goto(f"{lms.url}/start?user=teacher&hint=link-1")
        expect(again.locator("#class-joined-names")).to_have_text("Ada Lovelace, Sam Student")
        again.close()

        for phone, answer in ((sam, "thalamus"), (ada, "hippocampus")):
            phone.goto(pins[0])  # the first scan: no name asked, the pin's question
            phone.locator("#answer").fill(answer)
            phone.get_by_role("button", name="Send").click()
            expect(phone.locator("#answered")).to_be_visible()
        shot(sam, "student-pin-390")

        # End class: the gradebook refuses the first post; it is kept and tried again
        lms.misbehave(refuse_scores=1)
        dashboard.locator("#class-end").click()
        wait_until(lambda: len(lms.gradebook()["scores"].get("link-1", {})) == 2, 60, "scores")
        assert "not accepted (try 1" in server.log.read_text()  # refused, kept, retried
        scores = lms.gradebook()["scores"]["link-1"]
        assert set(scores) == {"sam", "ada"}  # Ben never joined: no score
        for score in scores.values():
            assert score["activityProgress"] == "Completed"
            assert score["gradingProgress"] == "FullyGraded"
            assert score["scoreMaximum"] >= 1
            assert 0 <= score["scoreGiven"] <= score["scoreMaximum"]
        expect(dashboard.locator("#class-grades")).to_have_text(
            "2 scores in the course's gradebook; no score for Ben Absent (not joined)",
            timeout=20_000,
        )
        shot(dashboard, "dashboard-grades")
    finally:
        db.dispose()
        server.stop()


def test_refusals_show_in_the_courses_frame(
    browser: Browser, tmp_path: Path, database_url: str, lms: TestLms
) -> None:
    """A deep link the platform refuses is its page, the course gets no link; a launch
    tagwall refuses (the platform's keys unreachable) is tagwall's page, framed by the
    course (only a registered platform may frame it), and nothing is created."""
    server = serve(tmp_path, database_url)
    db = Database(server.database_url)
    try:
        lms.serve(server.url, db)
        lms.misbehave(jwks_down=True)  # before any launch: tagwall has none of its keys
        course = browser.new_context(**DESKTOP).new_page()  # type: ignore[arg-type]
        course.goto(lms.page("deep-link", "teacher"))
        tool = course.frame_locator("#tool")
        expect(tool.locator("h1")).to_have_text("tagwall cannot open this")
        expect(tool.get_by_role("alert")).to_contain_text("could not read the learning platform")
        shot(course, "refused-in-frame")
        assert "LTI refused: JWKS of" in server.log.read_text()

        lms.misbehave(refuse_links=True)
        course.goto(lms.page("deep-link", "teacher"))
        tool.get_by_role("button", name="Add to the course").click()
        expect(tool.locator("h1")).to_have_text("The tool's link was refused")
        assert lms.gradebook()["links"] == {}
        assert "LTI deep link to" in server.log.read_text()
    finally:
        db.dispose()
        server.stop()
