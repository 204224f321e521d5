"""The image app's API: instructors upload, list and show images; tiles and the overview
fetch each image's manifest and the pyramid tiles their displays show."""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import IO

from fastapi import APIRouter, Depends, HTTPException, Request, status
from fastapi.responses import FileResponse
from pydantic import BaseModel, ConfigDict, Field
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException as StarletteHTTPException

from webapp.apps.image.library import image_library
from webapp.apps.image.state import APP, ImageState
from webapp.apps.image.store import (
    UPLOADING,
    ImageManifest,
    ImageRefused,
    ImageStore,
    NoLibvips,
)
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import WallState
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep, StaffOnly, WallDep
from webapp.web.problems import errors

router = APIRouter(tags=["image"])

FILE_FIELD = "file"
ENVELOPE_BYTES = 64 * 1024  # the multipart boundaries and part headers around the file
CHUNK_BYTES = 1 << 20
FOREVER = "public, max-age=31536000, immutable"  # a stored image never changes


def store_of(context: AppContext) -> ImageStore:
    return image_library(context).store(context.settings)


def _too_large(store: ImageStore) -> HTTPException:
    return HTTPException(
        status.HTTP_413_CONTENT_TOO_LARGE,
        f"The file is larger than {store.max_upload_bytes / 1e6:g} MB, the most taken.",
    )


async def upload_within_limit(request: Request, context: ContextDep) -> None:
    """An upload declares its length (browsers always do for a form), and one over the
    limit is refused before anything is read. This runs before the staff check, which
    may read the form for its CSRF token; the server reads no more than declared."""
    store = store_of(context)
    declared = request.headers.get("content-length", "")
    if not declared.isdigit():
        raise HTTPException(
            status.HTTP_411_LENGTH_REQUIRED, "Send the upload with its length (Content-Length)."
        )
    if int(declared) > store.max_upload_bytes + ENVELOPE_BYTES:
        raise _too_large(store)


class _TooLarge(Exception):
    pass


@router.post(
    "/api/image/images",
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
    store = store_of(context)
    try:  # the form the CSRF check read, if it read one (files spool to disk)
        form = await request.form(max_files=1, max_fields=4)
    except StarletteHTTPException as error:  # malformed multipart, too many parts
        raise HTTPException(status.HTTP_400_BAD_REQUEST, "The upload was malformed.") from error
    upload = form.get(FILE_FIELD)
    if not isinstance(upload, UploadFile):
        raise HTTPException(status.HTTP_400_BAD_REQUEST, "No file was sent (field 'file').")
    title = form.get("title")
    name = Path(upload.filename or "image").name
    try:
        return await run_blocking(
            _store_upload, store, upload.file, name, title if isinstance(title, str) else None
        )
    except ImageRefused as error:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(error)) from None
    except _TooLarge:
        raise _too_large(store) from None
    except NoLibvips as error:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(error)) from None
    finally:
        await form.close()


def _store_upload(
    store: ImageStore, file: IO[bytes], name: str, title: str | None
) -> ImageManifest:
    """Copy the upload to a file of its own beside the store (libvips reads a path),
    never past the limit, store it, and remove the copy whatever happens."""
    store.root.mkdir(parents=True, exist_ok=True)
    copy = store.root / f"{UPLOADING}{uuid.uuid4().hex}"
    try:
        with copy.open("wb") as out:
            size = 0
            while chunk := file.read(CHUNK_BYTES):
                size += len(chunk)
                if size > store.max_upload_bytes:
                    raise _TooLarge
                out.write(chunk)
        return store.add(copy, title, name)
    finally:
        copy.unlink(missing_ok=True)


@router.get("/api/image/images", dependencies=[StaffOnly])
async def list_images(context: ContextDep) -> list[ImageManifest]:
    """The stored images, newest first."""
    return await run_blocking(store_of(context).images)


class ShowImage(BaseModel):
    model_config = ConfigDict(extra="forbid")

    image: str = Field(min_length=1, max_length=64)


@router.post("/api/image/walls/{wall_id}/show", dependencies=[StaffOnly], responses=errors(404))
async def show(wall: WallDep, choice: ShowImage, context: ContextDep) -> ShowImage:
    """Put the image app on the wall showing ``image``, at the whole stage; every tile
    changes at the same instant once each holds the image's coarse level."""
    try:
        await run_blocking(store_of(context).get, choice.image)
    except KeyError:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"There is no image {choice.image}."
        ) from None

    def showing(state: WallState) -> WallState:
        return ImageState(image=choice.image).put(state.model_copy(update={"app": APP}))

    await context.change_wall(wall, showing)
    return choice


def _manifest(context: AppContext, image_id: str) -> ImageManifest:
    try:
        return store_of(context).get(image_id)
    except KeyError:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no image {image_id}.") from None


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
