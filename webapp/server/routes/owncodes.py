"""An instructor's own codes: a link, a text, a contact or a phone number at a point of
the wall, added from the dashboard's codes box, listed there and switched off there."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, status
from pydantic import ValidationError

from webapp.core.threads import run_blocking
from webapp.door.changes import unchanged
from webapp.server.deps import ServicesDep
from webapp.server.routes.tags import tag_info
from webapp.server.schemas import OWN_APP, OwnCode, TagInfo
from webapp.tags.registry import issue, wall_tags
from webapp.web.deps import StaffDep, WallDep

router = APIRouter(prefix="/api", tags=["tags"])

OWN_ACTIONS = ("link", "note")


@router.get("/walls/{wall_id}/own-codes")
async def list_own_codes(wall: WallDep, services: ServicesDep, staff: StaffDep) -> list[TagInfo]:
    """The instructors' own codes of the wall, newest first, those switched off too."""
    tags = await run_blocking(wall_tags, services.db, wall.id)
    own = [t for t in tags if t.app == OWN_APP and t.action in OWN_ACTIONS]
    return [tag_info(t, services) for t in sorted(own, key=lambda t: t.created_at, reverse=True)]


@router.post("/walls/{wall_id}/own-codes", status_code=201)
async def add_own_code(
    code: OwnCode, wall: WallDep, services: ServicesDep, staff: StaffDep
) -> TagInfo:
    """Put a code of one's own on the wall, at ``anchor`` (in every tag set: it stands
    whatever app is up); placed at once, beside the point when the point has no room."""
    x, y = code.anchor
    if not (0 <= x <= wall.width and 0 <= y <= wall.height):
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"({x:.0f}, {y:.0f}) mm is off the wall ({wall.width:.0f} x {wall.height:.0f} mm).",
        )
    try:
        spec = code.spec()
    except (ValueError, ValidationError) as error:
        reason = error.errors()[0]["msg"] if isinstance(error, ValidationError) else str(error)
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, reason) from None
    tag = await run_blocking(issue, services.db, wall.id, spec, staff)
    await services.change_wall(wall, unchanged, replace_codes=True)
    return tag_info(tag, services)
