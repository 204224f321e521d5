"""The client address middleware: which address a request comes from, behind proxies."""

from __future__ import annotations

from ipaddress import ip_network

from fastapi import FastAPI, Request
from fastapi.testclient import TestClient

from webapp.people.addresses import address_of
from webapp.web.middleware import ClientAddressMiddleware

PROXY = "10.0.0.2"


def _client(peer: str) -> TestClient:
    app = FastAPI()

    @app.get("/who")
    async def who(request: Request) -> dict[str, str]:
        return {"address": address_of(request), "scheme": request.url.scheme}

    app.add_middleware(ClientAddressMiddleware, trusted=[ip_network(PROXY)])
    return TestClient(app, client=(peer, 5000))


def test_a_trusted_proxy_names_the_client() -> None:
    answer = _client(PROXY).get("/who", headers={"X-Forwarded-For": "198.51.100.7"})
    assert answer.json() == {"address": "198.51.100.7", "scheme": "http"}


def test_repeated_forwarded_for_lines_are_one_list_read_from_the_right() -> None:
    """A proxy that appends its own header line (HAProxy's ``option forwardfor``) comes
    after the client's line: the client's own claim must not decide who it is."""
    headers = [("X-Forwarded-For", "10.0.0.9"), ("X-Forwarded-For", "203.0.113.5")]
    answer = _client(PROXY).get("/who", headers=headers)
    assert answer.json()["address"] == "203.0.113.5"


def test_an_untrusted_peer_is_itself_whatever_it_says() -> None:
    headers = {"X-Forwarded-For": "10.0.0.9", "X-Forwarded-Proto": "https"}
    answer = _client("203.0.113.9").get("/who", headers=headers)
    assert answer.json() == {"address": "203.0.113.9", "scheme": "http"}


def test_forwarded_proto_from_a_trusted_proxy_sets_the_scheme() -> None:
    headers = {"X-Forwarded-For": "198.51.100.7", "X-Forwarded-Proto": "https"}
    assert _client(PROXY).get("/who", headers=headers).json()["scheme"] == "https"
