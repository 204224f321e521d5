"""The image app's object as its routes and commands find it: its limits and its store."""

from __future__ import annotations

from webapp.apps.image.state import APP
from webapp.apps.image.store import MAX_PIXELS, MAX_UPLOAD_BYTES, ImageStore
from webapp.core.settings import Settings
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
