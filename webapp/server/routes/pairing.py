"""Pairing a phone: the dashboard shows a code, the phone scans it and confirms."""

from __future__ import annotations

import base64
from datetime import datetime

from fastapi import APIRouter, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from pydantic import BaseModel

from tag_service.codes import make_symbol, render_svg, url_payload
from webapp.core.threads import run_blocking
from webapp.people.pairing import PairingError, check_pairing, redeem, start_pairing
from webapp.people.person import grant, remember_person
from webapp.server.deps import ServicesDep
from webapp.web.deps import ClientAddressDep, CsrfDep, PersonDep, StaffDep
from webapp.web.templating import render

router = APIRouter()


class PairingCode(BaseModel):
    url: str
    image: str  # an SVG data URI (never cached, never on disk)
    expires_at: datetime


def _granter(actor: str) -> str:
    """``login:alice`` -> ``alice``; the operator stays ``operator``."""
    return actor.split(":", 1)[1] if actor.startswith(("login:", "pairing:")) else actor


@router.post("/api/pairing", tags=["people"])
async def new_pairing_code(services: ServicesDep, actor: StaffDep) -> PairingCode:
    token, expires_at = await run_blocking(
        start_pairing, services.db, _granter(actor), services.settings.pairing_ttl_s
    )
    url = url_payload(services.base_url, token, route="P")
    svg = render_svg(make_symbol(url))
    image = "data:image/svg+xml;base64," + base64.b64encode(svg).decode()
    return PairingCode(url=url, image=image, expires_at=expires_at)


def _problem(request: Request, error: PairingError) -> HTMLResponse:
    return render(
        request,
        "scan_problem.html",
        status_code=error.status,
        title="Pairing did not work",
        detail=str(error),
        wall_id=None,
    )


@router.get("/p/{token}", include_in_schema=False)
@router.get("/P/{token}", include_in_schema=False)
async def pairing_page(
    token: str, request: Request, person: PersonDep, services: ServicesDep
) -> Response:
    """The scanned pairing code: a confirm button (a link preview must not use it up)."""
    try:
        granted_by = await run_blocking(check_pairing, services.db, token)
    except PairingError as error:
        return _problem(request, error)
    return render(request, "pair.html", token=token.upper(), granted_by=granted_by)


@router.post("/p/{token}", include_in_schema=False, dependencies=[CsrfDep])
async def pair(
    token: str,
    request: Request,
    person: PersonDep,
    services: ServicesDep,
    address: ClientAddressDep,
) -> Response:
    try:
        granted_by = await run_blocking(redeem, services.db, token, person.visitor.id)
    except PairingError as error:
        return _problem(request, error)
    paired = await run_blocking(
        grant,
        services.db,
        person,
        "instructor",
        f"pairing:{granted_by}",
        services.settings,
        address,
    )
    remember_person(request, paired)
    return RedirectResponse("/me", status.HTTP_303_SEE_OTHER)
