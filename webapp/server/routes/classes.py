"""A class at a wall: Start class and End class from the dashboard, and the roll call
that puts a student on the class's roll (asking the name the class wants)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Form, HTTPException, Query, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from wall_client.layout import Wall
from webapp.classes.roll import (
    MAX_NAME,
    NAME_PROMPTS,
    ClassError,
    ClassSession,
    NameMode,
    end_class,
    get_class,
    join,
    joined_count,
    latest_class,
    roll_name,
    running_class,
    start_class,
)
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import View, WallState, differing_fields, read_state
from webapp.lti.courses import course_class, grades, queue_scores, roster
from webapp.people.person import Person
from webapp.server.deps import ServicesDep, showable_app
from webapp.server.schemas import ClassInfo, ClassStart, CourseInfo, ExportLink
from webapp.server.services import Services
from webapp.web.context import Update
from webapp.web.deps import CsrfDep, PersonDep, StaffDep, WallDep
from webapp.web.problems import errors
from webapp.web.templating import render

router = APIRouter(tags=["classes"])


# --- the dashboard's class ---------------------------------------------------------------


async def class_info(services: Services, wall: Wall, held: ClassSession) -> ClassInfo:
    """``held`` as the dashboard shows it: how many joined, and once it ended, what its
    app produced to download."""
    joined = await run_blocking(joined_count, services.db, held.id)
    exports = []
    if not held.running:
        _, state = await run_blocking(read_state, services.db, wall.id)
        if (app := services.wall_apps.get(state.app)) is not None:
            found = await run_blocking(app.class_exports, services, wall, held)
            exports = [ExportLink(label=e.label, url=e.url) for e in found]
    return ClassInfo(
        course=await course_info(services, held),
        id=held.id,
        title=held.title,
        names=held.names,
        running=held.running,
        started_at=held.started_at,
        ended_at=held.ended_at,
        joined=joined,
        exports=exports,
    )


async def course_info(services: Services, held: ClassSession) -> CourseInfo | None:
    """A class launched from a course: its roster (who joined, who is missing) and how
    its grades stand."""
    course = await run_blocking(course_class, services.db, held.id)
    if course is None:
        return None
    expected = await run_blocking(roster, services.db, held.id)
    standing = await run_blocking(grades, services.db, held.id)
    return CourseInfo(
        joined=[person.name for person in expected if person.joined],
        missing=[person.name for person in expected if not person.joined],
        roster_problem=course.roster_problem,
        graded=course.lineitem_url is not None,
        grades_posted=standing.posted,
        grades_waiting=standing.waiting,
        grades_problem=standing.problem,
        next_try_at=standing.next_try_at,
    )


async def send_grades(services: Services, ended: ClassSession) -> None:
    """An ended class launched from a course: its students' scores go to the course's
    gradebook (queued, posted by the outbox until accepted)."""
    if ended.ended_at is None:
        return
    if await run_blocking(queue_scores, services.db, ended, ended.ended_at):
        services.lti_outbox.wake()


@router.get("/api/walls/{wall_id}/class")
async def class_now(wall: WallDep, services: ServicesDep, staff: StaffDep) -> ClassInfo | None:
    """The class running at the wall, else the last one (null: none ever ran)."""
    held = await run_blocking(latest_class, services.db, wall.id)
    return None if held is None else await class_info(services, wall, held)


@router.post("/api/walls/{wall_id}/class", responses=errors(409))
async def begin(
    choice: ClassStart, wall: WallDep, services: ServicesDep, staff: StaffDep
) -> ClassInfo:
    """Start class: the running class ends; the chosen app comes on the wall at its
    first view, in the chosen mode (a fresh quiz round), with its own tag set, no
    balloons and an empty public screen, on every tile at once."""
    held = await start_on_wall(
        services, wall, choice.title, choice.app, choice.mode, choice.names, staff
    )
    return await class_info(services, wall, held)


async def start_on_wall(
    services: Services,
    wall: Wall,
    title: str,
    app_name: str | None,
    mode: str | None,
    names: NameMode,
    staff: str,
) -> ClassSession:
    """The one way a class starts, from the dashboard or a course's launch (a 409 when
    another start won the moment; a 422 for an app or mode there is not)."""
    _, state = await run_blocking(read_state, services.db, wall.id)
    app = showable_app(services, app_name or state.app, mode)
    if state.app != app.name:  # before the class starts: what the app settles is not its
        await services.change_wall(wall, lambda s: s.model_copy(update={"app": app.name}))
    before = await run_blocking(running_class, services.db, wall.id)
    try:
        held = await run_blocking(
            start_class, services.db, wall.id, title, names, staff, wall.time_zone
        )
    except ClassError as error:
        raise HTTPException(status.HTTP_409_CONFLICT, str(error)) from error
    if before is not None and (ended := await run_blocking(get_class, services.db, before.id)):
        await send_grades(services, ended)  # the class this start ended

    async def plan(current: WallState) -> Update:
        fresh = current.model_copy(
            update={"view": View(), "balloons": [], "public": None, "tag_set": app.default_tag_set}
        )
        began = await run_blocking(app.begin_class, services, wall, fresh, mode)
        fields = differing_fields(began, current)
        return lambda s: s.model_copy(update=fields)

    await services.plan_change(wall, plan)
    return held


@router.post("/api/walls/{wall_id}/class/end", responses=errors(409))
async def end(wall: WallDep, services: ServicesDep, staff: StaffDep) -> ClassInfo:
    """End class: the app closes what ran (the quiz round: students see the names), and
    the answer comes with what the class produced to download."""
    held = await run_blocking(end_class, services.db, wall.id, staff)
    if held is None:
        raise HTTPException(status.HTTP_409_CONFLICT, f"No class is running at {wall.name}.")

    async def plan(current: WallState) -> Update:
        if (app := services.wall_apps.get(current.app)) is None:
            return lambda s: s
        ended = await run_blocking(app.end_class, services, wall, current)
        fields = differing_fields(ended, current)
        return lambda s: s.model_copy(update=fields)

    await services.plan_change(wall, plan)
    await send_grades(services, held)
    return await class_info(services, wall, held)


def _back_to(target: str | None) -> str:
    """Where the join page sends the phone: the code it scanned (a local path of ours)."""
    if target and target.startswith("/t/") and target[3:].isalnum():
        return target
    return "/me"


@router.get("/classes/{class_id}/join", include_in_schema=False)
async def join_page(
    request: Request,
    class_id: int,
    services: ServicesDep,
    person: PersonDep,
    next_path: Annotated[str | None, Query(alias="next", max_length=64)] = None,
) -> HTMLResponse:
    return await _join_form(request, services, class_id, _back_to(next_path), None, person)


@router.post("/classes/{class_id}/join", include_in_schema=False, dependencies=[CsrfDep])
async def join_class(
    request: Request,
    class_id: int,
    services: ServicesDep,
    person: PersonDep,
    name: Annotated[str, Form(max_length=1_000)] = "",  # made plain and short
    next_path: Annotated[str, Form(alias="next", max_length=64)] = "/me",
) -> Response:
    back = _back_to(next_path)
    try:
        await run_blocking(join, services.db, class_id, person.visitor.id, name)
    except ClassError as error:
        return await _join_form(request, services, class_id, back, str(error), person, name)
    return RedirectResponse(back, status.HTTP_303_SEE_OTHER)


async def _join_form(
    request: Request,
    services: Services,
    class_id: int,
    back: str,
    error: str | None,
    person: Person,
    typed: str = "",
) -> HTMLResponse:
    held = await run_blocking(get_class, services.db, class_id)
    if held is None or not held.running:
        return render(
            request, "join_class.html", status.HTTP_410_GONE, held=None, back=back, error=None
        )
    # A class named by its course: its students join by their launch from the course,
    # and this page says under which name (or how to join); nothing is typed.
    member = await run_blocking(roll_name, services.db, held.id, person.visitor.id)
    return render(
        request,
        "join_class.html",
        status.HTTP_400_BAD_REQUEST if error else status.HTTP_200_OK,
        held=held,
        member=member,
        prompt="" if held.names == "course" else NAME_PROMPTS[held.names],
        back=back,
        error=error,
        typed=typed,
        max_name=MAX_NAME,
    )
