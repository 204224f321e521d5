"""Staff sign-in through the campus's OpenID providers: a provider's button, and its
answer, which signs the browser in as a password sign-in does (``login:NAME``)."""

from __future__ import annotations

import logging
from typing import Annotated

from fastapi import APIRouter, Query, Request, status
from fastapi.responses import RedirectResponse, Response

from webapp.campus.oidc import SignedIn, SignInFailed
from webapp.core.oidc import OIDCProvider, claim_of
from webapp.core.threads import run_blocking
from webapp.people.accounts import campus_account, forget_campus_account
from webapp.people.audit import audit
from webapp.people.person import grant, remember_person
from webapp.people.signin import Attempt
from webapp.server.deps import ServicesDep
from webapp.server.routes.people import safe_next, too_many
from webapp.server.services import Services
from webapp.web.deps import ClientAddressDep, PersonDep
from webapp.web.templating import render

log = logging.getLogger(__name__)
router = APIRouter(include_in_schema=False)


def _failed(request: Request, key: str, failed: SignInFailed, address: str) -> Response:
    log.warning("campus sign-in %r from %s refused: %s", key, address, failed.reason)
    return render(request, "oidc_failed.html", failed.status, detail=failed.detail)


def _audit_failure(services: Services, actor: str, address: str, reason: str) -> None:
    with services.db.session() as session:
        audit(session, "login_failed", actor=actor, address=address, reason=reason[:300])


@router.get("/login/oidc/{provider}")
async def begin_sign_in(
    request: Request,
    provider: str,
    services: ServicesDep,
    address: ClientAddressDep,
    next: Annotated[str | None, Query()] = None,
) -> Response:
    """A provider's button: the browser goes to the provider to sign in."""
    try:
        return await services.campus.begin(request, provider, safe_next(next))
    except SignInFailed as failed:
        return _failed(request, provider, failed, address)


@router.get("/login/oidc/{provider}/callback")
async def finish_sign_in(
    request: Request,
    provider: str,
    person: PersonDep,
    services: ServicesDep,
    address: ClientAddressDep,
) -> Response:
    """The provider's answer: the person signs in with the role its claims give, or
    is told why not; nothing is made for an answer that is refused."""
    campus = services.campus
    try:
        chosen = await campus.check_answer(request, provider)
    except SignInFailed as failed:
        return _failed(request, provider, failed, address)
    attempt = await services.login_throttle.reserve_client(address)
    if not isinstance(attempt, Attempt):
        return too_many(request, "error.html", attempt)
    actor = f"oidc:{provider}"
    try:
        signed = await campus.finish(request, chosen)
    except SignInFailed as failed:
        await run_blocking(_audit_failure, services, actor, address, failed.reason)
        return _failed(request, provider, failed, address)
    await services.login_throttle.succeeded(attempt)
    config = chosen.config
    outcome = config.outcome(signed.claims)
    identity = signed.identity
    if outcome.role is None:
        await run_blocking(
            forget_campus_account, services.db, identity.issuer, identity.subject, actor
        )
        reason = f"{signed.who} ({identity.subject}): the rules give no role"
        await run_blocking(_audit_failure, services, actor, address, reason)
        log.warning("campus sign-in %r from %s refused: %s", provider, address, reason)
        return _refused(request, config, signed)
    account = await run_blocking(campus_account, services.db, identity, outcome.role, actor)
    signed_in = await run_blocking(
        grant,
        services.db,
        person,
        outcome.role,
        f"login:{account.username}",
        services.settings,
        address,
        outcome.user_group,
    )
    remember_person(request, signed_in)
    return RedirectResponse(safe_next(signed.next), status.HTTP_303_SEE_OTHER)


def _refused(request: Request, config: OIDCProvider, signed: SignedIn) -> Response:
    """Why the provider's word is not enough: the rules that make instructors (not those
    naming who the admins are), and what this person's claims say of what rules read."""
    return render(
        request,
        "oidc_failed.html",
        status.HTTP_403_FORBIDDEN,
        detail=(
            f"{config.name} knows you as {signed.who}, but that gives you no role in "
            "tagwall, so you were not signed in and nothing was kept."
        ),
        provider=config.name,
        rules=[rule.describe() for rule in config.rules if rule.role == "instructor"],
        claims={claim: _shown(claim_of(signed.claims, claim)) for claim in config.claims_read},
    )


def _shown(value: object) -> str | None:
    """A claim's value as the page says it (None: the provider did not send it)."""
    if value is None:
        return None
    if isinstance(value, list):
        return ", ".join(str(item) for item in value) or "(an empty list)"
    return str(value)
