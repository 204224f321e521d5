"""The image app's API: instructors upload, list, show, retitle and remove images,
share them as lessons, mark their hotspots and run quiz rounds on their questions;
tiles and the overview fetch each image's
manifest and the pyramid tiles their displays show; phones open a hotspot's page and
answer its question."""

from __future__ import annotations

import uuid
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import Annotated, TypeVar

from fastapi import APIRouter, Depends, Form, HTTPException, Query, Request, Response, status
from fastapi.responses import FileResponse
from pydantic import BaseModel, ConfigDict, Field
from starlette.background import BackgroundTask
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException as StarletteHTTPException

from webapp.apps.image import hotspots, lesson, pages
from webapp.apps.image.hotspots import Hotspot, HotspotFields, HotspotRefused
from webapp.apps.image.library import ImageShown, image_library, remove_image
from webapp.apps.image.questions import (
    asked,
    described,
    fresh_orders,
    numbers,
    question_of,
    quiz_of,
    round_on_wall,
)
from webapp.apps.image.state import APP, ImageState, walls_showing
from webapp.apps.image.store import (
    MAX_IMAGE_TITLE,
    UPLOADING,
    ImageManifest,
    ImageRefused,
    ImageStore,
    NoLibvips,
)
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.wall_state import WallState, read_state
from webapp.quiz.http import answers_download, round_step
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep, CsrfDep, PersonDep, StaffDep, StaffOnly, WallDep
from webapp.web.downloads import attachment
from webapp.web.problems import errors

router = APIRouter(tags=["image"])

FILE_FIELD = "file"
ENVELOPE_BYTES = 64 * 1024  # the multipart boundaries and part headers around the file
CHUNK_BYTES = 1 << 20
T = TypeVar("T")
FOREVER = "public, max-age=31536000, immutable"  # a stored image never changes


def store_of(context: AppContext) -> ImageStore:
    return image_library(context).store(context.settings)


def _no_image(image_id: str) -> HTTPException:
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


async def _take_upload(
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
        return await _take_upload(request, context, stored)
    except ImageRefused as error:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(error)) from None


# --- lessons -------------------------------------------------------------------------


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
        return await _take_upload(request, context, imported)
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
        raise _no_image(image_id) from None
    except NoLibvips as error:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(error)) from None
    return FileResponse(
        target,
        media_type="application/zip",
        headers={"Content-Disposition": attachment([exported.title], lesson.SUFFIX)},
        background=BackgroundTask(target.unlink, missing_ok=True),
    )


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
        raise _no_image(image_id) from None


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
        raise _no_image(image_id) from None
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
        raise _no_image(choice.image) from None

    def showing(state: WallState) -> WallState:
        return ImageState(image=choice.image).put(state.model_copy(update={"app": APP}))

    await context.change_wall(wall, showing)
    return choice


def _manifest(context: AppContext, image_id: str) -> ImageManifest:
    try:
        return store_of(context).get(image_id)
    except KeyError:
        raise _no_image(image_id) from None


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


# --- hotspots ------------------------------------------------------------------------


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
    went); the others have nothing of it up."""
    walls = context.walls.values()
    for wall in await context.db.read(walls_showing, context.db, walls, image_id):
        await context.change_wall(wall, lambda current: current, replace_codes=True)


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


# --- phones ----------------------------------------------------------------------------


@router.get("/apps/image/{wall_id}/hotspots/{code}", include_in_schema=False)
async def hotspot_page(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep, code: str
) -> Response:
    """A hotspot's page again (after an answer), without counting a scan."""
    tag = await pages.tag_of(context, wall, code)
    return await pages.hotspot_page(request, context, wall, tag, person)


@router.post(
    "/apps/image/{wall_id}/hotspots/{code}/answer",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def answer(
    request: Request,
    wall: WallDep,
    context: ContextDep,
    person: PersonDep,
    code: str,
    answer: Annotated[str, Form()] = "",
) -> Response:
    return await pages.answer(request, context, wall, person, code, answer)


# --- the instructor's quiz controls ------------------------------------------------------


class RoundStatus(BaseModel):
    model_config = ConfigDict(from_attributes=True)  # read off the stored round

    number: int
    open: bool
    started_at: datetime
    closed_at: datetime | None


class QuestionStats(BaseModel):
    number: int
    hotspot: str
    title: str
    answered: int
    share_correct: float | None
    common_wrong: list[tuple[str, int]]


class QuizStatus(BaseModel):
    image: str | None  # the image on the wall (None: the app or an image is not up)
    questions: int  # its hotspots with a question
    round: RoundStatus | None
    participants: int
    answers: int
    finished: int
    items: list[QuestionStats]


def _quiz_status(context: AppContext, wall_id: str) -> QuizStatus:
    """The round on the wall and the class's results on the image shown (in a worker
    thread; names and answers included: staff only)."""
    _, state = read_state(context.db, wall_id)
    image_id = ImageState.of(state).image if state.app == APP else None
    try:
        spots = hotspots.hotspots(store_of(context), image_id) if image_id else []
    except KeyError:
        spots = []
    quiz_round = round_on_wall(context, wall_id, state)
    status_now = QuizStatus(
        image=image_id,
        questions=len(asked(spots)),
        round=None if quiz_round is None else RoundStatus.model_validate(quiz_round),
        participants=0,
        answers=0,
        finished=0,
        items=[],
    )
    if quiz_round is None or image_id is None:
        return status_now
    numbered = sorted((n, hid) for hid, n in numbers(quiz_round, image_id, spots).items())
    by_id = {spot.id: spot for spot in spots}
    ordered = [by_id[hid] for _, hid in numbered]
    questions = [question_of(spot) for spot in ordered]
    stats = quiz_of(context).statistics(wall_id, quiz_round.number, image_id, questions)
    return status_now.model_copy(
        update={
            "participants": stats.participants,
            "answers": stats.answers,
            "finished": stats.finished,
            "items": [
                QuestionStats(
                    number=n,
                    hotspot=spot.id,
                    title=spot.title,
                    answered=s.answered,
                    share_correct=s.share_correct,
                    common_wrong=s.common_wrong,
                )
                for (n, _), spot, s in zip(numbered, ordered, stats.items, strict=True)
            ],
        }
    )


@router.get("/api/apps/image/walls/{wall_id}")
async def quiz_status(wall: WallDep, context: ContextDep, staff: StaffDep) -> QuizStatus:
    """The image's quiz on a wall: its round and the class's results so far."""
    return await run_blocking(_quiz_status, context, wall.id)


@router.post("/api/apps/image/walls/{wall_id}/quiz/start", responses=errors(409))
async def start_round(wall: WallDep, context: ContextDep, staff: StaffDep) -> QuizStatus:
    """A new round on the image on the wall: the one before closes (its students see
    the answers), its questions get new numbers and codes on every tile at once."""
    now = await run_blocking(_quiz_status, context, wall.id)
    if now.image is None or not now.questions:
        raise HTTPException(status.HTTP_409_CONFLICT, f"No image with questions is on {wall.name}.")
    spots = await run_blocking(hotspots.hotspots, store_of(context), now.image)
    started = await round_step(
        quiz_of(context).start_round, wall.id, staff, fresh_orders(now.image, spots)
    )

    def apply(current: WallState) -> WallState:
        return ImageState.of(current).later_round(started.number).put(current)

    await context.change_wall(wall, apply)
    return await run_blocking(_quiz_status, context, wall.id)


@router.post("/api/apps/image/walls/{wall_id}/quiz/close", responses=errors(409))
async def close_round(wall: WallDep, context: ContextDep, staff: StaffDep) -> QuizStatus:
    """Close the round on the wall: answers stop counting and students see the answers."""
    now = await run_blocking(_quiz_status, context, wall.id)
    if now.round is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "The quiz has no round yet.")
    await round_step(quiz_of(context).close_round, wall.id, now.round.number, staff)
    return await run_blocking(_quiz_status, context, wall.id)


@router.get("/api/apps/image/walls/{wall_id}/answers.csv", responses=errors(404))
async def answers_csv(
    wall: WallDep,
    context: ContextDep,
    staff: StaffDep,
    round_number: Annotated[RowId | None, Query(alias="round")] = None,
) -> Response:
    """Every answer of a round (default: the one on the wall), for a spreadsheet, each
    named by its image and hotspot, the hotspot's title and question, in a file named
    by the wall, the round's class, the round and its day."""
    quiz = quiz_of(context)
    if round_number is None:
        now = await run_blocking(_quiz_status, context, wall.id)
        round_number = now.round.number if now.round is not None else None
    quiz_round = await run_blocking(quiz.get_round, wall.id, round_number) if round_number else None
    about = await run_blocking(described, store_of(context), quiz_round) if quiz_round else None
    return await answers_download(quiz, wall, quiz_round, about)
