"""FastAPI dependencies: every lookup and privilege check of a request lives here.

They are ``async`` although none awaits: FastAPI runs plain ``def`` dependencies in
the thread pool, a hop that cost more than the work itself on every request.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any
from urllib.parse import quote

from fastapi import Depends, Header, HTTPException, Query, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from wall_client.layout import Display, Wall
from webapp.people.addresses import address_of
from webapp.people.person import Person, person_of
from webapp.people.ratelimit import WallAction, retry_after_s
from webapp.people.security import csrf_token, token_matches
from webapp.people.visitors import Visitor
from webapp.web.context import AppContext, ServerContext


async def get_context(request: Request) -> ServerContext:
    """What the server holds, as request handlers see it (apps: as an ``AppContext``)."""
    context: ServerContext = request.app.state.services
    return context


ContextDep = Annotated[ServerContext, Depends(get_context)]


def wall_of(context: AppContext, wall_id: str) -> Wall:
    """The wall ``wall_id`` served here; 404 when there is none."""
    wall = context.walls.get(wall_id)
    if wall is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no wall called {wall_id!r}.")
    return wall


async def get_wall(wall_id: str, context: ContextDep) -> Wall:
    return wall_of(context, wall_id)


WallDep = Annotated[Wall, Depends(get_wall)]


async def get_tile(tile_id: str, wall: WallDep) -> Display:
    for display in wall.displays:
        if display.id == tile_id:
            return display
    raise HTTPException(
        status.HTTP_404_NOT_FOUND, f"Wall {wall.id!r} has no tile called {tile_id!r}."
    )


TileDep = Annotated[Display, Depends(get_tile)]


async def require_tile_token(
    wall: WallDep, context: ContextDep, token: Annotated[str | None, Query()] = None
) -> None:
    """Tile pages need the wall's tile token (printed by ``tagwall tiles``)."""
    if not token_matches(context.tile_token(wall.id), token):
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "This tile URL has a missing or wrong token; use the URL from `tagwall tiles`.",
        )


TileTokenDep = Depends(require_tile_token)

_bearer = HTTPBearer(auto_error=False)
BearerDep = Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})


async def get_client_address(request: Request) -> str:
    """The client's address (``X-Forwarded-For`` only from trusted proxies)."""
    return address_of(request)


ClientAddressDep = Annotated[str, Depends(get_client_address)]


def too_fast(wait: float) -> HTTPException:
    """The 429 for a phone that acts faster than its limits allow."""
    seconds = retry_after_s(wait)
    return HTTPException(
        status.HTTP_429_TOO_MANY_REQUESTS,
        f"That was a lot in a short time. Try again in {seconds} seconds.",
        headers={"Retry-After": str(seconds)},
    )


async def limit_action(
    context: AppContext, kind: WallAction, visitor: Visitor, address: str, wall_id: str = ""
) -> None:
    """The one check of the phones' limits (``webapp.people.ratelimit``): count one
    ``kind`` of action on the wall; a 429 with Retry-After when it is one too many (a
    page says "Slow down" and how long to wait, the API the same in JSON)."""
    wait = await context.action_allowed(kind, visitor, address, wall_id)
    if wait is not None:
        raise too_fast(wait)


async def get_person(request: Request, context: ContextDep, address: ClientAddressDep) -> Person:
    return await person_of(request, context.db, context.settings, address, context.address_rules)


PersonDep = Annotated[Person, Depends(get_person)]


@dataclass(frozen=True)
class Phone:
    """A phone's page of a wall: the server, the wall and who asks."""

    context: ServerContext
    wall: Wall
    person: Person


async def get_phone(request: Request, wall_id: str) -> Phone:
    """What :data:`ContextDep`, :data:`WallDep` and :data:`PersonDep` give, as one
    dependency: the pages phones ask for most pay FastAPI's solving of each
    dependency once, not four times (a fifth of a quiz page's cost went to it)."""
    context: ServerContext = request.app.state.services
    wall = wall_of(context, wall_id)
    return Phone(context, wall, await get_person(request, context, address_of(request)))


PhoneDep = Annotated[Phone, Depends(get_phone)]


async def require_csrf(
    request: Request, x_csrf_token: Annotated[str | None, Header()] = None
) -> None:
    """State-changing requests of a session carry its CSRF token (form field or header).
    One dependency, the person found through the request: forms are what phones send."""
    context: ServerContext = request.app.state.services
    person = await get_person(request, context, address_of(request))
    await check_csrf(request, person, context, x_csrf_token)


async def check_csrf(
    request: Request, person: Person, context: ServerContext, given: str | None
) -> None:
    """403 unless ``given`` (else the form's ``csrf`` field) is the session's CSRF token."""
    if given is None and request.headers.get("content-type", "").startswith(
        ("application/x-www-form-urlencoded", "multipart/form-data")
    ):
        value = (await request.form()).get("csrf")
        given = value if isinstance(value, str) else None
    if not token_matches(csrf_token(context.secret, person.visitor.session_id), given):
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "This form has expired or did not come from this site. Reload the page and try again.",
        )


CsrfDep = Depends(require_csrf)


async def require_staff_page(request: Request, person: PersonDep) -> Person:
    """Instructor pages: anyone else is sent to sign in (and brought back after)."""
    if not person.is_staff:
        target = quote(request.url.path + (f"?{request.url.query}" if request.url.query else ""))
        raise HTTPException(
            status.HTTP_303_SEE_OTHER,
            "Sign in as an instructor to open this page.",
            headers={"Location": f"/login?next={target}"},
        )
    return person


StaffPageDep = Annotated[Person, Depends(require_staff_page)]


async def require_admin_page(person: StaffPageDep) -> Person:
    if not person.at_least("admin"):
        raise HTTPException(status.HTTP_403_FORBIDDEN, "This page is for administrators.")
    return person


AdminPageDep = Annotated[Person, Depends(require_admin_page)]


async def require_staff(request: Request, context: ContextDep, credentials: BearerDep) -> str:
    """API calls of instructors: the operator token as a bearer token (scripts), or an
    instructor's session with its CSRF token in ``X-CSRF-Token`` (the dashboard).

    Returns who acts, for the audit log and publications.
    """
    if credentials is not None:
        if token_matches(context.operator_token, credentials.credentials):
            return "operator"
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            "The bearer token is not the operator token.",
            headers={"WWW-Authenticate": "Bearer"},
        )
    person = await get_person(request, context, address_of(request))
    if not person.is_staff:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            "Sign in as an instructor, or send the operator token (Authorization: Bearer ...).",
            headers={"WWW-Authenticate": "Bearer"},
        )
    if request.method not in SAFE_METHODS:
        await check_csrf(request, person, context, request.headers.get("x-csrf-token"))
    return person.authority or person.role


StaffDep = Annotated[str, Depends(require_staff)]


async def require_tile_or_staff_for_detail(
    request: Request,
    wall: WallDep,
    context: ContextDep,
    token: Annotated[str | None, Query()] = None,
    detail: Annotated[str, Query()] = "refined",
) -> None:
    """Detailed renders cost a second of CPU: only the wall's tiles (their token) and
    instructors get them; the instant fallback is for everyone (the overview)."""
    if detail == "fallback" or token_matches(context.tile_token(wall.id), token):
        return
    person = await get_person(request, context, address_of(request))
    if not person.is_staff:
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "Only the wall's tiles (with their token) and instructors may ask for this.",
        )


DetailedRenderAccess = Depends(require_tile_or_staff_for_detail)
StaffOnly = Depends(require_staff)


DEPENDENCY_ERRORS: dict[Callable[..., Any], tuple[int, ...]] = {
    get_wall: (404,),
    get_phone: (404,),
    get_tile: (404,),
    require_tile_token: (403,),
    require_staff: (401, 403),
    require_tile_or_staff_for_detail: (403,),
}
"""The error statuses each dependency answers with: every API route that uses one lists
them in the OpenAPI document (see ``webapp.server.app``)."""
