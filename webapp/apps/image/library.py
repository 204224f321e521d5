"""The image app's object as its routes and commands find it: its limits and its store;
and what its routes and commands both do with the walls (removing an image)."""

from __future__ import annotations

from collections.abc import Iterable

from wall_client.layout import Wall
from webapp.apps.image.state import APP, walls_showing
from webapp.apps.image.store import MAX_PIXELS, MAX_UPLOAD_BYTES, ImageManifest, ImageStore
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.web.context import AppContext


class ImageLibrary:
    """The limits live on the app object (one place an installation or a test changes
    them); the store is the folder under the var folder they apply to."""

    max_pixels: int = MAX_PIXELS
    max_upload_bytes: int = MAX_UPLOAD_BYTES

    def store(self, settings: Settings) -> ImageStore:
        return ImageStore(settings.var_dir / "images", self.max_pixels, self.max_upload_bytes)


def image_library(context: AppContext) -> ImageLibrary:
    """The running server's image app."""
    library = context.app(APP)
    if not isinstance(library, ImageLibrary):
        raise TypeError(f"the app {APP!r} is not the image app")
    return library


class ImageShown(RuntimeError):
    """An image a wall shows is not removed (its tiles would lose their picture mid
    lesson); the message names the walls."""


def remove_image(
    store: ImageStore, db: Database, walls: Iterable[Wall], image_id: str
) -> ImageManifest:
    """Remove the image, its pyramid and hotspots unless a wall shows it
    (:class:`ImageShown`; KeyError: no such image). Blocking: a large pyramid is
    thousands of files."""
    manifest = store.get(image_id)
    showing = walls_showing(db, walls, image_id)
    if showing:
        names = ", ".join(wall.name for wall in showing)
        raise ImageShown(f"{manifest.title!r} is shown on {names}: show another image there first.")
    return store.remove(image_id)
