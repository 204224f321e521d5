"""Anonymous visitors: a signed cookie names the phone, forged ones are replaced."""

from __future__ import annotations

from fastapi import FastAPI, Request, Response
from fastapi.testclient import TestClient

from webapp.visitors import VISITOR_COOKIE, visitor_of

SECRET = "visitor-test-secret"


def visitor_app(secret: str = SECRET) -> FastAPI:
    app = FastAPI()

    @app.get("/who")
    def who(request: Request, response: Response) -> dict[str, object]:
        visitor = visitor_of(request, secret)
        visitor.remember(request, response, secret)
        return {"id": visitor.id, "new": visitor.is_new}

    return app


def test_a_first_visit_gets_a_lasting_httponly_cookie() -> None:
    client = TestClient(visitor_app())
    response = client.get("/who")
    assert response.json()["new"] is True
    cookie = response.headers["set-cookie"]
    assert cookie.startswith(f"{VISITOR_COOKIE}=")
    assert "HttpOnly" in cookie and "SameSite=lax" in cookie and "Max-Age=31536000" in cookie
    assert "Secure" not in cookie


def test_the_cookie_brings_back_the_same_visitor() -> None:
    client = TestClient(visitor_app())
    first = client.get("/who").json()
    second = client.get("/who")
    assert second.json() == {"id": first["id"], "new": False}
    assert "set-cookie" not in second.headers


def test_under_https_the_cookie_is_secure() -> None:
    client = TestClient(visitor_app(), base_url="https://wall.example")
    assert "Secure" in client.get("/who").headers["set-cookie"]


def test_forged_or_foreign_cookies_make_a_new_visitor() -> None:
    other = TestClient(visitor_app("another-secret"))
    other.get("/who")
    foreign = other.cookies[VISITOR_COOKIE]
    for value in (foreign, "not-signed", "", "a" * 5000):
        client = TestClient(visitor_app())
        client.cookies.set(VISITOR_COOKIE, value)
        assert client.get("/who").json()["new"] is True, value
