"""The video app's API and pages: instructors upload, list, show and remove videos and
play, pause, seek and loop the one on a wall, from the dashboard or the phone remote;
tiles and the overview fetch a video's manifest and its file (in ranges, as browsers
stream it)."""

from __future__ import annotations

import base64
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Self

from fastapi import APIRouter, Depends, HTTPException, Request, Response, status
from fastapi.responses import FileResponse
from pydantic import BaseModel, ConfigDict, Field, model_validator
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException as StarletteHTTPException

from tag_service.codes import make_symbol, render_svg
from wall_client.layout import Wall
from webapp.apps.video.library import VideoShown, remove_video, video_library
from webapp.apps.video.probe import NoFfprobe, VideoRefused
from webapp.apps.video.state import (
    APP,
    VideoClock,
    VideoState,
    looped,
    paused,
    played,
    position_at,
    sought,
)
from webapp.apps.video.store import UPLOADING, VideoManifest, VideoStore
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import WallState, now_ms
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep, StaffOnly, StaffPageDep, WallDep
from webapp.web.problems import errors
from webapp.web.templating import render

router = APIRouter(tags=["video"])

FILE_FIELD = "file"
ENVELOPE_BYTES = 64 * 1024  # the multipart boundaries and part headers around the file
CHUNK_BYTES = 1 << 20
FOREVER = "public, max-age=31536000, immutable"  # a stored video never changes


def store_of(context: AppContext) -> VideoStore:
    return video_library(context).store(context.settings)


def _no_video(video_id: str) -> HTTPException:
    return HTTPException(status.HTTP_404_NOT_FOUND, f"There is no video {video_id}.")


def _too_large(store: VideoStore) -> HTTPException:
    return HTTPException(
        status.HTTP_413_CONTENT_TOO_LARGE,
        f"The file is larger than {store.max_bytes / 1e6:,.0f} MB, the most taken "
        "(TAGWALL_VIDEO_MAX_BYTES).",
    )


async def upload_within_limit(request: Request, context: ContextDep) -> None:
    """An upload declares its length (browsers always do for a form), and one over the
    limit is refused before anything is read. This runs before the staff check, which
    may read the form for its CSRF token; the server reads no more than declared."""
    declared = request.headers.get("content-length", "")
    if not declared.isdigit():
        raise HTTPException(
            status.HTTP_411_LENGTH_REQUIRED, "Send the upload with its length (Content-Length)."
        )
    store = store_of(context)
    if int(declared) > store.max_bytes + ENVELOPE_BYTES:
        raise _too_large(store)


class _TooLarge(Exception):
    pass


@router.post(
    "/api/apps/video/videos",
    dependencies=[Depends(upload_within_limit), StaffOnly],
    status_code=status.HTTP_201_CREATED,
    responses={
        **errors(400, 503),
        411: {"description": "The upload did not declare its length."},
        413: {"description": "The file is larger than TAGWALL_VIDEO_MAX_BYTES."},
        422: {"description": "Not an MP4 or WebM that browsers play, within the limits."},
    },
)
async def upload(request: Request, context: ContextDep) -> VideoManifest:
    """Store a video sent as the multipart field ``file`` (``title`` optional): 201 with
    its manifest; 413 over the byte limit, 422 for what browsers do not play or what is
    longer than the duration limit, with the reason in one line. Nothing of a refused
    upload is kept."""
    store = store_of(context)
    try:  # the form the CSRF check read, if it read one (files spool to disk)
        form = await request.form(max_files=1, max_fields=4)
    except StarletteHTTPException as error:  # malformed multipart, too many parts
        raise HTTPException(status.HTTP_400_BAD_REQUEST, "The upload was malformed.") from error
    upload = form.get(FILE_FIELD)
    title = form.get("title")
    if not isinstance(upload, UploadFile):
        await form.close()
        raise HTTPException(status.HTTP_400_BAD_REQUEST, "No file was sent (field 'file').")
    name = Path(upload.filename or "upload").name

    def stored() -> VideoManifest:
        store.root.mkdir(parents=True, exist_ok=True)
        copy = store.root / f"{UPLOADING}{uuid.uuid4().hex}"
        try:
            with copy.open("wb") as out:
                size = 0
                while chunk := upload.file.read(CHUNK_BYTES):
                    size += len(chunk)
                    if size > store.max_bytes:
                        raise _TooLarge
                    out.write(chunk)
            return store.add(copy, title if isinstance(title, str) else None, name, move=True)
        finally:
            copy.unlink(missing_ok=True)

    try:
        return await run_blocking(stored)
    except _TooLarge:
        raise _too_large(store) from None
    except VideoRefused as error:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(error)) from None
    except NoFfprobe as error:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(error)) from None
    finally:
        await form.close()


@router.get("/api/apps/video/videos", dependencies=[StaffOnly])
async def list_videos(context: ContextDep) -> list[VideoManifest]:
    """The stored videos, newest first."""
    return await run_blocking(store_of(context).videos)


@router.delete(
    "/api/apps/video/videos/{video_id}",
    dependencies=[StaffOnly],
    responses={**errors(404), 409: {"description": "A wall shows the video."}},
)
async def remove(video_id: str, context: ContextDep) -> list[VideoManifest]:
    """Remove the video: 409 while a wall shows it. The videos left, newest first."""
    store = store_of(context)
    try:
        await run_blocking(remove_video, store, context.db, context.walls.values(), video_id)
    except KeyError:
        raise _no_video(video_id) from None
    except VideoShown as error:
        raise HTTPException(status.HTTP_409_CONFLICT, str(error)) from None
    return await run_blocking(store.videos)


# --- for tiles -----------------------------------------------------------------------


@router.get("/apps/video/videos/{video_id}/info.json", responses=errors(404))
async def manifest(video_id: str, context: ContextDep) -> VideoManifest:
    """What tiles need to play the video: its file's name, size, frame rate, duration."""
    try:
        return await run_blocking(store_of(context).get, video_id)
    except KeyError:
        raise _no_video(video_id) from None


@router.get(
    "/apps/video/videos/{video_id}/{file_name}",
    response_class=FileResponse,
    responses={
        **errors(404),
        206: {"description": "The range asked for (Range: bytes=...)."},
        416: {"description": "The range asked for lies past the file's end."},
    },
)
async def video_file(video_id: str, file_name: str, context: ContextDep) -> FileResponse:
    """The video's file (``video.mp4`` or ``video.webm``), cached for good; a browser
    asks for it in ranges (``Range: bytes=...``, 206; 416 past its end) as it plays
    and seeks."""
    try:
        path, stored = await run_blocking(store_of(context).file, video_id, file_name)
    except KeyError:
        raise _no_video(video_id) from None
    return FileResponse(path, media_type=stored.media_type, headers={"Cache-Control": FOREVER})


# --- the wall's video -------------------------------------------------------------------


class WallVideo(BaseModel):
    """The video on a wall, for the dashboard and the remote: the slot, and where the
    video stands at ``server_ms`` (they move their position on from there)."""

    video: VideoManifest | None  # None: the app or a video is not up
    on_wall: bool  # the video app is the one the wall shows
    clock: VideoClock
    loop: bool
    sound: str | None
    displays: list[str]  # where the sound may play
    server_ms: int
    position_s: float
    playing: bool


def _wall_video(context: AppContext, wall_id: str, state: WallState) -> WallVideo:
    slot = VideoState.of(state)
    wall = context.walls[wall_id]
    video = None
    if slot.video is not None:
        try:
            video = store_of(context).get(slot.video)
        except KeyError:
            video = None
    now = now_ms()
    position, playing = position_at(slot.clock, now, video.duration_s if video else 0.0, slot.loop)
    return WallVideo(
        video=video,
        on_wall=state.app == APP,
        clock=slot.clock,
        loop=slot.loop,
        sound=slot.sound,
        displays=[display.id for display in wall.displays],
        server_ms=now,
        position_s=position,
        playing=playing and state.app == APP,
    )


async def _answer(context: AppContext, wall: Wall) -> WallVideo:
    state = await context.state(wall)
    return await run_blocking(_wall_video, context, wall.id, state)


@router.get("/api/apps/video/walls/{wall_id}", dependencies=[StaffOnly])
async def wall_video(wall: WallDep, context: ContextDep) -> WallVideo:
    """The video on the wall: which, where it stands now, looping, where its sound plays."""
    return await _answer(context, wall)


class ShowVideo(BaseModel):
    model_config = ConfigDict(extra="forbid")

    video: str = Field(min_length=1, max_length=64)


@router.post(
    "/api/apps/video/walls/{wall_id}/show", dependencies=[StaffOnly], responses=errors(404)
)
async def show(wall: WallDep, choice: ShowVideo, context: ContextDep) -> WallVideo:
    """Put the video app on the wall with ``video`` paused at its start, framed on the
    whole stage; every tile shows it at the same instant once each has loaded it."""
    try:
        await run_blocking(store_of(context).get, choice.video)
    except KeyError:
        raise _no_video(choice.video) from None

    def showing(state: WallState) -> WallState:
        slot = VideoState.of(state)
        chosen = slot.model_copy(update={"video": choice.video, "clock": VideoClock()})
        return chosen.put(state.model_copy(update={"app": APP}))

    await context.change_wall(wall, showing)
    return await _answer(context, wall)


Step = Callable[[VideoState, int, int, float], VideoState]
"""A change of the clock: the slot, now, the lead and the video's duration in; the slot out."""


async def _step(context: AppContext, wall: Wall, step: Step) -> WallVideo:
    """Change the wall's video by ``step`` at the instant of the change (under the door's
    hold, so two instructors pressing at once change it one after the other): 409 when
    no video is up."""
    state = await context.state(wall)
    slot = VideoState.of(state)
    if state.app != APP or slot.video is None:
        raise HTTPException(status.HTTP_409_CONFLICT, f"No video is on {wall.name}.")
    try:
        video = await run_blocking(store_of(context).get, slot.video)
    except KeyError:
        raise HTTPException(status.HTTP_409_CONFLICT, f"No video is on {wall.name}.") from None
    lead = video_library(context).settings.lead_ms

    def changed(current: WallState) -> WallState:
        now_slot = VideoState.of(current)
        if current.app != APP or now_slot.video != video.id:
            return current  # another video or app came meanwhile: this press was for that one
        return step(now_slot, now_ms(), lead, video.duration_s).put(current)

    await context.change_wall(wall, changed)
    return await _answer(context, wall)


@router.post(
    "/api/apps/video/walls/{wall_id}/play", dependencies=[StaffOnly], responses=errors(409)
)
async def play(wall: WallDep, context: ContextDep) -> WallVideo:
    """Play from where the video stands (from the start after its end), on every tile
    from the same instant."""
    return await _step(context, wall, played)


@router.post(
    "/api/apps/video/walls/{wall_id}/pause", dependencies=[StaffOnly], responses=errors(409)
)
async def pause(wall: WallDep, context: ContextDep) -> WallVideo:
    """Pause where the video stands, on every tile at the same frame."""
    return await _step(context, wall, paused)


class Seek(BaseModel):
    """Where to: ``to_s`` (seconds from the start) or ``by_s`` (seconds on from where
    it stands, back when negative), one of the two."""

    model_config = ConfigDict(extra="forbid")

    to_s: float | None = Field(default=None, ge=0)
    by_s: float | None = Field(default=None, ge=-86_400, le=86_400)

    @model_validator(mode="after")
    def _one(self) -> Self:
        if (self.to_s is None) == (self.by_s is None):
            raise ValueError("give to_s or by_s")
        return self


@router.post(
    "/api/apps/video/walls/{wall_id}/seek", dependencies=[StaffOnly], responses=errors(409)
)
async def seek(wall: WallDep, where: Seek, context: ContextDep) -> WallVideo:
    """Go to a moment of the video (kept within it), playing on if it was playing."""

    def step(slot: VideoState, now: int, lead: int, duration: float) -> VideoState:
        if where.to_s is not None:
            return sought(slot, where.to_s, now, lead, duration)
        position, _ = position_at(slot.clock, now + lead, duration, slot.loop)
        return sought(slot, position + (where.by_s or 0.0), now, lead, duration)

    return await _step(context, wall, step)


class Loop(BaseModel):
    model_config = ConfigDict(extra="forbid")

    loop: bool


@router.put("/api/apps/video/walls/{wall_id}/loop", dependencies=[StaffOnly], responses=errors(409))
async def loop(wall: WallDep, choice: Loop, context: ContextDep) -> WallVideo:
    """Loop the video (at its end it starts again) or not (it stops on its last frame)."""

    def step(slot: VideoState, now: int, lead: int, duration: float) -> VideoState:
        return looped(slot, choice.loop, now, lead, duration)

    return await _step(context, wall, step)


class Sound(BaseModel):
    model_config = ConfigDict(extra="forbid")

    display: str | None = Field(max_length=64)  # None: no sound anywhere


@router.put(
    "/api/apps/video/walls/{wall_id}/sound",
    dependencies=[StaffOnly],
    responses={**errors(409), 422: {"description": "No such display on the wall."}},
)
async def sound(wall: WallDep, choice: Sound, context: ContextDep) -> WallVideo:
    """Which display plays the sound (the one whose speakers face the room), or none."""
    if choice.display is not None and choice.display not in {d.id for d in wall.displays}:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"{wall.name} has no display {choice.display!r}.",
        )

    def step(slot: VideoState, now: int, lead: int, duration: float) -> VideoState:
        return slot.model_copy(update={"sound": choice.display})

    return await _step(context, wall, step)


# --- the instructor's phone remote -------------------------------------------------------


def remote_path(wall_id: str) -> str:
    return f"/apps/video/{wall_id}/remote"


class RemoteCode(BaseModel):
    url: str
    image: str  # an SVG data URI of the URL's QR code, for a phone to scan off the dashboard


@router.get("/api/apps/video/walls/{wall_id}/remote", dependencies=[StaffOnly])
async def remote_code(wall: WallDep, context: ContextDep) -> RemoteCode:
    """The phone remote's address, and a code of it to scan off the dashboard."""
    url = context.base_url.rstrip("/") + remote_path(wall.id)
    svg = render_svg(make_symbol(url))
    return RemoteCode(url=url, image="data:image/svg+xml;base64," + base64.b64encode(svg).decode())


@router.get(remote_path("{wall_id}"), include_in_schema=False)
async def remote(request: Request, wall: WallDep, person: StaffPageDep) -> Response:
    """The instructor's phone remote of the wall's video: big buttons to play and
    pause, go back and on, seek and loop (anyone else is sent to sign in first)."""
    return render(request, "video/remote.html", wall=wall)
