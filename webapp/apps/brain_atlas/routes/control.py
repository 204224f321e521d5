"""The instructor's controls of the brain atlas on a wall: its status with the quiz's
results, the mode, view preset, pin set and audience switches, and the pins no view
shows."""

from __future__ import annotations

from datetime import datetime

from fastapi import APIRouter, HTTPException, status
from pydantic import BaseModel, ConfigDict, Field

from webapp.apps.brain_atlas.atlas import brain_atlas
from webapp.apps.brain_atlas.audience import allow_audience_switches, audience_switches
from webapp.apps.brain_atlas.content import TagSetName
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
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import WallState
from webapp.quiz.engine import QuizError, Reveal
from webapp.quiz.http import round_step
from webapp.web.context import Update
from webapp.web.deps import ContextDep, StaffDep, WallDep
from webapp.web.problems import errors

router = APIRouter(tags=["brain"])


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
    state, quiz_round = await app.round_now(context, wall)
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
    state, quiz_round = await app.round_now(context, wall)
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
    state, quiz_round = await app.round_now(context, wall)
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
