"""The dashboard in Chromium: what the operator sees and switches."""

from __future__ import annotations

from playwright.sync_api import Browser, expect

from tests.browser.conftest import open_tiles, version_of
from webapp.people.security import operator_token
from webapp.testing import ServerProcess, wait_until


def test_switching_a_layer_on_the_dashboard_changes_the_tiles(
    browser: Browser, server: ServerProcess
) -> None:
    [tile] = open_tiles(browser, server, "demo", ["r1c1"])
    start = server.version("demo")
    wait_until(lambda: version_of(tile) == start, what="the tile to start")
    page = browser.new_page()
    page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    row = page.locator("#tiles tr", has_text="r1c1")
    expect(row).to_contain_text("yes")

    page.get_by_label("grid").uncheck()

    wait_until(lambda: version_of(tile) == start + 1, what="the tile to follow the dashboard")
    expect(page.locator("#version")).to_have_text(str(start + 1))
    expect(row).to_contain_text("+0.0 ms")
    assert server.status("demo")["state"]["layers"] == {"grid": False}
    tile.context.close()
    page.close()


def test_the_operator_link_refuses_a_wrong_token(browser: Browser, server: ServerProcess) -> None:
    page = browser.new_page()
    response = page.goto(f"{server.url}/login/operator?token=wrong")
    assert response is not None and response.status == 403
    expect(page.locator("body")).not_to_contain_text("Traceback")
    page.close()
