"""The public screen: phones publish to it; instructors moderate, clear and lock it."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Form, HTTPException, Request, status
from fastapi.responses import HTMLResponse

from tag_service.codes import normalize_code
from webapp.apps.hooks import Scan
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.wall_state import PublicPolicy, read_state
from webapp.publishing.screen import PublishRefused, clear, decide, set_policy, submit, waiting
from webapp.server.deps import ServicesDep
from webapp.server.schemas import PublicationInfo, PublicScreenInfo
from webapp.tags.registry import find, is_live
from webapp.web.deps import (
    ClientAddressDep,
    CsrfDep,
    PersonDep,
    StaffDep,
    StaffOnly,
    WallDep,
    limit_action,
)
from webapp.web.problems import errors
from webapp.web.templating import render

router = APIRouter()


@router.post("/publish", include_in_schema=False, dependencies=[CsrfDep])
async def publish(
    request: Request,
    person: PersonDep,
    services: ServicesDep,
    address: ClientAddressDep,
    code: Annotated[str, Form(max_length=32)],
    subject: Annotated[str | None, Form(max_length=64)] = None,
) -> HTMLResponse:
    """The Publish button of a phone page: the page's content goes to the public screen."""
    normalized = normalize_code(code)
    tag = await run_blocking(find, services.db, normalized) if normalized else None
    wall = services.walls.get(tag.wall_id) if tag else None
    app = services.apps.get(tag.app) if tag else None
    if tag is None or wall is None or app is None or not is_live(tag):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "There is nothing to publish for that code.")
    await limit_action(services, "publish", person.visitor, address, wall.id)
    scan = Scan(request, services, wall, tag, person.visitor, address, subject or None)
    publication = await app.publication(scan)
    if publication is None:
        raise HTTPException(status.HTTP_400_BAD_REQUEST, "This page has nothing to publish.")
    _, state = await run_blocking(read_state, services.db, wall.id)
    try:
        record = await submit(
            services,
            wall,
            state,
            request.app.state.templates.env,
            person,
            publication,
            source=f"{tag.app}:{tag.code}",
        )
    except PublishRefused as refused:
        return render(
            request,
            "published.html",
            status.HTTP_403_FORBIDDEN,
            wall=wall,
            outcome="locked",
            detail=str(refused),
        )
    return render(request, "published.html", wall=wall, outcome=record.status)


@router.get("/api/walls/{wall_id}/public", tags=["public"], dependencies=[StaffOnly])
async def public_screen(wall: WallDep, services: ServicesDep) -> PublicScreenInfo:
    _, state = await run_blocking(read_state, services.db, wall.id)
    queue = await run_blocking(waiting, services.db, wall.id)
    return PublicScreenInfo(
        shown=state.public,
        policy=state.public_policy,
        waiting=[PublicationInfo.of(record) for record in queue],
    )


@router.post(
    "/api/walls/{wall_id}/public/{publication_id}/{decision}",
    tags=["public"],
    responses=errors(404),
)
async def moderate(
    wall: WallDep, publication_id: RowId, decision: str, services: ServicesDep, actor: StaffDep
) -> PublicationInfo:
    """``approve`` (show it now) or ``reject`` a waiting publication."""
    if decision not in ("approve", "reject"):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "Decide with approve or reject.")
    try:
        record = await decide(services, wall, publication_id, decision == "approve", actor)
    except KeyError:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, "No publication with that id is waiting."
        ) from None
    return PublicationInfo.of(record)


@router.post("/api/walls/{wall_id}/public/clear", tags=["public"], dependencies=[StaffOnly])
async def clear_screen(wall: WallDep, services: ServicesDep) -> dict[str, bool]:
    await clear(services, wall)
    return {"cleared": True}


@router.put("/api/walls/{wall_id}/public/policy", tags=["public"], dependencies=[StaffOnly])
async def change_policy(wall: WallDep, policy: PublicPolicy, services: ServicesDep) -> PublicPolicy:
    await set_policy(services, wall, policy)
    return policy
