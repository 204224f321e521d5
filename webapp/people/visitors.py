"""Who a phone is: a stable visitor id and a session id, in one signed cookie.

The cookie carries no privilege by itself: roles live in the database under the
visitor id and count only while the cookie's session id matches the stored one
(see :mod:`webapp.people.person`). A request's visitor is kept in ``request.state``;
the session cookie middleware (:mod:`webapp.web.middleware`) writes the cookie
whenever it is new or rotated, so no route has to remember to.
"""

from __future__ import annotations

import secrets
import time
from dataclasses import dataclass, replace

from itsdangerous import BadSignature, URLSafeSerializer
from starlette.requests import HTTPConnection

SESSION_COOKIE = "tagwall_session"
SESSION_MAX_AGE_S = 365 * 24 * 3600
_MAX_ID_LENGTH = 64


def new_id() -> str:
    return secrets.token_urlsafe(16)


@dataclass(frozen=True)
class Visitor:
    id: str
    session_id: str
    issued: int = 0  # unix seconds its first cookie was issued (0: before this was recorded)
    changed: bool = False  # the cookie must be (re)written
    brought_cookie: bool = True  # False: made for a request that brought no valid cookie

    @classmethod
    def fresh(cls) -> Visitor:
        return cls(new_id(), new_id(), int(time.time()), changed=True, brought_cookie=False)

    def rotated(self) -> Visitor:
        """The same visitor under a new session id (after any privilege change)."""
        return replace(self, session_id=new_id(), changed=True)

    def age_s(self, now: float | None = None) -> float | None:
        """How long this phone has kept its cookie (None: it brought none), which the
        abuse limits read: the time is signed into the cookie, so no phone can make
        itself older."""
        if not self.brought_cookie:
            return None
        return max(0.0, (time.time() if now is None else now) - self.issued)


def _serializer(secret: str) -> URLSafeSerializer:
    return URLSafeSerializer(secret, salt="tagwall.session")


def visitor_of(request: HTTPConnection, secret: str) -> Visitor:
    """The request's visitor: from ``request.state``, else the cookie, else a new one.

    A forged, foreign or malformed cookie makes a new visitor.
    """
    known: Visitor | None = getattr(request.state, "visitor", None)
    if known is not None:
        return known
    visitor = _from_cookie(request.cookies.get(SESSION_COOKIE), secret) or Visitor.fresh()
    request.state.visitor = visitor
    return visitor


def _from_cookie(cookie: str | None, secret: str) -> Visitor | None:
    if not cookie or len(cookie) > 400:
        return None
    try:
        value = _serializer(secret).loads(cookie)
    except BadSignature:
        return None
    if not isinstance(value, list) or len(value) not in (2, 3):
        return None
    ids, issued = value[:2], value[2] if len(value) == 3 else 0
    if all(isinstance(part, str) and 0 < len(part) <= _MAX_ID_LENGTH for part in ids) and (
        isinstance(issued, int) and issued >= 0
    ):
        return Visitor(ids[0], ids[1], issued)
    return None


def adopt(request: HTTPConnection, visitor: Visitor) -> None:
    """Make ``visitor`` the request's visitor (its cookie is written with the response)."""
    request.state.visitor = visitor


def cookie_header(visitor: Visitor, secret: str, *, https: bool) -> str:
    """The ``Set-Cookie`` value of ``visitor``'s session cookie (HttpOnly, SameSite=Lax,
    Secure under https)."""
    value = _serializer(secret).dumps([visitor.id, visitor.session_id, visitor.issued])
    secure = "; Secure" if https else ""
    return (
        f"{SESSION_COOKIE}={value}; Max-Age={SESSION_MAX_AGE_S}; Path=/; "
        f"HttpOnly; SameSite=Lax{secure}"
    )
