"""The photo fallback for phones whose camera app does not read QR codes.

``GET /scan`` shows a form that opens the phone's camera; ``POST /scan`` decodes the
photo and sends the phone on to the code's page (``/t/CODE``) when it is clear which
code the photo was aimed at: the one nearest the photo's centre, standing in its middle
and clearly nearer than any other. Otherwise it asks, naming what each code found
marks (its label, the display it stands on), nearest the centre first. What a code
that is not one of this wall's holds is shown, its link never followed.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from typing import Literal
from urllib.parse import urlsplit

from fastapi import APIRouter, HTTPException, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from starlette.datastructures import FormData, UploadFile
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.types import Message

from tag_service.codes import normalize_code
from tag_service.verify import Decoded, NotAnImage, TooManyPixels, decode_image, open_image
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import read_state
from webapp.server.deps import ServicesDep
from webapp.server.services import Services
from webapp.tags.registry import find
from webapp.web.templating import render

router = APIRouter(include_in_schema=False)

CHUNK_BYTES = 64 * 1024
# Room for the multipart boundaries and part headers around the photo itself.
ENVELOPE_BYTES = 64 * 1024
PHOTO_FIELD = "photo"

NO_PHOTO = "No photo was sent: take or choose a photo of the code and try again."
EMPTY_PHOTO = "The photo was empty: take or choose a photo of the code and try again."
MALFORMED = "The upload was malformed: take or choose a photo of the code and try again."
NOT_A_PICTURE = "That file is not a picture we can read: take a photo of the code with the camera."
NO_CODE = (
    "No code found in the photo; hold the phone steady, fill the frame with the code and try again."
)

_OUR_PATH = re.compile(r"/[Tt]/([^/]*)")
_TEL = re.compile(r"tel:(\+?[0-9*#]{1,40})", re.IGNORECASE)

FoundKind = Literal["ours", "tel", "vcard", "url", "text"]


AIMED_SHARE = 0.5
"""A code counts as aimed at when its centre lies within this share of the photo's
half-diagonal from the photo's centre..."""
CLEARLY_NEARER = 2.0
"""...and every other code of ours is at least this many times further out."""


@dataclass(frozen=True)
class Found:
    """A decoded code as the page shows it."""

    kind: FoundKind
    text: str
    href: str | None = None  # only for our own codes (relative) and tel: numbers
    off_centre: float = 0.0  # distance from the photo's centre, in half-diagonals
    label: str = ""  # for our codes: what it marks
    where: str = ""  # for our codes: the display it stands on, and the wall


class _TooLarge(Exception):
    """The request body ran past the upload limit."""


def our_code(payload: str) -> str | None:
    """The code in one of our URL tags (``http(s)://ANY-HOST/T/CODE``, any case), or None.

    Any host: phones and the wall may know the server under different names. Only
    the code is kept, so what we redirect to is always our own ``/t/CODE``.
    """
    try:
        parts = urlsplit(payload.strip())
    except ValueError:
        return None
    if parts.scheme.lower() not in ("http", "https") or not parts.netloc:
        return None
    match = _OUR_PATH.fullmatch(parts.path)
    return normalize_code(match.group(1)) if match else None


def classify(payload: str) -> Found:
    """What the page does with a payload: link ours, offer to call, show the rest as text."""
    code = our_code(payload)
    if code is not None:
        return Found("ours", code, f"/t/{code}")
    stripped = payload.strip()
    if tel := _TEL.fullmatch(stripped):
        return Found("tel", tel.group(1), f"tel:{tel.group(1)}")
    if stripped.upper().startswith("BEGIN:VCARD"):
        return Found("vcard", payload)
    try:
        parts = urlsplit(stripped)
        looks_like_url = bool(parts.scheme and parts.netloc)
    except ValueError:
        looks_like_url = False
    return Found("url" if looks_like_url else "text", payload)


@router.get("/scan", response_class=HTMLResponse)
def scan_form(request: Request) -> HTMLResponse:
    return render(request, "scan.html")


@router.post("/scan")
async def scan_photo(request: Request, services: ServicesDep) -> Response:
    """Decode the uploaded photo: one of our codes redirects to it, others are shown."""
    limit = services.settings.scan_upload_max_bytes
    declared = request.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > limit + ENVELOPE_BYTES:
        raise _too_large(limit)
    data = await _read_photo(request, limit)
    try:
        size, decoded = await run_blocking(_decode, data)
    except TooManyPixels as error:
        raise HTTPException(
            status.HTTP_413_CONTENT_TOO_LARGE,
            f"The photo has too many pixels ({error}); take it at a lower resolution.",
        ) from error
    except NotAnImage as error:
        raise HTTPException(status.HTTP_415_UNSUPPORTED_MEDIA_TYPE, NOT_A_PICTURE) from error
    if not decoded:
        return render(request, "scan.html", status.HTTP_422_UNPROCESSABLE_CONTENT, problem=NO_CODE)
    found = await run_blocking(_described, services, decoded, size)
    aimed = aimed_at(found)
    if aimed is not None:
        return RedirectResponse(f"/t/{aimed.text}", status.HTTP_303_SEE_OTHER)
    return render(request, "scan.html", found=found, asking=any(f.kind == "ours" for f in found))


def aimed_at(found: list[Found]) -> Found | None:
    """The code of ours the photo was clearly aimed at, or None (then the phone asks):
    nearest the centre, in the photo's middle, and clearly nearer than any other."""
    ours = [f for f in found if f.kind == "ours"]
    if not ours:
        return None
    nearest = ours[0]  # ``found`` comes nearest the centre first
    others = [f.off_centre for f in ours if f.text != nearest.text]
    if nearest.off_centre > AIMED_SHARE:
        return None
    if others and min(others) < CLEARLY_NEARER * nearest.off_centre:
        return None
    return nearest


def _described(services: Services, decoded: list[Decoded], size: tuple[int, int]) -> list[Found]:
    """Each decoded code as the page shows it, nearest the centre of a photo of
    ``size`` first, once each (a code seen twice counts where it is nearest); our codes
    say what they mark and where they stand."""
    width, height = size
    half_diagonal = math.hypot(width, height) / 2
    seen: dict[str, Found] = {}
    for item in decoded:
        x, y, w, h = item.rect
        off = math.hypot(x + w / 2 - width / 2, y + h / 2 - height / 2) / half_diagonal
        found = replace(classify(item.payload), off_centre=round(off, 3))
        if found.kind == "ours":
            label, where = _what_it_marks(services, found.text)
            found = replace(found, label=label, where=where)
        key = f"{found.kind}:{found.text}"
        if key not in seen or off < seen[key].off_centre:
            seen[key] = found
    return sorted(seen.values(), key=lambda f: (f.off_centre, f.text))


def _what_it_marks(services: Services, code: str) -> tuple[str, str]:
    """The tag's label and where it stands now (display and wall), as far as known."""
    tag = find(services.db, code)
    if tag is None:
        return "", "not a code this server knows"
    wall = services.walls.get(tag.wall_id)
    wall_name = wall.name if wall is not None else tag.wall_id
    _, state = read_state(services.db, tag.wall_id)
    layout = services.layout(tag.wall_id, state.tag_layout)
    display = next(
        (p["display"] for p in (layout.placed if layout else []) if p["code"] == code), None
    )
    where = f"on display {display}, {wall_name}" if display else f"not on {wall_name} now"
    return tag.label, where


def _decode(data: bytes) -> tuple[tuple[int, int], list[Decoded]]:
    """The photo's size and its codes. CPU work (Pillow and zbar): runs in the thread
    pool, never on the event loop."""
    with open_image(data) as image:
        return image.size, decode_image(image)


def _too_large(limit: int) -> HTTPException:
    return HTTPException(
        status.HTTP_413_CONTENT_TOO_LARGE,
        f"The photo is larger than {limit / 1_000_000:g} MB; take a smaller one and try again.",
    )


async def _read_photo(request: Request, limit: int) -> bytes:
    """The ``photo`` field's bytes, never reading much past ``limit``.

    The raw body is counted as it arrives (a chunked upload has no Content-Length),
    so an endless upload stops at the limit plus the multipart envelope instead of
    filling the disk; the photo itself is then read in chunks up to ``limit``.
    """
    received = 0

    async def counting_receive() -> Message:
        nonlocal received
        message = await request.receive()
        if message["type"] == "http.request":
            received += len(message.get("body", b""))
            if received > limit + ENVELOPE_BYTES:
                raise _TooLarge
        return message

    try:
        form = await Request(request.scope, counting_receive).form(max_files=1, max_fields=8)
    except _TooLarge as error:
        raise _too_large(limit) from error
    except StarletteHTTPException as error:  # malformed multipart, too many parts
        raise HTTPException(status.HTTP_400_BAD_REQUEST, MALFORMED) from error
    try:
        return await _read_capped(form, limit)
    finally:
        await form.close()


async def _read_capped(form: FormData, limit: int) -> bytes:
    photo = form.get(PHOTO_FIELD)
    if not isinstance(photo, UploadFile):
        raise HTTPException(status.HTTP_400_BAD_REQUEST, NO_PHOTO)
    chunks: list[bytes] = []
    size = 0
    while chunk := await photo.read(CHUNK_BYTES):
        size += len(chunk)
        if size > limit:
            raise _too_large(limit)
        chunks.append(chunk)
    if size == 0:
        raise HTTPException(status.HTTP_400_BAD_REQUEST, EMPTY_PHOTO)
    return b"".join(chunks)
