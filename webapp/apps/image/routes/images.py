"""The instructor's images: upload, list, retitle and remove them, and show one on a
wall."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, Depends, HTTPException, Request, status
from pydantic import BaseModel, ConfigDict, Field

from webapp.apps.image.library import ImageShown, remove_image
from webapp.apps.image.routes.common import no_image, store_of, take_upload, upload_within_limit
from webapp.apps.image.state import APP, ImageState
from webapp.apps.image.store import MAX_IMAGE_TITLE, ImageManifest, ImageRefused, ImageStore
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import WallState
from webapp.web.deps import ContextDep, StaffOnly, WallDep
from webapp.web.problems import errors

router = APIRouter(tags=["image"])


@router.post(
    "/api/apps/image/images",
    dependencies=[Depends(upload_within_limit), StaffOnly],
    status_code=status.HTTP_201_CREATED,
    responses={
        **errors(400, 503),
        411: {"description": "The upload did not declare its length."},
        413: {"description": "The file is larger than the upload limit."},
        422: {"description": "Not a whole PNG, JPEG or TIFF image within the pixel limit."},
    },
)
async def upload(request: Request, context: ContextDep) -> ImageManifest:
    """Store an image sent as the multipart field ``file`` (``title`` optional): 201
    with its manifest; 413 over the byte limit, 422 for what is not a whole PNG, JPEG
    or TIFF within the pixel limit. Nothing of a refused upload is kept."""

    def stored(store: ImageStore, copy: Path, name: str, title: str | None) -> ImageManifest:
        return store.add(copy, title, name)

    try:
        return await take_upload(request, context, stored)
    except ImageRefused as error:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(error)) from None


@router.get("/api/apps/image/images", dependencies=[StaffOnly])
async def list_images(context: ContextDep) -> list[ImageManifest]:
    """The stored images, newest first."""
    return await run_blocking(store_of(context).images)


class ImageTitle(BaseModel):
    model_config = ConfigDict(extra="forbid", str_strip_whitespace=True)

    title: str = Field(min_length=1, max_length=MAX_IMAGE_TITLE)


@router.patch("/api/apps/image/images/{image_id}", dependencies=[StaffOnly], responses=errors(404))
async def retitle(image_id: str, change: ImageTitle, context: ContextDep) -> ImageManifest:
    """Give the image another title (what the dashboard and its lesson file call it);
    422 for an empty one or one longer than an upload's."""
    try:
        return await run_blocking(store_of(context).retitle, image_id, change.title)
    except KeyError:
        raise no_image(image_id) from None


@router.delete(
    "/api/apps/image/images/{image_id}",
    dependencies=[StaffOnly],
    responses={**errors(404), 409: {"description": "A wall shows the image."}},
)
async def remove(image_id: str, context: ContextDep) -> list[ImageManifest]:
    """Remove the image with its pyramid and hotspots, all or nothing: 409 while a wall
    shows it. The images left, newest first."""
    store = store_of(context)
    try:
        await run_blocking(remove_image, store, context.db, context.walls.values(), image_id)
    except KeyError:
        raise no_image(image_id) from None
    except ImageShown as error:
        raise HTTPException(status.HTTP_409_CONFLICT, str(error)) from None
    return await run_blocking(store.images)


class ShowImage(BaseModel):
    model_config = ConfigDict(extra="forbid")

    image: str = Field(min_length=1, max_length=64)


@router.post(
    "/api/apps/image/walls/{wall_id}/show", dependencies=[StaffOnly], responses=errors(404)
)
async def show(wall: WallDep, choice: ShowImage, context: ContextDep) -> ShowImage:
    """Put the image app on the wall showing ``image``, at the whole stage; every tile
    changes at the same instant once each holds the image's coarse level."""
    try:
        await run_blocking(store_of(context).get, choice.image)
    except KeyError:
        raise no_image(choice.image) from None

    def showing(state: WallState) -> WallState:
        return ImageState(image=choice.image).put(state.model_copy(update={"app": APP}))

    await context.change_wall(wall, showing)
    return choice
