"""The middlewares: which address a request comes from, behind proxies; the access log."""

from __future__ import annotations

import logging
import logging.config
from ipaddress import ip_network

import pytest
from fastapi import FastAPI, Request
from fastapi.responses import PlainTextResponse
from fastapi.testclient import TestClient

from webapp.core.logs import ACCESS_LOGGER, RedactSecrets, uvicorn_log_config
from webapp.people.addresses import address_of
from webapp.web.middleware import AccessLogMiddleware, ClientAddressMiddleware

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


def _logged_client(peer: str, log: logging.Logger) -> TestClient:
    """A page behind the access log, behind the client address (as create_app stacks them)."""
    app = FastAPI()

    @app.get("/wall/demo/tile/r1c1")
    async def tile() -> dict[str, str]:
        return {}

    app.add_middleware(AccessLogMiddleware, log=log)
    app.add_middleware(ClientAddressMiddleware, trusted=[ip_network(PROXY)])
    return TestClient(app, client=(peer, 5000))


def test_each_response_is_one_access_line_with_its_secrets_masked(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The line is masked as it is made: no handler or filter has to see the token."""
    log = logging.getLogger("tests.access")
    caplog.set_level(logging.INFO, logger=log.name)
    client = _logged_client("198.51.100.7", log)
    assert client.get("/wall/demo/tile/r1c1?token=s3cret.Tile&csrf=abc&x=1").status_code == 200
    assert client.get("/nowhere").status_code == 404
    lines = [record.getMessage() for record in caplog.records if record.name == log.name]
    assert lines == [
        '198.51.100.7:5000 - "GET /wall/demo/tile/r1c1?token=[redacted]&csrf=[redacted]&x=1'
        ' HTTP/1.1" 200 OK',
        '198.51.100.7:5000 - "GET /nowhere HTTP/1.1" 404 Not Found',
    ]


def test_a_response_to_an_unhandled_error_has_its_access_line_too(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The 500 page is sent outside every middleware (Starlette's last resort), so the
    access log never saw a response start: it writes the line as the error passes."""
    log = logging.getLogger("tests.access")
    caplog.set_level(logging.INFO, logger=log.name)
    app = FastAPI()

    @app.get("/broken")
    async def broken() -> None:
        raise RuntimeError("a bug")

    @app.exception_handler(Exception)
    async def server_error(request: Request, error: Exception) -> PlainTextResponse:
        return PlainTextResponse("Something went wrong on the server.", 500)

    app.add_middleware(AccessLogMiddleware, log=log)
    client = TestClient(app, client=("198.51.100.7", 5000), raise_server_exceptions=False)
    assert client.get("/broken?token=s3cret").status_code == 500
    lines = [record.getMessage() for record in caplog.records if record.name == log.name]
    assert lines == [
        '198.51.100.7:5000 - "GET /broken?token=[redacted] HTTP/1.1" 500 Internal Server Error'
    ]


def test_the_servers_500_page_is_logged_once_as_it_is_sent(
    app: FastAPI, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger=ACCESS_LOGGER)

    async def broken() -> None:
        raise RuntimeError("a bug")

    app.add_api_route("/broken", broken)
    with TestClient(app, raise_server_exceptions=False) as client:
        answer = client.get("/broken")
    assert answer.status_code == 500 and "it has been logged" in answer.text
    lines = [r.getMessage() for r in caplog.records if r.name == ACCESS_LOGGER]
    assert [line.split(" - ", 1)[1] for line in lines] == [
        '"GET /broken HTTP/1.1" 500 Internal Server Error'
    ]


def test_the_access_line_names_the_client_behind_a_trusted_proxy(
    caplog: pytest.LogCaptureFixture,
) -> None:
    log = logging.getLogger("tests.access")
    caplog.set_level(logging.INFO, logger=log.name)
    headers = {"X-Forwarded-For": "198.51.100.7"}
    assert _logged_client(PROXY, log).get("/wall/demo/tile/r1c1", headers=headers).is_success
    assert [r.getMessage().split(" - ")[0] for r in caplog.records] == ["198.51.100.7:0"]


def test_serve_writes_the_access_line_once_in_uvicorns_columns() -> None:
    """``tagwall serve``'s logging: the access lines have a handler of their own (uvicorn's
    access formatter wants uvicorn's arguments) and come out as uvicorn's did; every
    other handler masks secrets whatever logger the line came from."""
    config = uvicorn_log_config()
    assert config["loggers"][ACCESS_LOGGER]["propagate"] is False  # written once
    for name, handler in config["handlers"].items():
        assert name == "access_line" or "redact_secrets" in handler["filters"]
    assert config["filters"]["redact_secrets"]["()"].endswith(RedactSecrets.__name__)
    formatter = logging.config.DictConfigurator(config).configure_formatter(
        config["formatters"]["access_line"]
    )
    line = 'x - "GET / HTTP/1.1" 200 OK'
    record = logging.LogRecord(ACCESS_LOGGER, logging.INFO, "", 0, line, None, None)
    assert formatter.format(record) == f"INFO:     {line}"
