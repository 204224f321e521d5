"""The image app's slot of the wall state: which stored image the wall shows."""

from __future__ import annotations

from typing import ClassVar

from webapp.engine.wall_state import AppState

APP = "image"


class ImageState(AppState):
    app: ClassVar[str] = APP
    # tiles fetch the new image's coarse level before the swap, so it appears at once
    heavy: ClassVar[frozenset[str]] = frozenset({"image"})

    image: str | None = None  # the stored image's id (None: none chosen yet)
