"""Launches from a real platform (the test LMS, lti1p3platform in its own process) into
tagwall: the good one, and every bad input tagwall must refuse with a clear page and a
log line, creating nothing."""

from __future__ import annotations

import logging
import re
from urllib.parse import urlsplit

import httpx
import pytest
from fastapi.testclient import TestClient
from joserfc import jwt
from joserfc.jwk import KeySet
from sqlalchemy import func, select

from tests.conftest import services_of
from tests.lti.lms import TestLms
from webapp.database.models import ClassRecord, LtiPassRecord, VisitorRecord
from webapp.lti.platforms import Platform

FORM_FIELD = re.compile(r"name='(id_token|state)' value='([^']*)'")


@pytest.fixture
def platform(client: TestClient, lms: TestLms) -> Platform:
    return lms.serve(services_of(client).base_url, services_of(client).db)


def login(client: TestClient, lms: TestLms, user: str = "teacher") -> dict[str, str]:
    """The platform's side up to its form post: initiation at the LMS, tagwall's login
    (TestClient), the LMS's authorization endpoint; the id_token and state it posts."""
    started = httpx.get(f"{lms.url}/start", params={"user": user, "hint": "deep-link"})
    assert started.status_code == 307, started.text
    target = urlsplit(started.headers["location"])
    assert target.path == "/lti/login"
    redirected = client.get(f"{target.path}?{target.query}", follow_redirects=False)
    assert redirected.status_code == 302, redirected.text
    form = httpx.get(redirected.headers["location"])
    assert form.status_code == 200, form.text
    return dict(FORM_FIELD.findall(form.text))


def launched(client: TestClient, posted: dict[str, str]) -> httpx.Response:
    return client.post("/lti/launch", data=posted)


def nothing_created(client: TestClient) -> None:
    with services_of(client).db.session() as session:
        assert session.scalar(select(func.count()).select_from(ClassRecord)) == 0
        assert session.scalar(select(func.count()).select_from(VisitorRecord)) == 0
        assert (
            session.scalar(
                select(func.count())
                .select_from(LtiPassRecord)
                .where(LtiPassRecord.purpose != "state")
            )
            == 0
        )


def refused(
    response: httpx.Response, caplog: pytest.LogCaptureFixture, page: str, log: str
) -> None:
    assert response.status_code >= 400
    assert page in response.text
    assert "frame-ancestors http://localhost:" in response.headers["content-security-policy"]
    assert any(log in record.getMessage() for record in caplog.records), caplog.text


def test_a_deep_linking_launch_shows_the_walls_and_lessons(
    client: TestClient, lms: TestLms, platform: Platform
) -> None:
    page = launched(client, login(client, lms))
    assert page.status_code == 200, page.text
    assert "Add tagwall to Biology 101" in page.text
    assert 'value="brain:quiz"' in page.text
    policy = page.headers["content-security-policy"]
    assert f"frame-ancestors {lms.url}" in policy
    assert "x-frame-options" not in page.headers
    assert client.get("/me").headers["x-frame-options"] == "DENY"  # other pages: never framed


def test_unknown_issuer_and_deployment(
    client: TestClient, lms: TestLms, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO)
    platform = lms.serve(services_of(client).base_url, services_of(client).db)
    page = client.get(
        "/lti/login",
        params={"iss": "https://lms.example", "login_hint": "x", "target_link_uri": "https://t"},
    )
    refused(page, caplog, "not registered with tagwall", "unknown issuer 'https://lms.example'")
    page = client.get(
        "/lti/login",
        params={
            "iss": platform.issuer,
            "client_id": platform.client_id,
            "login_hint": "teacher",
            "target_link_uri": "https://t",
            "lti_deployment_id": "someone-else",
        },
    )
    refused(page, caplog, "deployment of tagwall", "unknown deployment 'someone-else'")
    page = client.get("/lti/login", params={"iss": platform.issuer})
    refused(page, caplog, "incomplete", "login initiation without login_hint")
    nothing_created(client)


def test_a_bad_signature(
    client: TestClient, lms: TestLms, platform: Platform, caplog: pytest.LogCaptureFixture
) -> None:
    posted = login(client, lms)
    head, body, signature = posted["id_token"].split(".")
    forged = signature[:-4] + ("AAAA" if not signature.endswith("AAAA") else "BBBB")
    page = launched(client, {**posted, "id_token": f"{head}.{body}.{forged}"})
    refused(page, caplog, "could not verify this launch", "refused: bad_signature")
    nothing_created(client)


def test_an_expired_launch(
    client: TestClient, lms: TestLms, platform: Platform, caplog: pytest.LogCaptureFixture
) -> None:
    lms.misbehave(token_lifetime=-120)  # past tagwall's leeway of 60 s
    page = launched(client, login(client, lms))
    refused(page, caplog, "This launch has expired", "expired id_token")
    nothing_created(client)


def test_a_replayed_launch_and_nonce(
    client: TestClient, lms: TestLms, platform: Platform, caplog: pytest.LogCaptureFixture
) -> None:
    posted = login(client, lms)
    assert launched(client, posted).status_code == 200
    refused(launched(client, posted), caplog, "expired or was used already", "used state")
    fresh = login(client, lms)  # a new state, the old token's nonce
    page = launched(client, {**fresh, "id_token": posted["id_token"]})
    refused(page, caplog, "could not verify", "invalid_claim: Invalid claim: 'nonce'")


def test_a_launch_for_another_audience(
    client: TestClient, lms: TestLms, platform: Platform, caplog: pytest.LogCaptureFixture
) -> None:
    lms.misbehave(audience="another-tool")
    page = launched(client, login(client, lms))
    refused(page, caplog, "could not verify", "invalid_claim: Invalid claim: 'aud'")
    nothing_created(client)


def test_a_launch_missing_claims(
    client: TestClient, lms: TestLms, platform: Platform, caplog: pytest.LogCaptureFixture
) -> None:
    lms.misbehave(drop_claims=["https://purl.imsglobal.org/spec/lti/claim/roles"])
    page = launched(client, login(client, lms))
    refused(page, caplog, "lacks what tagwall needs (roles)", "missing or wrong claims: roles")
    nothing_created(client)


def test_a_platform_whose_keys_cannot_be_fetched(
    client: TestClient, lms: TestLms, platform: Platform, caplog: pytest.LogCaptureFixture
) -> None:
    lms.misbehave(jwks_down=True)
    page = launched(client, login(client, lms))
    assert page.status_code == 502
    refused(page, caplog, "could not read the learning platform", "unreadable")
    nothing_created(client)


def test_the_deep_link_goes_back_signed_once(
    client: TestClient, lms: TestLms, platform: Platform, caplog: pytest.LogCaptureFixture
) -> None:
    page = launched(client, login(client, lms))
    choice = re.search(r'name="choice" value="([^"]+)"', page.text)
    assert choice
    form = {"choice": choice.group(1), "wall": "demo", "lesson": "brain:quiz"}
    wrong = client.post("/lti/deep-link", data={**form, "points": "0"})
    assert wrong.status_code == 400 and "Points: a whole number from 1 to 1000" in wrong.text
    assert f"frame-ancestors {lms.url}" in wrong.headers["content-security-policy"]

    sent = client.post("/lti/deep-link", data={**form, "points": "12", "title": "Brain quiz"})
    assert sent.status_code == 200, sent.text
    assert f'action="{lms.url}/deep-link-return"' in sent.text
    assert f"form-action 'self' {lms.url}" in sent.headers["content-security-policy"]
    token = re.search(r'name="JWT" value="([^"]+)"', sent.text)
    assert token
    keys = KeySet.import_key_set(client.get("/lti/jwks").json())
    claims = jwt.decode(token.group(1), keys, algorithms=["RS256"]).claims
    assert (claims["iss"], claims["aud"]) == (platform.client_id, platform.issuer)
    assert claims["https://purl.imsglobal.org/spec/lti/claim/deployment_id"] == "deployment-1"
    (item,) = claims["https://purl.imsglobal.org/spec/lti-dl/claim/content_items"]
    assert item["custom"] == {"wall": "demo", "app": "brain", "mode": "quiz"}
    assert item["lineItem"] == {
        "label": "Brain quiz",
        "scoreMaximum": 12,
        "resourceId": "demo:brain",
    }

    again = client.post("/lti/deep-link", data={**form, "points": "12"})
    refused(again, caplog, "This choice has expired", "used choice")
