"""People at the wall, in Chromium: a student registers from a code photographed off a
tile, an instructor pairs a phone from a code photographed off the dashboard, and
publications reach the public tile, at once or after approval."""

from __future__ import annotations

import io
import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from PIL import Image
from playwright.sync_api import Browser, BrowserContext, Locator, Page, expect

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles
from tests.browser.phone_audit import fits
from tests.conftest import TEST_PASSWORD
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess
from webapp.database.connection import Database
from webapp.people.accounts import add_account
from webapp.people.security import operator_token

PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}


def decoded(target: Page | Locator) -> set[str]:
    """The payloads of every code in a screenshot of ``target``, as a camera reads them."""
    image = Image.open(io.BytesIO(target.screenshot(type="png")))
    return {code.payload for code in decode_image(image)}


@pytest.fixture
def contexts(browser: Browser) -> Iterator[list[BrowserContext]]:
    """Contexts a test opens, closed whatever happens."""
    opened: list[BrowserContext] = []
    yield opened
    for context in opened:
        context.close()


def new_page(browser: Browser, contexts: list[BrowserContext], **options: object) -> Page:
    context = browser.new_context(**options)  # type: ignore[arg-type]
    contexts.append(context)
    return context.new_page()


def registration_payload(server: ServerProcess, tile: Page, label: str) -> str:
    """The payload of the registration code ``label``, read off the tile's screenshot."""
    _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    [placed] = [code for code in layout.placed if code.label == label]
    shown = decoded(tile)
    assert placed.payload in shown, (label, shown)
    return placed.payload


def sign_in_on_dashboard(page: Page, server: ServerProcess, username: str) -> None:
    page.goto(f"{server.url}/dashboard")
    expect(page.locator("h1")).to_have_text("Sign in")
    page.get_by_label("Username").fill(username)
    page.get_by_label("Password").fill(TEST_PASSWORD)
    page.get_by_role("button", name="Sign in").click()
    expect(page.locator("h1")).to_have_text("Dashboard")
    expect(page.locator("#live")).to_have_text("live")


@pytest.mark.persistence
def test_students_register_instructors_pair_and_publications_reach_the_public_tile(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    database = Database(server.database_url)
    add_account(database, "ines", "instructor", TEST_PASSWORD, actor="test")
    database.dispose()
    registration, public = open_tiles(browser, server, "demo", ["r2c1", "r1c2"], native=True)
    contexts.extend([registration.context, public.context])
    expect(registration.locator("body")).to_have_attribute(
        "data-version", str(server.version("demo"))
    )

    # A student scans the Student code photographed off the registration tile.
    student = new_page(browser, contexts, **PHONE)
    student.goto(registration_payload(server, registration, "Student"))
    expect(student.locator("#role")).to_have_text("student")

    # An unpaired phone scanning the Instructor code is sent to sign in.
    phone = new_page(browser, contexts, **PHONE)
    phone.goto(registration_payload(server, registration, "Instructor"))
    expect(phone.locator("h1")).to_have_text("Sign in")

    # The instructor signs in on the dashboard and shows a pairing code; the phone scans it.
    dashboard = new_page(browser, contexts, viewport={"width": 1280, "height": 1600})
    sign_in_on_dashboard(dashboard, server, "ines")
    dashboard.get_by_role("button", name="Show a pairing code").click()
    code_image = dashboard.locator("#pairing-code")
    expect(code_image).to_be_visible()
    [pairing] = decoded(code_image)
    assert "/P/" in pairing
    phone.goto(pairing)
    phone.get_by_role("button", name="Become instructor").click()
    expect(phone.locator("#role")).to_have_text("instructor")
    # the code works once: a second phone is refused
    late = new_page(browser, contexts, **PHONE)
    late.goto(pairing)
    expect(late.locator("h1")).to_have_text("Pairing did not work")
    expect(late.locator("body")).to_contain_text("already used")
    # the paired phone, scanning the Instructor code now, is an instructor at the wall
    phone.goto(registration_payload(server, registration, "Instructor"))
    expect(phone.locator("#role")).to_have_text("instructor")

    # The student publishes a setup code's page; the public tile shows it.
    _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    setup = {code.label: code.payload for code in layout.placed}
    student.goto(setup["Display r2c2"])
    student.get_by_role("button", name="Publish to the public screen").click()
    expect(student.locator("#outcome")).to_contain_text("on the public screen")
    screen = public.locator("#public")
    shown = screen.locator(".public-view:not([hidden]) h1")  # the next one is built off screen
    expect(screen).to_be_visible()
    expect(shown).to_have_text("Display r2c2")
    expect(screen).to_contain_text("Published by a student")
    expect(dashboard.locator("#public-shown")).to_contain_text("Display r2c2")

    # With moderation on, the next one waits for the instructor's approval.
    dashboard.get_by_label("hold students' publications for approval").check()
    expect(dashboard.locator("#public-moderated")).to_be_checked()
    student.goto(setup["Display r2c3"])
    student.get_by_role("button", name="Publish to the public screen").click()
    expect(student.locator("#outcome")).to_contain_text("instructor will look at it")
    waiting = dashboard.locator("#waiting li", has_text="Display r2c3")
    expect(waiting).to_be_visible()
    # a preview of what would go up: the server's escaped HTML, in a frame with no rights
    frame = waiting.locator("iframe.preview")
    expect(frame).to_have_attribute("sandbox", "")
    preview = waiting.frame_locator("iframe.preview")
    expect(preview.locator("h1")).to_have_text("Display r2c3")
    expect(preview.locator("footer")).to_contain_text("Published by a student")
    if shots := os.environ.get("TAGWALL_SCREENSHOTS"):
        waiting.screenshot(path=Path(shots) / "moderation-queue.png")
    expect(shown).to_have_text("Display r2c2")  # not shown yet
    waiting.get_by_role("button", name="Approve").click()
    expect(shown).to_have_text("Display r2c3")
    expect(dashboard.locator("#waiting li")).to_have_count(0)

    # One declined: the student's page says so.
    student.goto(setup["Display r1c1"])
    student.get_by_role("button", name="Publish to the public screen").click()
    expect(student.locator("#outcome")).to_contain_text("instructor will look at it")
    declined = dashboard.locator("#waiting li", has_text="Display r1c1")
    declined.get_by_role("button", name="Reject").click()
    expect(dashboard.locator("#waiting li")).to_have_count(0)
    student.get_by_role("link", name="Your page").click()
    expect(student.locator("#published")).to_contain_text(
        "Display r1c1: not shown: the instructor declined it"
    )
    expect(student.locator("#published")).to_contain_text("Display r2c3: on the public screen")
    problems = [p for fit in fits(student).values() for p in fit.problems]
    assert not problems, problems
    if shots:
        student.set_viewport_size({"width": 390, "height": 844})
        student.screenshot(path=Path(shots) / "me-published.png", full_page=True)

    # Clearing empties the public tile.
    dashboard.get_by_role("button", name="Clear the public screen").click()
    expect(screen).to_be_hidden()


def test_the_dashboard_feed_shows_scans_as_they_happen(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    database = Database(server.database_url)
    add_account(database, "ines", "instructor", TEST_PASSWORD, actor="test")
    database.dispose()
    dashboard = new_page(browser, contexts)
    sign_in_on_dashboard(dashboard, server, "ines")
    _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    phone = new_page(browser, contexts, **PHONE)
    phone.goto({code.label: code.payload for code in layout.placed}["Display r1c1"])
    expect(dashboard.locator("#scans li").first).to_contain_text("Display r1c1 (pattern)")


def test_a_student_cannot_open_the_dashboard(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    student = new_page(browser, contexts, **PHONE)
    student.goto({code.label: code.payload for code in layout.placed}["Student"])
    student.goto(f"{server.url}/dashboard")
    expect(student.locator("h1")).to_have_text("Sign in")


def kept_on(page: Page) -> list[str]:
    """The answers a phone keeps to send later (static/js/keptforms.js), as it stores them."""
    return page.evaluate(
        "Object.keys(localStorage).filter((key) => key.startsWith('tagwall:kept:'))"
        ".map((key) => JSON.parse(localStorage[key]).fields.answer)"
    )


def keep_an_answer(phone: Page, pin: str, answer: str) -> None:
    """Type ``answer`` on the pin's question page while sending answers fails (until
    the caller's ``unroute``): kept, not sent yet."""
    phone.goto(pin)
    phone.route("**/answer", lambda route: route.abort())  # the network fails for them
    phone.locator("#answer").fill(answer)
    phone.get_by_role("button", name="Send").click()
    expect(phone.locator("#kept-notice")).to_contain_text("kept on this phone")


def shows_nothing_kept(phone: Page, pin: str) -> None:
    """The pin's question page opened afresh: an empty answer, no word of a kept one,
    and nothing sent in this session's name (its count stays at none answered)."""
    phone.goto(pin)
    expect(phone.locator("#answer")).to_have_value("")
    expect(phone.locator("#kept-notice")).to_have_count(0)
    phone.wait_for_load_state("networkidle")
    assert kept_on(phone) == []
    expect(phone.locator(".hint", has_text="pins answered")).to_contain_text("0 of")


def test_a_kept_answer_leaves_a_shared_phone_with_the_person_who_typed_it(
    browser: Browser, server: ServerProcess, contexts: list[BrowserContext]
) -> None:
    """An answer typed where the connection failed is kept on the phone to send later;
    the phone passed to the next person (its user signed out, or its session gone)
    keeps, shows and sends nothing of it."""
    database = Database(server.database_url)
    add_account(database, "ines", "instructor", TEST_PASSWORD, actor="test")
    database.dispose()
    server.change("demo", {"app": "brain"})  # its pins, a quiz round open
    _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    pin = next(code.payload for code in layout.placed if code.label.startswith("Pin "))
    phone = new_page(browser, contexts, **PHONE)

    # The instructor, signed in on the room's phone, answers a pin; it is kept.
    phone.goto(f"{server.url}/login?next=/me")
    phone.get_by_label("Username").fill("ines")
    phone.get_by_label("Password").fill(TEST_PASSWORD)
    phone.get_by_role("button", name="Sign in").click()
    expect(phone.locator("#role")).to_have_text("instructor")
    keep_an_answer(phone, pin, "thalamus")
    assert kept_on(phone) == ["thalamus"]
    # She signs out before it could be sent: the phone forgets what it kept for her.
    phone.goto(f"{server.url}/me")
    with phone.expect_navigation():
        phone.get_by_role("button", name="Sign out").click()
    assert kept_on(phone) == []
    phone.unroute("**/answer")
    shows_nothing_kept(phone, pin)

    # A student's kept answer, then the phone in other hands with a session of its own
    # (the cookie gone): not shown, not sent as theirs, forgotten.
    keep_an_answer(phone, pin, "hippocampus")
    assert kept_on(phone) == ["hippocampus"]
    phone.unroute("**/answer")
    phone.context.clear_cookies()
    shows_nothing_kept(phone, pin)
