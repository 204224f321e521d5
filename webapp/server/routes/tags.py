"""The tags API: the registry and tag sets for the operator, layouts for tiles."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query, status
from fastapi.responses import JSONResponse

from tag_service.codes import PayloadError, normalize_code
from wall_client.layout import Rect, Viewport
from webapp.changes.door import unchanged
from webapp.core.caching import IMMUTABLE
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.database.models import TagRecord
from webapp.engine.wall_state import read_state
from webapp.server.deps import ServicesDep
from webapp.server.schemas import TagInfo, TagSetChoice, TagSetsInfo
from webapp.server.services import Services
from webapp.tags.registry import (
    TagSpec,
    anchor_of,
    find,
    issue,
    payload_of,
    tag_sets,
    update_tag,
    wall_tags,
)
from webapp.tags.schemas import LayoutInfo, TagUpdate
from webapp.web.deps import StaffOnly, WallDep
from webapp.web.problems import errors
from webapp.web.urls import code_image_path

router = APIRouter(prefix="/api", tags=["tags"])


def tag_info(tag: TagRecord, services: Services) -> TagInfo:
    """The tag as the API shows it: its stored columns plus what follows from them."""
    payload = payload_of(tag, services.base_url)
    stored = {name: getattr(tag, name) for name in TagInfo.model_fields if hasattr(tag, name)}
    return TagInfo(
        **stored,
        wall=tag.wall_id,
        payload=payload,
        anchor=anchor_of(tag),
        svg_url=code_image_path(tag.code, payload, "svg"),
        png_url=code_image_path(tag.code, payload, "png"),
    )


@router.get("/walls/{wall_id}/tags", dependencies=[StaffOnly])
async def list_tags(wall: WallDep, services: ServicesDep) -> list[TagInfo]:
    tags = await run_blocking(wall_tags, services.db, wall.id)
    return [tag_info(tag, services) for tag in tags]


@router.post("/walls/{wall_id}/tags", dependencies=[StaffOnly], status_code=201)
async def issue_tag(wall: WallDep, spec: TagSpec, services: ServicesDep) -> TagInfo:
    """Register a tag (any payload kind); when it belongs on the wall now, it is placed.

    Its app must be installed: a scan is handed to the tag's app, so a tag of no app
    could only ever answer "no longer in use". The registration app (``core``) counts:
    an extra student code on a poster by the door is one of its tags."""
    if spec.app not in services.apps:
        known = ", ".join(sorted(services.apps))
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"There is no app {spec.app!r} (installed: {known}); a scan of the tag is "
            "handed to its app.",
        )
    try:
        tag = await run_blocking(issue, services.db, wall.id, spec, "operator")
    except PayloadError as error:  # pragma: no cover - TagSpec validation catches these first
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(error)) from None
    await services.change_wall(wall, unchanged, replace_codes=True)
    return tag_info(tag, services)


async def _tag(code: str, services: Services) -> TagRecord:
    normalized = normalize_code(code)
    tag = await run_blocking(find, services.db, normalized) if normalized else None
    if tag is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no tag {code!r}.")
    return tag


@router.get("/tags/{code}", dependencies=[StaffOnly], responses=errors(404))
async def get_tag(code: str, services: ServicesDep) -> TagInfo:
    return tag_info(await _tag(code, services), services)


@router.patch("/tags/{code}", dependencies=[StaffOnly], responses=errors(404))
async def change_tag(code: str, update: TagUpdate, services: ServicesDep) -> TagInfo:
    """Relabel, switch off or set an expiry; the wall re-places when that changes it."""
    tag = await _tag(code, services)
    tag = await run_blocking(update_tag, services.db, tag.code, update)
    wall = services.walls.get(tag.wall_id)
    if wall is not None:
        await services.change_wall(wall, unchanged, replace_codes=True)
    else:
        services.codes.forget()  # a tag of a wall not served here: nothing to place
    return tag_info(tag, services)


@router.get("/walls/{wall_id}/tag-sets", dependencies=[StaffOnly])
async def list_tag_sets(wall: WallDep, services: ServicesDep) -> TagSetsInfo:
    sets = await run_blocking(tag_sets, services.db, wall.id)
    _, state = await run_blocking(read_state, services.db, wall.id)
    layout = await run_blocking(services.layout, wall.id, state.tag_layout)
    return TagSetsInfo(
        wall=wall.id,
        active=state.tag_set,
        sets=sets,
        layout=state.tag_layout,
        placed=len(layout.placed) if layout else 0,
        unplaced=layout.unplaced if layout else [],  # type: ignore[arg-type]
    )


@router.put("/walls/{wall_id}/tag-set", dependencies=[StaffOnly], responses=errors(404))
async def choose_tag_set(wall: WallDep, choice: TagSetChoice, services: ServicesDep) -> TagSetsInfo:
    """Switch the wall's codes to another set: placed, then shown by every tile at once."""
    sets = await run_blocking(tag_sets, services.db, wall.id)
    if choice.name is not None and choice.name not in sets:
        known = ", ".join(sets) or "none"
        raise HTTPException(
            status.HTTP_404_NOT_FOUND,
            f"Wall {wall.id!r} has no tag set {choice.name!r} (sets: {known}).",
        )
    await services.change_wall(
        wall, lambda state: state.model_copy(update={"tag_set": choice.name})
    )
    return await list_tag_sets(wall, services)


PIN_REACH_PX = 8
"""How far a pin's marks reach around its line, in a display's pixels: the head's
radius (6 px in ``static/js/codes.js``) with a margin for the line's width."""


def drawn_on(placed: dict[str, Any], viewport: Viewport) -> bool:
    """Whether a display draws any of a placed code: its symbol, its caption or its
    pin (line and head), which may cross into a neighbouring display."""
    rects = [placed["rect"], *([placed["caption"]] if placed.get("caption") else [])]
    if any(viewport.shows(Rect(*rect)) for rect in rects):
        return True
    leader = placed.get("leader")
    return leader is not None and viewport.shows_segment(leader[0], leader[1], PIN_REACH_PX)


@router.get("/walls/{wall_id}/layouts/{layout_id}")
async def get_wall_layout(
    wall: WallDep,
    layout_id: RowId,
    services: ServicesDep,
    display: Annotated[str | None, Query(max_length=64)] = None,
) -> JSONResponse:
    """A placement of codes, optionally just what one display draws of it (tiles
    fetch only theirs: :func:`drawn_on`).

    Public: the codes stand on the wall for anyone in the room to see. Layouts never
    change once made, so they are cached for good.
    """
    record = await run_blocking(services.layout, wall.id, layout_id)
    if record is None:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"Wall {wall.id!r} has no layout {layout_id}."
        )
    placed = record.placed
    if display is not None:
        try:
            viewport = wall.viewport(display)
        except KeyError as error:
            raise HTTPException(status.HTTP_404_NOT_FOUND, str(error.args[0])) from None
        placed = [p for p in placed if drawn_on(p, viewport)]
    info = LayoutInfo.model_validate(
        {
            "id": record.id,
            "wall": wall.id,
            "tag_set": record.tag_set,
            "placed": placed,
            "unplaced": record.unplaced,
        }
    )
    return JSONResponse(info.model_dump(mode="json"), headers={"Cache-Control": IMMUTABLE})
