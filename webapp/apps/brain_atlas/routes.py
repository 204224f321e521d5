"""The brain atlas's pages and API: pins, the quiz, the literature search, and the
instructor's controls (mode, view, pin set, statistics, reset, CSV export)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from fastapi import APIRouter, Form, HTTPException, Query, Request, Response, status
from pydantic import BaseModel, ConfigDict, Field

from webapp.apps.brain_atlas import pages
from webapp.apps.brain_atlas.atlas import brain_atlas
from webapp.apps.brain_atlas.audience import allow_audience_switches, audience_switches
from webapp.apps.brain_atlas.content import TagSetName
from webapp.apps.brain_atlas.literature import literature_for
from webapp.apps.brain_atlas.pins import VOLUME
from webapp.apps.brain_atlas.rules import (
    APP,
    TAG_SETS,
    Mode,
    mode_of,
    pin_question,
    quiz_of,
    set_on_wall,
)
from webapp.apps.brain_atlas.state import BrainState
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.wall_state import WallState
from webapp.quiz.engine import QuizError, Reveal
from webapp.quiz.http import answers_download, round_step
from webapp.web.context import Update
from webapp.web.deps import ContextDep, CsrfDep, PersonDep, PhoneDep, StaffDep, WallDep
from webapp.web.problems import errors
from webapp.web.templating import render

router = APIRouter(tags=["brain"])

TagSetPath = Literal["k5", "full"]
AnswerForm = Annotated[str, Form()]  # judged and bounded by the quiz, with its own words


# --- phones --------------------------------------------------------------------------


@router.get("/apps/brain/{wall_id}/pins/{code}", include_in_schema=False)
async def pin(request: Request, phone: PhoneDep, code: str) -> Response:
    """A pin's page again (from the progress page), without counting a scan."""
    context, wall = phone.context, phone.wall
    tag = await pages.tag_of(context, wall, code)
    return await pages.pin_page(brain_atlas(context), request, context, wall, tag, phone.person)


@router.post(
    "/apps/brain/{wall_id}/pins/{code}/answer", include_in_schema=False, dependencies=[CsrfDep]
)
async def answer(request: Request, phone: PhoneDep, code: str, answer: AnswerForm = "") -> Response:
    context = phone.context
    return await pages.answer(
        brain_atlas(context), request, context, phone.wall, phone.person, code, answer
    )


@router.post(
    "/apps/brain/{wall_id}/pins/{code}/reveal", include_in_schema=False, dependencies=[CsrfDep]
)
async def reveal(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep, code: str
) -> Response:
    """The instructor's Answer button."""
    return await pages.revealed(brain_atlas(context), request, context, wall, person, code)


@router.get("/apps/brain/{wall_id}/quiz/{tag_set}", include_in_schema=False)
async def quiz_progress(request: Request, phone: PhoneDep, tag_set: TagSetPath) -> Response:
    context = phone.context
    return await pages.progress_page(
        brain_atlas(context), request, context, phone.wall, phone.person, tag_set
    )


@router.post(
    "/apps/brain/{wall_id}/quiz/{tag_set}/finish", include_in_schema=False, dependencies=[CsrfDep]
)
async def quiz_finish(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep, tag_set: TagSetPath
) -> Response:
    return await pages.finished(brain_atlas(context), request, context, wall, person, tag_set)


@router.get("/apps/brain/{wall_id}/pins/{code}/literature", include_in_schema=False)
async def literature(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep, code: str
) -> Response:
    """The research group's literature search for a pin's region (tutor mode only:
    the query names the region)."""
    app = brain_atlas(context)
    tag = await pages.tag_of(context, wall, code)
    region = await pages.tutor_region(app, context, wall, tag)
    if not app.has_research(region):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "This region has no literature list.")
    result = await literature_for(region.id, app.content, app.pubmed(context.settings))
    return render(
        request, "brain/literature.html", wall=wall, tag=tag, region=region, literature=result
    )


@router.get("/apps/brain/{wall_id}/groups", include_in_schema=False)
async def groups(request: Request, wall: WallDep, person: PersonDep) -> Response:
    return pages.groups_page(request, wall, person)


@router.post(
    "/apps/brain/{wall_id}/groups/{group}", include_in_schema=False, dependencies=[CsrfDep]
)
async def join_group(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep, group: str
) -> Response:
    """A group chosen on the phone: as scanning its menu code."""
    return await pages.join_group(brain_atlas(context), request, context, wall, person, group)


# --- the instructor's controls -------------------------------------------------------


class BrainControl(BaseModel):
    """What the dashboard changes: the mode, the view preset and the pin set shown,
    when the open round's students see the names, and whether scanning a user group
    on the menu screen switches the wall's pins."""

    model_config = ConfigDict(extra="forbid")

    mode: Mode | None = None
    preset: str | None = Field(default=None, max_length=64)
    tag_set: TagSetName | None = None
    reveal: Reveal | None = None
    audience_switches: bool | None = None


class NewRound(BaseModel):
    """A new round: new pin numbers and codes; when its students see the names."""

    model_config = ConfigDict(extra="forbid")

    reveal: Reveal = "close"


class PresetEntry(BaseModel):
    id: str
    name: str


class RegionEntry(BaseModel):
    pin: int
    name: str
    answered: int
    share_correct: float | None
    common_wrong: list[tuple[str, int]]


class SetStats(BaseModel):
    participants: int
    answers: int
    finished: int
    regions: list[RegionEntry]


class RoundStatus(BaseModel):
    model_config = ConfigDict(from_attributes=True)  # read off the stored round

    number: int
    open: bool
    reveal: Reveal
    started_at: datetime
    closed_at: datetime | None
    last_answer_at: datetime | None


class BrainStatus(BaseModel):
    on_wall: bool
    mode: Mode
    tag_set: TagSetName
    presets: list[PresetEntry]
    audience_switches: bool
    round: RoundStatus | None
    quiz: dict[str, SetStats]


@router.get("/api/apps/brain/walls/{wall_id}")
async def brain_status(wall: WallDep, context: ContextDep, staff: StaffDep) -> BrainStatus:
    """The brain on a wall, its quiz round and the class's results (names included:
    staff only)."""
    app = brain_atlas(context)
    state, quiz_round = await pages.round_now(app, context, wall)
    quiz: dict[str, SetStats] = {}
    for tag_set in TAG_SETS if quiz_round is not None else ():
        assert quiz_round is not None
        numbered = sorted(app.pins(quiz_round, tag_set).items())
        questions = [pin_question(region, tag_set) for _, region in numbered]
        stats = await run_blocking(
            quiz_of(context).statistics, wall.id, quiz_round.number, tag_set, questions
        )
        quiz[tag_set] = SetStats(
            participants=stats.participants,
            answers=stats.answers,
            finished=stats.finished,
            regions=[
                RegionEntry(
                    pin=n,
                    name=region.name,
                    answered=s.answered,
                    share_correct=s.share_correct,
                    common_wrong=s.common_wrong,
                )
                for (n, region), s in zip(numbered, stats.items, strict=True)
            ],
        )
    return BrainStatus(
        on_wall=state.app == APP,
        mode=mode_of(state),
        tag_set=set_on_wall(state),
        presets=[PresetEntry(id=v.id, name=v.name) for v in app.views],
        audience_switches=await run_blocking(audience_switches, context.db, wall.id),
        round=None if quiz_round is None else RoundStatus.model_validate(quiz_round),
        quiz=quiz,
    )


class Unshown(BaseModel):
    """The pins of a round that no preset view puts on the wall."""

    round: int | None
    tag_set: TagSetName
    pins: int  # the set's pins in the round
    regions: list[str]  # the regions whose pin has a code in no view


@router.get("/api/apps/brain/walls/{wall_id}/unshown", responses=errors(409))
async def unshown_pins(
    wall: WallDep, context: ContextDep, staff: StaffDep, tag_set: TagSetName | None = None
) -> Unshown:
    """The regions whose pin no view can show, in the round on the wall (``tag_set``:
    by default the set on the wall). Apart from the status the dashboard polls: it
    places the round's pins in every view, seconds of work on a new round."""
    app = brain_atlas(context)
    state, quiz_round = await pages.round_now(app, context, wall)
    if state.app != APP:  # its pins are placed on the brain as the wall shows it
        raise HTTPException(status.HTTP_409_CONFLICT, f"The brain atlas is not on {wall.name}.")
    chosen = tag_set or set_on_wall(state)
    if quiz_round is None:
        return Unshown(round=None, tag_set=chosen, pins=0, regions=[])
    regions = await run_blocking(app.unshown, context, wall, quiz_round, chosen)
    return Unshown(
        round=quiz_round.number,
        tag_set=chosen,
        pins=len(app.pins(quiz_round, chosen)),
        regions=[region.name for region in regions],
    )


@router.post("/api/apps/brain/walls/{wall_id}", responses=errors(404, 409))
async def control(
    choice: BrainControl, wall: WallDep, context: ContextDep, staff: StaffDep
) -> BrainStatus:
    """Switch mode, view preset or pin set on every tile at once (codes placed again).

    Tutor pages name every pin, so switching to tutor mode closes a running round;
    switching back to quiz mode after a closed round starts a new one (new numbers
    and codes, in the same swap).
    """
    app = brain_atlas(context)
    preset = app.preset(choice.preset) if choice.preset else None
    if choice.preset and preset is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no view {choice.preset!r}.")
    state, quiz_round = await pages.round_now(app, context, wall)
    only_audience = choice.model_fields_set <= {"audience_switches"}
    if state.app != APP and not only_audience:
        raise HTTPException(status.HTTP_409_CONFLICT, f"The brain atlas is not on {wall.name}.")
    if choice.audience_switches is not None:
        await run_blocking(allow_audience_switches, context.db, wall.id, choice.audience_switches)
    if choice.reveal is not None and quiz_round is not None and quiz_round.open:
        await round_step(quiz_of(context).set_reveal, wall.id, quiz_round.number, choice.reveal)

    async def plan(current: WallState) -> Update:
        if current.app != APP:
            return lambda held: held
        changed = current
        if choice.mode is not None and choice.mode != mode_of(current):
            try:
                changed = await run_blocking(
                    app.switch_mode, context, wall.id, current, choice.mode, staff
                )
            except QuizError as error:
                raise HTTPException(status.HTTP_409_CONFLICT, str(error)) from error
        update: dict[str, object] = {}
        if choice.tag_set is not None:
            update["tag_set"] = TAG_SETS[choice.tag_set]
        if preset is not None:
            update["view"] = preset.view
            update["volume"] = preset.layer(VOLUME)
        planned = changed.model_copy(update=update)
        return lambda _held: planned

    await context.plan_change(wall, plan)
    return await brain_status(wall, context, staff)


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
    _, quiz_round = await pages.round_now(app, context, wall)
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
        _, quiz_round = await pages.round_now(brain_atlas(context), context, wall)
    else:
        quiz_round = await run_blocking(quiz_of(context).get_round, wall.id, round_number)
    return await answers_download(quiz_of(context), wall, quiz_round)
