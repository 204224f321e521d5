"""The public screen: what a phone shows, shown on the wall for everyone.

Every publication is stored, so the queue and the screen survive a restart, and each
decision (shown, waiting, approved, rejected, cleared) is one function here; how long a
long publication's pages stay is :class:`ScreenLayout`'s.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import Literal

from jinja2 import Environment
from pydantic import BaseModel, ConfigDict
from sqlalchemy import select
from sqlalchemy.orm import Session

from wall_client.layout import Wall
from webapp.core.settings import Settings
from webapp.core.threads import run_blocking
from webapp.database.connection import Database
from webapp.database.models import PublicationRecord
from webapp.engine.wall_state import PublicItem, PublicPolicy, WallState, now_ms
from webapp.people.person import Person
from webapp.publishing.publication import Publication, render_item
from webapp.web.context import AppContext

Status = Literal["shown", "pending", "rejected", "cleared"]


# Readable type from the seats: capital letters should subtend at least 16 minutes of arc
# for reading (ANSI/HFES 100-2007; 20-22' preferred), and system-ui capitals are about
# 0.7 em tall. On the demo wall (0.63 mm pixels, seats at 2 m) that is 22 px, the
# largest type 32 px (24'); shrinking stops at the minimum, then the screen pages.
MIN_CAP_ARCMIN = 16.0


MAX_CAP_ARCMIN = 24.0


CAP_HEIGHT_EM = 0.7


class ScreenLayout(BaseModel):
    """How public tiles lay a publication out: in one box of CSS pixels, the same on
    every public display of the wall (then scaled to each), so they all cut the same
    pages and show the same one at the same time."""

    model_config = ConfigDict(extra="forbid")

    box: tuple[int, int]  # the smallest public framebuffer, px
    min_font_px: int  # body type never smaller than what the seats can read
    max_font_px: int
    words_per_minute: int  # a page stays up as long as reading its words takes ...
    page_min_ms: int  # ... and never shorter than this


def screen_layout(wall: Wall, settings: Settings) -> ScreenLayout | None:
    """The wall's public screen layout (None: the wall has no public display)."""
    displays = wall.screen("public")
    if not displays:
        return None

    def font_px(display_mm_per_px: float, arcmin: float) -> int:
        cap_mm = wall.seat_distance_m * 1000 * math.tan(math.radians(arcmin / 60))
        return math.ceil(cap_mm / CAP_HEIGHT_EM / display_mm_per_px)

    # The coarsest pixels need the most of them; the box is what every display holds.
    pitch = min(d.mm_per_px for d in displays)
    return ScreenLayout(
        box=(min(d.resolution[0] for d in displays), min(d.resolution[1] for d in displays)),
        min_font_px=font_px(pitch, MIN_CAP_ARCMIN),
        max_font_px=font_px(pitch, MAX_CAP_ARCMIN),
        words_per_minute=settings.public_words_per_minute,
        page_min_ms=round(settings.public_page_min_s * 1000),
    )


class PublishRefused(Exception):
    """Publishing is not possible now (the screen is locked); the message says why."""


def _show(record: PublicationRecord) -> PublicItem:
    return PublicItem(
        id=record.id,
        title=record.title,
        html=record.html,
        author=record.author,
        published_at=int(record.created_at.timestamp() * 1000),
    )


async def _put_on_screen(context: AppContext, wall: Wall, item: PublicItem | None) -> None:
    await context.change_wall(wall, lambda state: state.model_copy(update={"public": item}))


async def submit(
    context: AppContext,
    wall: Wall,
    state: WallState,
    templates: Environment,
    person: Person,
    publication: Publication,
    source: str,
) -> PublicationRecord:
    """Publish for ``person``: shown at once, or queued when moderation holds students."""
    policy = state.public_policy
    if policy.locked and not person.is_staff:
        raise PublishRefused("The instructor has locked the public screen for now.")
    status: Status = "pending" if policy.moderated and not person.is_staff else "shown"
    now = now_ms()
    record = PublicationRecord(
        wall_id=wall.id,
        visitor_id=person.visitor.id,
        author=person.public_name[:100],
        title=publication.title,
        html=render_item(templates, publication, person.public_name, now),
        source=source[:200],
        status=status,
        created_at=datetime.fromtimestamp(now / 1000, UTC),
    )

    def store() -> None:
        with context.db.session() as session:
            if status == "shown":
                _retire_shown(session, wall.id)
            session.add(record)

    await run_blocking(store)
    if status == "shown":
        await _put_on_screen(context, wall, _show(record))
    return record


def _retire_shown(session: Session, wall_id: str) -> None:
    """What the screen showed before is no longer shown (one item at a time)."""
    for shown in session.scalars(
        select(PublicationRecord).where(
            PublicationRecord.wall_id == wall_id, PublicationRecord.status == "shown"
        )
    ):
        shown.status = "cleared"


async def decide(
    context: AppContext, wall: Wall, publication_id: int, approve: bool, actor: str
) -> PublicationRecord:
    """Approve (show) or reject a waiting publication; KeyError if none is waiting."""

    def store() -> PublicationRecord:
        with context.db.session() as session:
            record = session.get(PublicationRecord, publication_id)
            if record is None or record.wall_id != wall.id or record.status != "pending":
                raise KeyError(publication_id)
            if approve:
                _retire_shown(session, wall.id)
            record.status = "shown" if approve else "rejected"
            record.decided_at = datetime.now(UTC)
            record.decided_by = actor[:120]
            return record

    record = await run_blocking(store)
    if approve:
        await _put_on_screen(context, wall, _show(record))
    return record


async def clear(context: AppContext, wall: Wall) -> None:
    """Empty the public screen."""

    def store() -> None:
        with context.db.session() as session:
            _retire_shown(session, wall.id)

    await run_blocking(store)
    await _put_on_screen(context, wall, None)


async def set_policy(context: AppContext, wall: Wall, policy: PublicPolicy) -> None:
    await context.change_wall(
        wall, lambda state: state.model_copy(update={"public_policy": policy})
    )


def waiting(db: Database, wall_id: str) -> list[PublicationRecord]:
    """The moderation queue, oldest first."""
    with db.session() as session:
        return list(
            session.scalars(
                select(PublicationRecord)
                .where(PublicationRecord.wall_id == wall_id, PublicationRecord.status == "pending")
                .order_by(PublicationRecord.id)
            )
        )


# What became of a publication, in the words its author reads on their phone.
OUTCOMES = {
    "pending": "waiting for the instructor to look at it",
    "shown": "on the public screen now",
    "cleared": "was on the public screen",
    "rejected": "not shown: the instructor declined it",
}
OWN_LISTED = 5


def own(db: Database, visitor_id: str, limit: int = OWN_LISTED) -> list[PublicationRecord]:
    """A visitor's latest publications, newest first, so their phone can say what
    became of each (waiting, shown, declined)."""
    with db.session() as session:
        return list(
            session.scalars(
                select(PublicationRecord)
                .where(PublicationRecord.visitor_id == visitor_id)
                .order_by(PublicationRecord.id.desc())
                .limit(limit)
            )
        )
