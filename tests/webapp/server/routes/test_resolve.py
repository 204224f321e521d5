"""Scanning a code: ``/t/{code}`` resolves, records and hands over; bad codes get pages."""

import struct
from datetime import UTC, datetime, timedelta

import pytest
from fastapi import Response
from fastapi.responses import PlainTextResponse
from fastapi.testclient import TestClient
from itsdangerous import URLSafeSerializer

from tag_service.codes import content_hash, make_symbol
from tag_service.sizing import QUIET_ZONE_MODULES
from tests.conftest import operator_headers
from wall_client.layout import Wall
from webapp.apps.hooks import Scan
from webapp.database.models import ScanRecord
from webapp.people.visitors import SESSION_COOKIE
from webapp.server.services import Services
from webapp.tags.registry import TagSpec, issue, wall_tags
from webapp.tags.scanning import scans_of

PHONE = {"User-Agent": "Mozilla/5.0 (iPhone; CPU iPhone OS 17_0 like Mac OS X)"}


def services(client: TestClient) -> Services:
    return client.app.state.services  # type: ignore[attr-defined,no-any-return]


def recorded(client: TestClient, code: str) -> list[ScanRecord]:
    """The scans of ``code`` once the app's queue is written (it flushes every 0.1 s)."""
    services(client).scan_log.flush()
    return scans_of(services(client).db, code)


def code_named(client: TestClient, wall: str, name: str) -> str:
    return next(t.code for t in wall_tags(services(client).db, wall) if t.name == name)


def test_student_registration_code_resolves_and_records_the_scan(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    response = client.get(f"/t/{code}", headers=PHONE)
    assert response.status_code == 200
    assert "student" in response.text
    assert SESSION_COOKIE in response.cookies
    cookie = response.headers["set-cookie"].lower()
    assert "httponly" in cookie and "samesite=lax" in cookie
    (scan,) = recorded(client, code)
    assert scan.wall_id == "demo"
    assert scan.user_agent == PHONE["User-Agent"]
    assert scan.client_address == "testclient"
    assert scan.visitor_id


def test_the_same_phone_is_the_same_visitor(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    client.get(f"/t/{code}")
    client.get(f"/T/{code.lower()}")  # what a phone opens from the upper-case payload
    first, second = recorded(client, code)
    assert first.visitor_id == second.visitor_id


class ProbeApp:
    """An app that answers with the visitor id it was handed."""

    name = "probe"
    default_tag_set = None

    def declare_tags(self, wall: Wall) -> list[TagSpec]:
        return []

    async def on_scan(self, scan: Scan) -> Response:
        return PlainTextResponse(scan.visitor.id)


def test_the_app_the_scan_and_the_cookie_agree_on_a_new_visitor(client: TestClient) -> None:
    services(client).apps["probe"] = ProbeApp()
    spec = TagSpec(app="probe", action="probe", anchor=(100.0, 100.0))
    tag = issue(services(client).db, "demo", spec, "test")
    response = client.get(f"/t/{tag.code}")
    assert response.status_code == 200
    serializer = URLSafeSerializer(services(client).secret, salt="tagwall.session")
    cookie_id, _session_id, _issued = serializer.loads(response.cookies[SESSION_COOKIE])
    (scan,) = recorded(client, tag.code)
    assert response.text == scan.visitor_id == cookie_id


def test_a_forged_visitor_cookie_is_replaced(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    client.cookies.set(SESSION_COOKIE, "someone-else")
    response = client.get(f"/t/{code}")
    assert response.status_code == 200
    (scan,) = recorded(client, code)
    assert scan.visitor_id != "someone-else"


@pytest.mark.parametrize("code", ["ZZZZZZZ", "nope", "x" * 5000, "ABC..XY", "ABCDEF!"])
def test_unknown_or_malformed_codes_get_a_friendly_404(client: TestClient, code: str) -> None:
    response = client.get(f"/t/{code}")
    assert response.status_code == 404
    assert "not one of this wall" in response.text
    assert 'name="viewport"' in response.text
    assert "Traceback" not in response.text


def test_a_switched_off_code_is_410_with_a_link_to_the_wall(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    changed = client.patch(
        f"/api/tags/{code}", json={"active": False}, headers=operator_headers(client)
    )
    assert changed.status_code == 200
    response = client.get(f"/t/{code}")
    assert response.status_code == 410
    assert 'href="/wall/demo"' in response.text
    assert recorded(client, code) == []


def test_an_expired_code_is_410(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    past = (datetime.now(UTC) - timedelta(minutes=1)).isoformat()
    client.patch(f"/api/tags/{code}", json={"expires_at": past}, headers=operator_headers(client))
    assert client.get(f"/t/{code}").status_code == 410


def test_a_code_of_a_set_not_on_the_wall_is_410(client: TestClient) -> None:
    code = code_named(client, "demo", "setup-r1c1")
    assert client.get(f"/t/{code}").status_code == 200
    switched = client.put(
        "/api/walls/demo/tag-set", json={"name": None}, headers=operator_headers(client)
    )
    assert switched.status_code == 200
    response = client.get(f"/t/{code}")
    assert response.status_code == 410
    assert "setup" in response.text
    # permanent codes stay
    assert client.get(f"/t/{code_named(client, 'demo', 'register-student')}").status_code == 200


def test_instructor_code_sends_a_phone_that_is_not_authorised_to_sign_in(
    client: TestClient,
) -> None:
    code = code_named(client, "demo", "register-instructor")
    response = client.get(f"/t/{code}", follow_redirects=False)
    assert response.status_code == 303
    assert response.headers["location"] == f"/login?next=/t/{code}"


def test_setup_code_tells_the_installer_where_it_stands(client: TestClient) -> None:
    response = client.get(f"/t/{code_named(client, 'demo', 'setup-r2c2')}")
    assert response.status_code == 200
    assert "r2c2" in response.text and "px per module" in response.text


def test_scans_are_rate_limited_per_visitor(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    limit = services(client).settings.scan_rate_per_minute
    for _ in range(limit):
        assert client.get(f"/t/{code}").status_code == 200
    response = client.get(f"/t/{code}")
    assert response.status_code == 429
    assert int(response.headers["Retry-After"]) >= 1
    assert "Try again" in response.text
    assert len(recorded(client, code)) == limit
    client.cookies.clear()  # another phone is not held back
    assert client.get(f"/t/{code}").status_code == 200


def test_code_images_svg_png_and_caching(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    info = client.get(f"/api/tags/{code}", headers=operator_headers(client)).json()
    svg = client.get(info["svg_url"])
    assert svg.status_code == 200
    assert svg.headers["content-type"].startswith("image/svg+xml")
    assert "immutable" in svg.headers["cache-control"]
    assert b"crispEdges" in svg.content
    png = client.get(f"/codes/{code}.png?scale=4")
    assert png.content.startswith(b"\x89PNG")
    assert png.headers["cache-control"] == "no-cache"
    again = client.get(f"/codes/{code}.png?scale=4", headers={"If-None-Match": png.headers["etag"]})
    assert again.status_code == 304
    stale = client.get(f"/codes/{code}.0000000000000000.svg", follow_redirects=False)
    assert stale.status_code == 307 and stale.headers["location"] == info["svg_url"]
    assert client.get("/codes/ZZZZZZZ.svg").status_code == 404
    assert client.get(f"/codes/{code}.gif").status_code == 404
    assert client.get(f"/codes/{code}.png?scale=1000").status_code == 400


def test_code_images_at_the_error_level_a_code_was_placed_with(client: TestClient) -> None:
    code = code_named(client, "demo", "register-student")
    payload = client.get(f"/api/tags/{code}", headers=operator_headers(client)).json()["payload"]
    for level in ("M", "L"):
        png = client.get(f"/codes/{code}.png?scale=2&error={level}")
        across = make_symbol(payload, level).symbol_size(border=QUIET_ZONE_MODULES)[0]
        assert struct.unpack(">II", png.content[16:24]) == (2 * across,) * 2
    hashed = f"/codes/{code}.{content_hash(payload, 'L')}.png?scale=2&error=L"
    assert client.get(hashed, follow_redirects=False).status_code == 200
    stale = client.get(
        f"/codes/{code}.0000000000000000.png?scale=2&error=L", follow_redirects=False
    )
    assert stale.status_code == 307 and stale.headers["location"] == hashed
    assert client.get(f"/codes/{code}.png?error=H").status_code == 400


def test_wall_start_page(client: TestClient) -> None:
    response = client.get("/wall/demo")
    assert response.status_code == 200
    assert "r2c1" in response.text and 'href="/scan"' in response.text
