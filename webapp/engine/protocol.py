"""Websocket messages between the server and tiles (and read-only viewers).

Every frame is one JSON object whose ``type`` names one of the models below.
``docs/protocol.md`` documents each; a test fails when one is undocumented.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, TypeAdapter

from wall_client.layout import Viewport

NOTE_CHARS = 200  # a note on the dashboard: one line
MAX_NOTES = 8


def _cut(limit: int) -> BeforeValidator:
    """Longer than ``limit`` (a text, a list): cut, not refused (a tile's words about
    itself never cost it its socket)."""
    return BeforeValidator(lambda value: value[:limit] if isinstance(value, str | list) else value)


class Message(BaseModel):
    model_config = ConfigDict(extra="forbid")


# --- tile -> server -------------------------------------------------------------


class Hello(Message):
    """First frame of a connection: the version the tile already shows (None if none)."""

    type: Literal["hello"] = "hello"
    last_version: int | None = Field(default=None, ge=0)


class Ping(Message):
    """Clock probe; ``t0`` is the tile's clock when sent (ms)."""

    type: Literal["ping"] = "ping"
    t0: float


class Ready(Message):
    """The tile has loaded everything a prepared change needs and can swap."""

    type: Literal["ready"] = "ready"
    version: int = Field(ge=1)


Note = Annotated[str, _cut(NOTE_CHARS)]


class Applied(Message):
    """Report: the tile drew ``version`` at ``server_time`` (its estimate, ms); ``notes``
    say in words what it shows otherwise than asked (a layer's fallback), for the
    dashboard."""

    type: Literal["applied"] = "applied"
    version: int = Field(ge=0)
    server_time: float
    notes: Annotated[list[Note], _cut(MAX_NOTES)] = Field(default_factory=list)


ClientMessage = Annotated[Hello | Ping | Ready | Applied, Field(discriminator="type")]
CLIENT_MESSAGES: TypeAdapter[Hello | Ping | Ready | Applied] = TypeAdapter(ClientMessage)


# --- server -> tile -------------------------------------------------------------


class ViewportInfo(Message):
    """A tile's viewport as computed by ``wall_client.layout`` (tiles never re-derive it)."""

    display_id: str
    scene_rect: tuple[float, float, float, float]
    pixels: tuple[int, int]
    to_pixels: tuple[float, float, float, float, float, float]
    to_wall: tuple[float, float, float, float, float, float]

    @classmethod
    def of(cls, viewport: Viewport) -> ViewportInfo:
        return cls(
            display_id=viewport.display_id,
            scene_rect=viewport.scene_rect.xywh,
            pixels=viewport.pixels,
            to_pixels=viewport.to_pixels,
            to_wall=viewport.to_wall,
        )


class Snapshot(Message):
    """The whole state at ``version``: sent after hello when replay is impossible."""

    type: Literal["snapshot"] = "snapshot"
    wall: str
    version: int
    state: dict[str, Any]
    server_time: int
    viewport: ViewportInfo | None = None  # None for read-only viewers


class Event(Message):
    """A light change: merge ``changes`` into the state at ``apply_at`` (server ms)."""

    type: Literal["event"] = "event"
    version: int
    changes: dict[str, Any]
    apply_at: int


class Prepare(Message):
    """A heavy change: load what it needs, then answer ``ready``; apply only at ``swap``."""

    type: Literal["prepare"] = "prepare"
    version: int
    changes: dict[str, Any]


class Swap(Message):
    """Apply the prepared change ``version`` at ``apply_at`` (server ms)."""

    type: Literal["swap"] = "swap"
    version: int
    apply_at: int


class Pong(Message):
    """Answer to ping: the tile's ``t0``, server receive ``t1`` and send ``t2`` times (ms)."""

    type: Literal["pong"] = "pong"
    t0: float
    t1: float
    t2: float


class DashboardStatus(Message):
    """To dashboards, every second: the wall's status and the moderation queue."""

    type: Literal["status"] = "status"
    status: dict[str, Any]  # version, state and tiles, as GET /api/walls/{wall}/status
    waiting: list[dict[str, Any]]  # publications waiting for approval, oldest first
    class_session: dict[str, Any] | None = None  # the class running, as GET .../class


class ScanSeen(Message):
    """To dashboards, as it happens: a code of the wall was scanned."""

    type: Literal["scan"] = "scan"
    wall: str
    code: str
    label: str
    app: str
    visitor: str  # a short pseudonym of the visitor, stable per visitor
    at: int  # server ms


ServerMessage = Snapshot | Event | Prepare | Swap | Pong

# Close codes (RFC 6455 and the registered 4xxx private range).
CLOSE_POLICY = 1008  # bad token, bad or forbidden frame
CLOSE_TOO_BIG = 1009  # frame over the size limit
CLOSE_TRY_AGAIN = 1013  # too slow to keep up: reconnect and resync by snapshot
CLOSE_UNKNOWN = 4404  # unknown wall or tile
