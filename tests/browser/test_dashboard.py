"""The dashboard in Chromium: what the operator sees and switches."""

from __future__ import annotations

from pathlib import Path

import httpx
from playwright.sync_api import Browser, expect

from tests.browser.conftest import open_tiles, serve, version_of
from tests.browser.test_codes import shown_payloads
from tests.webapp.apps.image.test_routes import png_bytes
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, wait_until
from webapp.people.security import operator_token


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


def test_the_dashboard_shows_the_panel_of_the_app_on_the_wall_and_follows_switches(
    browser: Browser, server: ServerProcess
) -> None:
    """Issue 31: the census panel said "none yet" while the brain was on the wall: only
    the app on the wall's panel shows, and it changes with the app, live."""
    page = browser.new_page()
    page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    expect(page.locator("#app")).to_have_text("pattern")
    expect(page.locator("#pattern-panel")).to_be_visible()
    expect(page.locator("#volume-panel")).to_be_visible()
    expect(page.locator("#census-panel")).to_be_hidden()
    expect(page.locator("#brain-panel")).to_be_hidden()
    server.change("demo", {"app": "census"})
    expect(page.locator("#app")).to_have_text("census", timeout=60_000)
    expect(page.locator("#census-panel")).to_be_visible()
    expect(page.locator("#pattern-panel")).to_be_hidden()
    expect(page.locator("#brain-panel")).to_be_hidden()
    expect(page.locator("#volume-panel")).to_be_hidden()  # the census map draws no volume
    page.close()


def test_the_operator_link_refuses_a_wrong_token(browser: Browser, server: ServerProcess) -> None:
    page = browser.new_page()
    response = page.goto(f"{server.url}/login/operator?token=wrong")
    assert response is not None and response.status == 403
    expect(page.locator("body")).not_to_contain_text("Traceback")
    page.close()


def test_the_instructor_colours_the_census_map_from_the_dashboard(
    browser: Browser, server: ServerProcess
) -> None:
    server.change("demo", {"app": "census"})
    [tile] = open_tiles(browser, server, "demo", ["r2c2"])
    page = browser.new_page()
    page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    expect(page.locator("#census-theme-shown")).to_have_text("One plain colour.")
    panel = page.locator("#census-panel")
    # A person's click puts the focus in the form, and the panel leaves the choices of
    # an instructor who is choosing alone when a status arrives; Playwright's
    # select_option does not focus, so a late status (the tile saying it is ready) set
    # them back to the wall's before the click.
    panel.get_by_label("Value").focus()
    panel.get_by_label("Value").select_option(label="Median housing value")
    panel.get_by_label("Colours").select_option("PuBuGn")
    panel.get_by_label("Classes by").select_option("natural")
    panel.get_by_label("Number").select_option("4")
    panel.get_by_role("button", name="Colour the wall").click()

    expect(page.locator("#census-theme-shown")).to_have_text(
        "Coloured by Median housing value: 4 classes by natural breaks, PuBuGn."
    )
    theme = {"attribute": "HSG_VAL", "scheme": "PuBuGn", "method": "natural", "classes": 4}
    assert server.status("demo")["state"]["apps"]["census"]["theme"] == theme
    version = server.version("demo")
    wait_until(lambda: version_of(tile) == version, what="the tile to follow the dashboard")
    expect(tile.locator("body")).to_have_attribute("data-census-theme", "HSG_VAL 4")
    for zoom in (1.5, 2, 2.5, 3, 3.5):  # codes placed anew each time: the colouring stays
        zoomed = server.change("demo", {"view": {"center": [0.5, 0.5], "zoom": zoom}})
        wait_until(lambda: version_of(tile) == zoomed, what="the tile to zoom")  # noqa: B023
        expect(tile.locator("body")).to_have_attribute("data-census-theme", "HSG_VAL 4")

    panel.get_by_label("Value").select_option("")
    panel.get_by_role("button", name="Colour the wall").click()
    expect(page.locator("#census-theme-shown")).to_have_text("One plain colour.")
    assert server.status("demo")["state"]["apps"]["census"]["theme"] is None
    tile.context.close()
    page.close()


def test_a_panel_s_zoom_button_makes_one_change(browser: Browser, server: ServerProcess) -> None:
    """Zoom in on the census panel: one change, the map's zoom times 1.5. The volume
    panel's buttons once answered every zoom button on the page too, with their own
    limit (50): from 40, a second change to 50 raced the census panel's to 60."""
    server.change("demo", {"app": "census", "view": {"center": [0.5, 0.5], "zoom": 40}})
    page = browser.new_page()
    page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    before = server.version("demo")
    expect(page.locator("#version")).to_have_text(str(before))
    page.locator("#census-panel [data-zoom='1.5']").click()
    wait_until(lambda: server.version("demo") > before, timeout=60, what="the zoom")
    expect(page.locator("#version")).to_have_text(str(before + 1))
    page.wait_for_timeout(1000)  # a second change, if any, would be in by now
    assert server.version("demo") == before + 1
    assert server.status("demo")["state"]["view"]["zoom"] == 60
    page.close()


CRAMPED_WALL = """
id = "cramped"
seat_distance_m = 4.0
[grid]
columns = 2
rows = 2
resolution = [3840, 2160]
active_mm = [597.7, 336.2]
bezel_mm = 12
"""
"""Issue 31: a 2 x 2 wall of 27-inch 4K panels, students 3-4 m away."""


def test_the_dashboard_says_plainly_which_codes_do_not_fit_the_wall(
    browser: Browser, tmp_path: Path, database_url: str
) -> None:
    """Issue 31: the registration codes were silently missing from such a wall; the
    codes box now says why and what would fit, as `tagwall config check` does, and
    `tagwall serve` said it at start."""
    config = tmp_path / "cramped.toml"
    config.write_text(CRAMPED_WALL)
    server = serve(
        tmp_path, database_url, TAGWALL_WALL_CONFIGS=str(config), TAGWALL_DEFAULT_WALL="cramped"
    )
    try:
        page = browser.new_page()
        page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
        expect(page.locator("#codes-fit li").first).to_have_text(
            "Student and Instructor codes do not fit the registration screen at 4 m:"
            " seats up to 2.5 m fit, or give the registration screen more displays"
        )
        page.close()
        assert "wall cramped: error: Student and Instructor codes" in server.log.read_text()
    finally:
        server.stop()


def test_the_instructor_puts_a_link_of_their_own_on_the_wall(
    browser: Browser, server: ServerProcess
) -> None:
    """A click on the drawing of the wall chooses the point; the code is placed there and
    listed, and Switch off takes it away again."""
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    box = page.locator("#own-form")
    box.get_by_label("Kind").select_option("link")
    box.get_by_label("Caption on the wall").fill("Reading list")
    box.get_by_label("Web address").fill("https://example.org/reading")
    page.locator("#own-map").click(position={"x": 240, "y": 60})
    assert int(box.get_by_label("At x (mm)").input_value()) > 0
    box.get_by_role("button", name="Add the code").click()

    listed = page.locator("#own-codes li").first
    expect(listed).to_contain_text("Reading list · web link · https://example.org/reading")
    token = operator_token(server.secret)
    wait_until(
        lambda: (
            "Reading list" in {c.label for c in fetch_layout(server.url, "demo", token)[1].placed}
        ),
        what="the code to be placed",
    )
    listed.get_by_role("button", name="Switch off").click()
    expect(listed).to_contain_text("(switched off)")
    page.close()


def test_the_instructor_puts_a_text_of_their_own_at_a_hotspot(
    browser: Browser, server: ServerProcess, tmp_path: Path
) -> None:
    """Where: a place on the wall now. The code stands beside the hotspot, on its pin,
    read off a native tile of the stage; the list says where it stands."""
    with httpx.Client(base_url=server.url, headers=server.operator(), timeout=60) as api:
        upload = {"file": ("cells.png", png_bytes(), "image/png")}
        image = api.post("/api/apps/image/images", files=upload, data={"title": "Cells"}).json()[
            "id"
        ]
        api.post("/api/apps/image/walls/demo/show", json={"image": image}).raise_for_status()
        middle = {"x": 300, "y": 200, "title": "Middle"}
        api.post(f"/api/apps/image/images/{image}/hotspots", json=middle).raise_for_status()
        [place] = api.get("/api/walls/demo/places").json()
    stage = ["r2c2", "r2c3"]  # the demo's stage, where the image and its hotspots are
    tiles = dict(zip(stage, open_tiles(browser, server, "demo", stage, native=True), strict=True))
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    box = page.locator("#own-form")
    box.get_by_label("Kind").select_option("text")
    box.get_by_label("Caption on the wall").fill("Look here")
    box.get_by_label("Text", exact=True).fill("The middle of the cells")
    box.get_by_label("Where").select_option("place")
    box.get_by_label("Which place").select_option(label="hotspot Middle")
    box.get_by_role("button", name="Add the code").click()

    listed = page.locator("#own-codes li").first
    expect(listed).to_contain_text("Look here · text · The middle of the cells · at hotspot Middle")
    expect(listed).to_contain_text("on the wall")
    version = server.version("demo")
    wait_until(lambda: all(version_of(t) == version for t in tiles.values()), what="the code")
    layout = fetch_layout(server.url, "demo", operator_token(server.secret))[1]
    [code] = [c for c in layout.placed if c.label == "Look here"]
    assert code.anchor == tuple(place["anchor"]) and code.leader, "beside the hotspot, on a pin"
    assert "The middle of the cells" in shown_payloads(tiles[code.display])
    page.locator("#own-codes").screenshot(path=tmp_path / "own-codes.png")
    page.close()
    for tile in tiles.values():
        tile.context.close()
