"""The image app's slot of the wall state: which stored image the wall shows and the
quiz round whose hotspot codes stand on it."""

from __future__ import annotations

from collections.abc import Iterable
from typing import ClassVar

from wall_client.layout import Wall
from webapp.database.connection import Database, RowId
from webapp.engine.wall_state import AppState, read_state
from webapp.web.context import Update

APP = "image"


class ImageState(AppState):
    app: ClassVar[str] = APP
    # tiles fetch the new image's coarse level before the swap, so it appears at once
    heavy: ClassVar[frozenset[str]] = frozenset({"image"})
    # another image has other hotspots; a new round, new codes for them
    placing: ClassVar[frozenset[str]] = frozenset({"image", "quiz_round"})

    image: str | None = None  # the stored image's id (None: none chosen yet)
    quiz_round: RowId | None = None  # the round on the wall (None: none started yet)

    def later_round(self, number: int) -> ImageState:
        """The slot showing round ``number`` unless a later one is already up (two
        instructors starting rounds at once: the wall keeps the newest)."""
        return self.model_copy(update={"quiz_round": max(number, self.quiz_round or 0)})


def shows_round(number: int) -> Update:
    """The wall showing round ``number`` of the image's questions (or a later one)."""
    return lambda current: ImageState.of(current).later_round(number).put(current)


def walls_showing(db: Database, walls: Iterable[Wall], image_id: str) -> list[Wall]:
    """The walls whose scene shows ``image_id`` now: the image app up, that image chosen
    (a wall on another app keeps the choice in its slot, but shows nothing of it)."""
    showing = []
    for wall in walls:
        _, state = read_state(db, wall.id)
        if state.app == APP and ImageState.of(state).image == image_id:
            showing.append(wall)
    return showing
