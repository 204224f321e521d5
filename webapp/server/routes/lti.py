"""tagwall as an LTI 1.3 tool: the platform's login initiation and launch, the deep
link an instructor makes in a course, the hand-over from the platform's frame to
tagwall's own pages, tagwall's key set, and the admin page that registers platforms.

Pages a platform frames carry a policy that lets the registered platforms (and only
them) frame them; every other page keeps ``frame-ancestors 'none'``. No launch keeps
anything in a cookie: the frame gets none in Safari. What a launch carries from one
step to the next is a single-use pass (``webapp.lti.passes``); tagwall's session cookie
is set only on the first-party page a launch opens."""

from __future__ import annotations

import logging
from typing import Annotated, Literal

from fastapi import APIRouter, Form, HTTPException, Request, status
from fastapi.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from pydantic import BaseModel, ValidationError

from webapp.apps.installed import modes_of
from webapp.classes.roll import ClassError, running_class
from webapp.core.threads import run_blocking
from webapp.lti import passes
from webapp.lti.courses import (
    CourseClass,
    join_as,
    link_class,
    roster_failed,
    running_class_of_link,
    save_roster,
    teaches,
)
from webapp.lti.keys import public_key_set
from webapp.lti.messages import Jwks, LineItem, LoginInitiation, ResourceLinkItem
from webapp.lti.platforms import (
    PlatformError,
    add_platform,
    framing_origins,
    get_platform,
    list_platforms,
    origin,
    remove_platform,
    tool_values,
)
from webapp.lti.tool import LaunchError, ServiceError, Verified
from webapp.people.person import grant, remember_person, update_profile
from webapp.server.deps import ServicesDep
from webapp.server.routes.classes import start_on_wall
from webapp.server.services import Services
from webapp.web.deps import AdminPageDep, ClientAddressDep, CsrfDep, PersonDep
from webapp.web.middleware import content_security_policy
from webapp.web.templating import render

router = APIRouter(tags=["lti"])
log = logging.getLogger(__name__)

DEFAULT_POINTS = 10
MAX_POINTS = 1_000


class HandOver(BaseModel):
    """What a verified launch hands to the first-party page it opens."""

    role: Literal["teach", "learn"]
    platform: int
    deployment_id: str
    user_id: str
    name: str
    wall: str
    app: str | None
    mode: str | None
    context_id: str
    course_title: str
    link_id: str
    lineitem_url: str | None
    memberships_url: str | None


class Choice(BaseModel):
    """A verified deep-linking request waiting for the instructor's choice."""

    platform: int
    deployment_id: str
    return_url: str
    data: str | None
    course_title: str


async def framed(
    request: Request,
    services: Services,
    template: str,
    status_code: int = 200,
    form_action: tuple[str, ...] = (),
    **context: object,
) -> HTMLResponse:
    """A page the registered platforms may frame (and only they)."""
    origins = await run_blocking(framing_origins, services.db)
    response = render(request, template, status_code, **context)
    response.headers["content-security-policy"] = content_security_policy(origins, form_action)
    return response


async def problem(request: Request, services: Services, error: LaunchError) -> HTMLResponse:
    """A refused launch: a clear page in the platform's frame, a line in the log."""
    log.warning("LTI refused: %s", error.detail)
    return await framed(request, services, "lti_problem.html", error.status, message=error.message)


# --- the platform's side of a launch ------------------------------------------------------


@router.api_route("/lti/login", methods=["GET", "POST"], include_in_schema=False)
async def login(request: Request, services: ServicesDep) -> Response:
    """Third-party login initiation: the platform names itself and the person; tagwall
    sends the browser to the platform's authorization endpoint with a fresh state."""
    given = dict(request.query_params)
    if request.method == "POST":
        given |= {k: v for k, v in (await request.form()).items() if isinstance(v, str)}
    try:
        initiation = LoginInitiation.model_validate(given)
        target = await services.lti.login(initiation, services.base_url)
    except ValidationError as error:
        missing = ", ".join(str(p["loc"][0]) for p in error.errors())
        return await problem(
            request,
            services,
            LaunchError(
                "The learning platform's request to open tagwall is incomplete. Ask the "
                "platform's administrator.",
                f"login initiation without {missing}",
            ),
        )
    except LaunchError as error:
        return await problem(request, services, error)
    return RedirectResponse(target, status.HTTP_302_FOUND)


@router.post("/lti/launch", include_in_schema=False)
async def launch(
    request: Request,
    services: ServicesDep,
    id_token: Annotated[str, Form(max_length=20_000)] = "",
    state: Annotated[str, Form(max_length=200)] = "",
) -> HTMLResponse:
    """The platform's launch (the redirect URI): a deep-linking request shows the
    instructor the walls and lessons to pick; a link's launch hands over to the
    dashboard (instructors) or the class's join page (students)."""
    try:
        verified = await services.lti.verify(id_token, state)
    except LaunchError as error:
        return await problem(request, services, error)
    launch = verified.launch
    if launch.deep_linking is not None:
        return await _pick(request, services, verified)
    try:
        over = _hand_over(services, verified)
    except LaunchError as error:
        return await problem(request, services, error)
    value = await run_blocking(passes.issue, services.db, "handover", over.model_dump())
    log.info(
        "LTI launch from %s: %s %s at wall %s",
        verified.platform.issuer,
        over.role,
        over.user_id,
        over.wall,
    )
    wall = services.walls[over.wall]
    return await framed(request, services, "lti_launch.html", over=over, wall=wall, handover=value)


def _hand_over(services: Services, verified: Verified) -> HandOver:
    """The launch as what the page it opens needs; the wall and lesson come from the
    link's custom parameters (the deep link put them there)."""
    launch, custom = verified.launch, verified.launch.custom
    wall = str(custom.get("wall") or services.settings.default_wall)
    if wall not in services.walls:
        raise LaunchError(
            f"The wall this link names ({wall}) is not set up on tagwall any more. Ask "
            "your instructor to make the link again.",
            f"launch for unknown wall {wall!r} from {verified.platform.issuer}",
            status=404,
        )
    assert launch.resource_link is not None  # verify() refuses a link launch without one
    context = launch.context
    return HandOver(
        role="teach" if teaches(launch.roles) else "learn",
        platform=verified.platform.id,
        deployment_id=launch.deployment_id,
        user_id=launch.sub,
        name=launch.full_name,
        wall=wall,
        app=str(custom["app"]) if custom.get("app") else None,
        mode=str(custom["mode"]) if custom.get("mode") else None,
        context_id=context.id if context else launch.resource_link.id,
        course_title=(context.title or context.label) if context else launch.resource_link.title,
        link_id=launch.resource_link.id,
        lineitem_url=launch.ags.lineitem if launch.ags else None,
        memberships_url=launch.nrps.context_memberships_url if launch.nrps else None,
    )


# --- deep linking: the instructor picks the wall and the lesson ----------------------------


def _lessons(services: Services) -> list[tuple[str, str]]:
    """(value, label) of every app and mode a class can run."""
    return [
        (f"{app.name}:{mode}", f"{app.name} ({mode})" if len(modes_of(app)) > 1 else app.name)
        for app in services.wall_apps.values()
        for mode in modes_of(app)
    ]


async def _pick(request: Request, services: Services, verified: Verified) -> HTMLResponse:
    launch = verified.launch
    assert launch.deep_linking is not None
    if "ltiResourceLink" not in launch.deep_linking.accept_types:
        return await problem(
            request,
            services,
            LaunchError(
                "The learning platform does not accept the kind of link tagwall makes "
                "(an LTI resource link).",
                f"deep linking from {verified.platform.issuer} accepts only "
                f"{launch.deep_linking.accept_types}",
            ),
        )
    choice = Choice(
        platform=verified.platform.id,
        deployment_id=launch.deployment_id,
        return_url=launch.deep_linking.deep_link_return_url,
        data=launch.deep_linking.data,
        course_title=launch.context.title if launch.context else "",
    )
    value = await run_blocking(passes.issue, services.db, "choice", choice.model_dump())
    return await _picker(request, services, value, choice.course_title)


async def _picker(
    request: Request,
    services: Services,
    value: str,
    course_title: str,
    error: str | None = None,
) -> HTMLResponse:
    return await framed(
        request,
        services,
        "lti_pick.html",
        status.HTTP_400_BAD_REQUEST if error else status.HTTP_200_OK,
        choice=value,
        walls=list(services.walls.values()),
        lessons=_lessons(services),
        course_title=course_title,
        points=DEFAULT_POINTS,
        max_points=MAX_POINTS,
        error=error,
    )


@router.post("/lti/deep-link", include_in_schema=False)
async def deep_link(
    request: Request,
    services: ServicesDep,
    choice: Annotated[str, Form(max_length=200)] = "",
    wall: Annotated[str, Form(max_length=64)] = "",
    lesson: Annotated[str, Form(max_length=130)] = "",
    title: Annotated[str, Form(max_length=200)] = "",
    points: Annotated[str, Form(max_length=10)] = "",
) -> HTMLResponse:
    """The instructor's pick goes back to the platform as a signed deep-linking response
    (an auto-submitted form): the link, its wall and lesson, and a gradebook column.
    Whatever is wrong in the form is said on the picker (a page the course frames)."""
    app_name, _, mode = lesson.partition(":")
    if wall not in services.walls or f"{app_name}:{mode}" not in dict(_lessons(services)):
        return await _picker(request, services, choice, "", "Pick a wall and a lesson.")
    if not points.strip().isdigit() or not 1 <= int(points) <= MAX_POINTS:
        return await _picker(
            request, services, choice, "", f"Points: a whole number from 1 to {MAX_POINTS}."
        )
    kept = await run_blocking(passes.take, services.db, "choice", choice)
    platform = None
    if kept is not None:
        platform = await run_blocking(get_platform, services.db, int(kept["platform"]))
    if kept is None or platform is None:
        return await problem(
            request,
            services,
            LaunchError(
                "This choice has expired or was sent already. Add tagwall to the course again.",
                "deep link with an unknown, expired or used choice",
            ),
        )
    picked = Choice.model_validate(kept)
    name = title.strip()[:200] or f"{app_name} at {services.walls[wall].name}"
    item = ResourceLinkItem(
        title=name,
        text=f"A class at the {services.walls[wall].name} wall: {app_name}.",
        url=services.base_url + "/lti/launch",
        custom={"wall": wall, "app": app_name, "mode": mode},
        lineItem=LineItem(label=name, scoreMaximum=int(points), resourceId=f"{wall}:{app_name}"),
    )
    token = await services.lti.deep_link_response(platform, picked.deployment_id, picked.data, item)
    log.info("LTI deep link to %s: %s at wall %s", platform.issuer, lesson, wall)
    return await framed(
        request,
        services,
        "lti_return.html",
        form_action=(origin(picked.return_url),),
        return_url=picked.return_url,
        jwt=token,
        title=name,
    )


# --- the hand-over: tagwall's own page, in the first party -------------------------------


@router.post("/lti/continue", include_in_schema=False)
async def carry_on(
    request: Request,
    services: ServicesDep,
    person: PersonDep,
    address: ClientAddressDep,
    handover: Annotated[str, Form(max_length=200)] = "",
) -> Response:
    """The page a launch opens: an instructor's browser becomes an instructor's (their
    course said so) and the class starts for the course, its roster read from the
    platform; a student's phone joins the class under their course name."""
    kept = await run_blocking(passes.take, services.db, "handover", handover)
    if kept is None:
        raise HTTPException(
            status.HTTP_410_GONE,
            "This link from your course has expired or was used already. Open tagwall "
            "from your course again.",
        )
    over = HandOver.model_validate(kept)
    wall = services.walls.get(over.wall)
    platform = await run_blocking(get_platform, services.db, over.platform)
    if wall is None or platform is None:
        raise HTTPException(status.HTTP_410_GONE, "This wall or platform is gone from tagwall.")
    running = await run_blocking(running_class, services.db, wall.id)
    ours = await run_blocking(
        running_class_of_link, services.db, platform.id, over.link_id, running
    )
    if over.role == "learn":
        if running is None or not ours:
            return render(request, "lti_waiting.html", course_title=over.course_title)
        try:
            await run_blocking(
                join_as, services.db, running.id, person.visitor.id, over.user_id, over.name
            )
        except ClassError as error:  # ended meanwhile
            raise HTTPException(status.HTTP_410_GONE, str(error)) from error
        return RedirectResponse(f"/classes/{running.id}/join", status.HTTP_303_SEE_OTHER)
    if not person.is_staff:
        authority = f"lti:{platform.id}:{over.user_id}"[:120]
        person = await run_blocking(
            grant, services.db, person, "instructor", authority, services.settings, address
        )
        if over.name and not person.display_name:  # the dashboard names them as the course does
            person = await run_blocking(
                lambda: update_profile(
                    services.db,
                    person,
                    services.settings,
                    user_group=person.user_group,
                    info_class=person.info_class,
                    display_name=over.name,
                )
            )
        remember_person(request, person)
    if not ours:
        await _start_for_course(services, over, person.authority or "lti")
    return RedirectResponse(f"/dashboard?wall={wall.id}", status.HTTP_303_SEE_OTHER)


async def _start_for_course(services: Services, over: HandOver, staff: str) -> None:
    """A class at the link's wall for the course: titled by the course, its students
    named by the course, its expected students from the course's roster (NRPS)."""
    wall = services.walls[over.wall]
    held = await start_on_wall(
        services, wall, over.course_title, over.app, over.mode, "course", staff
    )
    app = over.app or (await services.state(wall)).app
    course = CourseClass(
        class_id=held.id,
        platform_id=over.platform,
        deployment_id=over.deployment_id,
        context_id=over.context_id,
        resource_link_id=over.link_id,
        app=app,
        lineitem_url=over.lineitem_url,
        memberships_url=over.memberships_url,
        roster_problem="",
    )
    await run_blocking(link_class, services.db, course)
    platform = await run_blocking(get_platform, services.db, over.platform)
    if over.memberships_url is None or platform is None:
        return
    try:
        members = await services.lti.roster(platform, over.memberships_url)
    except ServiceError as error:
        log.warning("LTI roster of class %s not read: %s", held.id, error)
        await run_blocking(roster_failed, services.db, held.id, str(error))
        return
    await run_blocking(save_roster, services.db, held.id, members)


# --- tagwall's keys and the registration -------------------------------------------------


@router.get("/lti/jwks", include_in_schema=False)
async def jwks(services: ServicesDep) -> JSONResponse:
    """tagwall's public keys as a tool (the signing key and those retired lately)."""
    keys = await run_blocking(public_key_set, services.db, services.settings.lti_key_overlap_h)
    return JSONResponse(Jwks(keys=keys).model_dump(), headers={"cache-control": "max-age=300"})


@router.get("/dashboard/lti", include_in_schema=False)
async def lti_admin(request: Request, services: ServicesDep, admin: AdminPageDep) -> HTMLResponse:
    return await _admin_page(request, services)


async def _admin_page(
    request: Request, services: Services, error: str | None = None
) -> HTMLResponse:
    platforms = await run_blocking(list_platforms, services.db)
    return render(
        request,
        "lti_admin.html",
        status.HTTP_400_BAD_REQUEST if error else status.HTTP_200_OK,
        platforms=platforms,
        values=tool_values(services.base_url),
        error=error,
    )


@router.post("/dashboard/lti", include_in_schema=False, dependencies=[CsrfDep])
async def lti_add(
    request: Request,
    services: ServicesDep,
    admin: AdminPageDep,
    issuer: Annotated[str, Form(max_length=500)],
    client_id: Annotated[str, Form(max_length=255)],
    deployment_ids: Annotated[str, Form(max_length=2_000)],
    auth_url: Annotated[str, Form(max_length=500)],
    token_url: Annotated[str, Form(max_length=500)],
    jwks_url: Annotated[str, Form(max_length=500)],
    name: Annotated[str, Form(max_length=80)] = "",
) -> Response:
    try:
        await run_blocking(
            lambda: add_platform(
                services.db,
                name=name,
                issuer=issuer.strip(),
                client_id=client_id.strip(),
                deployment_ids=deployment_ids.replace(",", " ").split(),
                auth_url=auth_url.strip(),
                token_url=token_url.strip(),
                jwks_url=jwks_url.strip(),
                actor=admin.authority or "admin",
            )
        )
    except PlatformError as error:
        return await _admin_page(request, services, str(error))
    return RedirectResponse("/dashboard/lti", status.HTTP_303_SEE_OTHER)


@router.post("/dashboard/lti/{platform_id}/remove", include_in_schema=False, dependencies=[CsrfDep])
async def lti_remove(platform_id: int, services: ServicesDep, admin: AdminPageDep) -> Response:
    await run_blocking(remove_platform, services.db, platform_id, admin.authority or "admin")
    return RedirectResponse("/dashboard/lti", status.HTTP_303_SEE_OTHER)
