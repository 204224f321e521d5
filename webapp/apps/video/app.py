"""The video app as a wall app: an instructor's video framed on the wall's stage, every
tile playing its part of the frame in step on the wall clock, the sound from one chosen
display; it stands no codes of its own."""

from __future__ import annotations

from pathlib import Path

import click
from fastapi import APIRouter

from wall_client.layout import Wall
from webapp.apps.hooks import WallApp, static_url
from webapp.apps.video import commands, routes
from webapp.apps.video.library import VideoLibrary
from webapp.apps.video.state import APP, VideoClock, VideoState, paused
from webapp.engine.wall_state import AppState, WallState, now_ms
from webapp.web.context import AppContext

FOLDER = Path(__file__).parent


class VideoApp(VideoLibrary, WallApp):
    """The video app's :class:`~webapp.apps.hooks.WallApp`: its store with what the
    core calls."""

    name: str = APP
    state: type[AppState] | None = VideoState
    layers: tuple[str, ...] = (f"{static_url(APP)}/video.js",)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"

    def settle(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """Coming on a wall that never chose a video, or whose video was removed while
        another app was up, it shows the newest one (the one just added, as a rule),
        paused at its start."""
        store = self.store(context.settings)
        slot = VideoState.of(state)
        if slot.video is not None and store.holds(slot.video):
            return state
        newest = store.videos()
        chosen = newest[0].id if newest else None
        return slot.model_copy(update={"video": chosen, "clock": VideoClock()}).put(state)

    def leave(self, state: WallState) -> WallState:
        """Another app comes: the video pauses where it stands (no tile plays on, or
        sounds, behind the next app), to go on from there when it comes back."""
        slot = VideoState.of(state)
        return paused(slot, now_ms(), 0, 0.0).put(state)

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "video/panel.html"

    def router(self) -> APIRouter | None:
        return routes.router

    def commands(self) -> list[click.Command]:
        return [commands.video]
