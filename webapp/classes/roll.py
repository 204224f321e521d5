"""A class at a wall and its roll: who joined, under which name.

An instructor starts a class from the dashboard and ends it there; at most one class
of a wall runs at a time (the database says no to a second). While it runs, a
student's first scan of the wall's codes joins them: silently when the class is
anonymous, after a page asking for the nickname or roster id the class wants. The
roll gives the dashboard its live count and an export its names.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any, Literal, get_args
from zoneinfo import ZoneInfo

from sqlalchemy import Row, and_, bindparam, func, select, update
from sqlalchemy.exc import IntegrityError
from starlette.requests import HTTPConnection

from webapp.core.settings import Settings
from webapp.core.threads import run_blocking
from webapp.database.connection import Database, as_utc, is_row_id
from webapp.database.models import ClassMemberRecord, ClassRecord
from webapp.people.addresses import AddressRules
from webapp.people.person import person_with, plain_text

NameMode = Literal["anonymous", "nickname", "roster"]
NAME_MODES: tuple[NameMode, ...] = get_args(NameMode)
NAME_PROMPTS: dict[NameMode, str] = {
    "anonymous": "No names",
    "nickname": "A nickname",
    "roster": "A roster id (student number)",
}
"""What the dashboard offers; the join page asks for the class's kind of name."""
MAX_NAME = 40
MAX_TITLE = 80


class ClassError(Exception):
    """What cannot be done with a class now; the message says why, in people's words."""


@dataclass(frozen=True)
class ClassSession:
    """One class at a wall (running while ``ended_at`` is None)."""

    id: int
    wall_id: str
    title: str
    names: NameMode
    started_at: datetime
    ended_at: datetime | None = None

    @property
    def running(self) -> bool:
        return self.ended_at is None

    def holds(self, when: datetime) -> bool:
        """Whether ``when`` falls within the class (a round started then belongs to it)."""
        return self.started_at <= when and (self.ended_at is None or when <= self.ended_at)


@dataclass(frozen=True)
class Standing:
    """Where a visitor stands with the wall's running class."""

    session: ClassSession
    joined: bool


def _session(row: ClassRecord | Row[Any]) -> ClassSession:
    names: NameMode = row.names if row.names in NAME_MODES else "anonymous"
    return ClassSession(
        id=row.id,
        wall_id=row.wall_id,
        title=row.title,
        names=names,
        started_at=as_utc(row.started_at),
        ended_at=as_utc(row.ended_at) if row.ended_at else None,
    )


def clean_title(text: str, local_start: datetime) -> str:
    """A class's title as kept: plain text, bounded; none given names it by its start
    as people at the wall read it (``local_start``, in the wall's time zone), so the
    title agrees with the dashboard's start time and the export's day."""
    title = plain_text(text)[:MAX_TITLE].strip()
    return title or f"Class of {local_start:%Y-%m-%d %H:%M}"


def clean_name(text: str, names: NameMode) -> str:
    """A student's name for a class as kept: plain text, at most :data:`MAX_NAME`
    characters, never empty (the class asked for it)."""
    name = plain_text(text)
    what = "roster id" if names == "roster" else "nickname"
    if not name:
        raise ClassError(f"Please type your {what}.")
    if len(name) > MAX_NAME:
        raise ClassError(f"A {what} has at most {MAX_NAME} characters.")
    return name


# --- a class from start to end ----------------------------------------------------------


def start_class(
    db: Database,
    wall_id: str,
    title: str,
    names: NameMode,
    started_by: str,
    time_zone: str = "UTC",
) -> ClassSession:
    """A new class at ``wall_id`` (whose clock reads ``time_zone``); the class running
    there ends (two starts at once: one wins, the other is told to try again)."""
    now = datetime.now(UTC)
    try:
        with db.session() as session:
            session.execute(
                update(ClassRecord)
                .where(ClassRecord.wall_id == wall_id, ClassRecord.ended_at.is_(None))
                .values(ended_at=now, ended_by=started_by)
            )
            record = ClassRecord(
                wall_id=wall_id,
                title=clean_title(title, now.astimezone(ZoneInfo(time_zone))),
                names=names,
                started_at=now,
                started_by=started_by,
            )
            session.add(record)
            session.flush()
            return _session(record)
    except IntegrityError as error:
        raise ClassError("Another class was started at the same moment; try again.") from error


def end_class(db: Database, wall_id: str, ended_by: str) -> ClassSession | None:
    """End the class running at ``wall_id``: the ended class, or None when none ran."""
    with db.session() as session:
        record = session.scalars(
            select(ClassRecord).where(
                ClassRecord.wall_id == wall_id, ClassRecord.ended_at.is_(None)
            )
        ).first()
        if record is None:
            return None
        record.ended_at = datetime.now(UTC)
        record.ended_by = ended_by
        session.flush()
        return _session(record)


def get_class(db: Database, class_id: int) -> ClassSession | None:
    """The class ``class_id`` (from a join page's address: any number), None when
    there is none."""
    if not is_row_id(class_id):
        return None
    with db.reading() as connection:
        row = connection.execute(
            select(ClassRecord.__table__).where(ClassRecord.id == class_id)
        ).first()
    return _session(row) if row is not None else None


def running_class(db: Database, wall_id: str) -> ClassSession | None:
    with db.reading() as connection:
        row = connection.execute(
            select(ClassRecord.__table__).where(
                ClassRecord.wall_id == wall_id, ClassRecord.ended_at.is_(None)
            )
        ).first()
    return _session(row) if row is not None else None


def latest_class(db: Database, wall_id: str) -> ClassSession | None:
    """The class running at ``wall_id``, else the last one that ran there."""
    with db.reading() as connection:
        row = connection.execute(
            select(ClassRecord.__table__)
            .where(ClassRecord.wall_id == wall_id)
            .order_by(ClassRecord.id.desc())
            .limit(1)
        ).first()
    return _session(row) if row is not None else None


def class_at(db: Database, wall_id: str, when: datetime) -> ClassSession | None:
    """The class that ran at ``wall_id`` when ``when`` happened (None: none did)."""
    with db.reading() as connection:
        row = connection.execute(
            select(ClassRecord.__table__)
            .where(
                ClassRecord.wall_id == wall_id,
                ClassRecord.started_at <= when,
                (ClassRecord.ended_at.is_(None)) | (ClassRecord.ended_at >= when),
            )
            .order_by(ClassRecord.id.desc())
            .limit(1)
        ).first()
    return _session(row) if row is not None else None


# --- the roll -----------------------------------------------------------------------------

# Every scan of a wall with a class running asks this: built once (see Database.reading).
_STANDING = (
    select(ClassRecord.__table__, ClassMemberRecord.visitor_id.label("member"))
    .outerjoin(
        ClassMemberRecord,
        and_(
            ClassMemberRecord.class_id == ClassRecord.id,
            ClassMemberRecord.visitor_id == bindparam("visitor_id"),
        ),
    )
    .where(ClassRecord.wall_id == bindparam("wall_id"), ClassRecord.ended_at.is_(None))
)


def standing(db: Database, wall_id: str, visitor_id: str) -> Standing | None:
    """The wall's running class and whether the visitor joined it (None: no class runs),
    in one query: every scan of the wall asks."""
    with db.reading() as connection:
        row = connection.execute(_STANDING, {"wall_id": wall_id, "visitor_id": visitor_id}).first()
    return None if row is None else Standing(_session(row), joined=row.member is not None)


def join(db: Database, class_id: int, visitor_id: str, name: str = "") -> ClassSession:
    """Put the visitor on the roll of a running class (again: their name changes).

    ``name`` is checked against what the class asks for: none for an anonymous class.
    """
    try:
        return _join(db, class_id, visitor_id, name)
    except IntegrityError:  # the same phone joining twice at once: the second renames
        return _join(db, class_id, visitor_id, name)


def _join(db: Database, class_id: int, visitor_id: str, name: str) -> ClassSession:
    with db.session() as session:
        record = session.get(ClassRecord, class_id) if is_row_id(class_id) else None
        if record is None or record.ended_at is not None:
            raise ClassError("This class has ended.")
        held = _session(record)
        kept = "" if held.names == "anonymous" else clean_name(name, held.names)
        member = session.get(ClassMemberRecord, (class_id, visitor_id))
        if member is None:
            session.add(ClassMemberRecord(class_id=class_id, visitor_id=visitor_id, name=kept))
        else:
            member.name = kept
    return held


def joined_count(db: Database, class_id: int) -> int:
    with db.reading() as connection:
        count = connection.scalar(
            select(func.count()).where(ClassMemberRecord.class_id == class_id)
        )
    return int(count or 0)


def roll_names(db: Database, class_id: int) -> dict[str, str]:
    """Visitor id -> the name given for the class ("" in an anonymous class)."""
    with db.reading() as connection:
        rows = connection.execute(
            select(ClassMemberRecord.visitor_id, ClassMemberRecord.name).where(
                ClassMemberRecord.class_id == class_id
            )
        ).all()
    return {row.visitor_id: row.name for row in rows}


async def roll_call(
    request: HTTPConnection,
    db: Database,
    settings: Settings,
    address: str,
    rules: AddressRules,
    wall_id: str,
    visitor_id: str,
) -> int | None:
    """The one rule of a running class's roll, asked before every scan of its wall: a
    student not on the roll joins it, at once in an anonymous class; for a class that
    asks a name, the id of the class whose join page asks it first. None: go on with
    the scan. Staff are never asked.

    The scan's app wants the person too: both come in one short read (on the loop for
    SQLite; one hand-off to a thread, not two, for a database server)."""
    person, now = await person_with(
        request, db, settings, address, rules, standing, db, wall_id, visitor_id
    )
    if now is None or now.joined or person.is_staff:
        return None
    if now.session.names != "anonymous":
        return now.session.id
    with contextlib.suppress(ClassError):  # ended meanwhile: nothing to join
        await run_blocking(join, db, now.session.id, visitor_id)
    return None
