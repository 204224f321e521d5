import html
import json
import re

import pytest
from fastapi.testclient import TestClient

from webapp.server.app import STATIC_DIR as STATIC
from webapp.web.middleware import HEADERS


def test_healthz_ok(client: TestClient) -> None:
    response = client.get("/healthz")
    assert response.status_code == 200 and response.json() == {"status": "ok"}


def test_healthz_503_when_database_unreachable(client: TestClient) -> None:
    services = client.app.state.services  # type: ignore[attr-defined]
    services.db.ping = lambda: False
    response = client.get("/healthz")
    assert response.status_code == 503 and response.json()["status"] == "unavailable"


def test_healthz_503_with_a_dead_database(client: TestClient) -> None:
    from webapp.database.connection import Database

    services = client.app.state.services  # type: ignore[attr-defined]
    services.db = Database("postgresql+psycopg://nobody@127.0.0.1:1/none")
    assert client.get("/healthz").status_code == 503


@pytest.mark.walls("demo", "hiperwall")
def test_start_page_lists_walls(client: TestClient) -> None:
    page = client.get("/").text
    assert "/wall/demo/overview" in page and "/wall/hiperwall/overview" in page


def test_tile_page_needs_the_wall_token(client: TestClient) -> None:
    token = client.app.state.services.tile_token("demo")  # type: ignore[attr-defined]
    page = client.get(f"/wall/demo/tile/r1c1?token={token}")
    assert page.status_code == 200
    assert 'data-tile="r1c1"' in page.text and "tile.js" in page.text
    for url in ("/wall/demo/tile/r1c1", "/wall/demo/tile/r1c1?token=wrong"):
        refused = client.get(url)
        assert refused.status_code == 403
        assert "text/html" in refused.headers["content-type"]
        assert "tagwall tiles" in refused.text


def test_unknown_wall_or_tile_is_a_friendly_404(client: TestClient) -> None:
    token = client.app.state.services.tile_token("demo")  # type: ignore[attr-defined]
    for url in ("/wall/nowhere/overview", f"/wall/demo/tile/r7c7?token={token}", "/nope"):
        response = client.get(url)
        assert response.status_code == 404
        assert "Back to the start page" in response.text
        assert "Traceback" not in response.text


@pytest.mark.walls("kl-3x3")
def test_overview_page_carries_the_layout(client: TestClient) -> None:
    page = client.get("/wall/kl-3x3/overview")
    assert page.status_code == 200
    assert "overview.js" in page.text and "data-wall-info" in page.text


def test_scene_pages_list_each_apps_layers_and_import_no_app_module(client: TestClient) -> None:
    """Tiles and the overview draw through the layers the apps register: the census
    map never shows a volume (the pattern shows one the dashboard puts up)."""
    token = client.app.state.services.tile_token("demo")  # type: ignore[attr-defined]
    for url in (f"/wall/demo/tile/r2c2?token={token}", "/wall/demo/overview"):
        found = re.search(r'data-layers="([^"]*)"', client.get(url).text)
        assert found is not None, url
        stacks = json.loads(html.unescape(found.group(1)))
        assert stacks["shared"] == [
            "/static/js/pointers.js",
            "/static/js/codes.js",
            "/static/js/balloons.js",
        ]
        assert stacks["apps"]["brain"] == ["/static/js/volume.js"]
        pattern = ["/static/js/volume.js", "/static/apps/pattern/scene.js"]
        assert stacks["apps"]["pattern"] == pattern
        assert stacks["apps"]["census"] == ["/static/apps/census/census.js"]
    for page in ("tile", "overview"):
        source = (STATIC / "js" / "pages" / f"{page}.js").read_text()
        imported = set(re.findall(r'from "\.\./([a-z]+)\.js"', source))
        assert imported <= {"layers", "live", "public"}, imported


def test_the_operator_link_signs_in_as_admin_and_opens_the_dashboard(
    client: TestClient,
) -> None:
    assert client.get("/dashboard", follow_redirects=False).status_code == 303
    token = client.app.state.services.operator_token  # type: ignore[attr-defined]
    page = client.get(f"/login/operator?token={token}")
    assert page.status_code == 200 and "dashboard.js" in page.text
    assert "Accounts and address rules" in page.text


def test_a_wrong_operator_link_is_refused(client: TestClient) -> None:
    page = client.get("/login/operator?token=guess")
    assert page.status_code == 403
    assert client.get("/dashboard", follow_redirects=False).status_code == 303


def test_security_headers_on_every_page(client: TestClient) -> None:
    for url in ("/", "/wall/demo/overview", "/nope", "/healthz", "/static/js/pages/tile.js"):
        response = client.get(url)
        for name, value in HEADERS.items():
            assert response.headers[name] == value, (url, name)
    assert "'unsafe-inline'" not in HEADERS["content-security-policy"]


def test_pages_are_never_shown_again_from_a_browsers_cache(client: TestClient) -> None:
    """A phone that scanned a code while it did not work (a 410 page) must see its page
    once it works again, and a shared phone must not show the last person's page."""
    for url in ("/", "/wall/demo/overview", "/nope", "/t/ZZZZZZZ", "/login"):
        assert client.get(url).headers["cache-control"] == "no-store", url
    assert client.get("/static/js/pages/tile.js").headers.get("cache-control") != "no-store"
    assert "no-store" not in client.get("/healthz").headers.get("cache-control", "")


def test_pages_have_no_inline_script(client: TestClient) -> None:
    token = client.app.state.services.tile_token("demo")  # type: ignore[attr-defined]
    operator = client.app.state.services.operator_token  # type: ignore[attr-defined]
    pages = ("/", "/wall/demo/overview", f"/wall/demo/tile/r1c1?token={token}", "/login", "/me")
    for url in (*pages, f"/login/operator?token={operator}", "/dashboard/admin"):
        text_ = client.get(url).text
        assert "<script>" not in text_ and "onclick=" not in text_


def test_server_errors_are_pages_not_tracebacks(client: TestClient) -> None:
    services = client.app.state.services  # type: ignore[attr-defined]

    def explode(*_: object) -> None:
        raise RuntimeError("secret internals")

    services.hub.tile_statuses = explode
    client_no_raise = TestClient(client.app, raise_server_exceptions=False)
    token = services.operator_token
    headers = {"Authorization": f"Bearer {token}"}
    response = client_no_raise.get("/api/walls/demo/status", headers=headers)
    assert response.status_code == 500
    assert "secret internals" not in response.text
    for name, value in HEADERS.items():  # sent outside the middleware, with its own
        assert response.headers[name] == value, name
