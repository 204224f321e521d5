"""Apps installed beside tagwall, refused, uninstalled and installed again.

Two plug-ins of ``tests/plugins`` are installed (``pip install --target``) into folders
of their own that only the test's server sees: the smallest app there is (a drawing and
a code, under 40 lines of Python) and one that reaches outside its name (``/login``, the
census map's slot), which the server refuses at start with one line for each. The
smallest one's code is read off the tiles as a camera reads it; once the app is
uninstalled and the server restarted its code is on no tile, and it comes back, the same
code, when the app is installed again.
"""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image
from playwright.sync_api import Browser, Page

from tag_service.verify import decode_image
from tests.browser.conftest import install_plugin, open_tiles, serve
from webapp.cli.testing import ServerProcess, wait_until

TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}


@pytest.fixture(scope="module")
def sites(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Each plug-in installed into a folder of its own."""
    return {name: install_plugin(name, tmp_path_factory) for name in ("minimal_app", "rogue_app")}


def test_an_app_reaching_outside_its_name_stops_the_server_with_one_line_each(
    sites: dict[str, Path], tmp_path: Path, database_url: str
) -> None:
    server = ServerProcess(
        var_dir=tmp_path / "var",
        database_url=database_url,
        secret="rogue-test-secret",
        extra_env={"PYTHONPATH": str(sites["rogue_app"])},
    )
    tagwall = Path(sys.executable).with_name("tagwall")
    started = subprocess.run(
        [str(tagwall), "serve"], env=server.env(), capture_output=True, text=True, timeout=120
    )
    assert started.returncode == 2
    where = "error: app 'rogue' (tagwall-rogue-app 1.0, rogue_app.app:RogueApp): "
    assert started.stderr.splitlines() == [
        f"{where}keeps its slot under 'census': an app's slot is named after it",
        f"{where}may not answer /login: an app's routes live under /apps/rogue/ and"
        " /api/apps/rogue/",
    ]
    # switched off without uninstalling it, the rest of tagwall starts
    server.extra_env["TAGWALL_APPS"] = "brain, census, image, pattern"
    server.start()
    assert server.http.get("/login").status_code == 200
    assert "the rogue app" not in server.http.get("/login").text
    server.stop()


def codes_on(tiles: list[Page]) -> set[str]:
    """Every code's payload read off the tiles' screenshots, as a camera reads them."""
    found = set()
    for tile in tiles:
        picture = Image.open(io.BytesIO(tile.screenshot(type="png")))
        found |= {code.payload for code in decode_image(picture)}
    return found


def test_an_uninstalled_apps_codes_leave_every_tile_and_come_back_when_installed_again(
    browser: Browser, sites: dict[str, Path], tmp_path: Path, database_url: str
) -> None:
    minimal = str(sites["minimal_app"])
    server = serve(tmp_path, database_url, PYTHONPATH=minimal, TAGWALL_FIRST_APP="minimal")
    try:
        tags = server.http.get("/api/walls/demo/tags", headers=server.operator()).json()
        sun = next(t["code"] for t in tags if t["app"] == "minimal")
        tiles = open_tiles(browser, server, "demo", TILES, native=True)
        wait_until(
            lambda: any(sun in payload for payload in codes_on(tiles)),
            timeout=60,
            what="the minimal app's code on a tile",
        )
        # its drawing was told where the codes and the designated screens stand
        assert all(int(t.evaluate("document.body.dataset.minimalClear")) >= 2 for t in tiles)
        payload = next(p for p in codes_on(tiles) if sun in p)
        phone = browser.new_context(**PHONE).new_page()
        phone.goto(payload)
        assert phone.locator("h1").inner_text() == "The sun"  # the default page of a code

        server.stop()
        del server.extra_env["PYTHONPATH"], server.extra_env["TAGWALL_FIRST_APP"]  # uninstalled
        server.start()
        assert "app 'minimal' is not installed: its 1 codes leave wall 'demo'" in (
            server.log.read_text()
        )
        assert server.status("demo")["state"]["app"] == "pattern"  # the first app
        version = server.version("demo")
        wait_until(
            lambda: all(
                int(t.evaluate("document.body.dataset.version") or 0) >= version for t in tiles
            ),
            timeout=60,
            what="every tile to show the restarted wall",
        )
        tags = server.http.get("/api/walls/demo/tags", headers=server.operator()).json()
        student = next(t["code"] for t in tags if t["name"] == "register-student")
        wait_until(
            lambda: any(student in payload for payload in codes_on(tiles)),
            timeout=60,
            what="the restarted wall's codes on the tiles",
        )
        left = codes_on(tiles)
        assert not any(sun in payload for payload in left), left
        phone.goto(payload)
        assert phone.locator("h1").inner_text() == "This code is no longer in use"

        server.stop()
        server.extra_env["PYTHONPATH"] = minimal  # installed again
        server.start()
        server.change("demo", {"app": "minimal"})
        wait_until(
            lambda: any(sun in payload for payload in codes_on(tiles)),
            timeout=60,
            what="the minimal app's code, the same, on a tile again",
        )
        phone.goto(payload)
        assert phone.locator("h1").inner_text() == "The sun"
    finally:
        server.stop()
