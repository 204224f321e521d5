"""The video app's object as its routes and commands find it: its settings and its store;
and what its routes and commands both do with the walls (removing a video)."""

from __future__ import annotations

from collections.abc import Iterable

from wall_client.layout import Wall
from webapp.apps.video.settings import VideoSettings, video_settings
from webapp.apps.video.state import APP, walls_showing
from webapp.apps.video.store import VideoManifest, VideoStore
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.web.context import AppContext


class VideoLibrary:
    """The settings live on the app object, read once as it loads (a bad one stops the
    server); the store is the folder under the var folder they apply to."""

    def __init__(self, settings: VideoSettings | None = None) -> None:
        self.settings = settings or video_settings()

    def store(self, settings: Settings) -> VideoStore:
        return VideoStore(
            settings.var_dir / "videos", self.settings.max_bytes, self.settings.max_duration_s
        )


def video_library(context: AppContext) -> VideoLibrary:
    """The running server's video app."""
    library = context.app(APP)
    if not isinstance(library, VideoLibrary):
        raise TypeError(f"the app {APP!r} is not the video app")
    return library


class VideoShown(RuntimeError):
    """A video a wall shows is not removed (its tiles would lose it mid lesson); the
    message names the walls."""


def remove_video(
    store: VideoStore, db: Database, walls: Iterable[Wall], video_id: str
) -> VideoManifest:
    """Remove the video unless a wall shows it (:class:`VideoShown`; KeyError: no such
    video)."""
    manifest = store.get(video_id)
    showing = walls_showing(db, walls, video_id)
    if showing:
        names = ", ".join(wall.name for wall in showing)
        raise VideoShown(f"{manifest.title!r} is shown on {names}: show another video there first.")
    return store.remove(video_id)
