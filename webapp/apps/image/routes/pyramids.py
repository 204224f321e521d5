"""What tiles and the overview fetch of an image: its manifest and the pyramid tiles
their displays show."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, status
from fastapi.responses import FileResponse

from webapp.apps.image.routes.common import no_image, store_of
from webapp.apps.image.store import ImageManifest
from webapp.core.threads import run_blocking
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep
from webapp.web.problems import errors

router = APIRouter(tags=["image"])

FOREVER = "public, max-age=31536000, immutable"  # a stored image never changes


def _manifest(context: AppContext, image_id: str) -> ImageManifest:
    try:
        return store_of(context).get(image_id)
    except KeyError:
        raise no_image(image_id) from None


@router.get("/apps/image/images/{image_id}/info.json", responses=errors(404))
async def manifest(image_id: str, context: ContextDep) -> ImageManifest:
    """What tiles need to lay the image out: its size, tile size and levels."""
    return await run_blocking(_manifest, context, image_id)


@router.get(
    "/apps/image/images/{image_id}/{level}/{col}_{row}.jpg",
    response_class=FileResponse,
    responses=errors(404),
)
async def pyramid_tile(
    image_id: str, level: str, col: str, row: str, context: ContextDep
) -> FileResponse:
    """One tile of the image's pyramid (Deep Zoom level, column, row), cached for good;
    404 for anything else (numbers are parsed here: a word is no tile, not a 422)."""
    try:
        if not (level.isdigit() and col.isdigit() and row.isdigit()):
            raise KeyError(level, col, row)
        path = await run_blocking(store_of(context).tile, image_id, int(level), int(col), int(row))
    except KeyError:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "There is no such image tile.") from None
    return FileResponse(path, media_type="image/jpeg", headers={"Cache-Control": FOREVER})
