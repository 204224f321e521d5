"""Who a phone is: an anonymous visitor id in a signed cookie, created at first scan."""

from __future__ import annotations

import secrets
from dataclasses import dataclass

from fastapi import Request, Response
from itsdangerous import BadSignature, URLSafeSerializer

VISITOR_COOKIE = "tagwall_visitor"
VISITOR_MAX_AGE_S = 365 * 24 * 3600


@dataclass(frozen=True)
class Visitor:
    id: str
    is_new: bool

    def remember(self, request: Request, response: Response, secret: str) -> None:
        """Set the cookie on a first visit (HttpOnly, SameSite=Lax, Secure under https)."""
        if not self.is_new:
            return
        response.set_cookie(
            VISITOR_COOKIE,
            _serializer(secret).dumps(self.id),
            max_age=VISITOR_MAX_AGE_S,
            httponly=True,
            samesite="lax",
            secure=request.url.scheme == "https",
        )


def _serializer(secret: str) -> URLSafeSerializer:
    return URLSafeSerializer(secret, salt="tagwall.visitor")


def visitor_of(request: Request, secret: str) -> Visitor:
    """The visitor the request's cookie names; a new one when it has none or a forged one."""
    cookie = request.cookies.get(VISITOR_COOKIE)
    if cookie:
        try:
            visitor_id = _serializer(secret).loads(cookie)
        except BadSignature:
            visitor_id = None
        if isinstance(visitor_id, str) and 0 < len(visitor_id) <= 64:
            return Visitor(visitor_id, is_new=False)
    return Visitor(secrets.token_urlsafe(12), is_new=True)
