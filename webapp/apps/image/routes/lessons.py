"""Lessons to share: an image with its hotspots exported as one file, and such a file
imported as a new image."""

from __future__ import annotations

import uuid
from pathlib import Path

from fastapi import APIRouter, Depends, HTTPException, Request, status
from fastapi.responses import FileResponse
from starlette.background import BackgroundTask

from webapp.apps.image import lesson
from webapp.apps.image.routes.common import no_image, store_of, take_upload, upload_within_limit
from webapp.apps.image.store import UPLOADING, ImageManifest, ImageStore, NoLibvips
from webapp.core.threads import run_blocking
from webapp.web.deps import ContextDep, StaffOnly
from webapp.web.downloads import attachment
from webapp.web.problems import errors

router = APIRouter(tags=["image"])


@router.post(
    "/api/apps/image/lessons",
    dependencies=[Depends(upload_within_limit), StaffOnly],
    status_code=status.HTTP_201_CREATED,
    responses={
        **errors(400, 503),
        411: {"description": "The upload did not declare its length."},
        413: {"description": "The file is larger than the upload limit."},
        422: {"description": "Not a lesson file: every problem, one line each."},
    },
)
async def import_lesson(request: Request, context: ContextDep) -> ImageManifest:
    """Store a lesson file sent as the multipart field ``file`` as a new image with its
    hotspots: 201 with the image's manifest; 422 with every problem, one line each
    (``detail``), and nothing stored."""

    def imported(store: ImageStore, copy: Path, name: str, title: str | None) -> ImageManifest:
        return lesson.import_lesson(store, copy, name)[0]

    try:
        return await take_upload(request, context, imported)
    except lesson.LessonRefused as error:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(error)) from None


@router.get(
    "/api/apps/image/images/{image_id}/lesson",
    dependencies=[StaffOnly],
    response_class=FileResponse,
    responses={**errors(404, 503), 200: {"content": {"application/zip": {}}}},
)
async def export_lesson(image_id: str, context: ContextDep) -> FileResponse:
    """The image's lesson file (the image, its hotspots, texts and questions), named
    after its title, to import on another installation."""
    store = store_of(context)
    store.root.mkdir(parents=True, exist_ok=True)
    target = store.root / f"{UPLOADING}{uuid.uuid4().hex}"  # swept if a kill leaves it
    try:
        exported = await run_blocking(lesson.export, store, image_id, target)
    except KeyError:
        raise no_image(image_id) from None
    except NoLibvips as error:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(error)) from None
    return FileResponse(
        target,
        media_type="application/zip",
        headers={"Content-Disposition": attachment([exported.title], lesson.SUFFIX)},
        background=BackgroundTask(target.unlink, missing_ok=True),
    )
