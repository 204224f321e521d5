"""Staff sign in at the test OpenID Provider (oidc-provider from npm): the whole
authorization code flow over real HTTP, and every answer tagwall must refuse."""

from __future__ import annotations

import base64
import html
import json
import logging
import re
import time
from collections.abc import Callable
from urllib.parse import parse_qs, quote, urlencode, urlsplit

import pytest
from fastapi.testclient import TestClient
from joserfc.jwk import RSAKey
from sqlalchemy import select

from tests.conftest import csrf_of, migrate, server_port, services_of
from tests.oidc.provider import Client, OpenIDProvider, nonce_of
from tests.webapp.campus.conftest import answer, begin, sign_in, with_providers
from webapp.cli.testing import wait_until
from webapp.core.logs import ACCESS_LOGGER
from webapp.core.settings import Settings
from webapp.database.models import AccountRecord, AuditRecord
from webapp.people.accounts import add_account, remove_account
from webapp.server.app import create_app


def accounts(client: TestClient) -> list[AccountRecord]:
    with services_of(client).db.session() as session:
        return list(session.scalars(select(AccountRecord)))


def audit_actions(client: TestClient) -> list[str]:
    with services_of(client).db.session() as session:
        return list(session.scalars(select(AuditRecord.action).order_by(AuditRecord.id)))


def role_of(client: TestClient) -> str:
    """The browser's role as the dashboard lets it in or not."""
    response = client.get("/dashboard", follow_redirects=False)
    return "staff" if response.status_code == 200 else "not staff"


def test_a_staff_member_signs_in_and_the_first_sign_in_makes_the_account(
    campus: TestClient, openid_provider: OpenIDProvider, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger=ACCESS_LOGGER)
    redirect = openid_provider.sign_in(begin(campus), "sam")
    response = answer(campus, redirect)

    assert response.status_code == 303, response.text
    assert response.headers["location"] == "/dashboard"
    [account] = accounts(campus)
    assert (account.username, account.role, account.full_name) == ("sam", "instructor", "Sam Staff")
    assert (account.issuer, account.subject) == (openid_provider.issuer, "sam")
    assert account.password_hash is None
    assert role_of(campus) == "staff"
    me = campus.get("/me").text
    assert 'value="medical" selected' in me  # groups has medicine: the medical user group
    assert audit_actions(campus)[-2:] == ["account_added", "role_granted"]
    code = parse_qs(urlsplit(redirect).query)["code"][0]
    assert "/callback?code=[redacted]&state=" in caplog.text and code not in caplog.text


def test_later_sign_ins_follow_the_claims_and_a_lower_role_signs_out_other_phones(
    campus: TestClient, openid_provider: OpenIDProvider, campus_settings: Settings
) -> None:
    openid_provider.add_account(
        "dean-1", {"preferred_username": "dean", "name": "Dana Dean", "groups": ["staff"]}
    )
    assert sign_in(campus, openid_provider, "dean-1").status_code == 303
    with TestClient(campus.app) as laptop:
        assert sign_in(laptop, openid_provider, "dean-1").status_code == 303
        [account] = accounts(campus)
        assert (account.username, account.role) == ("dean", "admin")
        admin_page = laptop.get("/dashboard/admin").text
        assert f"<td>{openid_provider.issuer} (Dana Dean)</td>" in admin_page

        # The provider renames the person and they are no longer the named admin.
        openid_provider.add_account(
            "dean-1", {"preferred_username": "dana", "name": "Dana Deane", "groups": ["staff"]}
        )
        assert sign_in(laptop, openid_provider, "dean-1").status_code == 303

        [account] = accounts(campus)
        assert (account.username, account.role, account.full_name) == (
            "dean",  # the username stays: the phones' authority names it
            "instructor",
            "Dana Deane",
        )
        assert role_of(laptop) == "staff"
        assert role_of(campus) == "not staff"  # signed in as admin before: sign in again
        assert "account_role_changed" in audit_actions(campus)


def test_a_sign_in_without_the_role_any_more_removes_the_account_and_demotes_its_phones(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    openid_provider.add_account("leaver", {"preferred_username": "leaver", "groups": ["staff"]})
    assert sign_in(campus, openid_provider, "leaver").status_code == 303
    openid_provider.add_account("leaver", {"preferred_username": "leaver", "groups": []})
    with TestClient(campus.app) as laptop:
        refused = sign_in(laptop, openid_provider, "leaver")

    assert refused.status_code == 403
    assert accounts(campus) == []
    assert role_of(campus) == "not staff"


def test_a_person_the_rules_give_no_role_is_told_why_and_nothing_is_made(
    campus: TestClient, openid_provider: OpenIDProvider, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING):
        response = sign_in(campus, openid_provider, "vic")

    assert response.status_code == 403
    page = response.text
    assert "Not signed in" in page
    assert "vic@elsewhere.example.org" in page and "no role in tagwall" in page
    assert "groups has staff: role instructor" in page
    assert "email at faculty.example.edu: role instructor" in page
    assert "dean" not in page  # who the admins are is not for everyone to read
    assert "guests" in page  # what the provider said of the claims the rules read
    assert accounts(campus) == []
    assert role_of(campus) == "not staff"
    assert audit_actions(campus)[-1] == "login_failed"
    assert "the rules give no role" in caplog.text


def test_claims_the_provider_does_not_send_are_named_on_the_refusal(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    openid_provider.add_account("bare", {"preferred_username": "bare"})

    response = sign_in(campus, openid_provider, "bare")

    assert response.status_code == 403
    assert "nothing (it did not send this claim)" in response.text
    assert accounts(campus) == []


def test_a_mail_domain_makes_an_instructor_unless_the_provider_has_not_verified_it(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    claims = {"preferred_username": "fay", "email": "Fay@Faculty.Example.edu"}
    openid_provider.add_account("fay-unverified", {**claims, "email_verified": False})
    assert sign_in(campus, openid_provider, "fay-unverified").status_code == 403
    openid_provider.add_account("fay", {**claims, "email_verified": True})

    assert sign_in(campus, openid_provider, "fay").status_code == 303
    [account] = accounts(campus)
    assert (account.username, account.role) == ("fay", "instructor")


def test_a_campus_account_never_takes_a_local_accounts_name(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    add_account(services_of(campus).db, "sam", "admin", "a-long-password", actor="test")

    assert sign_in(campus, openid_provider, "sam").status_code == 303

    names = {(a.username, a.role, a.issuer) for a in accounts(campus)}
    assert names == {("sam", "admin", None), ("sam-2", "instructor", openid_provider.issuer)}
    login = campus.post(
        "/login",
        data={"username": "sam-2", "password": "anything", "csrf": csrf_of(campus, "/login")},
    )
    assert login.status_code == 401  # a campus account has no password


def test_removing_the_account_demotes_the_browser_it_signed_in(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    sign_in(campus, openid_provider, "sam")

    remove_account(services_of(campus).db, "sam", actor="test")

    assert role_of(campus) == "not staff"


def test_an_answer_with_a_wrong_state_is_refused(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    redirect = openid_provider.sign_in(begin(campus), "sam")
    parts = urlsplit(redirect)
    query = dict(pair.split("=", 1) for pair in parts.query.split("&"))

    wrong = answer(campus, parts._replace(query=urlencode({**query, "state": "x" * 27})).geturl())
    with TestClient(campus.app) as other_browser:
        elsewhere = answer(other_browser, redirect)  # the right state, in another browser

    for response in (wrong, elsewhere):
        assert response.status_code == 400
        assert "did not start in this browser" in response.text
    assert accounts(campus) == []


def test_a_replayed_answer_is_refused_by_tagwall_and_its_code_by_the_provider(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    redirect = openid_provider.sign_in(begin(campus), "sam")
    kept = campus.cookies.get("tagwall_signin")
    assert answer(campus, redirect).status_code == 303
    sign_out(campus)

    again = answer(campus, redirect)  # the same browser: its sign-in is over
    campus.cookies.set("tagwall_signin", kept, path="/login/oidc")  # a copy of the cookie
    replayed = answer(campus, redirect)

    assert again.status_code == 400 and "did not start in this browser" in again.text
    assert replayed.status_code == 400
    assert "refused this sign-in (invalid_grant" in replayed.text
    assert role_of(campus) == "not staff"


def sign_out(client: TestClient) -> None:
    client.post("/logout", data={"csrf": csrf_of(client)}, follow_redirects=False)


Forge = Callable[[OpenIDProvider, Client, str, RSAKey], str]
"""An ID token for a sign-in: the provider, the client, the request's nonce, and a key
the provider does not have."""
AN_HOUR = 3600
BAD_ID_TOKENS: dict[str, tuple[Forge, str]] = {
    "forged": (
        lambda op, client, nonce, stranger: op.id_token(client, nonce, key=stranger),
        "is not signed by Campus account's keys",
    ),
    "forged-with-a-key-it-does-not-publish": (
        lambda op, client, nonce, stranger: op.id_token(client, nonce, key=stranger, kid="x"),
        "is not signed by Campus account's keys",
    ),
    "altered": (
        lambda op, client, nonce, _: altered(op.id_token(client, nonce), sub="dean"),
        "is not signed by Campus account's keys",
    ),
    "for-another-client": (
        lambda op, client, nonce, _: op.id_token(client, nonce, aud="another-client"),
        "is meant for another client",
    ),
    "from-another-issuer": (
        lambda op, client, nonce, _: op.id_token(client, nonce, iss="https://idp.example.org"),
        "comes from another issuer",
    ),
    "expired": (
        lambda op, client, nonce, _: op.id_token(
            client, nonce, iat=int(time.time()) - 2 * AN_HOUR, exp=int(time.time()) - AN_HOUR
        ),
        "had expired when it arrived",
    ),
    "of-another-sign-in": (
        lambda op, client, nonce, _: op.id_token(client, "an-earlier-nonce"),
        "answers another sign-in",
    ),
    "without-sub": (
        lambda op, client, nonce, _: op.id_token(client, nonce, omit=("sub",)),
        "lacks what every ID token says (sub)",
    ),
    "without-nonce": (
        lambda op, client, nonce, _: op.id_token(client, nonce, omit=("nonce",)),
        "lacks what every ID token says (nonce)",
    ),
    "without-exp": (
        lambda op, client, nonce, _: op.id_token(client, nonce, omit=("exp",)),
        "lacks what every ID token says (exp)",
    ),
}


def altered(token: str, **claims: object) -> str:
    """``token`` with ``claims`` changed in its payload, its signature kept."""
    header, payload, signature = token.split(".")
    body = json.loads(base64.urlsafe_b64decode(payload + "=" * (-len(payload) % 4)))
    changed = base64.urlsafe_b64encode(json.dumps({**body, **claims}).encode()).rstrip(b"=")
    return f"{header}.{changed.decode()}.{signature}"


@pytest.mark.parametrize("case", list(BAD_ID_TOKENS))
def test_an_id_token_that_fails_a_check_signs_no_one_in(
    campus: TestClient,
    openid_provider: OpenIDProvider,
    op_client: Client,
    caplog: pytest.LogCaptureFixture,
    case: str,
) -> None:
    forge, words = BAD_ID_TOKENS[case]
    stranger = RSAKey.generate_key(2048, parameters={"kid": "test-op"}, private=True)
    authorization = begin(campus)
    token = forge(openid_provider, op_client, nonce_of(authorization), stranger)
    openid_provider.hand_out(op_client, token)

    with caplog.at_level(logging.WARNING):
        response = answer(campus, openid_provider.sign_in(authorization, "sam"))

    assert response.status_code == 401
    assert words in html.unescape(response.text) and "No one was signed in" in response.text
    assert "ID token refused" in caplog.text
    assert accounts(campus) == []
    assert role_of(campus) == "not staff"
    assert audit_actions(campus)[-1] == "login_failed"


def test_a_provider_clock_off_by_a_minute_is_within_the_leeway(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    with openid_provider.clock_off(60):
        response = sign_in(campus, openid_provider, "sam")

    assert response.status_code == 303
    assert role_of(campus) == "staff"


def test_a_provider_clock_off_by_minutes_is_refused_and_the_page_says_so(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    with openid_provider.clock_off(5 * 60):
        response = sign_in(campus, openid_provider, "sam")

    assert response.status_code == 401
    page = html.unescape(response.text)
    assert "was issued in the future by this server's clock" in page
    assert "disagree by more than the 120 s allowed" in page
    assert accounts(campus) == []


def test_the_leeway_is_a_setting(
    campus_settings: Settings, openid_provider: OpenIDProvider
) -> None:
    settings = campus_settings.model_copy(update={"oidc_leeway_s": 600})
    migrate(settings.resolved_database_url)
    with TestClient(create_app(settings)) as client, openid_provider.clock_off(5 * 60):
        assert sign_in(client, openid_provider, "sam").status_code == 303


def test_an_answer_that_does_not_come_from_the_provider_is_refused(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    """RFC 9207: the provider names itself in its answer (a mix-up of providers)."""
    redirect = openid_provider.sign_in(begin(campus), "sam")
    assert f"iss={quote(openid_provider.issuer, safe='')}" in redirect

    response = answer(campus, redirect.replace("iss=", "iss=https%3A%2F%2Fevil.example.org&x="))

    assert response.status_code == 400
    assert "does not come from Campus account" in response.text
    assert accounts(campus) == []


def test_a_sign_in_the_person_cancels_at_the_provider_says_so(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    authorization = begin(campus)
    state = parse_qs(urlsplit(authorization).query)["state"][0]
    query = urlencode(
        {
            "error": "access_denied",
            "error_description": "End-User aborted interaction",
            "state": state,
        }
    )

    response = campus.get(f"/login/oidc/campus/callback?{query}")

    assert response.status_code == 401
    assert "did not sign you in: End-User aborted interaction" in response.text


def test_an_unknown_provider_is_not_found(campus: TestClient) -> None:
    assert campus.get("/login/oidc/nowhere", follow_redirects=False).status_code == 404
    assert campus.get("/login/oidc/nowhere/callback?code=x&state=y").status_code == 404


def test_a_provider_unreachable_at_start_leaves_the_server_up_and_says_so(
    settings: Settings, caplog: pytest.LogCaptureFixture
) -> None:
    dead = f"http://127.0.0.1:{server_port()}"  # nothing listens there
    settings = with_providers(
        settings,
        gone={
            "issuer": dead,
            "client_id": "tagwall",
            "client_secret": "secret",
            "name": "Old campus",
            "rules": [{"claim": "groups", "value": "staff", "role": "instructor"}],
        },
    )
    migrate(settings.resolved_database_url)
    with caplog.at_level(logging.WARNING), TestClient(create_app(settings)) as client:
        gone = services_of(client).campus.providers["gone"]
        wait_until(lambda: gone.problem is not None, what="the first try to fail")
        page = client.get("/login").text
        response = client.get("/login/oidc/gone", follow_redirects=False)
        client.get("/login/oidc/gone", follow_redirects=False)

    assert "Sign in with Old campus" in page and "Unavailable right now" in page
    assert response.status_code == 503
    assert "Old campus cannot be reached right now: ConnectError" in response.text
    said = [r for r in caplog.records if "is unavailable" in r.getMessage()]
    assert len(said) == 1, "the log says why once"


def test_a_provider_unreachable_at_sign_in_is_a_clear_page_until_it_answers_again(
    campus: TestClient, openid_provider: OpenIDProvider
) -> None:
    redirect = openid_provider.sign_in(begin(campus), "sam")
    openid_provider.cable.cut()
    try:
        response = answer(campus, redirect)
        page = campus.get("/login").text
        again = campus.get("/login/oidc/campus", follow_redirects=False)
    finally:
        openid_provider.cable.mend()

    assert response.status_code == 503
    assert "Campus account cannot be reached right now" in response.text
    assert "Unavailable right now" in page
    assert again.status_code == 503
    assert accounts(campus) == []
    assert sign_in(campus, openid_provider, "sam").status_code == 303  # asked again: it answers
    assert "Unavailable" not in campus.get("/login").text


def test_an_issuer_that_is_not_what_the_provider_says_is_unavailable(
    settings: Settings, openid_provider: OpenIDProvider, op_client: Client
) -> None:
    """OpenID Connect Discovery 4.3: the metadata's issuer is the one configured, exactly."""
    other_name = openid_provider.issuer.replace("127.0.0.1", "localhost")
    settings = with_providers(
        settings, campus=openid_provider.settings(op_client, issuer=other_name)
    )
    migrate(settings.resolved_database_url)
    with TestClient(create_app(settings)) as client:
        response = client.get("/login/oidc/campus", follow_redirects=False)

    assert response.status_code == 503
    assert f"it says its issuer is &#39;{openid_provider.issuer}&#39;" in response.text


def test_the_sign_in_page_shows_a_button_per_provider_beside_the_password_form(
    campus: TestClient,
) -> None:
    page = campus.get("/login?next=/dashboard/admin").text

    assert 'href="/login/oidc/campus?next=/dashboard/admin"' in page
    assert "Sign in with Campus account" in page
    assert 'name="password"' in page


def test_the_password_form_can_be_switched_off(campus_settings: Settings) -> None:
    settings = campus_settings.model_copy(update={"password_sign_in": False})
    migrate(settings.resolved_database_url)
    with TestClient(create_app(settings)) as client:
        page = client.get("/login").text
        tried = client.post(
            "/login",
            data={"username": "sam", "password": "whatever", "csrf": csrf_of(client)},
        )

    assert "Sign in with Campus account" in page and 'name="password"' not in page
    assert tried.status_code == 403
    assert "Password sign-in is switched off here" in tried.text


def test_signing_out_offers_the_providers_sign_out(
    campus: TestClient, openid_provider: OpenIDProvider, op_client: Client
) -> None:
    sign_in(campus, openid_provider, "sam")

    response = campus.post("/logout", data={"csrf": csrf_of(campus)}, follow_redirects=False)

    assert response.status_code == 200
    assert role_of(campus) == "not staff"
    link = re.search(r'href="([^"]+/session/end[^"]+)"', response.text)
    assert link, response.text
    url = html.unescape(link.group(1))
    assert parse_qs(urlsplit(url).query) == {
        "client_id": [op_client.client_id],
        "post_logout_redirect_uri": ["http://192.168.1.20:8000/"],
    }
    confirm = openid_provider.http.get(url)  # the provider takes it: its own sign-out page
    assert confirm.status_code == 200, confirm.text


def test_failed_answers_from_one_client_are_throttled(
    campus_settings: Settings, openid_provider: OpenIDProvider, op_client: Client
) -> None:
    settings = campus_settings.model_copy(update={"login_client_free_attempts": 1})
    migrate(settings.resolved_database_url)
    with TestClient(create_app(settings)) as client:
        for expected in (401, 429):
            authorization = begin(client)
            nonce = nonce_of(authorization)
            openid_provider.hand_out(op_client, openid_provider.id_token(op_client, nonce, aud="x"))
            response = answer(client, openid_provider.sign_in(authorization, "sam"))
            assert response.status_code == expected
        assert "Retry-After" in response.headers
