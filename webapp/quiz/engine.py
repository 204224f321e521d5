"""A quiz as stored, for any app: rounds, each visitor's answers, who finished.

An app asks questions about items it shows (the brain atlas its regions, each marked by
a pin; an image its hotspots), in named sets (the brain's K-5 and full sets); this
engine keeps the rounds and answers, per app and wall, judges the answer to a choice
question and counts the class's answers. A free-text answer is judged by its app. The
public API, for any plug-in app, is described in docs/quiz.md.

The answer key is the dissertation's example of confidential data, so a round guards
it three ways. Each round numbers its items in a fresh random order (question 1 is no
particular item, and the app issues new codes with each round). A visitor answers each
item of a set once in a round, changing answers until they finish; finishing makes them
final. Correct answers reach students only when the instructor closes the round (the
default) or, when the instructor chose that for the round, at finishing. A throw-away
visitor who finishes at once therefore learns nothing while answers still count; and
once the round is closed, no answer is taken any more. A poll's answer is final as it
is given (:meth:`Quiz.answer_once`): there is nothing to change or finish.

Rounds are numbered per app and wall; the app's slot of the wall state names the round
the wall shows, so starting one goes through the one door for state changes and its
codes arrive in the same swap as its numbering.
"""

from __future__ import annotations

import csv
import io
import secrets
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any, Literal, Protocol, TypeVar, get_args
from zoneinfo import ZoneInfo

from sqlalchemy import Connection, Row, bindparam, func, insert, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from webapp.classes.roll import ClassSession, class_at, roll_names
from webapp.database.connection import Database, as_utc
from webapp.database.models import (
    QuizAnswerRecord,
    QuizFinishRecord,
    QuizRoundRecord,
    VisitorRecord,
)
from webapp.people.person import plain_text

COMMON_WRONG = 3  # wrong answers listed per item on the dashboard
MAX_ANSWER_LENGTH = 200
"""Longer answers are refused outright: no name is that long, and it bounds the cost of
judging them."""
MAX_ITEM_ID = 64  # as the answers' table keeps an item's id
Reveal = Literal["close", "finish"]
REVEALS: tuple[Reveal, ...] = get_args(Reveal)


class QuizError(Exception):
    """Something the visitor cannot do now; the message says why, in their words."""


class Item(Protocol):
    """What a quiz asks about: anything with a stable id (a region, a hotspot, a
    :class:`Question`), numbered in a round and counted for finishing."""

    @property
    def id(self) -> str: ...


ItemT = TypeVar("ItemT", bound=Item)


@dataclass(frozen=True)
class Question:
    """What is asked about an item (``id``, the item's), and how an answer is judged.

    With ``choices`` the visitor picks one of them and the engine judges it: right when
    among ``right``; with ``right`` None nothing is right or wrong (a poll). Without
    choices the answer is typed and its app judges it (the brain's answer key,
    :func:`webapp.quiz.matching.matches`), or nobody does (a free-text poll).
    ``text`` is the question as the phone asks it.
    """

    id: str
    text: str
    choices: tuple[str, ...] = ()
    right: frozenset[str] | None = None

    def __post_init__(self) -> None:
        """Refuse a question no answer could be judged against (the app's mistake)."""
        if not 0 < len(self.id) <= MAX_ITEM_ID:
            raise ValueError(f"A question's id has 1 to {MAX_ITEM_ID} characters: {self.id!r}.")
        for choice in self.choices:
            if not choice or choice != plain_text(choice) or len(choice) > MAX_ANSWER_LENGTH:
                raise ValueError(f"Question {self.id}: {choice!r} is not a plain choice.")
        if len(set(self.choices)) != len(self.choices):
            raise ValueError(f"Question {self.id} offers a choice twice.")
        if self.right is not None and not (self.choices and self.right <= set(self.choices)):
            raise ValueError(f"Question {self.id}: its right answers must be among its choices.")

    def answer(self, text: str, correct: bool | None = None) -> Answer:
        """``text`` as this question stores it, judged.

        A choice must be one of the choices (QuizError otherwise) and is judged here, so
        ``correct`` is the app's verdict on a typed answer only (None: not judged).
        """
        if not self.choices:
            return Answer(self.id, clean_answer(text), correct)
        if correct is not None:
            raise ValueError(f"Question {self.id} has choices: the quiz judges its answers.")
        chosen = plain_text(text)
        if chosen not in self.choices:
            raise QuizError("Please choose one of the answers offered.")
        return Answer(self.id, chosen, None if self.right is None else chosen in self.right)


@dataclass(frozen=True)
class Round:
    """One round of a wall's quiz: its order per set, and whether it still runs."""

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

    def numbered(self, set_name: str, items: Sequence[ItemT]) -> dict[int, ItemT]:
        """Question number -> item for ``set_name`` (its items in the content's order).

        Question n is the n-th item of the round's order. An item the content gained
        after the round started gets a number after the others; one it lost leaves its
        number unused, so no other question changes its number mid-round.
        """
        by_id = {item.id: item for item in items}
        order = list(self.orders.get(set_name, []))
        order += [item.id for item in items if item.id not in order]
        return {n: by_id[iid] for n, iid in enumerate(order, start=1) if iid in by_id}

    def names_shown(self, finished: bool) -> bool:
        """The one rule for when a student sees the correct answers (and which of theirs
        were right): once the round is closed, or at finishing where the instructor
        chose that for the round. Finishing early reveals nothing otherwise, so a
        throw-away visitor cannot harvest the key while answers still count."""
        return not self.open or (self.reveal == "finish" and finished)


@dataclass(frozen=True)
class Answer:
    """A visitor's answer to one item: ``correct`` None where nothing is right or wrong."""

    item_id: str
    text: str
    correct: bool | None


@dataclass(frozen=True)
class Progress:
    """Where a visitor stands in one set's quiz of one round."""

    answers: dict[str, Answer]
    finished: bool

    def complete(self, items: Sequence[Item]) -> bool:
        return all(item.id in self.answers for item in items)


@dataclass(frozen=True)
class ItemStats:
    """The class's answers to one item: how many, how many judged and right, the
    commonest wrong ones and, for a choice question, how often each choice was taken
    (in the question's order, untaken ones at 0)."""

    item_id: str
    answered: int
    judged: int
    correct: int
    common_wrong: list[tuple[str, int]]
    choices: dict[str, int] = field(default_factory=dict)

    @property
    def share_correct(self) -> float | None:
        """The share of judged answers that are right (None: none judged, as in a poll)."""
        return self.correct / self.judged if self.judged else None


@dataclass(frozen=True)
class Score:
    """A student's score of a class: answers judged right of the questions asked."""

    right: int
    asked: int


@dataclass(frozen=True)
class QuizStats:
    round: int
    participants: int
    answers: int
    finished: int
    items: list[ItemStats] = field(default_factory=list)


def new_order(items: Sequence[Item]) -> list[str]:
    """Item ids in a fresh random order (a CSPRNG: the order is the key)."""
    order = [item.id for item in items]
    secrets.SystemRandom().shuffle(order)
    return order


def clean_answer(text: str) -> str:
    """An answer as stored: plain text, bounded; empty answers are refused."""
    cleaned = plain_text(text)
    if not cleaned:
        raise QuizError("Please type a name before sending.")
    if len(cleaned) > MAX_ANSWER_LENGTH:
        raise QuizError(f"That is longer than any name here ({MAX_ANSWER_LENGTH} characters).")
    return cleaned


def _round(record: QuizRoundRecord | Row[Any]) -> Round:
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
_ROUND = select(QuizRoundRecord.__table__).where(
    QuizRoundRecord.app == bindparam("app"),
    QuizRoundRecord.wall_id == bindparam("wall_id"),
    QuizRoundRecord.number == bindparam("number"),
)
_ANSWERS = select(
    QuizAnswerRecord.item_id, QuizAnswerRecord.answer, QuizAnswerRecord.correct
).where(
    QuizAnswerRecord.app == bindparam("app"),
    QuizAnswerRecord.wall_id == bindparam("wall_id"),
    QuizAnswerRecord.round == bindparam("number"),
    QuizAnswerRecord.visitor_id == bindparam("visitor_id"),
    QuizAnswerRecord.set_name == bindparam("set_name"),
)
_FINISHED = select(QuizFinishRecord.visitor_id).where(
    QuizFinishRecord.app == bindparam("app"),
    QuizFinishRecord.wall_id == bindparam("wall_id"),
    QuizFinishRecord.round == bindparam("number"),
    QuizFinishRecord.visitor_id == bindparam("visitor_id"),
    QuizFinishRecord.set_name == bindparam("set_name"),
)
_CLAIM_OPEN = (
    update(QuizRoundRecord)
    .where(
        QuizRoundRecord.app == bindparam("of_app"),
        QuizRoundRecord.wall_id == bindparam("of_wall"),
        QuizRoundRecord.number == bindparam("of_round"),
        QuizRoundRecord.closed_at.is_(None),
    )
    .values(last_answer_at=bindparam("now"))
)
_CHANGE_ANSWER = (
    update(QuizAnswerRecord)
    .where(
        QuizAnswerRecord.app == bindparam("of_app"),
        QuizAnswerRecord.wall_id == bindparam("of_wall"),
        QuizAnswerRecord.round == bindparam("of_round"),
        QuizAnswerRecord.visitor_id == bindparam("of_visitor"),
        QuizAnswerRecord.set_name == bindparam("of_set"),
        QuizAnswerRecord.item_id == bindparam("of_item"),
    )
    .where(QuizAnswerRecord.final.is_(False))
    .values(answer=bindparam("text"), correct=bindparam("is_correct"))
)
_NEW_ANSWER = insert(QuizAnswerRecord)


@dataclass(frozen=True)
class Columns:
    """How an app's answers CSV names what its answers are about: the column of the set
    and of the item (the brain's ``tag_set`` and ``region``), and the columns after the
    item's that describe it (the image app's hotspot ``title`` and ``question``)."""

    set: str = "set"
    item: str = "item"
    about: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        names = self.header()
        if len(set(names)) != len(names):
            raise ValueError(f"An answers CSV names each column once: {', '.join(names)}.")

    def header(self) -> list[str]:
        return [
            "round",
            "visitor",
            "name",
            self.set,
            self.item,
            *self.about,
            "answer",
            "correct",
            "answered_at",
            "class",
        ]


CORRECT_CELL = {True: "yes", False: "no", None: "n/a"}
"""The ``correct`` column: n/a where nothing is right or wrong (a poll)."""


def _spreadsheet_safe(text: str) -> str:
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


@dataclass(frozen=True)
class Quiz:
    """The quiz of one app (``app``, its name) in ``db``: its rounds on every wall, and
    the ``columns`` its answers CSV names."""

    db: Database
    app: str
    columns: Columns = Columns()

    # --- rounds ---------------------------------------------------------------------

    def get_round(self, wall_id: str, number: int) -> Round | None:
        with self.db.reading() as connection:
            row = connection.execute(
                _ROUND, {"app": self.app, "wall_id": wall_id, "number": number}
            ).first()
        return _round(row) if row is not None else None

    def start_round(
        self,
        wall_id: str,
        started_by: str,
        orders: dict[str, list[str]],
        reveal: Reveal = "close",
    ) -> Round:
        """A new round with ``orders`` as its numbering; the round before it closes.

        The caller puts it on the wall (its app's slot of the wall state), which
        brings the round's codes.
        """
        for _ in range(3):
            try:
                with self.db.session() as session:
                    number = (self._latest_number(session, wall_id) or 0) + 1
                    session.execute(
                        update(QuizRoundRecord)
                        .where(
                            QuizRoundRecord.app == self.app,
                            QuizRoundRecord.wall_id == wall_id,
                            QuizRoundRecord.closed_at.is_(None),
                        )
                        .values(closed_at=datetime.now(UTC), closed_by=started_by)
                    )
                    record = QuizRoundRecord(
                        app=self.app,
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

    def open_round(self, wall_id: str, started_by: str, orders: dict[str, list[str]]) -> Round:
        """The wall's latest round if it is still open, else a new one with ``orders``
        (the app coming on a wall for the first time: every server process may ask)."""
        with self.db.session() as session:
            number = self._latest_number(session, wall_id)
            record = session.get(QuizRoundRecord, (self.app, wall_id, number)) if number else None
            if record is not None and record.closed_at is None:
                return _round(record)
        return self.start_round(wall_id, started_by, orders)

    def close_round(self, wall_id: str, number: int, closed_by: str) -> Round:
        """Close a round: no answer counts any more, and its students see the names.

        The UPDATE waits for answers being stored in the round (they write the same row
        first), so an answer either lands before the round closes or is refused.
        """
        with self.db.session() as session:
            session.execute(
                update(QuizRoundRecord)
                .where(
                    QuizRoundRecord.app == self.app,
                    QuizRoundRecord.wall_id == wall_id,
                    QuizRoundRecord.number == number,
                    QuizRoundRecord.closed_at.is_(None),
                )
                .values(closed_at=datetime.now(UTC), closed_by=closed_by)
            )
            record = session.get(QuizRoundRecord, (self.app, wall_id, number))
            if record is None:
                raise QuizError(f"There is no round {number}.")
            session.refresh(record)
            return _round(record)

    def set_reveal(self, wall_id: str, number: int, reveal: Reveal) -> Round:
        """Change when the students of an open round see the names."""
        with self.db.session() as session:
            record = session.get(QuizRoundRecord, (self.app, wall_id, number))
            if record is None:
                raise QuizError(f"There is no round {number}.")
            if record.closed_at is not None:
                raise QuizError("That round is closed: its names are shown already.")
            record.reveal = reveal
            session.flush()
            return _round(record)

    def rounds_during(self, wall_id: str, held: ClassSession) -> list[int]:
        """The numbers of the wall's rounds started while the class ``held`` ran."""
        with self.db.reading() as connection:
            rows = connection.execute(
                select(QuizRoundRecord.number, QuizRoundRecord.started_at)
                .where(QuizRoundRecord.app == self.app, QuizRoundRecord.wall_id == wall_id)
                .order_by(QuizRoundRecord.number)
            ).all()
        return [row.number for row in rows if held.holds(as_utc(row.started_at))]

    def scores(self, wall_id: str, held: ClassSession, students: Iterable[str]) -> dict[str, Score]:
        """The score of each of ``students`` (visitor ids) in the class ``held``, the one
        rule of a grade: over the rounds the class ran, the answers judged right against
        the questions asked. In each round a student is asked the set they answered most
        in, and one who answered nothing there the round's largest set. A round whose
        answers are judged neither right nor wrong (a poll) asks nothing; a class that
        asked nothing judged scores no one."""
        rounds = self.rounds_during(wall_id, held)
        if not rounds:
            return {}
        with self.db.reading() as connection:
            sizes = {
                row.number: {name: len(order) for name, order in row.orders.items()}
                for row in connection.execute(
                    select(QuizRoundRecord.number, QuizRoundRecord.orders).where(
                        QuizRoundRecord.app == self.app,
                        QuizRoundRecord.wall_id == wall_id,
                        QuizRoundRecord.number.in_(rounds),
                    )
                )
            }
            answers = connection.execute(
                select(
                    QuizAnswerRecord.round,
                    QuizAnswerRecord.visitor_id,
                    QuizAnswerRecord.set_name,
                    QuizAnswerRecord.correct,
                ).where(
                    QuizAnswerRecord.app == self.app,
                    QuizAnswerRecord.wall_id == wall_id,
                    QuizAnswerRecord.round.in_(rounds),
                )
            ).all()
        judged = sorted({row.round for row in answers if row.correct is not None})
        sets: dict[tuple[int, str], Counter[str]] = {}
        right: Counter[str] = Counter()
        for row in answers:
            sets.setdefault((row.round, row.visitor_id), Counter())[row.set_name] += 1
            right[row.visitor_id] += row.correct is True
        scores = {}
        for visitor in students:
            asked = 0
            for number in judged:
                in_round = sizes.get(number, {})
                answered = sets.get((number, visitor))
                if answered:
                    asked += in_round.get(answered.most_common(1)[0][0], 0)
                else:
                    asked += max(in_round.values(), default=0)
            if asked:
                scores[visitor] = Score(right=right[visitor], asked=asked)
        return scores

    def _latest_number(self, session: Session, wall_id: str) -> int | None:
        number = session.scalar(
            select(func.max(QuizRoundRecord.number)).where(
                QuizRoundRecord.app == self.app, QuizRoundRecord.wall_id == wall_id
            )
        )
        return None if number is None else int(number)

    def _claim_open(self, writer: Session | Connection, wall_id: str, number: int) -> None:
        """Take the round's row for this transaction, or QuizError when it is closed.

        Writing the row first holds its lock until the answer is stored (PostgreSQL) or
        takes the database's write lock (SQLite): closing the round waits for us, and we
        see a close that came first.
        """
        claimed = writer.execute(
            _CLAIM_OPEN,
            {"of_app": self.app, "of_wall": wall_id, "of_round": number, "now": datetime.now(UTC)},
        )
        if claimed.rowcount != 1:  # type: ignore[attr-defined]
            raise QuizError("This round is closed: answers are no longer taken.")

    # --- answers ----------------------------------------------------------------------

    def progress(self, wall_id: str, number: int, visitor_id: str, set_name: str) -> Progress:
        with self.db.reading() as connection:
            return self._progress(connection, wall_id, number, visitor_id, set_name)

    def _progress(
        self,
        reader: Session | Connection,
        wall_id: str,
        number: int,
        visitor_id: str,
        set_name: str,
    ) -> Progress:
        """The visitor's answers and whether they finished (in a session that writes
        them, or on a connection that only reads)."""
        key = {
            "app": self.app,
            "wall_id": wall_id,
            "number": number,
            "visitor_id": visitor_id,
            "set_name": set_name,
        }
        answers = {row.item_id: Answer(*row) for row in reader.execute(_ANSWERS, key)}
        return Progress(answers, reader.execute(_FINISHED, key).first() is not None)

    def record_answer(
        self,
        wall_id: str,
        number: int,
        visitor_id: str,
        set_name: str,
        question: Question,
        text: str,
        correct: bool | None = None,
    ) -> None:
        """Store (or change) the visitor's answer to ``question`` in an open round,
        judged (:meth:`Question.answer`: ``correct`` is the app's verdict on typed
        text); refused once they finished, the answer is final or the round closed.
        Nothing is read back: the phone goes on to its progress page, which reads it,
        and the write lock is held no longer."""
        given = question.answer(text, correct)
        try:
            self._store_answer(wall_id, number, visitor_id, set_name, given)
        except IntegrityError:  # the same answer sent twice at once: the second changes it
            try:
                self._store_answer(wall_id, number, visitor_id, set_name, given)
            except IntegrityError:  # there, and not changed: it is final
                raise QuizError("You have answered this question: your answer is final.") from None

    def _store_answer(
        self, wall_id: str, number: int, visitor_id: str, set_name: str, given: Answer
    ) -> None:
        with self.db.engine.begin() as connection:  # a room's answers: Core, built once
            self._claim_unfinished(connection, wall_id, number, visitor_id, set_name)
            changed = connection.execute(
                _CHANGE_ANSWER,
                {
                    "of_app": self.app,
                    "of_wall": wall_id,
                    "of_round": number,
                    "of_visitor": visitor_id,
                    "of_set": set_name,
                    "of_item": given.item_id,
                    "text": given.text,
                    "is_correct": given.correct,
                },
            )
            if changed.rowcount == 0:
                connection.execute(
                    _NEW_ANSWER, self._new_answer(wall_id, number, visitor_id, set_name, given)
                )

    def answer_once(
        self,
        wall_id: str,
        number: int,
        visitor_id: str,
        set_name: str,
        question: Question,
        text: str,
        correct: bool | None = None,
    ) -> None:
        """Store the visitor's answer to ``question`` final as it is given (a poll's:
        no changing it, no finishing), judged as :meth:`record_answer` judges, in one
        transaction; QuizError when they answered it already or the round is closed."""
        given = question.answer(text, correct)
        try:
            with self.db.engine.begin() as connection:
                self._claim_unfinished(connection, wall_id, number, visitor_id, set_name)
                row = self._new_answer(wall_id, number, visitor_id, set_name, given)
                connection.execute(_NEW_ANSWER, {**row, "final": True})
        except IntegrityError:
            raise QuizError("You have answered this question already.") from None

    def _claim_unfinished(
        self, connection: Connection, wall_id: str, number: int, visitor_id: str, set_name: str
    ) -> None:
        """Claim the open round (:meth:`_claim_open`) for an answer of a visitor who has
        not finished the set; QuizError otherwise."""
        self._claim_open(connection, wall_id, number)
        key = {
            "app": self.app,
            "wall_id": wall_id,
            "number": number,
            "visitor_id": visitor_id,
            "set_name": set_name,
        }
        if connection.execute(_FINISHED, key).first() is not None:
            raise QuizError("You have finished this quiz: your answers are final.")

    def _new_answer(
        self, wall_id: str, number: int, visitor_id: str, set_name: str, given: Answer
    ) -> dict[str, object]:
        return {
            "app": self.app,
            "wall_id": wall_id,
            "round": number,
            "visitor_id": visitor_id,
            "set_name": set_name,
            "item_id": given.item_id,
            "answer": given.text,
            "correct": given.correct,
        }

    def finish(
        self,
        wall_id: str,
        number: int,
        visitor_id: str,
        set_name: str,
        items: Sequence[Item],
    ) -> Progress:
        """Make the visitor's answers final; only when every item of the set is answered
        and while the round is open (one attempt per visitor and set in a round)."""
        try:
            with self.db.session() as session:
                self._claim_open(session, wall_id, number)
                now = self._progress(session, wall_id, number, visitor_id, set_name)
                if now.finished:
                    return now
                missing = sum(1 for item in items if item.id not in now.answers)
                if missing == 1:
                    raise QuizError("1 question still needs an answer.")
                if missing:
                    raise QuizError(f"{missing} questions still need an answer.")
                session.add(
                    QuizFinishRecord(
                        app=self.app,
                        wall_id=wall_id,
                        round=number,
                        visitor_id=visitor_id,
                        set_name=set_name,
                    )
                )
        except IntegrityError:  # finished twice at once
            pass
        with self.db.session() as session:
            return self._progress(session, wall_id, number, visitor_id, set_name)

    def statistics(
        self, wall_id: str, number: int, set_name: str, questions: Sequence[Question]
    ) -> QuizStats:
        """The class's results in a round, per question of ``set_name``."""
        with self.db.session() as session:
            rows = session.execute(
                select(
                    QuizAnswerRecord.visitor_id,
                    QuizAnswerRecord.item_id,
                    QuizAnswerRecord.answer,
                    QuizAnswerRecord.correct,
                ).where(
                    QuizAnswerRecord.app == self.app,
                    QuizAnswerRecord.wall_id == wall_id,
                    QuizAnswerRecord.round == number,
                    QuizAnswerRecord.set_name == set_name,
                )
            ).all()
            finished = session.scalar(
                select(func.count()).where(
                    QuizFinishRecord.app == self.app,
                    QuizFinishRecord.wall_id == wall_id,
                    QuizFinishRecord.round == number,
                    QuizFinishRecord.set_name == set_name,
                )
            )
        per_item = []
        for question in questions:
            mine = [r for r in rows if r.item_id == question.id]
            wrong = Counter(r.answer.casefold() for r in mine if r.correct is False)
            taken = Counter(r.answer for r in mine)
            per_item.append(
                ItemStats(
                    question.id,
                    answered=len(mine),
                    judged=sum(1 for r in mine if r.correct is not None),
                    correct=sum(1 for r in mine if r.correct),
                    common_wrong=wrong.most_common(COMMON_WRONG),
                    choices={choice: taken[choice] for choice in question.choices},
                )
            )
        return QuizStats(
            round=number,
            participants=len({r.visitor_id for r in rows}),
            answers=len(rows),
            finished=int(finished or 0),
            items=per_item,
        )

    def export_csv(
        self,
        wall_id: str,
        number: int,
        time_zone: str = "UTC",
        about: Mapping[tuple[str, str], Sequence[str]] | None = None,
    ) -> str:
        """Every answer of a round as CSV, one row per answer, times in ``time_zone``,
        in the app's :attr:`columns`: ``about`` gives a set's item, by ``(set, item
        id)``, its cells in the ``columns.about`` columns (empty for one not given).

        Visitors appear by their pseudonymous id and their name: the one the round's
        class asked for, else the one they chose, if any. Cells are written so
        spreadsheets do not run an answer that starts like a formula.
        """
        described = dict(about or {})
        blank = [""] * len(self.columns.about)
        if any(len(cells) != len(blank) for cells in described.values()):
            raise ValueError(f"Each item is described in {len(blank)} columns here.")
        quiz_round = self.get_round(wall_id, number)
        held = class_at(self.db, wall_id, quiz_round.started_at) if quiz_round else None
        on_roll = roll_names(self.db, held.id) if held is not None else {}
        with self.db.session() as session:
            rows = session.execute(
                select(QuizAnswerRecord, VisitorRecord.display_name)
                .outerjoin(VisitorRecord, VisitorRecord.id == QuizAnswerRecord.visitor_id)
                .where(
                    QuizAnswerRecord.app == self.app,
                    QuizAnswerRecord.wall_id == wall_id,
                    QuizAnswerRecord.round == number,
                )
                .order_by(
                    QuizAnswerRecord.visitor_id, QuizAnswerRecord.set_name, QuizAnswerRecord.id
                )
            ).all()
        zone = ZoneInfo(time_zone)
        out = io.StringIO()
        writer = csv.writer(out)
        writer.writerow(self.columns.header())
        for row, chosen_name in rows:
            cells = described.get((row.set_name, row.item_id), blank)
            writer.writerow(
                [
                    row.round,
                    row.visitor_id,
                    _spreadsheet_safe(on_roll.get(row.visitor_id) or chosen_name or ""),
                    row.set_name,
                    row.item_id,
                    *(_spreadsheet_safe(cell) for cell in cells),
                    _spreadsheet_safe(row.answer),
                    CORRECT_CELL[row.correct],
                    as_utc(row.answered_at).astimezone(zone).isoformat(timespec="seconds"),
                    _spreadsheet_safe(held.title if held is not None else ""),
                ]
            )
        return out.getvalue()
