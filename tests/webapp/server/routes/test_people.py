"""Signing in and out, registration codes, address rules, CSRF and session rotation,
through HTTP as a phone or a browser does it."""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from ipaddress import ip_network

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import select

from tests.conftest import (
    TEST_PASSWORD,
    csrf_of,
    migrate,
    register_student,
    services_of,
    sign_in,
)
from webapp.core.settings import Settings
from webapp.database.models import AuditRecord
from webapp.people.accounts import add_account, remove_account
from webapp.people.address_rules import add_rule
from webapp.people.visitors import SESSION_COOKIE
from webapp.tags.registry import wall_tags


def code_named(client: TestClient, name: str) -> str:
    return next(t.code for t in wall_tags(services_of(client).db, "demo") if t.name == name)


def role_of(client: TestClient) -> str:
    text = client.get("/me").text
    return text.split('<dd id="role">')[1].split("<")[0]


def audit_actions(client: TestClient) -> list[str]:
    with services_of(client).db.session() as session:
        return list(session.scalars(select(AuditRecord.action).order_by(AuditRecord.id)))


def login(client: TestClient, username: str, password: str, next: str = "/me") -> object:
    return client.post(
        "/login",
        data={
            "username": username,
            "password": password,
            "csrf": csrf_of(client, "/login"),
            "next": next,
        },
        follow_redirects=False,
    )


def test_scanning_the_student_code_makes_a_student(client: TestClient) -> None:
    register_student(client)
    assert role_of(client) == "student"


def test_instructor_code_after_sign_in_makes_an_instructor(client: TestClient) -> None:
    code = code_named(client, "register-instructor")
    first = client.get(f"/t/{code}", follow_redirects=False)
    assert first.headers["location"] == f"/login?next=/t/{code}"
    add_account(services_of(client).db, "ines", "instructor", TEST_PASSWORD, actor="test")
    signed_in = login(client, "ines", TEST_PASSWORD, next=f"/t/{code}")
    assert signed_in.status_code == 303  # type: ignore[attr-defined]
    assert signed_in.headers["location"] == f"/t/{code}"  # type: ignore[attr-defined]
    page = client.get(f"/t/{code}")
    assert page.status_code == 200 and '<strong id="role">instructor</strong>' in page.text


def test_an_instructor_steps_down_and_up_without_signing_in_again(client: TestClient) -> None:
    sign_in(client, "instructor")
    register_student(client)
    assert role_of(client) == "student"
    client.get(f"/t/{code_named(client, 'register-instructor')}")
    assert role_of(client) == "instructor"


def test_wrong_password_is_401_and_audited(client: TestClient) -> None:
    add_account(services_of(client).db, "ines", "instructor", TEST_PASSWORD, actor="test")
    response = login(client, "ines", "not-the-password")
    assert response.status_code == 401  # type: ignore[attr-defined]
    assert "Wrong username or password" in response.text  # type: ignore[attr-defined]
    assert login(client, "nobody", "whatever").status_code == 401  # type: ignore[attr-defined]
    assert audit_actions(client).count("login_failed") == 2
    assert role_of(client) == "student"


def test_failed_sign_ins_meet_growing_delays_per_account_at_a_client(app: FastAPI) -> None:
    with TestClient(app) as browser:
        add_account(services_of(browser).db, "ines", "instructor", TEST_PASSWORD, actor="test")
        throttle = services_of(browser).login_throttle
        for _ in range(app.state.services.settings.login_free_attempts):
            assert login(browser, "ines", "wrong-password").status_code == 401  # type: ignore[attr-defined]
        throttled = login(browser, "ines", TEST_PASSWORD)
        assert throttled.status_code == 429  # type: ignore[attr-defined]
        assert int(throttled.headers["retry-after"]) >= 1  # type: ignore[attr-defined]
        # the delay doubles with each further failure (the throttle's clock is monotonic)
        later = time.monotonic() + 10
        reserve = partial(browser.portal.call, throttle.reserve, "ines", "testclient", None)
        first_wait = reserve(later)
        assert not isinstance(first_wait, float), "the first delay was over"
        second_wait = reserve(later)
        assert isinstance(second_wait, float) and second_wait == pytest.approx(2.0)


def test_sign_in_rotates_the_session_and_the_old_cookie_is_worthless(client: TestClient) -> None:
    register_student(client)
    before = client.cookies[SESSION_COOKIE]
    old_csrf = csrf_of(client)
    sign_in(client, "instructor")
    after = client.cookies[SESSION_COOKIE]
    assert after != before
    # the pre-sign-in cookie (say, copied off the phone) is an anonymous visitor now
    with TestClient(client.app) as thief:
        thief.cookies.set(SESSION_COOKIE, before)
        assert role_of(thief) == "student"
        assert thief.get("/dashboard", follow_redirects=False).status_code == 303
    # and the old CSRF token no longer works for the signed-in session
    refused = client.post("/logout", data={"csrf": old_csrf})
    assert refused.status_code == 403
    assert role_of(client) == "instructor"


def test_logout_drops_role_and_rotates(client: TestClient) -> None:
    sign_in(client, "admin")
    before = client.cookies[SESSION_COOKIE]
    response = client.post("/logout", data={"csrf": csrf_of(client)}, follow_redirects=False)
    assert response.status_code == 303
    assert client.cookies[SESSION_COOKIE] != before
    assert role_of(client) == "student"
    assert client.get("/dashboard", follow_redirects=False).status_code == 303
    assert "logout" in audit_actions(client)


def test_the_next_person_on_a_shared_phone_inherits_nothing_of_the_last(
    client: TestClient,
) -> None:
    """Sign-out makes the phone a new visitor: the last person's name (and their answers,
    their group, kept under their visitor) are not the next person's."""
    saved = client.post(
        "/me",
        data={
            "csrf": csrf_of(client),
            "user_group": "medical",
            "info_class": "3",
            "display_name": "Ann",
        },
    )
    assert saved.status_code == 200 and 'value="Ann"' in client.get("/me").text
    signed_in_as = client.cookies[SESSION_COOKIE].split(".")[0]
    client.post("/logout", data={"csrf": csrf_of(client)})
    after = client.get("/me").text
    assert 'value="Ann"' not in after and 'value="medical" selected' not in after
    assert client.cookies[SESSION_COOKIE].split(".")[0] != signed_in_as


@pytest.mark.parametrize("csrf", [None, "", "forged-token"])
def test_forms_without_the_right_csrf_token_are_refused(
    client: TestClient, csrf: str | None
) -> None:
    add_account(services_of(client).db, "ines", "instructor", TEST_PASSWORD, actor="test")
    client.get("/login")
    data = {"username": "ines", "password": TEST_PASSWORD}
    if csrf is not None:
        data["csrf"] = csrf
    response = client.post("/login", data=data, follow_redirects=False)
    assert response.status_code == 403
    assert "did not come from this site" in response.text
    assert role_of(client) == "student"


def test_another_sessions_csrf_token_is_refused(app: FastAPI) -> None:
    with TestClient(app) as attacker, TestClient(app) as victim:
        token = csrf_of(attacker)
        sign_in(victim, "instructor")
        assert victim.post("/logout", data={"csrf": token}).status_code == 403
        assert role_of(victim) == "instructor"


@pytest.mark.parametrize(
    "target,landing",
    [
        ("/dashboard", "/dashboard"),
        ("https://evil.example/", "/dashboard"),
        ("//evil.example/x", "/dashboard"),
        ("/\\evil.example", "/dashboard"),
        ("/me?x=1", "/me?x=1"),
    ],
)
def test_after_sign_in_only_local_paths(client: TestClient, target: str, landing: str) -> None:
    add_account(services_of(client).db, "ines", "instructor", TEST_PASSWORD, actor="test")
    response = login(client, "ines", TEST_PASSWORD, next=target)
    assert response.headers["location"] == landing  # type: ignore[attr-defined]


def test_removing_an_account_demotes_its_phones(client: TestClient) -> None:
    sign_in(client, "instructor", "ines")
    remove_account(services_of(client).db, "ines", actor="test")
    assert role_of(client) == "student"
    assert client.get("/dashboard", follow_redirects=False).status_code == 303


def test_profile_choices_and_the_class_cap(client: TestClient) -> None:
    register_student(client)
    response = client.post(
        "/me",
        data={
            "csrf": csrf_of(client),
            "display_name": "<b>Sam</b>",
            "user_group": "medical",
            "info_class": "5",
        },
    )
    assert response.status_code == 200
    assert "&lt;b&gt;Sam&lt;/b&gt;" in response.text  # escaped, never markup
    assert '<option value="medical" selected>' in response.text
    # students are capped at class 3 by default
    assert '<option value="3" selected>' in response.text and 'value="4"' not in response.text


@pytest.mark.parametrize(
    "field,value", [("user_group", "aliens"), ("info_class", "9"), ("info_class", "x")]
)
def test_bad_profile_forms_are_clear_errors(client: TestClient, field: str, value: str) -> None:
    data = {"csrf": csrf_of(client), "user_group": "k5", "info_class": "1", field: value}
    response = client.post("/me", data=data)
    assert response.status_code == 400
    assert "Traceback" not in response.text


def with_settings(settings: Settings, **changes: object) -> Settings:
    return settings.model_copy(update=changes)


@pytest.fixture
def make_app() -> Callable[[Settings], FastAPI]:
    from webapp.server.app import create_app

    def build(settings: Settings) -> FastAPI:
        migrate(settings.resolved_database_url)
        return create_app(settings)

    return build


def test_x_forwarded_for_counts_only_from_trusted_proxies(
    settings: Settings, make_app: Callable[[Settings], FastAPI]
) -> None:
    """The peer is 127.0.0.1 (``client=`` of the TestClient): a proxy or not, by setting."""
    rule = {"role": "instructor", "user_group": "research", "info_class": 2, "note": ""}
    code_app = make_app(with_settings(settings, address_rules_grant_roles=True))
    with TestClient(code_app, client=("127.0.0.1", 5000)) as untrusted:
        add_rule(services_of(untrusted).db, "10.9.0.0/16", actor="test", **rule)  # type: ignore[arg-type]
        code = code_named(untrusted, "register-instructor")
        forged = untrusted.get(
            f"/t/{code}", headers={"X-Forwarded-For": "10.9.1.1"}, follow_redirects=False
        )
        assert forged.status_code == 303  # to the sign-in page: the header proves nothing
    trusted_settings = with_settings(
        settings, address_rules_grant_roles=True, trusted_proxies=[ip_network("127.0.0.1")]
    )
    with TestClient(make_app(trusted_settings), client=("127.0.0.1", 5000)) as behind_proxy:
        page = behind_proxy.get(f"/t/{code}", headers={"X-Forwarded-For": "203.0.113.5, 10.9.1.1"})
        assert '<strong id="role">instructor</strong>' in page.text
        me = behind_proxy.get("/me", headers={"X-Forwarded-For": "10.9.1.1"}).text
        assert '<option value="research" selected>' in me
        # a client-written hop left of an untrusted one is ignored
        with TestClient(behind_proxy.app, client=("127.0.0.1", 5001)) as other:
            spoofed = other.get(
                f"/t/{code}",
                headers={"X-Forwarded-For": "10.9.1.1, 198.51.100.7"},
                follow_redirects=False,
            )
            assert spoofed.status_code == 303


def test_address_rule_roles_stay_off_by_default(
    settings: Settings, make_app: Callable[[Settings], FastAPI]
) -> None:
    with TestClient(make_app(settings), client=("10.9.1.1", 5000)) as phone:
        add_rule(
            services_of(phone).db,
            "10.9.0.0/16",
            role="instructor",
            user_group="k5",
            info_class=None,
            note="",
            actor="test",
        )
        code = code_named(phone, "register-instructor")
        assert phone.get(f"/t/{code}", follow_redirects=False).status_code == 303
        assert '<option value="k5" selected>' in phone.get("/me").text  # defaults still apply
