"""The brain atlas's quiz rounds on a wall, as the instructor runs them: a new round,
closing the one on the wall, and a round's answers as a CSV download. Each answers
with the brain's status (``control``)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, HTTPException, Query, Response, status
from pydantic import BaseModel, ConfigDict

from webapp.apps.brain_atlas.atlas import brain_atlas
from webapp.apps.brain_atlas.routes.control import BrainStatus, brain_status
from webapp.apps.brain_atlas.rules import quiz_of
from webapp.apps.brain_atlas.state import BrainState
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.wall_state import WallState
from webapp.quiz.engine import Reveal
from webapp.quiz.http import answers_download, round_step
from webapp.web.deps import ContextDep, StaffDep, WallDep
from webapp.web.problems import errors

router = APIRouter(tags=["brain"])


class NewRound(BaseModel):
    """A new round: new pin numbers and codes; when its students see the names."""

    model_config = ConfigDict(extra="forbid")

    reveal: Reveal = "close"


@router.post("/api/apps/brain/walls/{wall_id}/quiz/reset", responses=errors(409))
async def reset_quiz(
    wall: WallDep, context: ContextDep, staff: StaffDep, choice: NewRound | None = None
) -> BrainStatus:
    """A new round: the one before closes (its students see the names), the pins get
    new numbers and codes on every tile at once; earlier rounds stay for export."""
    app = brain_atlas(context)
    reveal = choice.reveal if choice is not None else "close"
    started = await round_step(
        quiz_of(context).start_round, wall.id, staff, app.fresh_orders(), reveal
    )

    def apply(current: WallState) -> WallState:
        return BrainState.of(current).later_round(started.number).put(current)

    await context.change_wall(wall, apply)
    return await brain_status(wall, context, staff)


@router.post("/api/apps/brain/walls/{wall_id}/quiz/close", responses=errors(409))
async def close_quiz(wall: WallDep, context: ContextDep, staff: StaffDep) -> BrainStatus:
    """Close the round on the wall: answers stop counting and every student sees the
    correct names and their results."""
    app = brain_atlas(context)
    _, quiz_round = await app.round_now(context, wall)
    if quiz_round is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "The quiz has no round yet.")
    await round_step(quiz_of(context).close_round, wall.id, quiz_round.number, staff)
    return await brain_status(wall, context, staff)


@router.get("/api/apps/brain/walls/{wall_id}/answers.csv")
async def answers_csv(
    wall: WallDep,
    context: ContextDep,
    staff: StaffDep,
    round_number: Annotated[RowId | None, Query(alias="round")] = None,
) -> Response:
    """Every answer of a round (default: the one on the wall), for a spreadsheet, in a
    file named by the wall, the round's class, the round and its day."""
    if round_number is None:
        _, quiz_round = await brain_atlas(context).round_now(context, wall)
    else:
        quiz_round = await run_blocking(quiz_of(context).get_round, wall.id, round_number)
    return await answers_download(quiz_of(context), wall, quiz_round)
