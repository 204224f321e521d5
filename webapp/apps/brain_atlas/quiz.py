"""The brain atlas quiz as stored: rounds, each visitor's answers, who finished.

A visitor answers each region of a tag set once (changing an answer is allowed until
they finish the set); finishing needs every region answered and makes the answers
final, and only then are the correct names shown to that visitor. An instructor's
reset starts the next round: earlier rounds stay in the database for export.
"""

from __future__ import annotations

import csv
import io
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime

from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from webapp.apps.brain_atlas.content import Region
from webapp.apps.brain_atlas.matching import MAX_ANSWER_LENGTH
from webapp.db import Database
from webapp.models import (
    BrainAnswerRecord,
    BrainQuizFinishRecord,
    BrainQuizRoundRecord,
    VisitorRecord,
)

COMMON_WRONG = 3  # wrong answers listed per region on the dashboard


class QuizError(Exception):
    """Something the visitor cannot do now; the message says why, in their words."""


@dataclass(frozen=True)
class Answer:
    region_id: str
    text: str
    correct: bool


@dataclass(frozen=True)
class Progress:
    """Where a visitor stands in one set's quiz."""

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
    finished: int
    regions: list[RegionStats] = field(default_factory=list)


def clean_answer(text: str) -> str:
    """An answer as stored: one line, trimmed, bounded; empty answers are refused."""
    cleaned = " ".join(text.split())
    if not cleaned:
        raise QuizError("Please type a name before sending.")
    if len(cleaned) > MAX_ANSWER_LENGTH:
        raise QuizError(f"That is longer than any region's name ({MAX_ANSWER_LENGTH} characters).")
    return cleaned


def current_round(db: Database, wall_id: str) -> int:
    """The wall's round now (the first is started on first use)."""
    with db.session() as session:
        number = _latest_round(session, wall_id)
    if number is not None:
        return number
    try:
        with db.session() as session:
            session.add(BrainQuizRoundRecord(wall_id=wall_id, number=1))
    except IntegrityError:  # another request started it first
        pass
    return 1


def _latest_round(session: Session, wall_id: str) -> int | None:
    number = session.scalar(
        select(func.max(BrainQuizRoundRecord.number)).where(BrainQuizRoundRecord.wall_id == wall_id)
    )
    return None if number is None else int(number)


def start_round(db: Database, wall_id: str, started_by: str) -> int:
    """Reset the quiz: everyone starts again in a new round; returns its number."""
    for _ in range(3):
        try:
            with db.session() as session:
                number = (_latest_round(session, wall_id) or 0) + 1
                session.add(
                    BrainQuizRoundRecord(wall_id=wall_id, number=number, started_by=started_by)
                )
            return number
        except IntegrityError:  # two resets at once: the other one won, try after it
            continue
    raise QuizError("The quiz is being reset by someone else; try again.")


def progress(db: Database, wall_id: str, visitor_id: str, tag_set: str) -> Progress:
    number = current_round(db, wall_id)
    with db.session() as session:
        return _progress(session, wall_id, number, visitor_id, tag_set)


def _progress(
    session: Session, wall_id: str, number: int, visitor_id: str, tag_set: str
) -> Progress:
    rows = session.scalars(
        select(BrainAnswerRecord).where(
            BrainAnswerRecord.wall_id == wall_id,
            BrainAnswerRecord.round == number,
            BrainAnswerRecord.visitor_id == visitor_id,
            BrainAnswerRecord.tag_set == tag_set,
        )
    )
    answers = {r.region_id: Answer(r.region_id, r.answer, r.correct) for r in rows}
    finished = session.get(BrainQuizFinishRecord, (wall_id, number, visitor_id, tag_set))
    return Progress(answers, finished is not None)


def record_answer(
    db: Database,
    wall_id: str,
    visitor_id: str,
    tag_set: str,
    region_id: str,
    text: str,
    correct: bool,
) -> Progress:
    """Store (or change) the visitor's answer for a region; refused once they finished."""
    cleaned = clean_answer(text)
    number = current_round(db, wall_id)
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
    with db.session() as session:
        if session.get(BrainQuizFinishRecord, (wall_id, number, visitor_id, tag_set)):
            raise QuizError("You have finished this quiz: your answers are final.")
        row = session.scalar(
            select(BrainAnswerRecord).where(
                BrainAnswerRecord.wall_id == wall_id,
                BrainAnswerRecord.round == number,
                BrainAnswerRecord.visitor_id == visitor_id,
                BrainAnswerRecord.tag_set == tag_set,
                BrainAnswerRecord.region_id == region_id,
            )
        )
        if row is None:
            session.add(
                BrainAnswerRecord(
                    wall_id=wall_id,
                    round=number,
                    visitor_id=visitor_id,
                    tag_set=tag_set,
                    region_id=region_id,
                    answer=text,
                    correct=correct,
                )
            )
        else:
            row.answer, row.correct = text, correct
        session.flush()
        return _progress(session, wall_id, number, visitor_id, tag_set)


def finish(
    db: Database, wall_id: str, visitor_id: str, tag_set: str, regions: Sequence[Region]
) -> Progress:
    """Make the visitor's answers final; only when every region of the set is answered."""
    number = current_round(db, wall_id)
    try:
        with db.session() as session:
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


def statistics(db: Database, wall_id: str, tag_set: str, regions: Sequence[Region]) -> QuizStats:
    """The class's results in the current round, per region of ``tag_set``."""
    number = current_round(db, wall_id)
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
        finished=int(finished or 0),
        regions=per_region,
    )


CSV_COLUMNS = ("round", "visitor", "name", "tag_set", "region", "answer", "correct", "answered_at")


def export_csv(db: Database, wall_id: str, number: int | None = None) -> str:
    """Every answer of a round (default: the current one) as CSV, one row per answer.

    Visitors appear by their pseudonymous id and the name they chose, if any; cells
    are written so spreadsheets do not run an answer that starts like a formula.
    """
    chosen = number if number is not None else current_round(db, wall_id)
    with db.session() as session:
        rows = session.execute(
            select(BrainAnswerRecord, VisitorRecord.display_name)
            .outerjoin(VisitorRecord, VisitorRecord.id == BrainAnswerRecord.visitor_id)
            .where(BrainAnswerRecord.wall_id == wall_id, BrainAnswerRecord.round == chosen)
            .order_by(BrainAnswerRecord.visitor_id, BrainAnswerRecord.tag_set, BrainAnswerRecord.id)
        ).all()
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(CSV_COLUMNS)
    for row, name in rows:
        writer.writerow(
            [
                row.round,
                row.visitor_id,
                _spreadsheet_safe(name or ""),
                row.tag_set,
                row.region_id,
                _spreadsheet_safe(row.answer),
                "yes" if row.correct else "no",
                _iso(row.answered_at),
            ]
        )
    return out.getvalue()


def _spreadsheet_safe(text: str) -> str:
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


def _iso(when: datetime) -> str:
    return when.isoformat(timespec="seconds")
