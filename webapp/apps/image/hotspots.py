"""Hotspots: places on an image an instructor marks, each with a title, a text per user
group and, optionally, a question; and where each stands on the wall.

They are stored per image, beside its pyramid, in ``hotspots.json`` (the app keeps its
data in its own files, not in the core's tables), written whole to a temporary file and
renamed over the old one, so a reader never sees half a list and a refused change
leaves the file as it was. An image never changes, so a hotspot's place in image pixels
holds for good; where it stands on the wall follows the view (:func:`placement`).
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, field_validator

from wall_client.layout import Rect, Wall
from webapp.apps.image.store import ImageManifest, ImageStore, write_whole
from webapp.core.roles import UserGroup
from webapp.engine.wall_state import View

HOTSPOTS = "hotspots.json"
MAX_TITLE = 120
MAX_TEXT = 5_000
MAX_QUESTION = 500
MAX_ACCEPTED = 20
MAX_HOTSPOTS = 200  # per image: more would not find room for their codes on any wall
FALLBACK: dict[UserGroup, tuple[UserGroup, ...]] = {
    "k5": ("k5", "undergraduate", "medical", "research"),
    "undergraduate": ("undergraduate", "medical", "k5", "research"),
    "medical": ("medical", "undergraduate", "research", "k5"),
    "research": ("research", "medical", "undergraduate", "k5"),
}
"""Whose text a group reads when its own is empty: the nearest in level first."""


class HotspotRefused(ValueError):
    """A hotspot that is not stored; the message says why in one line."""


Accepted = Annotated[str, Field(min_length=1, max_length=200)]


class HotspotFields(BaseModel):
    """What an instructor gives a hotspot (the API's body)."""

    model_config = ConfigDict(extra="forbid", str_strip_whitespace=True)

    x: float  # image pixels from the left edge (full size)
    y: float  # image pixels from the top edge
    title: str = Field(min_length=1, max_length=MAX_TITLE)
    texts: dict[UserGroup, Annotated[str, Field(max_length=MAX_TEXT)]] = Field(
        default_factory=dict
    )  # Markdown per user group
    question: str | None = Field(default=None, max_length=MAX_QUESTION)
    accepted: list[Accepted] = Field(default_factory=list, max_length=MAX_ACCEPTED)

    @field_validator("question")
    @classmethod
    def _blank_is_none(cls, question: str | None) -> str | None:
        return question or None

    def text_for(self, group: UserGroup) -> tuple[UserGroup, str] | None:
        """The text ``group`` reads and whom it was written for (its own, else the
        nearest group's); None when the hotspot has no text at all."""
        for reader in FALLBACK[group]:
            text = self.texts.get(reader, "").strip()
            if text:
                return reader, text
        return None


class Hotspot(HotspotFields):
    """A stored hotspot: its fields and its id (stable: its codes are named by it)."""

    id: str = Field(pattern=r"^[0-9a-f]{12}$")


_LIST = TypeAdapter(list[Hotspot])


def check(fields: HotspotFields, image: ImageManifest) -> None:
    """Refuse what may not be stored, with one line saying why."""
    if not (0 <= fields.x <= image.width and 0 <= fields.y <= image.height):
        raise HotspotRefused(
            f"({fields.x:g}, {fields.y:g}) is outside the image"
            f" ({image.width} x {image.height} px)."
        )
    if fields.question and not fields.accepted:
        raise HotspotRefused("A question needs at least one accepted answer.")
    if fields.accepted and not fields.question:
        raise HotspotRefused("Accepted answers need a question.")


def encoded(spots: list[Hotspot]) -> bytes:
    """A hotspot list as ``hotspots.json`` holds it (a change, or an imported lesson)."""
    return _LIST.dump_json(spots, indent=2)


def hotspots(store: ImageStore, image_id: str) -> list[Hotspot]:
    """The hotspots of ``image_id`` in the order they were added (KeyError: no image)."""
    store.get(image_id)
    path = store.root / image_id / HOTSPOTS
    return _LIST.validate_json(path.read_bytes()) if path.is_file() else []


def change(
    store: ImageStore, image_id: str, edit: Callable[[list[Hotspot]], list[Hotspot]]
) -> list[Hotspot]:
    """Apply ``edit`` to the image's hotspots and store the result atomically, one
    change at a time (read, change, write: two instructors never lose each other's);
    what ``edit`` raises leaves the file untouched."""
    with store.locked(image_id):
        changed = edit(hotspots(store, image_id))
        if len(changed) > MAX_HOTSPOTS:
            raise HotspotRefused(f"An image has at most {MAX_HOTSPOTS} hotspots.")
        write_whole(store.root / image_id / HOTSPOTS, encoded(changed))
        return changed


def add(store: ImageStore, image_id: str, fields: HotspotFields) -> Hotspot:
    check(fields, store.get(image_id))
    added = Hotspot(id=uuid.uuid4().hex[:12], **fields.model_dump())
    change(store, image_id, lambda now: [*now, added])
    return added


def edit(store: ImageStore, image_id: str, hotspot_id: str, fields: HotspotFields) -> Hotspot:
    """Replace a hotspot's fields (KeyError: no such hotspot)."""
    check(fields, store.get(image_id))
    edited = Hotspot(id=hotspot_id, **fields.model_dump())

    def replace(now: list[Hotspot]) -> list[Hotspot]:
        if hotspot_id not in {h.id for h in now}:
            raise KeyError(hotspot_id)
        return [edited if h.id == hotspot_id else h for h in now]

    change(store, image_id, replace)
    return edited


def delete(store: ImageStore, image_id: str, hotspot_id: str) -> list[Hotspot]:
    """Remove a hotspot (KeyError: no such hotspot); the hotspots left."""

    def remove(now: list[Hotspot]) -> list[Hotspot]:
        if hotspot_id not in {h.id for h in now}:
            raise KeyError(hotspot_id)
        return [h for h in now if h.id != hotspot_id]

    return change(store, image_id, remove)


# --- on the wall -------------------------------------------------------------------------


def placement(width: int, height: int, stage: Rect, view: View) -> tuple[float, float, float]:
    """Full-size image pixels -> scene mm as ``(a, e, f)``: x = a u + e, y = a v + f.

    The one framing rule, the layer's ``Pyramid.placement`` in ``static/image.js``
    (a test holds the two to the same numbers): at zoom 1 the image is as large as
    fits on the stage, centred; the view's centre (a fraction of the stage) comes to
    the stage's middle and the view zooms about it."""
    zoom = view.zoom
    cx, cy = view.center
    fit = min(stage.width / width, stage.height / height)
    return (
        zoom * fit,
        stage.x + stage.width / 2 + zoom * ((0.5 - cx) * stage.width - width * fit / 2),
        stage.y + stage.height / 2 + zoom * ((0.5 - cy) * stage.height - height * fit / 2),
    )


def wall_points(
    image: ImageManifest, spots: list[Hotspot], wall: Wall, view: View
) -> dict[str, tuple[float, float]]:
    """Where each hotspot stands on the wall (scene mm) in ``view``, for those the wall
    shows: a hotspot off the wall, or under a designated screen (a zoomed image runs
    on under them, where a panel or a publication covers it), gets none."""
    a, e, f = placement(image.width, image.height, wall.stage, view)
    panels = [wall.viewport(d).scene_rect for d in wall.designated()]
    points: dict[str, tuple[float, float]] = {}
    for spot in spots:
        x, y = a * spot.x + e, a * spot.y + f
        on_wall = 0.0 <= x <= wall.width and 0.0 <= y <= wall.height
        if on_wall and not any(panel.contains((x, y)) for panel in panels):
            points[spot.id] = (x, y)
    return points
