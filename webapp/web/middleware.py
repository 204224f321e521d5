"""The middlewares, all plain ASGI (no per-request task or body copy), outermost first:
the client's address, the access log, the security headers, the session cookie (and a
campus sign-in's own cookie on its paths)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from http import HTTPStatus
from urllib.parse import quote

from starlette.datastructures import Headers, MutableHeaders
from starlette.middleware.sessions import SessionMiddleware
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from webapp.core.logs import redact
from webapp.people.addresses import Network, client_address, is_trusted_peer
from webapp.people.visitors import Visitor, cookie_header
from webapp.web.templating import IMPORT_MAP_HASH

HEADERS = {
    # Scripts and styles only from our own static files, nothing foreign; the one inline
    # script is the import map, allowed by its hash.
    "content-security-policy": (
        f"default-src 'self'; script-src 'self' '{IMPORT_MAP_HASH}'; style-src 'self'; "
        "img-src 'self' data: blob:; connect-src 'self'; frame-ancestors 'none'; "
        "base-uri 'none'; form-action 'self'"
    ),
    "x-frame-options": "DENY",
    "x-content-type-options": "nosniff",
    "referrer-policy": "same-origin",
}
_RAW = [(name.encode(), value.encode()) for name, value in HEADERS.items()]
_PHRASES = {status.value: status.phrase for status in HTTPStatus}


class ClientAddressMiddleware:
    """Puts the client's address (and, from a trusted proxy, ``X-Forwarded-Proto``'s
    scheme) into every HTTP and websocket connection's scope.

    Repeated ``X-Forwarded-For`` lines are one comma-joined list (RFC 9110 5.3): a
    proxy that appends its own line (HAProxy's ``option forwardfor``) must not let the
    client's own line decide."""

    def __init__(self, app: ASGIApp, trusted: Sequence[Network]) -> None:
        self.app = app
        self.trusted = list(trusted)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if self.trusted and scope["type"] in ("http", "websocket"):
            peer = scope["client"][0] if scope.get("client") else ""
            if is_trusted_peer(peer, self.trusted):
                headers = Headers(scope=scope)
                forwarded = ", ".join(headers.getlist("x-forwarded-for")) or None
                scope = dict(scope)
                scope["client"] = (client_address(peer, forwarded, self.trusted), 0)
                proto = headers.get("x-forwarded-proto", "").strip().lower()
                if proto in ("http", "https"):
                    secure = proto == "https"
                    web = scope["type"] == "http"
                    scope["scheme"] = (
                        ("https" if secure else "http") if web else ("wss" if secure else "ws")
                    )
        await self.app(scope, receive, send)


class AccessLogMiddleware:
    """One line per HTTP response, as uvicorn's access log wrote it: the client (as
    tagwall sees it, behind trusted proxies), the request line and the status. Secrets in
    the query string are masked as the line is made. uvicorn's own access log passed
    five arguments through the redaction filter and copied each record to format it:
    3-5 % of a phone's request (issue 32).

    An unhandled error's 500 is sent outside every middleware (by Starlette's
    ``ServerErrorMiddleware``), so its line is written here as the error passes on the
    way there, when no response had started."""

    def __init__(self, app: ASGIApp, log: logging.Logger) -> None:
        self.app = app
        self.log = log

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not self.log.isEnabledFor(logging.INFO):
            await self.app(scope, receive, send)
            return
        started = False

        async def send_logged(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
                self.log.info(access_line(scope, message["status"]))
            await send(message)

        try:
            await self.app(scope, receive, send_logged)
        except Exception:
            if not started:
                self.log.info(access_line(scope, HTTPStatus.INTERNAL_SERVER_ERROR))
            raise


def access_line(scope: Scope, status: int) -> str:
    """``client - "METHOD /path?query HTTP/1.1" 200 OK``, secrets in the query masked."""
    client = scope.get("client")
    who = f"{client[0]}:{client[1]}" if client else ""
    raw = scope.get("raw_path")
    path = raw.decode("latin-1") if raw else quote(scope["path"])
    if query := scope["query_string"]:
        path = f"{path}?{redact(query.decode('latin-1'))}"
    request = f"{scope['method']} {path} HTTP/{scope['http_version']}"
    return f'{who} - "{request}" {status} {_PHRASES.get(status, "")}'.rstrip()


class SecurityHeadersMiddleware:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                given = {name.lower(): value for name, value in message.get("headers", [])}
                extra = [(n, v) for n, v in _RAW if n not in given]
                # A page is made for one person at one moment: never shown again from a
                # browser's cache (a code's page once it works again, or another
                # person's page on a shared phone); pages may say otherwise themselves.
                page = given.get(b"content-type", b"").startswith(b"text/html")
                if page and b"cache-control" not in given:
                    extra.append((b"cache-control", b"no-store"))
                message["headers"] = [*message.get("headers", []), *extra]
            await send(message)

        await self.app(scope, receive, send_with_headers)


class SessionCookieMiddleware:
    """Writes the session cookie of a new or rotated visitor, so no route has to."""

    def __init__(self, app: ASGIApp, secret: str) -> None:
        self.app = app
        self.secret = secret

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_cookie(message: Message) -> None:
            visitor: Visitor | None = scope.get("state", {}).get("visitor")
            if message["type"] == "http.response.start" and visitor and visitor.changed:
                headers = MutableHeaders(scope=message)
                https = scope["scheme"] == "https"
                headers.append("set-cookie", cookie_header(visitor, self.secret, https=https))
            await send(message)

        await self.app(scope, receive, send_with_cookie)


class SignInStateMiddleware:
    """Starlette's signed session cookie on the paths under ``path`` only: Authlib keeps
    a campus sign-in's state, nonce and PKCE verifier there from the provider's button
    to its answer, for ``max_age`` seconds at most, in the browser that started it
    (SameSite=Lax: the provider's redirect back is a top-level navigation). Every other
    request passes by without a cookie read."""

    def __init__(
        self, app: ASGIApp, secret: str, path: str, cookie: str, max_age: int, https: bool
    ) -> None:
        self.app = app
        self.prefix = path + "/"
        self.sessions = SessionMiddleware(
            app,
            secret_key=secret,
            session_cookie=cookie,
            max_age=max_age,
            path=path,
            same_site="lax",
            https_only=https,
        )

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope["path"].startswith(self.prefix):
            await self.sessions(scope, receive, send)
        else:
            await self.app(scope, receive, send)
