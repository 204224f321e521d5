"""HTTP API models of the core's routes (websocket messages are in ``protocol``)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, HttpUrl, UrlConstraints, model_validator

from wall_client.layout import Wall
from webapp.classes.roll import ChosenNameMode, NameMode
from webapp.database.models import PublicationRecord
from webapp.engine.hub import TileStatus
from webapp.engine.wall_state import PublicItem, PublicPolicy, View, VolumeLayer
from webapp.tags.registry import PLACE, ContactSpec, Place, TagSpec
from webapp.tags.schemas import UnplacedCode


class DisplayInfo(BaseModel):
    id: str
    rect: tuple[float, float, float, float]
    resolution: tuple[int, int]
    rotation: int
    node: str
    index: int
    roles: list[str]
    scene_rect: tuple[float, float, float, float]
    to_wall: tuple[float, float, float, float, float, float]
    to_pixels: tuple[float, float, float, float, float, float]  # scene mm -> native px


class WallInfo(BaseModel):
    """A wall's layout as the overview and the dashboard draw it."""

    id: str
    name: str
    width: float
    height: float
    bezel_mode: str
    time_zone: str  # the times the dashboard shows are the wall's
    stage: tuple[float, float, float, float]  # the scene rect pictures are framed on (mm)
    displays: list[DisplayInfo]

    @classmethod
    def of(cls, wall: Wall) -> WallInfo:
        roles = {
            display_id: [role for role, ids in wall.screens.items() if display_id in ids]
            for display_id in (d.id for d in wall.displays)
        }
        displays = []
        for display in wall.displays:
            viewport = wall.viewport(display.id)
            displays.append(
                DisplayInfo(
                    id=display.id,
                    rect=display.rect.xywh,
                    resolution=display.resolution,
                    rotation=display.rotation,
                    node=display.node,
                    index=display.index,
                    roles=roles[display.id],
                    scene_rect=viewport.scene_rect.xywh,
                    to_wall=viewport.to_wall,
                    to_pixels=viewport.to_pixels,
                )
            )
        return cls(
            id=wall.id,
            name=wall.name,
            width=wall.width,
            height=wall.height,
            bezel_mode=wall.bezel_mode,
            time_zone=wall.time_zone,
            stage=wall.stage.xywh,
            displays=displays,
        )


class TileStatusInfo(BaseModel):
    tile_id: str
    connected: bool
    connections: int
    connected_since: int | None
    last_seen: int | None
    version: int | None
    applied_at: float | None
    address: str | None
    notes: list[str]  # what it shows otherwise than asked ("shows the flat map: no WebGL")

    @classmethod
    def of(cls, status: TileStatus) -> TileStatusInfo:
        return cls(connected=status.connections > 0, **status.model_dump())


class WallStatus(BaseModel):
    wall: str
    version: int
    state: dict[str, Any]
    tiles: list[TileStatusInfo]


class ChangeResult(BaseModel):
    wall: str
    version: int
    changed: list[str]


class TagInfo(BaseModel):
    code: str
    name: str | None
    label: str
    wall: str
    app: str
    action: str
    params: dict[str, Any]
    kind: str
    payload: str
    tag_set: str | None
    anchor: tuple[float, float] | None
    screen: str | None
    slot: int
    size_mm: float | None
    clear_mm: float | None
    active: bool
    expires_at: datetime | None
    created_at: datetime
    created_by: str
    svg_url: str
    png_url: str


class TagSetChoice(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str | None = Field(max_length=64)


class TagSetsInfo(BaseModel):
    wall: str
    active: str | None
    sets: list[str]
    layout: int
    placed: int
    unplaced: list[UnplacedCode]


class PublicationInfo(BaseModel):
    """A publication as the dashboard's moderation queue lists it."""

    id: int
    author: str
    title: str
    html: str
    status: str
    created_at: datetime

    @classmethod
    def of(cls, record: PublicationRecord) -> PublicationInfo:
        return cls(
            id=record.id,
            author=record.author,
            title=record.title,
            html=record.html,
            status=record.status,
            created_at=record.created_at,
        )


class PublicScreenInfo(BaseModel):
    shown: PublicItem | None
    policy: PublicPolicy
    waiting: list[PublicationInfo]


class VolumeInfo(BaseModel):
    """A built volume the wall can show."""

    name: str
    source: str
    shape: tuple[int, int, int]
    spacing: tuple[float, float, float]
    brick: int
    levels: int
    stored_bricks: int
    empty_bricks: int
    fallback_level: int


class VolumeScene(BaseModel):
    """What a tile asks the server to render: the wall's view and its volume layer."""

    model_config = ConfigDict(extra="forbid")

    view: View
    volume: VolumeLayer


class TileDetail(BaseModel):
    """The level of detail one tile shows (the dashboard's level-of-detail map)."""

    tile_id: str
    level: int
    bricks: int
    voxels: int
    pixel_scale: int  # tile pixels per rendered pixel


class VolumeDetail(BaseModel):
    wall: str
    version: int
    volume: str
    budget: int
    levels: int
    fallback_level: int
    tiles: list[TileDetail]


class ClassStart(BaseModel):
    """Start class: which app in which of its modes, how students are named."""

    model_config = ConfigDict(extra="forbid")

    title: str = Field(default="", max_length=200)  # made plain and short
    app: str | None = Field(default=None, max_length=64)  # None: the app on the wall
    mode: str | None = Field(default=None, max_length=64)  # None: the app's first mode
    names: ChosenNameMode = "anonymous"


class ExportLink(BaseModel):
    label: str
    url: str


class CourseInfo(BaseModel):
    """A class launched from a course (LTI): the course's students by name, who joined
    and who is missing, and how its grades stand in the course's gradebook."""

    joined: list[str]
    missing: list[str]
    roster_problem: str  # why the course's roster could not be read ("": it was)
    graded: bool  # the link has a gradebook column for the class's scores
    grades_posted: int
    grades_waiting: int  # not accepted yet: tried again
    grades_problem: str  # the last reason a score was not accepted
    next_try_at: datetime | None


class ClassInfo(BaseModel):
    """A class at a wall as the dashboard shows it (the running one, else the last)."""

    id: int
    title: str
    names: NameMode
    running: bool
    started_at: datetime
    ended_at: datetime | None
    joined: int  # students on the roll
    exports: list[ExportLink]  # what the class produced, once it ended
    course: CourseInfo | None = None  # a class launched from a course (LTI)


OWN_APP = "core"
"""The app of an instructor's own codes: the core's, like the registration codes."""
OwnKind = Literal["link", "text", "contact", "phone"]
WebAddress = Annotated[HttpUrl, UrlConstraints(max_length=500, allowed_schemes=["http", "https"])]


class PlaceChoice(BaseModel):
    """A place of the material on the wall, as ``GET /api/walls/{wall}/places`` names it."""

    model_config = ConfigDict(extra="forbid")

    app: str = Field(min_length=1, max_length=64)
    id: str = Field(min_length=1, max_length=100)


class OwnCode(BaseModel):
    """A code of the instructor's own at a point of the wall (``anchor``, wall mm) or at
    a place of the material the wall shows now (``place``: a hotspot of the image, which
    it follows as the view moves): a web page to open, a text to read, a contact to save
    or a number to call. A link goes through the server (its scans are counted, and
    switching it off works on printed copies too); the others carry their content in
    the symbol."""

    model_config = ConfigDict(extra="forbid")

    kind: OwnKind
    label: str = Field(min_length=1, max_length=60)  # its caption on the wall
    url: WebAddress | None = None
    text: str | None = Field(default=None, min_length=1, max_length=500)
    number: str | None = Field(default=None, min_length=1, max_length=40)
    contact: ContactSpec | None = None
    anchor: tuple[float, float] | None = None
    place: PlaceChoice | None = None

    @model_validator(mode="after")
    def _one_point(self) -> OwnCode:
        if (self.anchor is None) == (self.place is None):
            raise ValueError("give the code either a point of the wall (anchor) or a place")
        return self

    def spec(self, place: Place | None = None) -> TagSpec:
        """The tag that stands for it, at its anchor or at ``place`` (the one it names,
        where the wall shows it now; the tag keeps it, to follow it); the tag's own
        checks apply: a text QR codes cannot carry is refused."""
        common: dict[str, Any] = {"label": self.label, "app": OWN_APP, "anchor": self.anchor}
        bound = {}
        if place is not None:
            common |= {"anchor": place.anchor, "clear_mm": place.clear_mm}
            bound = {PLACE: place.binding()}
        if self.kind == "link":
            if self.url is None:
                raise ValueError("a link needs its url")
            return TagSpec(**common, action="link", params={"url": str(self.url), **bound})
        note: dict[str, Any] = {**common, "action": "note", "params": bound}
        if self.kind == "text":
            return TagSpec(**note, kind="text", text=self.text)
        if self.kind == "phone":
            return TagSpec(**note, kind="tel", number=self.number)
        return TagSpec(**note, kind="vcard", contact=self.contact)


class OwnCodeInfo(TagInfo):
    """An own code as the dashboard lists it: the tag, and whether the wall shows it
    now (a code at a place not in view, or one switched off, is not on the wall)."""

    on_wall: bool
