"""An instructor's own codes: a link, a text, a contact or a phone number at a point of
the wall or at a place of the material it shows (a hotspot of the image), added from the
dashboard's codes box, listed there and switched off there; and the places on offer."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, status
from pydantic import ValidationError

from wall_client.layout import Wall
from webapp.apps.installed import places_shown
from webapp.changes.door import unchanged
from webapp.core.threads import run_blocking
from webapp.database.models import TagRecord
from webapp.engine.wall_state import read_state
from webapp.server.deps import ServicesDep
from webapp.server.routes.tags import tag_info
from webapp.server.schemas import OWN_APP, OwnCode, OwnCodeInfo, PlaceChoice
from webapp.server.services import Services
from webapp.tags.registry import Place, issue, wall_tags
from webapp.web.deps import StaffDep, WallDep

router = APIRouter(prefix="/api", tags=["tags"])

OWN_ACTIONS = ("link", "note")


def _places_now(services: Services, wall: Wall) -> list[Place]:
    """The places the wall shows in its state now."""
    _, state = read_state(services.db, wall.id)
    return places_shown(services.apps, services, wall, state)


def _on_wall_now(services: Services, wall: Wall) -> set[str]:
    """The codes the wall's layout in use places."""
    _, state = read_state(services.db, wall.id)
    layout = services.layout(wall.id, state.tag_layout)
    return {placed["code"] for placed in layout.placed} if layout is not None else set()


def _listed(tag: TagRecord, services: Services, on_wall: set[str]) -> OwnCodeInfo:
    return OwnCodeInfo(**tag_info(tag, services).model_dump(), on_wall=tag.code in on_wall)


@router.get("/walls/{wall_id}/places")
async def list_places(wall: WallDep, services: ServicesDep, staff: StaffDep) -> list[Place]:
    """The places of the material the wall shows now (the image's hotspots in view),
    where a code of one's own may stand; none while the app on the wall has none."""
    return await run_blocking(_places_now, services, wall)


@router.get("/walls/{wall_id}/own-codes")
async def list_own_codes(
    wall: WallDep, services: ServicesDep, staff: StaffDep
) -> list[OwnCodeInfo]:
    """The instructors' own codes of the wall, newest first, those switched off too, each
    saying whether the wall shows it now."""
    tags = await run_blocking(wall_tags, services.db, wall.id)
    shown = await run_blocking(_on_wall_now, services, wall)
    own = [t for t in tags if t.app == OWN_APP and t.action in OWN_ACTIONS]
    return [
        _listed(t, services, shown) for t in sorted(own, key=lambda t: t.created_at, reverse=True)
    ]


def _place(places: list[Place], choice: PlaceChoice) -> Place:
    """The place ``choice`` names among those the wall shows now (422: not among them)."""
    for place in places:
        if (place.app, place.id) == (choice.app, choice.id):
            return place
    raise HTTPException(
        status.HTTP_422_UNPROCESSABLE_CONTENT,
        f"The place {choice.app} {choice.id} is not on the wall now.",
    )


@router.post("/walls/{wall_id}/own-codes", status_code=201)
async def add_own_code(
    code: OwnCode, wall: WallDep, services: ServicesDep, staff: StaffDep
) -> OwnCodeInfo:
    """Put a code of one's own on the wall, at ``anchor`` or at ``place`` (in every tag
    set: it stands whatever app is up, one at a place while its place is shown); placed
    at once, beside the point when the point has no room or is a place."""
    place = None
    if code.place is not None:
        place = _place(await run_blocking(_places_now, services, wall), code.place)
    elif code.anchor is not None:
        x, y = code.anchor
        if not (0 <= x <= wall.width and 0 <= y <= wall.height):
            raise HTTPException(
                status.HTTP_422_UNPROCESSABLE_CONTENT,
                f"({x:.0f}, {y:.0f}) mm is off the wall ({wall.width:.0f} x {wall.height:.0f} mm).",
            )
    try:
        spec = code.spec(place)
    except (ValueError, ValidationError) as error:
        reason = error.errors()[0]["msg"] if isinstance(error, ValidationError) else str(error)
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, reason) from None
    tag = await run_blocking(issue, services.db, wall.id, spec, staff)
    await services.change_wall(wall, unchanged, replace_codes=True)
    return _listed(tag, services, await run_blocking(_on_wall_now, services, wall))
