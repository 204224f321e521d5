"""Pairing over HTTP: the dashboard's code, the phone's confirm page, single use."""

from __future__ import annotations

import base64
from datetime import UTC, datetime, timedelta

from fastapi.testclient import TestClient
from sqlalchemy import update

from tests.conftest import csrf_of, services_of, sign_in
from webapp.database.models import PairingRecord


def new_code(instructor: TestClient) -> dict[str, str]:
    response = instructor.post("/api/pairing", headers={"X-CSRF-Token": csrf_of(instructor)})
    assert response.status_code == 200
    result: dict[str, str] = response.json()
    return result


def token_of(code: dict[str, str]) -> str:
    return code["url"].rsplit("/P/", 1)[1]


def test_a_pairing_code_makes_the_phone_an_instructor_once(client: TestClient) -> None:
    with TestClient(client.app) as instructor, TestClient(client.app) as late:  # type: ignore[arg-type]
        sign_in(instructor, "instructor", "ines")
        code = new_code(instructor)
        assert code["url"].startswith("HTTP://192.168.1.20:8000/P/")  # alphanumeric QR mode
        svg = base64.b64decode(code["image"].split(",", 1)[1])
        assert svg.startswith(b"<svg") and b"crispEdges" in svg
        page = client.get(f"/p/{token_of(code).lower()}")
        assert page.status_code == 200 and "ines offers" in page.text
        paired = client.post(
            f"/p/{token_of(code)}", data={"csrf": csrf_of(client)}, follow_redirects=False
        )
        assert paired.status_code == 303
        assert '<dd id="role">instructor</dd>' in client.get("/me").text
        assert "pairing:ines" in client.get("/me").text
        replayed = late.post(f"/p/{token_of(code)}", data={"csrf": csrf_of(late)})
        assert replayed.status_code == 410 and "already used" in replayed.text
        assert late.get(f"/p/{token_of(code)}").status_code == 410


def test_an_expired_pairing_code_is_410(client: TestClient) -> None:
    with TestClient(client.app) as instructor:  # type: ignore[arg-type]
        sign_in(instructor, "instructor")
        code = new_code(instructor)
    with services_of(client).db.session() as session:
        session.execute(
            update(PairingRecord).values(expires_at=datetime.now(UTC) - timedelta(seconds=1))
        )
    response = client.post(f"/p/{token_of(code)}", data={"csrf": csrf_of(client)})
    assert response.status_code == 410 and "expired" in response.text
    assert '<dd id="role">student</dd>' in client.get("/me").text


def test_pairing_needs_the_phone_sessions_csrf_token(client: TestClient) -> None:
    with TestClient(client.app) as instructor:  # type: ignore[arg-type]
        sign_in(instructor, "instructor")
        code = new_code(instructor)
    forged = client.post(f"/p/{token_of(code)}", data={"csrf": "forged"})
    assert forged.status_code == 403
    # the code was not used up by the forged request
    assert client.get(f"/p/{token_of(code)}").status_code == 200
