"""Signing in and out, the operator's sign-in link, and a visitor's own profile."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Form, Query, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from webapp.core.roles import USER_GROUPS
from webapp.core.threads import run_blocking, run_blocking_within
from webapp.people.accounts import authenticate, campus_issuer
from webapp.people.audit import audit
from webapp.people.person import (
    GROUP_LABELS,
    Person,
    grant,
    plain_text,
    remember_person,
    sign_out,
    update_profile,
)
from webapp.people.ratelimit import retry_after_s
from webapp.people.security import token_matches
from webapp.people.signin import DEVICE_COOKIE, Attempt, device_cookie, device_of
from webapp.publishing.screen import OUTCOMES, own
from webapp.server.deps import ServicesDep
from webapp.server.services import Services
from webapp.web.deps import ClientAddressDep, CsrfDep, PersonDep
from webapp.web.templating import render

router = APIRouter(include_in_schema=False)


def safe_next(target: str | None, default: str = "/dashboard") -> str:
    """Only a path on this site: never an open redirect to somewhere else."""
    if target and target.startswith("/") and not target.startswith("//") and "\\" not in target:
        return target
    return default


def _login_page(
    request: Request,
    services: Services,
    target: str,
    error: str | None = None,
    status_code: int = status.HTTP_200_OK,
) -> HTMLResponse:
    """The sign-in page: a button per campus provider, and the password form unless
    it is switched off (``TAGWALL_PASSWORD_SIGN_IN``)."""
    return render(
        request,
        "login.html",
        status_code,
        next=target,
        error=error,
        campus=services.campus.buttons(),
        password_sign_in=services.settings.password_sign_in,
    )


@router.get("/login")
async def login_page(
    request: Request,
    person: PersonDep,
    services: ServicesDep,
    next: Annotated[str | None, Query()] = None,
) -> HTMLResponse:
    return _login_page(request, services, safe_next(next))


def too_many(request: Request, template: str, wait: float, **context: object) -> Response:
    """The 429 page of a client that failed to sign in too often, with ``Retry-After``."""
    seconds = retry_after_s(wait)
    response = render(
        request,
        template,
        status.HTTP_429_TOO_MANY_REQUESTS,
        status=429,
        detail=f"Too many failed sign-ins. Try again in {seconds} seconds.",
        error=f"Too many failed sign-ins. Try again in {seconds} seconds.",
        **context,
    )
    response.headers["Retry-After"] = str(seconds)
    return response


def _audit_failure(services: Services, username: str, address: str) -> None:
    with services.db.session() as session:
        audit(session, "login_failed", actor=plain_text(username)[:64], address=address)


@router.post("/login", dependencies=[CsrfDep])
async def login(
    request: Request,
    person: PersonDep,
    services: ServicesDep,
    address: ClientAddressDep,
    username: Annotated[str, Form(max_length=200)],
    password: Annotated[str, Form(max_length=1_000)],
    next: Annotated[str | None, Form()] = None,
) -> Response:
    target = safe_next(next)
    if not services.settings.password_sign_in:
        return _login_page(
            request,
            services,
            target,
            "Password sign-in is switched off here: sign in with your campus account.",
            status.HTTP_403_FORBIDDEN,
        )
    name = username.strip().lower()
    device = device_of(services.secret, request.cookies.get(DEVICE_COOKIE), name)
    attempt = await services.login_throttle.reserve(name, address, device)
    if not isinstance(attempt, Attempt):
        return too_many(
            request,
            "login.html",
            attempt,
            next=target,
            campus=services.campus.buttons(),
            password_sign_in=True,
        )
    account = await run_blocking_within(
        services.password_checks, authenticate, services.db, username, password
    )
    if account is None:
        await run_blocking(_audit_failure, services, username, address)
        return _login_page(
            request,
            services,
            target,
            "Wrong username or password.",
            status.HTTP_401_UNAUTHORIZED,
        )
    await services.login_throttle.succeeded(attempt)
    signed_in = await run_blocking(
        grant,
        services.db,
        person,
        account.role,  # type: ignore[arg-type]  # validated when the account was made
        f"login:{account.username}",
        services.settings,
        address,
    )
    remember_person(request, signed_in)
    response = RedirectResponse(target, status.HTTP_303_SEE_OTHER)
    response.headers.append("set-cookie", device_cookie(services.secret, account.username))
    return response


@router.get("/login/operator")
async def operator_sign_in(
    request: Request,
    person: PersonDep,
    services: ServicesDep,
    address: ClientAddressDep,
    token: Annotated[str | None, Query()] = None,
) -> Response:
    """The link `tagwall urls` prints: signs this browser in as administrator, so a new
    installation can reach the dashboard and make the first accounts."""
    attempt = await services.login_throttle.reserve("operator", address, None)
    if not isinstance(attempt, Attempt):
        return too_many(request, "error.html", attempt)
    if not token_matches(services.operator_token, token):
        await run_blocking(_audit_failure, services, "operator", address)
        return render(
            request,
            "error.html",
            status.HTTP_403_FORBIDDEN,
            status=403,
            detail="This operator link is wrong or out of date; `tagwall urls` prints it.",
        )
    await services.login_throttle.succeeded(attempt)
    signed_in = await run_blocking(
        grant, services.db, person, "admin", "operator", services.settings, address
    )
    remember_person(request, signed_in)
    return RedirectResponse("/dashboard", status.HTTP_303_SEE_OTHER)


@router.post("/logout", dependencies=[CsrfDep])
async def logout(
    request: Request, person: PersonDep, services: ServicesDep, address: ClientAddressDep
) -> Response:
    """Sign out of tagwall; a campus account is offered its provider's sign-out too
    (a shared computer stays signed in there otherwise)."""
    authority = person.authority or ""
    issuer = None
    if services.campus.providers and authority.startswith("login:"):
        issuer = await run_blocking(campus_issuer, services.db, authority.removeprefix("login:"))
    signed_out = await run_blocking(sign_out, services.db, person, services.settings, address)
    remember_person(request, signed_out)
    offer = services.campus.end_session(issuer) if issuer else None
    if offer is None:
        return RedirectResponse("/", status.HTTP_303_SEE_OTHER)
    provider, url = offer
    return render(request, "signed_out.html", provider=provider, end_session=url)


async def _profile(
    request: Request, person: Person, services: Services, *, saved: bool
) -> HTMLResponse:
    """The profile page, with what became of the visitor's latest publications (a
    student learns there that the instructor declined one)."""
    published = await run_blocking(own, services.db, person.visitor.id)
    return render(
        request, "me.html", groups=GROUP_LABELS, saved=saved, published=published, outcomes=OUTCOMES
    )


@router.get("/me")
async def profile_page(request: Request, person: PersonDep, services: ServicesDep) -> HTMLResponse:
    return await _profile(request, person, services, saved=False)


@router.post("/me", dependencies=[CsrfDep])
async def change_profile(
    request: Request,
    person: PersonDep,
    services: ServicesDep,
    user_group: Annotated[str, Form()],
    info_class: Annotated[int, Form(ge=1, le=5)],
    display_name: Annotated[str, Form(max_length=1_000)] = "",  # made plain and short
) -> HTMLResponse:
    if user_group not in USER_GROUPS:
        return render(
            request,
            "error.html",
            status.HTTP_400_BAD_REQUEST,
            status=400,
            detail=f"{user_group!r} is not a user group.",
        )
    changed = await run_blocking(
        lambda: update_profile(
            services.db,
            person,
            services.settings,
            user_group=user_group,
            info_class=info_class,
            display_name=display_name,
        )
    )
    remember_person(request, changed)
    return await _profile(request, changed, services, saved=True)
