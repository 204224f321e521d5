"""Staff sign in through the test OpenID Provider in Chromium (issue 42): the provider's
own sign-in page filled in, then the dashboard; someone whose claims give no role is
told why. The sign-in page with its provider button and the refusal must fit phones
(360-430 px) and pass axe-core. With TAGWALL_SCREENSHOTS=DIR set, screenshots of the
sign-in page on a phone and a desktop and of the refusal land in DIR."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, BrowserContext, Page, expect

from tests.browser.conftest import serve
from tests.browser.phone_audit import SERIOUS, axe_violations, fits
from tests.conftest import server_port
from tests.oidc.provider import OpenIDProvider
from webapp.cli.testing import ServerProcess

PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
DESKTOP = {"viewport": {"width": 1280, "height": 800}}
SHOTS = os.environ.get("TAGWALL_SCREENSHOTS")


@pytest.fixture
def campus_server(
    tmp_path: Path, database_url: str, openid_provider: OpenIDProvider
) -> Iterator[ServerProcess]:
    """A server whose staff sign in at the test provider, through a client of its own."""
    port = server_port()
    base = f"http://127.0.0.1:{port}"
    client = openid_provider.register(f"{base}/login/oidc/campus/callback", f"{base}/")
    providers = json.dumps({"campus": openid_provider.settings(client)})
    process = serve(tmp_path, database_url, port=port, TAGWALL_OIDC_PROVIDERS=providers)
    yield process
    process.stop()


@pytest.fixture
def contexts(browser: Browser) -> Iterator[list[BrowserContext]]:
    opened: list[BrowserContext] = []
    yield opened
    for context in opened:
        context.close()


def new_page(browser: Browser, contexts: list[BrowserContext], **options: object) -> Page:
    context = browser.new_context(**options)  # type: ignore[arg-type]
    contexts.append(context)
    return context.new_page()


def shoot(page: Page, name: str) -> None:
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        page.screenshot(path=f"{SHOTS}/{name}.png", full_page=True)


def at_the_provider(page: Page, provider: OpenIDProvider, login: str) -> None:
    """Sign ``login`` in on the provider's own sign-in page."""
    expect(page).to_have_url(re.compile(re.escape(provider.issuer) + "/interaction/"))
    page.locator("input[name=login]").fill(login)
    page.locator("input[name=password]").fill("their campus password")
    page.get_by_role("button", name="Sign-in").click()


def problems_on_phones(page: Page) -> list[str]:
    found = [p for fit in fits(page).values() for p in fit.problems]
    found += [v["id"] for v in axe_violations(page) if v["impact"] in SERIOUS]
    return found


def test_an_instructor_signs_in_at_the_campus_provider_and_lands_on_the_dashboard(
    browser: Browser,
    campus_server: ServerProcess,
    openid_provider: OpenIDProvider,
    contexts: list[BrowserContext],
) -> None:
    page = new_page(browser, contexts, **DESKTOP)
    page.goto(f"{campus_server.url}/dashboard")
    expect(page.locator("h1")).to_have_text("Sign in")
    button = page.get_by_role("link", name="Sign in with Campus account")
    expect(button).to_be_visible()
    expect(page.get_by_label("Password")).to_be_visible()  # the password form stays
    shoot(page, "sign-in-desktop")

    button.click()
    at_the_provider(page, openid_provider, "sam")

    expect(page.locator("h1")).to_have_text("Dashboard")
    expect(page.locator("#live")).to_have_text("live")
    assert page.url == f"{campus_server.url}/dashboard"

    page.get_by_role("button", name="Sign out").first.click()
    expect(page.locator("h1")).to_have_text("Signed out of tagwall")
    shoot(page, "signed-out-desktop")
    sign_out = page.get_by_role("link", name="Sign out of Campus account")
    expect(sign_out).to_have_attribute("href", re.compile(r"/session/end\?client_id="))
    page.goto(f"{campus_server.url}/dashboard")
    expect(page.locator("h1")).to_have_text("Sign in")


def test_someone_the_rules_give_no_role_is_refused_and_told_why(
    browser: Browser,
    campus_server: ServerProcess,
    openid_provider: OpenIDProvider,
    contexts: list[BrowserContext],
) -> None:
    phone = new_page(browser, contexts, **PHONE)
    phone.goto(f"{campus_server.url}/login")
    assert not problems_on_phones(phone)
    phone.set_viewport_size(PHONE["viewport"])  # type: ignore[arg-type]
    shoot(phone, "sign-in-phone")

    phone.get_by_role("link", name="Sign in with Campus account").click()
    at_the_provider(phone, openid_provider, "vic")

    expect(phone.locator("h1")).to_have_text("Not signed in")
    expect(phone.locator("[role=alert]")).to_contain_text(
        "Campus account knows you as vic@elsewhere.example.org, but that gives you no role"
    )
    expect(phone.locator(".rules")).to_contain_text("groups has staff: role instructor")
    expect(phone.locator(".facts")).to_contain_text("guests")
    assert not problems_on_phones(phone)
    phone.set_viewport_size(PHONE["viewport"])  # type: ignore[arg-type]
    shoot(phone, "refused-phone")
    phone.goto(f"{campus_server.url}/dashboard")
    expect(phone.locator("h1")).to_have_text("Sign in")
