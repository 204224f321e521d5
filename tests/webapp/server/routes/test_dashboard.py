"""The dashboard pages: app panels, the admin's forms and their errors, and the live
socket, which closes when its instructor's authority ends."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from tests.conftest import TEST_PASSWORD, csrf_of, migrate, register_student, services_of, sign_in
from webapp.cli.testing import wait_until
from webapp.core.settings import Settings
from webapp.engine.protocol import CLOSE_POLICY
from webapp.people.accounts import authenticate, list_accounts, remove_account, set_password
from webapp.people.address_rules import list_rules
from webapp.server.app import create_app


def test_the_dashboard_includes_each_apps_panel(client: TestClient) -> None:
    sign_in(client, "instructor")
    page = client.get("/dashboard").text
    assert "Test pattern" in page and "/static/apps/pattern/panel.js" in page
    assert "Pair a phone" in page and "Public screen" in page
    assert "Accounts and address rules" not in page  # instructors are not admins


def test_only_the_panel_of_the_app_on_the_wall_shows(client: TestClient) -> None:
    """Issue 31: every app's panel showed at once (the census panel said "none yet"
    while the brain was on the wall)."""
    sign_in(client, "instructor")
    page = client.get("/dashboard").text
    shown = re.findall(r'<div class="app-panel" data-app-panel="(\w+)">', page)
    hidden = re.findall(r'<div class="app-panel" data-app-panel="(\w+)" hidden>', page)
    assert shown == ["pattern"]  # the first app on the demo wall
    assert {"census", "brain"} <= set(hidden) and "pattern" not in hidden
    assert '<fieldset id="volume-panel" data-for-apps="brain pattern">' in page


def test_the_volume_box_shows_only_while_the_app_on_the_wall_draws_a_volume(
    client: TestClient,
) -> None:
    """Issue 41: an image class had an empty Volume box on its dashboard."""
    sign_in(client, "instructor")
    client.post(
        "/api/walls/demo/state", json={"app": "image"}, headers={"X-CSRF-Token": csrf_of(client)}
    )
    page = client.get("/dashboard").text
    assert '<fieldset id="volume-panel" data-for-apps="brain pattern" hidden>' in page


def test_admins_add_and_remove_accounts(client: TestClient) -> None:
    sign_in(client, "admin")
    form = {"username": "Tom", "role": "instructor", "password": TEST_PASSWORD}
    added = client.post("/dashboard/admin/accounts", data={**form, "csrf": csrf_of(client)})
    assert added.status_code == 200 and "tom" in added.text
    assert authenticate(services_of(client).db, "tom", TEST_PASSWORD) is not None
    client.post("/dashboard/admin/accounts/tom/remove", data={"csrf": csrf_of(client)})
    assert "tom" not in [a.username for a in list_accounts(services_of(client).db)]
    assert "account_removed" in client.get("/dashboard/admin").text


@pytest.mark.parametrize(
    "form,message",
    [
        (
            {"username": "t", "role": "instructor", "password": TEST_PASSWORD},
            "not a valid username",
        ),
        ({"username": "tom", "role": "student", "password": TEST_PASSWORD}, "role must be one of"),
        ({"username": "tom", "role": "instructor", "password": "short"}, "at least 8"),
    ],
)
def test_bad_account_forms_are_clear_400s(
    client: TestClient, form: dict[str, str], message: str
) -> None:
    sign_in(client, "admin")
    response = client.post("/dashboard/admin/accounts", data={**form, "csrf": csrf_of(client)})
    assert response.status_code == 400 and message in response.text


def test_admins_add_and_remove_address_rules(client: TestClient) -> None:
    sign_in(client, "admin")
    form = {"network": "10.1.2.3/16", "role": "instructor", "user_group": "medical"}
    client.post("/dashboard/admin/rules", data={**form, "info_class": "4", "csrf": csrf_of(client)})
    [rule] = list_rules(services_of(client).db)
    assert (rule.network, rule.role, rule.user_group, rule.info_class) == (
        "10.1.0.0/16",
        "instructor",
        "medical",
        4,
    )
    page = client.get("/dashboard/admin").text
    assert "weak identity" not in page  # roles by address are off here, and the page says so
    assert "do not grant roles" in page
    client.post(f"/dashboard/admin/rules/{rule.id}/remove", data={"csrf": csrf_of(client)})
    assert list_rules(services_of(client).db) == []


def group_shown(phone: TestClient) -> str:
    """The user group the phone's own page has chosen."""
    found = re.search(r'<option value="(\w+)" selected>', phone.get("/me").text)
    assert found is not None
    return found.group(1)


@pytest.mark.parametrize("bus", ["memory", "redis"])
def test_an_address_rule_reaches_the_very_next_request_of_every_app_instance(
    settings: Settings, bus: str, request: pytest.FixtureRequest
) -> None:
    """The rules are cached per app instance (a minute here, so only the word drops
    them): an admin's change is seen by this instance's next request, and by another
    instance on the same database and bus as soon as the word arrives. Two instances
    with a memory bus each share no word: the other one keeps what it cached."""
    if bus == "redis":
        redis, prefix = (request.getfixturevalue(f) for f in ("redis_server", "redis_prefix"))
        settings = settings.model_copy(
            update={"bus": "redis", "redis_url": redis, "redis_prefix": prefix}
        )
    migrate(settings.resolved_database_url)
    address, default = ("10.1.2.3", 50000), settings.default_user_group
    with (
        TestClient(create_app(settings), client=address) as admin,
        TestClient(create_app(settings), client=address) as other,
    ):
        for client in (admin, other):
            services_of(client).address_rules.ttl_s = 60.0
        sign_in(admin, "admin")
        assert group_shown(admin) == group_shown(other) == default != "medical"
        form = {"network": "10.1.0.0/16", "user_group": "medical", "csrf": csrf_of(admin)}
        assert admin.post("/dashboard/admin/rules", data=form).status_code == 200
        assert group_shown(admin) == "medical"
        if bus == "redis":
            wait_until(lambda: group_shown(other) == "medical", what="the other instance")
        else:
            assert group_shown(other) == default
        [rule] = list_rules(services_of(admin).db)
        admin.post(f"/dashboard/admin/rules/{rule.id}/remove", data={"csrf": csrf_of(admin)})
        assert group_shown(admin) == default
        if bus == "redis":
            wait_until(lambda: group_shown(other) == default, what="the other instance")


@pytest.mark.parametrize(
    "form,message",
    [
        ({"network": "not-a-network"}, "not an address or network"),
        ({"network": "10.0.0.0/8", "role": "admin"}, "only the instructor role"),
        ({"network": "10.0.0.0/8", "user_group": "aliens"}, "not a user group"),
        ({"network": "10.0.0.0/8", "info_class": "x"}, "a number 1-5"),
        ({"network": "10.0.0.0/8", "info_class": "9"}, "1 to 5"),
    ],
)
def test_bad_rule_forms_are_clear_400s(
    client: TestClient, form: dict[str, str], message: str
) -> None:
    sign_in(client, "admin")
    response = client.post("/dashboard/admin/rules", data={**form, "csrf": csrf_of(client)})
    assert response.status_code == 400 and message in response.text
    assert list_rules(services_of(client).db) == []


def test_admin_forms_answer_what_the_database_cannot_hold_without_a_500(
    client: TestClient,
) -> None:
    """A rule id past what the database holds failed on SQLite and PostgreSQL, a NUL
    byte in an account's name or a rule's note on PostgreSQL: a 400 page, a plain note."""
    sign_in(client, "admin")
    csrf = csrf_of(client)
    huge = client.post("/dashboard/admin/rules/99999999999999999999999/remove", data={"csrf": csrf})
    assert huge.status_code == 400 and "malformed" in huge.text
    nul = client.post("/dashboard/admin/accounts/admin-one%00/remove", data={"csrf": csrf})
    assert nul.status_code == 400 and "there is no account" in nul.text
    form = {"network": "10.0.0.0/8", "note": "lab\x00 3\u202e", "csrf": csrf}
    assert client.post("/dashboard/admin/rules", data=form).status_code == 200
    assert [rule.note for rule in list_rules(services_of(client).db)] == ["lab 3"]


def test_a_duplicate_rule_is_refused(client: TestClient) -> None:
    sign_in(client, "admin")
    for _ in range(2):
        response = client.post(
            "/dashboard/admin/rules", data={"network": "10.0.0.0/8", "csrf": csrf_of(client)}
        )
    assert response.status_code == 400 and "already a rule" in response.text


def _remove(client: TestClient) -> None:
    remove_account(services_of(client).db, "instructor-one", actor="test")


def _new_password(client: TestClient) -> None:
    set_password(services_of(client).db, "instructor-one", "another-password", actor="test")


def _sign_out(client: TestClient) -> None:
    client.post("/logout", data={"csrf": csrf_of(client)})


REVOCATIONS: dict[str, Callable[[TestClient], object]] = {
    "account removed": _remove,
    "password changed": _new_password,
    "signed out": _sign_out,
    "stepped down to student": register_student,
}


@pytest.mark.parametrize("how", sorted(REVOCATIONS))
def test_an_open_dashboard_socket_closes_when_its_authority_ends(
    client: TestClient, how: str
) -> None:
    sign_in(client, "instructor")
    with client.websocket_connect(
        "/ws/dashboard/demo", headers={"origin": "http://testserver"}
    ) as socket:
        assert socket.receive_json()["type"] == "status"
        REVOCATIONS[how](client)
        with pytest.raises(WebSocketDisconnect) as closed:
            for _ in range(60):  # status arrives every second until the socket closes
                socket.receive_json()
        assert closed.value.code == CLOSE_POLICY


def test_without_walls_the_dashboard_says_so(settings: Settings, tmp_path: Path) -> None:
    empty = tmp_path / "no-walls"
    empty.mkdir()
    bare = settings.model_copy(update={"wall_configs": [empty]})
    migrate(bare.resolved_database_url)
    with TestClient(create_app(bare)) as browser:
        sign_in(browser, "instructor")
        page = browser.get("/dashboard")
    assert page.status_code == 503
    assert "No walls are configured" in page.text and "TAGWALL_WALL_CONFIGS" in page.text


def test_every_link_and_script_of_the_dashboard_leads_somewhere(client: TestClient) -> None:
    """Every path the dashboard (every app's panel on it) links to, loads or posts to is
    answered by a route or a static file: the brain panel's CSV link stayed on the old
    path when the apps' API moved under /api/apps/<name>/."""
    from starlette.routing import Match

    sign_in(client, "instructor")
    page = client.get("/dashboard").text
    paths = {
        re.sub(r"\{\{[^}]*\}\}", "demo", path).split("?")[0]
        for path in re.findall(r'(?:href|src|action)="(/[^"]*)"', page)
    }
    assert paths
    app = client.app
    lost = []
    for path in sorted(paths):
        scope = {"type": "http", "path": path, "method": "GET", "root_path": ""}
        routed = any(route.matches(scope)[0] != Match.NONE for route in app.routes)  # type: ignore[attr-defined]
        if not routed or (path.startswith("/static/") and client.get(path).status_code == 404):
            lost.append(path)
    assert not lost, lost
