"""The brain atlas's phone pages: a pin (the quiz question or the tutor page), the
quiz's progress and results, the instructor's answer, the user-group menu.

Every page that could name a region checks, on the server and for this visitor, that
it may: the quiz form never carries the name, the answer page needs an instructor,
results need the visitor to have finished, tutor pages need tutor mode.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fastapi import HTTPException, Request, Response, status
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import RedirectResponse

from tag_service.codes import normalize_code
from wall_client.layout import Wall
from webapp.apps import Scan, change_state
from webapp.apps.brain_atlas import (
    APP,
    GROUP_LABELS,
    TAG_SETS,
    BrainApp,
    mode_of,
    pin_tag,
    reveals_answers,
    set_of_group,
)
from webapp.apps.brain_atlas.content import Region, TagSetName
from webapp.apps.brain_atlas.quiz import Progress, QuizError, finish, progress, record_answer
from webapp.deps import limit_action, remember_person
from webapp.markdown import markdown_html
from webapp.models import TagRecord
from webapp.people import Person, update_profile
from webapp.routes.pages import render
from webapp.settings import USER_GROUPS, UserGroup
from webapp.tags import find, wall_tags
from webapp.wall_state import WallState, read_state

if TYPE_CHECKING:
    from webapp.services import Services

SUMMARY_PARAGRAPHS = 2  # of a tutor text, on the phone; the public screen shows it all


# --- looking things up -----------------------------------------------------------------


def tag_of(services: Services, wall: Wall, code: str) -> TagRecord:
    """A brain pin of this wall by its code (switched off ones too: an answer to a
    pin the wall no longer shows still counts); 404 otherwise."""
    normal = normalize_code(code)
    tag = find(services.db, normal) if normal else None
    if tag is None or tag.wall_id != wall.id or tag.app != APP or tag.action != "pin":
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That is not a pin of this wall's brain.")
    return tag


def pin_codes(services: Services, wall: Wall, tag_set: TagSetName) -> dict[int, str]:
    """The codes of a set's pins on this wall by pin number (pins ever declared)."""
    prefix = pin_tag(tag_set, 0).removesuffix("0")
    return {
        int(tag.name.removeprefix(prefix)): tag.code
        for tag in wall_tags(services.db, wall.id)
        if tag.app == APP and tag.name and tag.name.startswith(prefix)
    }


def region_of(app: BrainApp, tag: TagRecord) -> tuple[TagSetName, int, Region]:
    tag_set: TagSetName = "k5" if tag.params.get("set") == "k5" else "full"
    number = int(tag.params.get("pin", 0))
    region = app.region_of_pin(tag_set, number)
    if region is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That pin is no longer in the atlas.")
    return tag_set, number, region


async def wall_state(services: Services, wall: Wall) -> WallState:
    _, state = await run_in_threadpool(read_state, services.db, wall.id)
    return state


async def tutor_subject(
    app: BrainApp, services: Services, wall: Wall, tag: TagRecord
) -> Region | None:
    """The region a pin shows in tutor mode (None while the quiz is on: then a pin
    must not be named anywhere)."""
    state = await wall_state(services, wall)
    if state.app != APP or mode_of(state) != "tutor":
        return None
    return region_of(app, tag)[2]


async def tutor_region(app: BrainApp, services: Services, wall: Wall, tag: TagRecord) -> Region:
    """The region of a tutor page; 409 while the quiz is on."""
    found = await tutor_subject(app, services, wall, tag)
    if found is None:
        raise HTTPException(
            status.HTTP_409_CONFLICT, "The quiz is on: the tutor pages open when it is over."
        )
    return found


def pin_views(app: BrainApp, region: Region) -> list[str]:
    """The names of the preset views that show a region's pin."""
    return app.views_showing()[region.id]


# --- pins --------------------------------------------------------------------------


async def pin_page(
    app: BrainApp, request: Request, services: Services, wall: Wall, tag: TagRecord, person: Person
) -> Response:
    """A scanned pin: the quiz question, or the region's tutor page."""
    state = await wall_state(services, wall)
    if mode_of(state) == "tutor":
        return await tutor_page(app, request, services, wall, tag, person)
    return await question_page(app, request, services, wall, tag, person)


async def question_page(
    app: BrainApp,
    request: Request,
    services: Services,
    wall: Wall,
    tag: TagRecord,
    person: Person,
    problem: str | None = None,
    status_code: int = 200,
) -> Response:
    tag_set, number, region = region_of(app, tag)
    now = await run_in_threadpool(progress, services.db, wall.id, person.visitor.id, tag_set)
    mine = now.answers.get(region.id)
    return render(
        request,
        "brain/question.html",
        status_code=status_code,
        wall=wall,
        tag=tag,
        number=number,
        tag_set=tag_set,
        previous=mine.text if mine else "",
        finished=now.finished,
        answered=len(now.answers),
        total=len(app.regions(tag_set)),
        may_reveal=reveals_answers(person),
        problem=problem,
    )


async def answer(
    app: BrainApp,
    request: Request,
    services: Services,
    wall: Wall,
    person: Person,
    code: str,
    text: str,
) -> Response:
    """Store the visitor's answer, judged now, and go on to their progress."""
    tag = await run_in_threadpool(tag_of, services, wall, code)
    tag_set, _, region = region_of(app, tag)
    correct = app.answer_key(tag_set).judge(region.id, text[:1_000])
    try:
        await run_in_threadpool(
            record_answer,
            services.db,
            wall.id,
            person.visitor.id,
            tag_set,
            region.id,
            text,
            correct,
        )
    except QuizError as error:
        return await question_page(
            app,
            request,
            services,
            wall,
            tag,
            person,
            str(error),
            status.HTTP_422_UNPROCESSABLE_CONTENT,
        )
    return progress_redirect(wall, tag_set)


def progress_redirect(wall: Wall, tag_set: TagSetName) -> Response:
    return RedirectResponse(f"/apps/brain/{wall.id}/quiz/{tag_set}", status.HTTP_303_SEE_OTHER)


async def revealed(
    app: BrainApp, request: Request, services: Services, wall: Wall, person: Person, code: str
) -> Response:
    """The correct name of a pin, for instructors only (checked here, for this
    session: a URL copied from an instructor's phone gives a student nothing)."""
    if not reveals_answers(person):
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "Only instructors see answers before the end: answer every pin, then finish.",
        )
    tag = await run_in_threadpool(tag_of, services, wall, code)
    tag_set, number, region = region_of(app, tag)
    return render(
        request,
        "brain/revealed.html",
        wall=wall,
        number=number,
        tag_set=tag_set,
        region=region,
        views=pin_views(app, region),
    )


# --- the quiz as a whole -------------------------------------------------------------


async def progress_page(
    app: BrainApp,
    request: Request,
    services: Services,
    wall: Wall,
    person: Person,
    tag_set: TagSetName,
    problem: str | None = None,
) -> Response:
    """How far the visitor is; once finished, their results with the correct names."""
    now = await run_in_threadpool(progress, services.db, wall.id, person.visitor.id, tag_set)
    regions = app.regions(tag_set)
    codes = await run_in_threadpool(pin_codes, services, wall, tag_set)
    rows = [
        _row(app, now, number, region, codes.get(number))
        for number, region in enumerate(regions, start=1)
    ]
    return render(
        request,
        "brain/progress.html",
        wall=wall,
        tag_set=tag_set,
        rows=rows,
        finished=now.finished,
        complete=now.complete(regions),
        answered=len(now.answers),
        right=sum(1 for a in now.answers.values() if a.correct),
        total=len(regions),
        problem=problem,
    )


def _row(
    app: BrainApp, now: Progress, number: int, region: Region, code: str | None
) -> dict[str, object]:
    """One pin on the progress page: the visitor's own answer; the correct name and
    whether they were right only after they finished."""
    mine = now.answers.get(region.id)
    row: dict[str, object] = {
        "number": number,
        "code": code,
        "answer": mine.text if mine else None,
        "views": pin_views(app, region),
    }
    if now.finished:
        row["name"] = region.name
        row["correct"] = bool(mine and mine.correct)
    return row


async def finished(
    app: BrainApp,
    request: Request,
    services: Services,
    wall: Wall,
    person: Person,
    tag_set: TagSetName,
) -> Response:
    try:
        await run_in_threadpool(
            finish, services.db, wall.id, person.visitor.id, tag_set, app.regions(tag_set)
        )
    except QuizError as error:
        return await progress_page(app, request, services, wall, person, tag_set, str(error))
    return progress_redirect(wall, tag_set)


# --- tutor ---------------------------------------------------------------------------


async def tutor_page(
    app: BrainApp, request: Request, services: Services, wall: Wall, tag: TagRecord, person: Person
) -> Response:
    """The region's page for the visitor's group: a summary here, the whole text on
    the public screen when published."""
    region = await tutor_region(app, services, wall, tag)
    text = app.tutor_text(region, person.user_group)
    if text is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "This region has no page for you yet.")
    paragraphs = text.text.strip().split("\n\n")
    return render(
        request,
        "brain/tutor.html",
        wall=wall,
        tag=tag,
        region=region,
        group=GROUP_LABELS[person.user_group],
        summary=markdown_html("\n\n".join(paragraphs[:SUMMARY_PARAGRAPHS])),
        more=len(paragraphs) > SUMMARY_PARAGRAPHS,
        references=[app.content.references[r] for r in text.references],
        research=person.user_group == "research" and app.has_research(region),
    )


# --- the user-group menu -------------------------------------------------------------


async def choose_group(app: BrainApp, scan: Scan) -> Response:
    """A scanned group code: the visitor joins that group and the wall shows its pins."""
    person = await scan.person()
    group = str(scan.tag.params.get("group", ""))
    return await join_group(
        app, scan.request, scan.services, scan.wall, person, group, scan.address
    )


async def join_group(
    app: BrainApp,
    request: Request,
    services: Services,
    wall: Wall,
    person: Person,
    group: str,
    address: str,
) -> Response:
    """The visitor joins ``group`` and the wall shows that group's pins (from a menu
    code, or from the phone's group list on walls whose menu screen has no room)."""
    if group not in USER_GROUPS:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no user group {group!r}.")
    limit_action(services, "group", person.visitor, address, wall.id)
    chosen: UserGroup = group
    updated = await run_in_threadpool(
        update_profile,
        services.db,
        person,
        services.settings,
        user_group=chosen,
        info_class=person.info_class,
        display_name=person.display_name,
    )
    remember_person(request, updated)
    tag_set = set_of_group(chosen)
    await show_set(services, wall, tag_set)
    return render(
        request,
        "brain/group.html",
        wall=wall,
        group=GROUP_LABELS[chosen],
        tag_set=tag_set,
        pins=len(app.regions(tag_set)),
    )


def groups_page(request: Request, wall: Wall, person: Person) -> Response:
    """Every user group as a button: the menu screen's codes, for phones."""
    return render(
        request, "brain/groups.html", wall=wall, groups=GROUP_LABELS, current=person.user_group
    )


async def show_set(services: Services, wall: Wall, tag_set: TagSetName) -> None:
    """Put a set's pins on the wall (every tile at once)."""

    def switch(state: WallState) -> WallState:
        if state.app != APP:
            return state
        return state.model_copy(update={"tag_set": TAG_SETS[tag_set]})

    await change_state(services, wall, switch)
