"""The session cookie: a signed visitor id and session id, written by the middleware
whenever the visitor is new or rotated; forged ones make a new visitor."""

from __future__ import annotations

from fastapi import FastAPI, Request
from fastapi.testclient import TestClient

from webapp.people.visitors import SESSION_COOKIE, adopt, visitor_of
from webapp.web.middleware import SessionCookieMiddleware

SECRET = "visitor-test-secret"


def visitor_app(secret: str = SECRET) -> FastAPI:
    app = FastAPI()
    app.add_middleware(SessionCookieMiddleware, secret=secret)

    @app.get("/who")
    def who(request: Request) -> dict[str, object]:
        visitor = visitor_of(request, secret)
        return {"id": visitor.id, "session": visitor.session_id, "new": visitor.changed}

    @app.get("/rotate")
    def rotate(request: Request) -> dict[str, object]:
        visitor = visitor_of(request, secret).rotated()
        adopt(request, visitor)
        return {"id": visitor.id, "session": visitor.session_id}

    return app


def test_a_first_visit_gets_a_lasting_httponly_cookie() -> None:
    client = TestClient(visitor_app())
    response = client.get("/who")
    assert response.json()["new"] is True
    cookie = response.headers["set-cookie"]
    assert cookie.startswith(f"{SESSION_COOKIE}=")
    assert "HttpOnly" in cookie and "SameSite=Lax" in cookie and "Max-Age=31536000" in cookie
    assert "Path=/" in cookie and "Secure" not in cookie


def test_the_cookie_brings_back_the_same_visitor_and_session() -> None:
    client = TestClient(visitor_app())
    first = client.get("/who").json()
    second = client.get("/who")
    assert second.json() == {**first, "new": False}
    assert "set-cookie" not in second.headers


def test_rotation_keeps_the_visitor_and_replaces_the_session() -> None:
    client = TestClient(visitor_app())
    first = client.get("/who").json()
    rotated = client.get("/rotate")
    assert "set-cookie" in rotated.headers
    assert rotated.json()["id"] == first["id"]
    assert rotated.json()["session"] != first["session"]
    assert client.get("/who").json()["session"] == rotated.json()["session"]


def test_under_https_the_cookie_is_secure() -> None:
    client = TestClient(visitor_app(), base_url="https://wall.example")
    assert "Secure" in client.get("/who").headers["set-cookie"]


def test_forged_or_foreign_cookies_make_a_new_visitor() -> None:
    other = TestClient(visitor_app("another-secret"))
    other.get("/who")
    foreign = other.cookies[SESSION_COOKIE]
    for value in (foreign, "not-signed", "", "a" * 5000):
        client = TestClient(visitor_app())
        client.cookies.set(SESSION_COOKIE, value)
        assert client.get("/who").json()["new"] is True, value
