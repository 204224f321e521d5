"""The poll's API, every path under /api/apps/poll/: instructors ask a question and
close the poll (the dashboard's panel) and download its votes; tiles read the question
of the poll on the wall."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, HTTPException, Response, status
from pydantic import BaseModel, Field

from poll_app.polls import (
    ITEM,
    SET,
    PollState,
    ask,
    closed,
    columns,
    counts,
    later_poll,
    question_of,
    quiz_of,
)
from wall_client.layout import Wall
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.wall_state import WallState
from webapp.people.person import plain_text
from webapp.quiz.engine import Question
from webapp.quiz.http import answers_download, round_step
from webapp.web.context import AppContext, Update
from webapp.web.deps import ContextDep, StaffDep, WallDep

router = APIRouter(tags=["poll"])

Choice = Annotated[str, Field(min_length=1, max_length=40)]


class Asked(BaseModel):
    """A question for the room and its choices, as the instructor typed them."""

    question: str = Field(min_length=1, max_length=200)
    choices: list[Choice] = Field(min_length=2, max_length=6)


class Poll(BaseModel):
    """A poll as tiles draw it: its question, its choices and where each one's bar and
    code stand on the wall (scene mm, left to right)."""

    round: int
    question: str
    choices: tuple[str, ...]
    columns: list[tuple[float, float]]

    @classmethod
    def of(cls, wall: Wall, number: int, question: Question) -> Poll:
        placed = columns(wall, len(question.choices))
        return cls(round=number, question=question.text, choices=question.choices, columns=placed)


@router.post("/api/apps/poll/walls/{wall_id}/polls")
async def new_poll(wall: WallDep, context: ContextDep, staff: StaffDep, asked: Asked) -> Poll:
    """A new poll on the wall (the one before closes): its bars and codes on every tile."""
    try:
        question = Question(ITEM, plain_text(asked.question), tuple(map(plain_text, asked.choices)))
    except ValueError as error:  # a choice twice, or one of spaces only
        detail = "Give each choice once, in a few words."
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, detail) from error
    started = await round_step(ask, context.db, wall.id, staff, question)
    await context.change_wall(wall, later_poll(started.number, len(question.choices)))
    return Poll.of(wall, started.number, question)


@router.post("/api/apps/poll/walls/{wall_id}/polls/{number}/close")
async def close(wall: WallDep, context: ContextDep, staff: StaffDep, number: RowId) -> None:
    """The poll takes no more votes; the wall keeps its counts."""
    await round_step(quiz_of(context.db).close_round, wall.id, number, staff)
    await context.change_wall(wall, closed(number))


@router.get("/api/apps/poll/walls/{wall_id}/polls/{number}")
async def poll(wall: WallDep, context: ContextDep, number: RowId) -> Poll:
    """A poll's question, as the wall shows it to anyone in the room."""
    question = await context.db.read(question_of, context.db, wall.id, number)
    if question is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no poll {number}.")
    return Poll.of(wall, number, question)


@router.get("/api/apps/poll/walls/{wall_id}/polls/{number}/answers.csv")
async def votes(wall: WallDep, context: ContextDep, staff: StaffDep, number: RowId) -> Response:
    """Every vote of a poll, one row each, with the question's text."""
    quiz = quiz_of(context.db)
    shown = await run_blocking(quiz.get_round, wall.id, number)
    question = await run_blocking(question_of, context.db, wall.id, number)
    about = {(SET, ITEM): (question.text,)} if question is not None else None
    return await answers_download(quiz, wall, shown, about)


async def show_counts(context: AppContext, wall: Wall, number: int, question: Question) -> None:
    """Every tile's bars at poll ``number``'s votes: a light change of the slot, counted
    with the wall held, so the change after the last vote carries every vote."""

    async def plan(current: WallState) -> Update:
        counted = await run_blocking(counts, context.db, wall.id, number, question)

        def update(state: WallState) -> WallState:
            slot = PollState.of(state)
            if slot.round != number:
                return state
            return slot.model_copy(update={"counts": tuple(counted.values())}).put(state)

        return update

    await context.plan_change(wall, plan)
