"""An app from outside tagwall: installed beside it, found through its entry point, and
used on a wall like the built-in ones, with no file of tagwall changed.

``tests/plugins/hello_app`` is installed (``pip install --target``) into a folder of its
own that only the test's server and command see: its layer on every tile, its code in
the middle of the wall (decoded from a tile's screenshot), its phone page, its API
changing its slot of the wall state, and its ``tagwall`` command.
"""

from __future__ import annotations

import io
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles, serve
from webapp.cli.testing import ServerProcess, wait_until
from webapp.core.settings import PROJECT_ROOT

PLUGIN = PROJECT_ROOT / "tests" / "plugins" / "hello_app"
TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The hello app installed into a folder of its own (with its entry point's metadata)."""
    source = tmp_path_factory.mktemp("source") / "hello_app"
    shutil.copytree(PLUGIN, source)  # building writes beside the sources: not in the checkout
    target = tmp_path_factory.mktemp("site")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
    )
    return target


@pytest.fixture
def server(tmp_path: Path, database_url: str, site: Path) -> Iterator[ServerProcess]:
    process = serve(tmp_path, database_url, PYTHONPATH=str(site), TAGWALL_FIRST_APP="hello")
    yield process
    process.stop()


def greeting_on(page: Page) -> str | None:
    value: str | None = page.evaluate("document.body.dataset.hello")
    return value


def test_an_installed_app_draws_its_layer_and_its_code_opens_its_page(
    browser: Browser, server: ServerProcess
) -> None:
    tiles = open_tiles(browser, server, "demo", TILES, native=True)
    wait_until(lambda: all(greeting_on(t) == "Hello, wall" for t in tiles), what="the layer")
    # the layer's green across a display the app draws on (r1c1: no screen of the core's)
    picture = Image.open(io.BytesIO(tiles[0].screenshot(type="png"))).convert("RGB")
    assert picture.getpixel((40, picture.height - 40)) == (0x1F, 0x7A, 0x3A)

    wave = httpx.get(f"{server.url}/api/walls/demo/tags", headers=server.operator()).json()
    code = next(t["code"] for t in wave if t["name"] == "hello:wave")

    def scanned() -> list[str]:
        return [payload for tile in tiles for payload in decoded(tile) if code in payload]

    wait_until(scanned, what="the hello code on a tile, as a camera reads it")
    payload = scanned()[0]

    phone = browser.new_context(**PHONE).new_page()
    phone.goto(payload)
    assert phone.locator("#greeting").inner_text() == "Hello, wall"
    assert phone.evaluate("document.documentElement.scrollWidth") <= 390

    answer = httpx.post(
        f"{server.url}/api/apps/hello/walls/demo/greeting",
        json={"greeting": "Hi, class"},
        headers=server.operator(),
    )
    assert answer.status_code == 200, answer.text
    wait_until(lambda: all(greeting_on(t) == "Hi, class" for t in tiles), what="the new greeting")
    phone.reload()
    assert phone.locator("#greeting").inner_text() == "Hi, class"
    state = server.status("demo")["state"]
    assert state["app"] == "hello" and state["apps"]["hello"]["greeting"] == "Hi, class"


def decoded(page: Page) -> set[str]:
    image = Image.open(io.BytesIO(page.screenshot(type="png")))
    return {code.payload for code in decode_image(image)}


def test_an_installed_apps_command_joins_the_cli(site: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(site)}
    tagwall = Path(sys.executable).with_name("tagwall")
    result = subprocess.run([str(tagwall), "hello"], env=env, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "hello from an installed app"
    listed = subprocess.run([str(tagwall), "--help"], env=env, capture_output=True, text=True)
    assert "hello" in listed.stdout
