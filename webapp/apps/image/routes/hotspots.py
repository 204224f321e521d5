"""An image's hotspots as instructors mark them: list, add, edit and delete; the walls
showing the image place their codes again."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from fastapi import APIRouter, HTTPException, status

from webapp.apps.image import hotspots
from webapp.apps.image.hotspots import Hotspot, HotspotFields, HotspotRefused
from webapp.apps.image.questions import asked, round_on_wall, start_round
from webapp.apps.image.routes.common import store_of
from webapp.apps.image.state import APP, shows_round, walls_showing
from webapp.classes.roll import running_class
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import read_state
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep, StaffOnly
from webapp.web.problems import errors

router = APIRouter(tags=["image"])

T = TypeVar("T")


async def _hotspot_step(step: Callable[..., T], *args: object) -> T:
    """Run a change of an image's hotspots in a worker thread: 404 for an image or
    hotspot that is not there, 422 with the reason for a refused one."""
    try:
        return await run_blocking(step, *args)
    except KeyError as missing:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no {missing.args[0]}.") from None
    except HotspotRefused as error:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(error)) from None


async def _replace_codes(context: AppContext, image_id: str) -> None:
    """The walls showing ``image_id`` place their codes again (a hotspot came, moved or
    went); the others have nothing of it up. A wall whose class is running with no round
    of the image's questions open starts one, as Start class would have had the image
    asked them then (the instructor added the first question during the class)."""
    walls = context.walls.values()
    for wall in await context.db.read(walls_showing, context.db, walls, image_id):
        if await run_blocking(_round_wanted, context, wall.id, image_id):
            started = await run_blocking(
                start_round, context, store_of(context), wall.id, image_id, f"app:{APP}"
            )
            await context.change_wall(wall, shows_round(started.number))
        else:
            await context.change_wall(wall, lambda current: current, replace_codes=True)


def _round_wanted(context: AppContext, wall_id: str, image_id: str) -> bool:
    """Whether the wall's running class waits for a round of the image's questions."""
    if running_class(context.db, wall_id) is None:
        return False
    if not asked(hotspots.hotspots(store_of(context), image_id)):
        return False
    _, state = read_state(context.db, wall_id)
    shown = round_on_wall(context, wall_id, state)
    return shown is None or not shown.open


@router.get(
    "/api/apps/image/images/{image_id}/hotspots", dependencies=[StaffOnly], responses=errors(404)
)
async def list_hotspots(image_id: str, context: ContextDep) -> list[Hotspot]:
    """An image's hotspots, in the order they were added."""
    return await _hotspot_step(hotspots.hotspots, store_of(context), image_id)


@router.post(
    "/api/apps/image/images/{image_id}/hotspots",
    dependencies=[StaffOnly],
    status_code=status.HTTP_201_CREATED,
    responses={
        **errors(404),
        422: {"description": "A place outside the image, a question without an answer."},
    },
)
async def add_hotspot(image_id: str, fields: HotspotFields, context: ContextDep) -> Hotspot:
    """Mark a place of the image (in its full-size pixels): 422 for a place outside the
    image or a question without an accepted answer, nothing stored."""
    added = await _hotspot_step(hotspots.add, store_of(context), image_id, fields)
    await _replace_codes(context, image_id)
    return added


@router.put(
    "/api/apps/image/images/{image_id}/hotspots/{hotspot_id}",
    dependencies=[StaffOnly],
    responses={**errors(404), 422: {"description": "As adding: refused, nothing changed."}},
)
async def edit_hotspot(
    image_id: str, hotspot_id: str, fields: HotspotFields, context: ContextDep
) -> Hotspot:
    """Replace a hotspot's fields (its id, and so its codes, stay)."""
    edited = await _hotspot_step(hotspots.edit, store_of(context), image_id, hotspot_id, fields)
    await _replace_codes(context, image_id)
    return edited


@router.delete(
    "/api/apps/image/images/{image_id}/hotspots/{hotspot_id}",
    dependencies=[StaffOnly],
    responses=errors(404),
)
async def delete_hotspot(image_id: str, hotspot_id: str, context: ContextDep) -> list[Hotspot]:
    """Remove a hotspot (its code leaves the wall); the image's hotspots left."""
    left = await _hotspot_step(hotspots.delete, store_of(context), image_id, hotspot_id)
    await _replace_codes(context, image_id)
    return left
