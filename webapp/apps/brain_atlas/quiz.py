"""The brain atlas quiz as stored: rounds, each visitor's answers, who finished.

The answer key is the dissertation's example of confidential data, so a round guards
it three ways. Each round numbers its pins in a fresh random order (pin 1 is no
particular region, and the wall issues new codes with each round: see
``BrainApp.declare_tags``). A visitor answers each pin of a set once in a round,
changing answers until they finish; finishing makes them final. Correct names reach
students only when the instructor closes the round (the default) or, when the
instructor chose that for the round, at finishing. A throw-away visitor who finishes
at once therefore learns nothing while answers still count; and once the round is
closed, no answer is taken any more.

Rounds are numbered per wall; the wall state names the round the wall shows
(``BrainState.quiz_round``, the brain's slot of the wall state), so starting one goes
through the one door for state changes and its codes arrive in the same swap as its numbering.
"""

from __future__ import annotations

import csv
import io
import secrets
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any, Literal, get_args
from zoneinfo import ZoneInfo

from sqlalchemy import Connection, Row, bindparam, func, insert, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from webapp.apps.brain_atlas.content import Region, TagSetName
from webapp.apps.brain_atlas.matching import MAX_ANSWER_LENGTH
from webapp.classes.roll import ClassSession, class_at, roll_names
from webapp.database.connection import Database, as_utc
from webapp.database.models import (
    BrainAnswerRecord,
    BrainQuizFinishRecord,
    BrainQuizRoundRecord,
    VisitorRecord,
)
from webapp.people.person import plain_text

COMMON_WRONG = 3  # wrong answers listed per region on the dashboard
Reveal = Literal["close", "finish"]
REVEALS: tuple[Reveal, ...] = get_args(Reveal)


class QuizError(Exception):
    """Something the visitor cannot do now; the message says why, in their words."""


@dataclass(frozen=True)
class Round:
    """One round of a wall's quiz: its pin order per set, and whether it still runs."""

    wall_id: str
    number: int
    orders: dict[str, list[str]]
    reveal: Reveal
    started_at: datetime
    closed_at: datetime | None = None
    last_answer_at: datetime | None = None

    @property
    def open(self) -> bool:
        return self.closed_at is None

    def pins(self, tag_set: TagSetName, regions: Sequence[Region]) -> dict[int, Region]:
        """Pin number -> region for ``tag_set`` (its regions in the content's order).

        Pin n is the n-th region of the round's order. A region the content gained
        after the round started gets a number after the others; one it lost leaves
        its number unused, so no other pin changes its number mid-round.
        """
        by_id = {region.id: region for region in regions}
        order = list(self.orders.get(tag_set, []))
        order += [region.id for region in regions if region.id not in order]
        return {n: by_id[rid] for n, rid in enumerate(order, start=1) if rid in by_id}

    def names_shown(self, finished: bool) -> bool:
        """The one rule for when a student sees the correct names (and which answers
        were right): once the round is closed, or at finishing where the instructor
        chose that for the round. Finishing early reveals nothing otherwise, so a
        throw-away visitor cannot harvest the key while answers still count."""
        return not self.open or (self.reveal == "finish" and finished)


@dataclass(frozen=True)
class Answer:
    region_id: str
    text: str
    correct: bool


@dataclass(frozen=True)
class Progress:
    """Where a visitor stands in one set's quiz of one round."""

    answers: dict[str, Answer]
    finished: bool

    def complete(self, regions: Sequence[Region]) -> bool:
        return all(r.id in self.answers for r in regions)


@dataclass(frozen=True)
class RegionStats:
    region_id: str
    answered: int
    correct: int
    common_wrong: list[tuple[str, int]]

    @property
    def share_correct(self) -> float | None:
        return self.correct / self.answered if self.answered else None


@dataclass(frozen=True)
class QuizStats:
    round: int
    participants: int
    answers: int
    finished: int
    regions: list[RegionStats] = field(default_factory=list)


def new_order(regions: Sequence[Region]) -> list[str]:
    """Region ids in a fresh random order (a CSPRNG: the order is the key)."""
    order = [region.id for region in regions]
    secrets.SystemRandom().shuffle(order)
    return order


def clean_answer(text: str) -> str:
    """An answer as stored: plain text, bounded; empty answers are refused."""
    cleaned = plain_text(text)
    if not cleaned:
        raise QuizError("Please type a name before sending.")
    if len(cleaned) > MAX_ANSWER_LENGTH:
        raise QuizError(f"That is longer than any region's name ({MAX_ANSWER_LENGTH} characters).")
    return cleaned


# --- rounds --------------------------------------------------------------------------


def _round(record: BrainQuizRoundRecord | Row[Any]) -> Round:
    reveal: Reveal = "finish" if record.reveal == "finish" else "close"
    return Round(
        wall_id=record.wall_id,
        number=record.number,
        orders={key: list(value) for key, value in record.orders.items()},
        reveal=reveal,
        started_at=as_utc(record.started_at),
        closed_at=as_utc(record.closed_at) if record.closed_at else None,
        last_answer_at=as_utc(record.last_answer_at) if record.last_answer_at else None,
    )


# A phone's pages and answers run these: built once (see Database.reading).
_ROUND = select(BrainQuizRoundRecord.__table__).where(
    BrainQuizRoundRecord.wall_id == bindparam("wall_id"),
    BrainQuizRoundRecord.number == bindparam("number"),
)
_ANSWERS = select(
    BrainAnswerRecord.region_id, BrainAnswerRecord.answer, BrainAnswerRecord.correct
).where(
    BrainAnswerRecord.wall_id == bindparam("wall_id"),
    BrainAnswerRecord.round == bindparam("number"),
    BrainAnswerRecord.visitor_id == bindparam("visitor_id"),
    BrainAnswerRecord.tag_set == bindparam("tag_set"),
)
_FINISHED = select(BrainQuizFinishRecord.visitor_id).where(
    BrainQuizFinishRecord.wall_id == bindparam("wall_id"),
    BrainQuizFinishRecord.round == bindparam("number"),
    BrainQuizFinishRecord.visitor_id == bindparam("visitor_id"),
    BrainQuizFinishRecord.tag_set == bindparam("tag_set"),
)
_CLAIM_OPEN = (
    update(BrainQuizRoundRecord)
    .where(
        BrainQuizRoundRecord.wall_id == bindparam("of_wall"),
        BrainQuizRoundRecord.number == bindparam("of_round"),
        BrainQuizRoundRecord.closed_at.is_(None),
    )
    .values(last_answer_at=bindparam("now"))
)
_CHANGE_ANSWER = (
    update(BrainAnswerRecord)
    .where(
        BrainAnswerRecord.wall_id == bindparam("of_wall"),
        BrainAnswerRecord.round == bindparam("of_round"),
        BrainAnswerRecord.visitor_id == bindparam("of_visitor"),
        BrainAnswerRecord.tag_set == bindparam("of_set"),
        BrainAnswerRecord.region_id == bindparam("of_region"),
    )
    .values(answer=bindparam("text"), correct=bindparam("is_correct"))
)
_NEW_ANSWER = insert(BrainAnswerRecord)


def get_round(db: Database, wall_id: str, number: int) -> Round | None:
    with db.reading() as connection:
        row = connection.execute(_ROUND, {"wall_id": wall_id, "number": number}).first()
    return _round(row) if row is not None else None


def start_round(
    db: Database,
    wall_id: str,
    started_by: str,
    orders: dict[str, list[str]],
    reveal: Reveal = "close",
) -> Round:
    """A new round with ``orders`` as its pin numbering; the round before it closes.

    The caller puts it on the wall (``BrainState.quiz_round``, the brain's slot of the
    wall state), which brings the round's codes.
    """
    for _ in range(3):
        try:
            with db.session() as session:
                number = (_latest_number(session, wall_id) or 0) + 1
                session.execute(
                    update(BrainQuizRoundRecord)
                    .where(
                        BrainQuizRoundRecord.wall_id == wall_id,
                        BrainQuizRoundRecord.closed_at.is_(None),
                    )
                    .values(closed_at=datetime.now(UTC), closed_by=started_by)
                )
                record = BrainQuizRoundRecord(
                    wall_id=wall_id,
                    number=number,
                    started_by=started_by,
                    orders=orders,
                    reveal=reveal,
                )
                session.add(record)
                session.flush()
                return _round(record)
        except IntegrityError:  # two starts at once: the other one won, go after it
            continue
    raise QuizError("A new round is being started by someone else; try again.")


def open_round(db: Database, wall_id: str, started_by: str, orders: dict[str, list[str]]) -> Round:
    """The wall's latest round if it is still open, else a new one with ``orders``
    (the brain coming on a wall for the first time: every server process may ask)."""
    with db.session() as session:
        number = _latest_number(session, wall_id)
        record = session.get(BrainQuizRoundRecord, (wall_id, number)) if number else None
        if record is not None and record.closed_at is None:
            return _round(record)
    return start_round(db, wall_id, started_by, orders)


def close_round(db: Database, wall_id: str, number: int, closed_by: str) -> Round:
    """Close a round: no answer counts any more, and its students see the names.

    The UPDATE waits for answers being stored in the round (they write the same row
    first), so an answer either lands before the round closes or is refused.
    """
    with db.session() as session:
        session.execute(
            update(BrainQuizRoundRecord)
            .where(
                BrainQuizRoundRecord.wall_id == wall_id,
                BrainQuizRoundRecord.number == number,
                BrainQuizRoundRecord.closed_at.is_(None),
            )
            .values(closed_at=datetime.now(UTC), closed_by=closed_by)
        )
        record = session.get(BrainQuizRoundRecord, (wall_id, number))
        if record is None:
            raise QuizError(f"There is no round {number}.")
        session.refresh(record)
        return _round(record)


def rounds_during(db: Database, wall_id: str, held: ClassSession) -> list[int]:
    """The numbers of the wall's rounds started while the class ``held`` ran."""
    with db.reading() as connection:
        rows = connection.execute(
            select(BrainQuizRoundRecord.number, BrainQuizRoundRecord.started_at)
            .where(BrainQuizRoundRecord.wall_id == wall_id)
            .order_by(BrainQuizRoundRecord.number)
        ).all()
    return [row.number for row in rows if held.holds(as_utc(row.started_at))]


def set_reveal(db: Database, wall_id: str, number: int, reveal: Reveal) -> Round:
    """Change when the students of an open round see the names."""
    with db.session() as session:
        record = session.get(BrainQuizRoundRecord, (wall_id, number))
        if record is None:
            raise QuizError(f"There is no round {number}.")
        if record.closed_at is not None:
            raise QuizError("That round is closed: its names are shown already.")
        record.reveal = reveal
        session.flush()
        return _round(record)


def _latest_number(session: Session, wall_id: str) -> int | None:
    number = session.scalar(
        select(func.max(BrainQuizRoundRecord.number)).where(BrainQuizRoundRecord.wall_id == wall_id)
    )
    return None if number is None else int(number)


def _claim_open(writer: Session | Connection, wall_id: str, number: int) -> None:
    """Take the round's row for this transaction, or QuizError when it is closed.

    Writing the row first holds its lock until the answer is stored (PostgreSQL) or
    takes the database's write lock (SQLite): closing the round waits for us, and we
    see a close that came first.
    """
    claimed = writer.execute(
        _CLAIM_OPEN, {"of_wall": wall_id, "of_round": number, "now": datetime.now(UTC)}
    )
    if claimed.rowcount != 1:  # type: ignore[attr-defined]
        raise QuizError("This round is closed: answers are no longer taken.")


# --- answers -------------------------------------------------------------------------


def progress(db: Database, wall_id: str, number: int, visitor_id: str, tag_set: str) -> Progress:
    with db.reading() as connection:
        return _progress(connection, wall_id, number, visitor_id, tag_set)


def _progress(
    reader: Session | Connection, wall_id: str, number: int, visitor_id: str, tag_set: str
) -> Progress:
    """The visitor's answers and whether they finished (in a session that writes them,
    or on a connection that only reads)."""
    key = {"wall_id": wall_id, "number": number, "visitor_id": visitor_id, "tag_set": tag_set}
    answers = {row.region_id: Answer(*row) for row in reader.execute(_ANSWERS, key)}
    return Progress(answers, reader.execute(_FINISHED, key).first() is not None)


def record_answer(
    db: Database,
    wall_id: str,
    number: int,
    visitor_id: str,
    tag_set: str,
    region_id: str,
    text: str,
    correct: bool,
) -> Progress:
    """Store (or change) the visitor's answer for a region in an open round; refused
    once they finished or the round closed."""
    cleaned = clean_answer(text)
    try:
        return _store_answer(db, wall_id, number, visitor_id, tag_set, region_id, cleaned, correct)
    except IntegrityError:  # the same answer sent twice at once: the second one changes it
        return _store_answer(db, wall_id, number, visitor_id, tag_set, region_id, cleaned, correct)


def _store_answer(
    db: Database,
    wall_id: str,
    number: int,
    visitor_id: str,
    tag_set: str,
    region_id: str,
    text: str,
    correct: bool,
) -> Progress:
    key = {"wall_id": wall_id, "number": number, "visitor_id": visitor_id, "tag_set": tag_set}
    with db.engine.begin() as connection:  # every answer of a room: Core, statements built once
        _claim_open(connection, wall_id, number)
        if connection.execute(_FINISHED, key).first() is not None:
            raise QuizError("You have finished this quiz: your answers are final.")
        changed = connection.execute(
            _CHANGE_ANSWER,
            {
                "of_wall": wall_id,
                "of_round": number,
                "of_visitor": visitor_id,
                "of_set": tag_set,
                "of_region": region_id,
                "text": text,
                "is_correct": correct,
            },
        )
        if changed.rowcount == 0:
            connection.execute(
                _NEW_ANSWER,
                {
                    "wall_id": wall_id,
                    "round": number,
                    "visitor_id": visitor_id,
                    "tag_set": tag_set,
                    "region_id": region_id,
                    "answer": text,
                    "correct": correct,
                },
            )
        return _progress(connection, wall_id, number, visitor_id, tag_set)


def finish(
    db: Database,
    wall_id: str,
    number: int,
    visitor_id: str,
    tag_set: str,
    regions: Sequence[Region],
) -> Progress:
    """Make the visitor's answers final; only when every region of the set is answered
    and while the round is open (one attempt per visitor and set in a round)."""
    try:
        with db.session() as session:
            _claim_open(session, wall_id, number)
            now = _progress(session, wall_id, number, visitor_id, tag_set)
            if now.finished:
                return now
            missing = [r for r in regions if r.id not in now.answers]
            if missing:
                raise QuizError(f"{len(missing)} pins still need an answer.")
            session.add(
                BrainQuizFinishRecord(
                    wall_id=wall_id, round=number, visitor_id=visitor_id, tag_set=tag_set
                )
            )
    except IntegrityError:  # finished twice at once
        pass
    with db.session() as session:
        return _progress(session, wall_id, number, visitor_id, tag_set)


def statistics(
    db: Database, wall_id: str, number: int, tag_set: str, regions: Sequence[Region]
) -> QuizStats:
    """The class's results in a round, per region of ``tag_set``."""
    with db.session() as session:
        rows = session.execute(
            select(
                BrainAnswerRecord.visitor_id,
                BrainAnswerRecord.region_id,
                BrainAnswerRecord.answer,
                BrainAnswerRecord.correct,
            ).where(
                BrainAnswerRecord.wall_id == wall_id,
                BrainAnswerRecord.round == number,
                BrainAnswerRecord.tag_set == tag_set,
            )
        ).all()
        finished = session.scalar(
            select(func.count()).where(
                BrainQuizFinishRecord.wall_id == wall_id,
                BrainQuizFinishRecord.round == number,
                BrainQuizFinishRecord.tag_set == tag_set,
            )
        )
    per_region = []
    for region in regions:
        mine = [r for r in rows if r.region_id == region.id]
        wrong = Counter(r.answer.casefold() for r in mine if not r.correct)
        per_region.append(
            RegionStats(
                region.id,
                answered=len(mine),
                correct=sum(1 for r in mine if r.correct),
                common_wrong=wrong.most_common(COMMON_WRONG),
            )
        )
    return QuizStats(
        round=number,
        participants=len({r.visitor_id for r in rows}),
        answers=len(rows),
        finished=int(finished or 0),
        regions=per_region,
    )


CSV_COLUMNS = (
    "round",
    "visitor",
    "name",
    "tag_set",
    "region",
    "answer",
    "correct",
    "answered_at",
    "class",
)


def export_csv(db: Database, wall_id: str, number: int, time_zone: str = "UTC") -> str:
    """Every answer of a round as CSV, one row per answer, times in ``time_zone``.

    Visitors appear by their pseudonymous id and their name: the one the round's class
    asked for, else the one they chose, if any. Cells are written so spreadsheets do
    not run an answer that starts like a formula.
    """
    quiz_round = get_round(db, wall_id, number)
    held = class_at(db, wall_id, quiz_round.started_at) if quiz_round is not None else None
    on_roll = roll_names(db, held.id) if held is not None else {}
    with db.session() as session:
        rows = session.execute(
            select(BrainAnswerRecord, VisitorRecord.display_name)
            .outerjoin(VisitorRecord, VisitorRecord.id == BrainAnswerRecord.visitor_id)
            .where(BrainAnswerRecord.wall_id == wall_id, BrainAnswerRecord.round == number)
            .order_by(BrainAnswerRecord.visitor_id, BrainAnswerRecord.tag_set, BrainAnswerRecord.id)
        ).all()
    zone = ZoneInfo(time_zone)
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(CSV_COLUMNS)
    for row, chosen_name in rows:
        writer.writerow(
            [
                row.round,
                row.visitor_id,
                _spreadsheet_safe(on_roll.get(row.visitor_id) or chosen_name or ""),
                row.tag_set,
                row.region_id,
                _spreadsheet_safe(row.answer),
                "yes" if row.correct else "no",
                as_utc(row.answered_at).astimezone(zone).isoformat(timespec="seconds"),
                _spreadsheet_safe(held.title if held is not None else ""),
            ]
        )
    return out.getvalue()


def _spreadsheet_safe(text: str) -> str:
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text
