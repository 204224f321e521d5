"""The brain atlas's pages and API: pins, the quiz, the literature search, and the
instructor's controls (mode, view, pin set, statistics, reset, CSV export)."""

from __future__ import annotations

from typing import Annotated, Literal, cast

from fastapi import APIRouter, Form, HTTPException, Query, Request, Response, status
from fastapi.concurrency import run_in_threadpool
from pydantic import BaseModel, ConfigDict, Field

from webapp.apps import change_state
from webapp.apps.brain_atlas import (
    APP,
    TAG_SETS,
    BrainApp,
    Mode,
    mode_of,
    pages,
    set_on_wall,
)
from webapp.apps.brain_atlas.content import TagSetName
from webapp.apps.brain_atlas.literature import literature_for
from webapp.apps.brain_atlas.pins import VOLUME
from webapp.apps.brain_atlas.quiz import export_csv, start_round, statistics
from webapp.db import RowId
from webapp.deps import ClientAddressDep, CsrfDep, PersonDep, ServicesDep, StaffDep, WallDep
from webapp.routes.pages import render
from webapp.schemas import errors
from webapp.services import Services
from webapp.wall_state import WallState

router = APIRouter(tags=["brain"])

TagSetPath = Literal["k5", "full"]
AnswerForm = Annotated[str, Form()]  # judged and bounded by the quiz, with its own words


def brain_app(services: Services) -> BrainApp:
    return cast(BrainApp, services.apps[APP])


# --- phones --------------------------------------------------------------------------


@router.get("/apps/brain/{wall_id}/pins/{code}", include_in_schema=False)
async def pin(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep, code: str
) -> Response:
    """A pin's page again (from the progress page), without counting a scan."""
    tag = await run_in_threadpool(pages.tag_of, services, wall, code)
    return await pages.pin_page(brain_app(services), request, services, wall, tag, person)


@router.post(
    "/apps/brain/{wall_id}/pins/{code}/answer", include_in_schema=False, dependencies=[CsrfDep]
)
async def answer(
    request: Request,
    wall: WallDep,
    services: ServicesDep,
    person: PersonDep,
    code: str,
    answer: AnswerForm = "",
) -> Response:
    return await pages.answer(brain_app(services), request, services, wall, person, code, answer)


@router.post(
    "/apps/brain/{wall_id}/pins/{code}/reveal", include_in_schema=False, dependencies=[CsrfDep]
)
async def reveal(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep, code: str
) -> Response:
    """The instructor's Answer button."""
    return await pages.revealed(brain_app(services), request, services, wall, person, code)


@router.get("/apps/brain/{wall_id}/quiz/{tag_set}", include_in_schema=False)
async def quiz_progress(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep, tag_set: TagSetPath
) -> Response:
    return await pages.progress_page(brain_app(services), request, services, wall, person, tag_set)


@router.post(
    "/apps/brain/{wall_id}/quiz/{tag_set}/finish", include_in_schema=False, dependencies=[CsrfDep]
)
async def quiz_finish(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep, tag_set: TagSetPath
) -> Response:
    return await pages.finished(brain_app(services), request, services, wall, person, tag_set)


@router.get("/apps/brain/{wall_id}/pins/{code}/literature", include_in_schema=False)
async def literature(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep, code: str
) -> Response:
    """The research group's literature search for a pin's region (tutor mode only:
    the query names the region)."""
    app = brain_app(services)
    tag = await run_in_threadpool(pages.tag_of, services, wall, code)
    region = await pages.tutor_region(app, services, wall, tag)
    if not app.has_research(region):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "This region has no literature list.")
    result = await literature_for(region.id, app.content, app.pubmed(services.settings))
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
    request: Request,
    wall: WallDep,
    services: ServicesDep,
    person: PersonDep,
    address: ClientAddressDep,
    group: str,
) -> Response:
    """A group chosen on the phone: as scanning its menu code."""
    app = brain_app(services)
    return await pages.join_group(app, request, services, wall, person, group, address)


# --- the instructor's controls -------------------------------------------------------


class BrainControl(BaseModel):
    """What the dashboard changes: the mode, the view preset and the pin set shown."""

    model_config = ConfigDict(extra="forbid")

    mode: Mode | None = None
    preset: str | None = Field(default=None, max_length=64)
    tag_set: TagSetName | None = None


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
    finished: int
    regions: list[RegionEntry]


class BrainStatus(BaseModel):
    on_wall: bool
    mode: Mode
    tag_set: TagSetName
    presets: list[PresetEntry]
    round: int
    quiz: dict[str, SetStats]


@router.get("/api/walls/{wall_id}/brain")
async def brain_status(wall: WallDep, services: ServicesDep, staff: StaffDep) -> BrainStatus:
    """The brain on a wall and its class's quiz results (names included: staff only)."""
    app = brain_app(services)
    state = await pages.wall_state(services, wall)
    quiz: dict[str, SetStats] = {}
    number = 0
    for tag_set in TAG_SETS:
        regions = app.regions(tag_set)
        stats = await run_in_threadpool(statistics, services.db, wall.id, tag_set, regions)
        number = stats.round
        quiz[tag_set] = SetStats(
            participants=stats.participants,
            finished=stats.finished,
            regions=[
                RegionEntry(
                    pin=n,
                    name=region.name,
                    answered=s.answered,
                    share_correct=s.share_correct,
                    common_wrong=s.common_wrong,
                )
                for n, (region, s) in enumerate(zip(regions, stats.regions, strict=True), 1)
            ],
        )
    return BrainStatus(
        on_wall=state.app == APP,
        mode=mode_of(state),
        tag_set=set_on_wall(state),
        presets=[PresetEntry(id=v.id, name=v.name) for v in app.views],
        round=number,
        quiz=quiz,
    )


@router.post("/api/walls/{wall_id}/brain", responses=errors(404, 409))
async def control(
    choice: BrainControl, wall: WallDep, services: ServicesDep, staff: StaffDep
) -> BrainStatus:
    """Switch mode, view preset or pin set on every tile at once (codes placed again)."""
    app = brain_app(services)
    preset = app.preset(choice.preset) if choice.preset else None
    if choice.preset and preset is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no view {choice.preset!r}.")
    state = await pages.wall_state(services, wall)
    if state.app != APP:
        raise HTTPException(status.HTTP_409_CONFLICT, f"The brain atlas is not on {wall.name}.")

    def apply(current: WallState) -> WallState:
        if current.app != APP:
            return current
        update: dict[str, object] = {}
        if choice.mode is not None:
            update["mode"] = choice.mode
        if choice.tag_set is not None:
            update["tag_set"] = TAG_SETS[choice.tag_set]
        if preset is not None:
            update["view"] = preset.view
            update["volume"] = preset.layer(VOLUME)
        return current.model_copy(update=update)

    await change_state(services, wall, apply)
    return await brain_status(wall, services, staff)


@router.post("/api/walls/{wall_id}/brain/quiz/reset")
async def reset_quiz(wall: WallDep, services: ServicesDep, staff: StaffDep) -> BrainStatus:
    """Everyone starts again in a new round (earlier rounds stay for export)."""
    await run_in_threadpool(start_round, services.db, wall.id, staff)
    return await brain_status(wall, services, staff)


@router.get("/api/walls/{wall_id}/brain/answers.csv")
async def answers_csv(
    wall: WallDep,
    services: ServicesDep,
    staff: StaffDep,
    round_number: Annotated[RowId | None, Query(alias="round")] = None,
) -> Response:
    """Every answer of a round (default: the current one), for a spreadsheet."""
    body = await run_in_threadpool(export_csv, services.db, wall.id, round_number)
    return Response(
        body,
        media_type="text/csv; charset=utf-8",
        headers={"Content-Disposition": f'attachment; filename="brain-quiz-{wall.id}.csv"'},
    )
