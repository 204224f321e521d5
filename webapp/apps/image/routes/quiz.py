"""The image's quiz on a wall as the instructor runs it: its status with the class's
results, a new round, closing it, and a round's answers as a CSV download."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated

from fastapi import APIRouter, HTTPException, Query, Response, status
from pydantic import BaseModel, ConfigDict

from webapp.apps.image import hotspots
from webapp.apps.image.questions import (
    asked,
    described,
    numbers,
    question_of,
    quiz_of,
    round_on_wall,
    start_round,
)
from webapp.apps.image.routes.common import store_of
from webapp.apps.image.state import APP, ImageState, shows_round
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.wall_state import read_state
from webapp.quiz.http import answers_download, round_step
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep, StaffDep, WallDep
from webapp.web.problems import errors

router = APIRouter(tags=["image"])


class RoundStatus(BaseModel):
    model_config = ConfigDict(from_attributes=True)  # read off the stored round

    number: int
    open: bool
    started_at: datetime
    closed_at: datetime | None


class QuestionStats(BaseModel):
    number: int
    hotspot: str
    title: str
    answered: int
    share_correct: float | None
    common_wrong: list[tuple[str, int]]


class QuizStatus(BaseModel):
    image: str | None  # the image on the wall (None: the app or an image is not up)
    questions: int  # its hotspots with a question
    round: RoundStatus | None
    participants: int
    answers: int
    finished: int
    items: list[QuestionStats]


def _quiz_status(context: AppContext, wall_id: str) -> QuizStatus:
    """The round on the wall and the class's results on the image shown (in a worker
    thread; names and answers included: staff only)."""
    _, state = read_state(context.db, wall_id)
    image_id = ImageState.of(state).image if state.app == APP else None
    try:
        spots = hotspots.hotspots(store_of(context), image_id) if image_id else []
    except KeyError:
        spots = []
    quiz_round = round_on_wall(context, wall_id, state)
    status_now = QuizStatus(
        image=image_id,
        questions=len(asked(spots)),
        round=None if quiz_round is None else RoundStatus.model_validate(quiz_round),
        participants=0,
        answers=0,
        finished=0,
        items=[],
    )
    if quiz_round is None or image_id is None:
        return status_now
    numbered = sorted((n, hid) for hid, n in numbers(quiz_round, image_id, spots).items())
    by_id = {spot.id: spot for spot in spots}
    ordered = [by_id[hid] for _, hid in numbered]
    questions = [question_of(spot) for spot in ordered]
    stats = quiz_of(context).statistics(wall_id, quiz_round.number, image_id, questions)
    return status_now.model_copy(
        update={
            "participants": stats.participants,
            "answers": stats.answers,
            "finished": stats.finished,
            "items": [
                QuestionStats(
                    number=n,
                    hotspot=spot.id,
                    title=spot.title,
                    answered=s.answered,
                    share_correct=s.share_correct,
                    common_wrong=s.common_wrong,
                )
                for (n, _), spot, s in zip(numbered, ordered, stats.items, strict=True)
            ],
        }
    )


@router.get("/api/apps/image/walls/{wall_id}")
async def quiz_status(wall: WallDep, context: ContextDep, staff: StaffDep) -> QuizStatus:
    """The image's quiz on a wall: its round and the class's results so far."""
    return await run_blocking(_quiz_status, context, wall.id)


@router.post("/api/apps/image/walls/{wall_id}/quiz/start", responses=errors(409))
async def start_quiz(wall: WallDep, context: ContextDep, staff: StaffDep) -> QuizStatus:
    """A new round on the image on the wall: the one before closes (its students see
    the answers), its questions get new numbers and codes on every tile at once."""
    now = await run_blocking(_quiz_status, context, wall.id)
    if now.image is None or not now.questions:
        raise HTTPException(status.HTTP_409_CONFLICT, f"No image with questions is on {wall.name}.")
    started = await round_step(start_round, context, store_of(context), wall.id, now.image, staff)
    await context.change_wall(wall, shows_round(started.number))
    return await run_blocking(_quiz_status, context, wall.id)


@router.post("/api/apps/image/walls/{wall_id}/quiz/close", responses=errors(409))
async def close_round(wall: WallDep, context: ContextDep, staff: StaffDep) -> QuizStatus:
    """Close the round on the wall: answers stop counting and students see the answers."""
    now = await run_blocking(_quiz_status, context, wall.id)
    if now.round is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "The quiz has no round yet.")
    await round_step(quiz_of(context).close_round, wall.id, now.round.number, staff)
    return await run_blocking(_quiz_status, context, wall.id)


@router.get("/api/apps/image/walls/{wall_id}/answers.csv", responses=errors(404))
async def answers_csv(
    wall: WallDep,
    context: ContextDep,
    staff: StaffDep,
    round_number: Annotated[RowId | None, Query(alias="round")] = None,
) -> Response:
    """Every answer of a round (default: the one on the wall), for a spreadsheet, each
    named by its image and hotspot, the hotspot's title and question, in a file named
    by the wall, the round's class, the round and its day."""
    quiz = quiz_of(context)
    if round_number is None:
        now = await run_blocking(_quiz_status, context, wall.id)
        round_number = now.round.number if now.round is not None else None
    quiz_round = await run_blocking(quiz.get_round, wall.id, round_number) if round_number else None
    about = await run_blocking(described, store_of(context), quiz_round) if quiz_round else None
    return await answers_download(quiz, wall, quiz_round, about)
