"""The app contract: every part an app owns in its package reaches the server."""

from __future__ import annotations

import re
from importlib.metadata import EntryPoint

import pytest
from fastapi.routing import APIWebSocketRoute, iter_route_contexts
from fastapi.testclient import TestClient

from tests.conftest import services_of
from webapp.apps.discovery import GROUP, installed_apps, load_app
from webapp.apps.hooks import WallApp, static_url
from webapp.apps.installed import heavy_keys, placing_keys
from webapp.core.settings import PROJECT_ROOT
from webapp.engine.wall_state import CORE_HEAVY_KEYS, CORE_PLACING_KEYS, WallState
from webapp.web.templating import IMPORT_MAP_HASH

APPS = installed_apps()
IMPORTED = re.compile(r'^import .* from "([^"]+)";', re.MULTILINE)


@pytest.mark.parametrize("wall_app", APPS.values(), ids=lambda wall_app: wall_app.name)
def test_an_apps_templates_live_under_its_own_name(wall_app: WallApp) -> None:
    """Apps share one template search path: a prefix per app keeps them apart."""
    if wall_app.templates is None:
        return
    names = [p.relative_to(wall_app.templates) for p in wall_app.templates.rglob("*.html")]
    assert names and all(name.parts[0] == wall_app.name for name in names), names


@pytest.mark.parametrize("wall_app", APPS.values(), ids=lambda wall_app: wall_app.name)
def test_an_apps_modules_are_served_and_import_only_what_is_served(
    wall_app: WallApp, client: TestClient
) -> None:
    """Every module of the app's ``static`` folder and its scene layers load in a browser:
    each is served as JavaScript, and so is everything it imports: the core's modules
    through the import map (``tagwall/``), the app's own beside it (``./``)."""
    urls = set(wall_app.layers)
    if wall_app.static is not None:
        urls |= {f"{static_url(wall_app.name)}/{p.name}" for p in wall_app.static.glob("*.js")}
    for url in sorted(urls):
        response = client.get(url)
        assert response.status_code == 200, url
        assert "javascript" in response.headers["content-type"], url
        for imported in IMPORTED.findall(response.text):
            if imported.startswith("tagwall/"):
                served = "/static/js/" + imported.removeprefix("tagwall/")
            else:
                assert imported.startswith("./"), f"{url} imports {imported} by a server path"
                served = url.rsplit("/", 1)[0] + imported.removeprefix(".")
            assert client.get(served).status_code == 200, f"{url} imports {imported}"


def test_the_app_factory_registers_the_installed_apps(client: TestClient) -> None:
    assert set(services_of(client).apps) == set(APPS) >= {"core", "pattern", "census", "brain"}


def test_apps_add_their_slots_keys_to_the_cores() -> None:
    """The census map's data set and colouring make tiles prepare; its data set and the
    brain's round move codes; the core's own keys stay whatever the apps say."""
    assert heavy_keys(APPS) >= CORE_HEAVY_KEYS | {"census.dataset", "census.theme"}
    assert placing_keys(APPS) >= CORE_PLACING_KEYS | {"census.dataset", "brain.quiz_round"}
    assert "census.theme" not in placing_keys(APPS) and "brain.quiz_round" not in heavy_keys(APPS)


def test_pages_carry_the_import_map_the_policy_allows(client: TestClient) -> None:
    page = client.get("/wall/demo/overview")
    assert '<script type="importmap">{"imports":{"tagwall/":"/static/js/"}}</script>' in page.text
    assert f"'{IMPORT_MAP_HASH}'" in page.headers["content-security-policy"]


def test_a_panel_template_is_found_from_its_app(client: TestClient) -> None:
    templates = client.app.state.templates  # type: ignore[attr-defined]
    wall = services_of(client).walls["demo"]
    for app in APPS.values():
        panel = app.dashboard_panel(wall)
        if panel is not None:
            assert templates.get_template(panel).filename.startswith(str(app.templates)), panel


def test_apps_without_places_offer_none_the_hello_app_too(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An app written on the contract alone (``tests/plugins/hello_app``) loads with every
    member, ``places`` among them; it and the built-in apps but the image app (no
    image up yet) offer no places while they are on the wall."""
    monkeypatch.syspath_prepend(str(PROJECT_ROOT / "tests" / "plugins" / "hello_app"))
    hello = load_app(EntryPoint(name="hello", value="hello_app.app:HelloApp", group=GROUP))
    services = services_of(client)
    wall = services.walls["demo"]
    for app in [*APPS.values(), hello]:
        assert app.places(services, wall, WallState(app=app.name)) == [], app.name


URL_IN_JS = re.compile(r"""[`"'](/(?:api|apps|wall|walls|ws|t|static)/[^`"'\s]*)[`"']""")


def test_every_path_a_browser_module_asks_for_is_a_route(client: TestClient) -> None:
    """The apps' and the core's modules build their API's paths in strings: each, its
    ``${...}`` parts filled in, is answered by a route (a move of an app's API under
    /api/apps/<name>/ once left a panel's link on the old path)."""
    modules = [*(PROJECT_ROOT / "static" / "js").rglob("*.js")]
    for wall_app in APPS.values():
        if wall_app.static is not None:
            modules += wall_app.static.glob("*.js")
    routes = [
        (route.path_format.split("/"), isinstance(route.original_route, APIWebSocketRoute))
        for route in iter_route_contexts(client.app.routes)  # type: ignore[attr-defined]
    ]
    lost = []
    for module in modules:
        for found in URL_IN_JS.findall(module.read_text()):
            path = found.split("?")[0]
            if path.startswith("/static/") or path.endswith("/") or re.search(r"[^/]\$\{", path):
                continue  # files (checked above), and paths a module completes by itself
            segments = path.split("/")
            if not any(
                len(segments) == len(template)
                and is_socket == path.startswith("/ws/")
                and all(
                    given == wanted or given.startswith("${") or wanted.startswith("{")
                    for given, wanted in zip(segments, template, strict=True)
                )
                for template, is_socket in routes
            ):
                lost.append(f"{module.name}: {found}")
    assert not lost, lost


def test_no_template_styles_inline_what_the_policy_blocks() -> None:
    """The pages' Content-Security-Policy allows styles only from files (style-src
    'self'): an inline ``style=`` or ``<style>`` is dropped by the browser (the image
    panel's picture of hotspots lost its size and cursor so)."""
    folders = [PROJECT_ROOT / "webapp" / "web" / "templates"]
    folders += [app.templates for app in APPS.values() if app.templates is not None]
    inline = [
        str(page)
        for folder in folders
        for page in folder.rglob("*.html")
        if re.search(r"\sstyle=|<style", page.read_text())
    ]
    assert not inline, inline
