"""What the image app's routes share: its store, the answer for an image that is not
there, and taking an upload (an image, a lesson file) within the limit."""

from __future__ import annotations

import uuid
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from fastapi import HTTPException, Request, status
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException as StarletteHTTPException

from webapp.apps.image.library import image_library
from webapp.apps.image.store import UPLOADING, ImageStore, NoLibvips
from webapp.core.threads import run_blocking
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep

FILE_FIELD = "file"
ENVELOPE_BYTES = 64 * 1024  # the multipart boundaries and part headers around the file
CHUNK_BYTES = 1 << 20
T = TypeVar("T")


def store_of(context: AppContext) -> ImageStore:
    return image_library(context).store(context.settings)


def no_image(image_id: str) -> HTTPException:
    return HTTPException(status.HTTP_404_NOT_FOUND, f"There is no image {image_id}.")


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


async def take_upload(
    request: Request, context: ContextDep, then: Callable[[ImageStore, Path, str, str | None], T]
) -> T:
    """Copy the multipart field ``file`` (``title`` optional) to a file of its own beside
    the store (libvips and zipfile read a path), never past the limit, run ``then`` on
    it in a worker thread, and remove the copy whatever happens: 400 for a malformed
    upload, 413 over the limit, 503 without libvips."""
    store = store_of(context)
    try:  # the form the CSRF check read, if it read one (files spool to disk)
        form = await request.form(max_files=1, max_fields=4)
    except StarletteHTTPException as error:  # malformed multipart, too many parts
        raise HTTPException(status.HTTP_400_BAD_REQUEST, "The upload was malformed.") from error
    upload = form.get(FILE_FIELD)
    if not isinstance(upload, UploadFile):
        raise HTTPException(status.HTTP_400_BAD_REQUEST, "No file was sent (field 'file').")
    title = form.get("title")
    name = Path(upload.filename or "upload").name

    def copied() -> T:
        store.root.mkdir(parents=True, exist_ok=True)
        copy = store.root / f"{UPLOADING}{uuid.uuid4().hex}"
        try:
            with copy.open("wb") as out:
                size = 0
                while chunk := upload.file.read(CHUNK_BYTES):
                    size += len(chunk)
                    if size > store.max_upload_bytes:
                        raise _TooLarge
                    out.write(chunk)
            return then(store, copy, name, title if isinstance(title, str) else None)
        finally:
            copy.unlink(missing_ok=True)

    try:
        return await run_blocking(copied)
    except _TooLarge:
        raise _too_large(store) from None
    except NoLibvips as error:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(error)) from None
    finally:
        await form.close()
