"""The poll's data: its slot of the wall state, its table of questions, and the votes,
which the shared quiz engine keeps (each poll is one round of the app's quiz)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import sqlalchemy as sa

from wall_client.layout import Wall
from webapp.database.connection import Database
from webapp.engine.wall_state import AppState, WallState
from webapp.quiz.engine import Columns, Question, Quiz, QuizError, Round
from webapp.web.context import Update

APP = "poll"
SET, ITEM = "poll", "question"  # a poll's round asks one set of one question


class PollState(AppState):
    """The poll on the wall: its round, and the votes per choice that tiles draw."""

    app: ClassVar[str] = APP
    heavy: ClassVar[frozenset[str]] = frozenset({"round"})  # tiles fetch the question first
    placing: ClassVar[frozenset[str]] = frozenset({"round"})  # a new poll, new codes

    round: int | None = None  # the poll's quiz round (None: no poll asked yet)
    counts: tuple[int, ...] = ()  # votes per choice, in the choices' order
    closed: bool = False


def later_poll(number: int, choices: int) -> Update:
    """The wall showing poll ``number`` with no votes yet, unless it shows a later one
    (two instructors asking at once: the wall keeps the newest)."""

    def update(state: WallState) -> WallState:
        if (PollState.of(state).round or 0) > number:
            return state
        return PollState(round=number, counts=(0,) * choices).put(state)

    return update


def closed(number: int) -> Update:
    """The wall marking poll ``number`` closed, if it still shows it."""

    def update(state: WallState) -> WallState:
        slot = PollState.of(state)
        if slot.round != number:
            return state
        return slot.model_copy(update={"closed": True}).put(state)

    return update


QUESTIONS = sa.Table(
    "poll_questions",  # as its revision (migrations/poll_0001_questions.py) made it
    sa.MetaData(),
    sa.Column("wall_id", sa.String(64), primary_key=True),
    sa.Column("round", sa.Integer, primary_key=True),
    sa.Column("text", sa.String(200), nullable=False),
    sa.Column("choices", sa.JSON, nullable=False),
)

COLUMNS = Columns(about=("question",))
"""The votes CSV: round, visitor, name, set, item, the question's text, the vote..."""


def quiz_of(db: Database) -> Quiz:
    return Quiz(db, APP, COLUMNS)


def ask(db: Database, wall_id: str, asked_by: str, question: Question) -> Round:
    """A new poll on the wall: a new round (the one before closes) and its question."""
    started = quiz_of(db).start_round(wall_id, asked_by, {SET: [ITEM]})
    with db.session() as session:
        session.execute(
            sa.insert(QUESTIONS).values(
                wall_id=wall_id,
                round=started.number,
                text=question.text,
                choices=list(question.choices),
            )
        )
    return started


def question_of(db: Database, wall_id: str, number: int) -> Question | None:
    """Poll ``number``'s question (None: no such poll on the wall)."""
    with db.reading() as connection:
        row = connection.execute(
            sa.select(QUESTIONS.c.text, QUESTIONS.c.choices).where(
                QUESTIONS.c.wall_id == wall_id, QUESTIONS.c.round == number
            )
        ).first()
    return None if row is None else Question(ITEM, row.text, tuple(row.choices))


def counts(db: Database, wall_id: str, number: int, question: Question) -> dict[str, int]:
    """Each choice with its votes, in the question's order."""
    [votes] = quiz_of(db).statistics(wall_id, number, SET, [question]).items
    return votes.choices


@dataclass(frozen=True)
class Ballot:
    """What a phone's scan of a choice came to: the question, the votes so far, the
    phone's own vote, why this scan's vote did not count (None: it did) and whether the
    poll still takes votes."""

    question: Question
    counts: dict[str, int]
    mine: str | None
    refused: str | None
    open: bool


def vote(
    db: Database, wall_id: str, number: int, visitor_id: str, choice: str | None
) -> Ballot | None:
    """The visitor's vote for ``choice`` in poll ``number``, counted once (in a worker
    thread; None: no vote, the counts only); None when there is no such poll."""
    question = question_of(db, wall_id, number)
    if question is None:
        return None
    quiz = quiz_of(db)
    refused: str | None = "This code is no longer in use: scan one on the wall now."
    if choice is not None:
        try:
            quiz.answer_once(wall_id, number, visitor_id, SET, question, choice)
            refused = None
        except QuizError as error:  # voted already, or the poll closed
            refused = str(error)
    mine = quiz.progress(wall_id, number, visitor_id, SET).answers.get(ITEM)
    shown = quiz.get_round(wall_id, number)
    return Ballot(
        question,
        counts(db, wall_id, number, question),
        mine.text if mine is not None else None,
        refused,
        shown is not None and shown.open,
    )


def columns(wall: Wall, choices: int) -> list[tuple[float, float]]:
    """Where each choice's bar and code stand, left to right (scene mm): equal columns
    across the stage, each kept to one display (a column across a display's edge keeps
    its larger part), so no bar, count or code is cut by a bezel."""
    stage = wall.stage
    displays = [wall.viewport(display_id).scene_rect for display_id in wall.stage_ids]
    width = stage.width / choices
    placed = []
    for index in range(choices):
        left, right = stage.x + index * width, stage.x + (index + 1) * width
        on = max(displays, key=lambda r: min(right, r.right) - max(left, r.x))
        placed.append((max(left, on.x), min(right, on.right)))
    return placed
