"""What phones ask for of the brain atlas and what they do: a pin's page and its answer,
the instructor's Answer button, the quiz's progress and finishing it, a region's
literature, the user groups and joining one (a group code on the menu screen too).

Every write a phone makes is here, each beside the route that takes it: an answer is
judged by the atlas's answer key and stored by the quiz engine; finishing is the quiz
engine's; joining a group changes the phone's person and, where the instructor lets
the audience switch the wall, the wall's pins. The pages they lead to are ``pages``'.
"""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Form, HTTPException, Request, Response, status
from fastapi.responses import RedirectResponse

from tag_service.codes import normalize_code
from wall_client.layout import Wall
from webapp.apps.brain_atlas import pages
from webapp.apps.brain_atlas.atlas import Atlas, Pin, RoundChanged, brain_atlas
from webapp.apps.brain_atlas.audience import audience_switches, claim_audience_switch
from webapp.apps.brain_atlas.content import TagSetName
from webapp.apps.brain_atlas.literature import literature_for
from webapp.apps.brain_atlas.rules import (
    APP,
    GROUP_LABELS,
    TAG_SETS,
    mode_of,
    quiz_of,
    set_of_group,
    set_on_wall,
)
from webapp.apps.hooks import Scan
from webapp.core.roles import USER_GROUPS, UserGroup
from webapp.core.threads import run_blocking
from webapp.database.models import TagRecord
from webapp.engine.wall_state import WallState
from webapp.people.person import Person, remember_person, update_profile
from webapp.people.visitors import Visitor
from webapp.quiz.engine import Progress, QuizError
from webapp.web.context import AppContext
from webapp.web.deps import CsrfDep, PhoneDep
from webapp.web.templating import render

router = APIRouter(tags=["brain"])

TagSetPath = Literal["k5", "full"]
AnswerForm = Annotated[str, Form()]  # judged and bounded by the quiz, with its own words


async def tag_of(context: AppContext, wall: Wall, code: str) -> TagRecord:
    """A brain pin of this wall by its code (switched off ones too: a pin the wall no
    longer shows may still be answered); 404 otherwise. From the scan path's cache of
    codes: every answer of a room looks its pin up."""
    normal = normalize_code(code)
    tag = (await context.codes.resolve(normal)).tag if normal else None
    if tag is None or tag.wall_id != wall.id or tag.app != APP or tag.action != "pin":
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That is not a pin of this wall's brain.")
    return tag


def progress_redirect(wall: Wall, tag_set: TagSetName) -> Response:
    return RedirectResponse(f"/apps/brain/{wall.id}/quiz/{tag_set}", status.HTTP_303_SEE_OTHER)


# --- pins ----------------------------------------------------------------------------


@router.get("/apps/brain/{wall_id}/pins/{code}", include_in_schema=False)
async def pin(request: Request, phone: PhoneDep, code: str) -> Response:
    """A pin's page again (from the progress page), without counting a scan."""
    context, wall = phone.context, phone.wall
    tag = await tag_of(context, wall, code)
    return await pages.pin_page(brain_atlas(context), request, context, wall, tag, phone.person)


@router.post(
    "/apps/brain/{wall_id}/pins/{code}/answer", include_in_schema=False, dependencies=[CsrfDep]
)
async def answer(request: Request, phone: PhoneDep, code: str, answer: AnswerForm = "") -> Response:
    """Store the visitor's answer, judged now, and go on to their progress."""
    context, wall, person = phone.context, phone.wall, phone.person
    app = brain_atlas(context)
    tag = await tag_of(context, wall, code)
    try:
        pin, refused = await run_blocking(store_answer, app, context, wall, tag, person, answer)
    except RoundChanged as changed:
        return pages.round_changed_page(request, wall, changed.tag, status.HTTP_409_CONFLICT)
    if refused is not None:
        now, problem = refused
        return pages.question_page(
            app, request, wall, pin, now, person, problem, status.HTTP_422_UNPROCESSABLE_CONTENT
        )
    return progress_redirect(wall, pin.tag_set)


def store_answer(
    app: Atlas, context: AppContext, wall: Wall, tag: TagRecord, person: Person, text: str
) -> tuple[Pin, tuple[Progress, str] | None]:
    """Judge and store an answer to the pin ``tag`` (in a worker thread); when the
    quiz refuses it, the visitor's progress and why. The pin's reads share one connection
    (as a page's do in :meth:`~webapp.database.connection.Database.read`); the answer is
    written on another, in a transaction of its own."""
    with context.db.reading():
        pin = app.pin(context, wall, tag)
    correct = app.answer_key(pin.tag_set).judge(pin.region.id, text[:1_000])
    quiz = quiz_of(context)
    try:
        if mode_of(pin.state) != "quiz":
            raise QuizError("The wall is in tutor mode: answers are taken in quiz mode only.")
        quiz.record_answer(
            wall.id, pin.round.number, person.visitor.id, pin.tag_set, pin.question, text, correct
        )
    except QuizError as error:
        now = quiz.progress(wall.id, pin.round.number, person.visitor.id, pin.tag_set)
        return pin, (now, str(error))
    return pin, None


@router.post(
    "/apps/brain/{wall_id}/pins/{code}/reveal", include_in_schema=False, dependencies=[CsrfDep]
)
async def reveal(request: Request, phone: PhoneDep, code: str) -> Response:
    """The instructor's Answer button."""
    context, wall = phone.context, phone.wall
    tag = await tag_of(context, wall, code)
    return await pages.revealed(brain_atlas(context), request, context, wall, phone.person, tag)


@router.get("/apps/brain/{wall_id}/pins/{code}/literature", include_in_schema=False)
async def literature(request: Request, phone: PhoneDep, code: str) -> Response:
    """The research group's literature search for a pin's region (tutor mode only:
    the query names the region)."""
    context, wall = phone.context, phone.wall
    app = brain_atlas(context)
    tag = await tag_of(context, wall, code)
    region = await pages.tutor_region(app, context, wall, tag)
    if not app.has_research(region):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "This region has no literature list.")
    result = await literature_for(region.id, app.content, app.pubmed(context.settings))
    return render(
        request, "brain/literature.html", wall=wall, tag=tag, region=region, literature=result
    )


# --- the quiz as a whole -------------------------------------------------------------


@router.get("/apps/brain/{wall_id}/quiz/{tag_set}", include_in_schema=False)
async def quiz_progress(request: Request, phone: PhoneDep, tag_set: TagSetPath) -> Response:
    context = phone.context
    return await pages.progress_page(
        brain_atlas(context), request, context, phone.wall, phone.person, tag_set
    )


@router.post(
    "/apps/brain/{wall_id}/quiz/{tag_set}/finish", include_in_schema=False, dependencies=[CsrfDep]
)
async def quiz_finish(request: Request, phone: PhoneDep, tag_set: TagSetPath) -> Response:
    """The visitor is done with the set: their answers are final."""
    context, wall, person = phone.context, phone.wall, phone.person
    app = brain_atlas(context)
    _, quiz_round = await app.round_now(context, wall)
    try:
        if quiz_round is None:
            raise QuizError("The quiz has not started yet.")
        await run_blocking(
            quiz_of(context).finish,
            wall.id,
            quiz_round.number,
            person.visitor.id,
            tag_set,
            app.regions(tag_set),
        )
    except QuizError as error:
        return await pages.progress_page(app, request, context, wall, person, tag_set, str(error))
    return progress_redirect(wall, tag_set)


# --- the user groups -----------------------------------------------------------------


@router.get("/apps/brain/{wall_id}/groups", include_in_schema=False)
async def groups(request: Request, phone: PhoneDep) -> Response:
    return pages.groups_page(request, phone.wall, phone.person)


@router.post(
    "/apps/brain/{wall_id}/groups/{group}", include_in_schema=False, dependencies=[CsrfDep]
)
async def choose_group_here(request: Request, phone: PhoneDep, group: str) -> Response:
    """A group chosen on the phone: as scanning its menu code."""
    context = phone.context
    return await join_group(brain_atlas(context), request, context, phone.wall, phone.person, group)


async def choose_group(app: Atlas, scan: Scan) -> Response:
    """A scanned group code on the menu screen: the phone joins that group, and the
    wall follows only where the instructor lets the audience switch it."""
    person = await scan.person()
    group = str(scan.tag.params.get("group", ""))
    return await join_group(
        app, scan.request, scan.context, scan.wall, person, group, True, scan.address
    )


async def join_group(
    app: Atlas,
    request: Request,
    context: AppContext,
    wall: Wall,
    person: Person,
    group: str,
    from_menu: bool = False,
    address: str = "",
) -> Response:
    """The phone joins ``group`` (its pages speak to that group from now on). Scanned
    off the menu screen, the wall may follow too (:func:`audience_switch`)."""
    if group not in USER_GROUPS:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no user group {group!r}.")
    chosen: UserGroup = group
    updated = await run_blocking(
        update_profile,
        context.db,
        person,
        context.settings,
        user_group=chosen,
        info_class=person.info_class,
        display_name=person.display_name,
    )
    remember_person(request, updated)
    wanted = set_of_group(chosen)
    outcome = (
        await audience_switch(app, context, wall, wanted, person.visitor, address)
        if from_menu
        else None
    )
    state = await context.state(wall)
    return render(
        request,
        "brain/group.html",
        wall=wall,
        group=GROUP_LABELS[chosen],
        wanted=wanted,
        on_wall=set_on_wall(state) if state.app == APP else None,
        outcome=outcome,
        pins=len(app.regions(wanted)),
    )


async def audience_switch(
    app: Atlas,
    context: AppContext,
    wall: Wall,
    wanted: TagSetName,
    visitor: Visitor,
    address: str,
) -> str:
    """Switch the wall to ``wanted``'s pins for an audience scan, if allowed now; says
    what happened: ``same``, ``switched``, ``instructor`` (the instructor keeps the
    wall's pins), ``quiz`` (a round is running) or ``wait`` (the cooldown, or the
    phone's own limits on changing the wall: the phone still joins its group)."""
    state, quiz_round = await app.round_now(context, wall)
    if state.app != APP or set_on_wall(state) == wanted:
        return "same"
    if not await run_blocking(audience_switches, context.db, wall.id):
        return "instructor"
    if mode_of(state) == "quiz" and quiz_round is not None and quiz_round.open:
        return "quiz"
    if await context.action_allowed("group", visitor, address, wall.id) is not None:
        return "wait"
    cooldown = context.settings.brain_group_switch_cooldown
    if not await run_blocking(claim_audience_switch, context.db, wall.id, cooldown):
        return "wait"
    await show_set(context, wall, wanted)
    return "switched"


async def show_set(context: AppContext, wall: Wall, tag_set: TagSetName) -> None:
    """Put a set's pins on the wall (every tile at once)."""

    def switch(state: WallState) -> WallState:
        if state.app != APP:
            return state
        return state.model_copy(update={"tag_set": TAG_SETS[tag_set]})

    await context.change_wall(wall, switch)
