"""The instructor dashboard, its live socket, and the admin's accounts and rules."""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import Awaitable, Callable
from typing import Annotated
from urllib.parse import urlsplit

from fastapi import APIRouter, Form, HTTPException, Query, Request, WebSocket, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from starlette.websockets import WebSocketDisconnect

from webapp.apps.fitting import wall_fit
from webapp.apps.hooks import VOLUME_LAYER
from webapp.classes.roll import NAME_PROMPTS, running_class
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.bus.base import BusUnavailable, SubscriberTooSlow, Subscription
from webapp.engine.protocol import CLOSE_POLICY, CLOSE_TRY_AGAIN, DashboardStatus
from webapp.engine.wall_state import read_state
from webapp.people.accounts import AccountError, add_account, list_accounts, remove_account
from webapp.people.address_rules import RuleError, add_rule, list_rules, remove_rule
from webapp.people.addresses import address_of
from webapp.people.audit import recent_entries
from webapp.people.person import GROUP_LABELS, load_person
from webapp.people.visitors import visitor_of
from webapp.publishing.screen import waiting
from webapp.server.deps import ServicesDep, open_wall_socket
from webapp.server.routes.classes import class_info
from webapp.server.routes.walls import status_of
from webapp.server.schemas import PublicationInfo, WallInfo
from webapp.server.services import Services
from webapp.tags.scanning import recent_scans
from webapp.web.deps import AdminPageDep, CsrfDep, StaffPageDep
from webapp.web.templating import render

router = APIRouter(include_in_schema=False)

STATUS_INTERVAL_S = 1.0
FEED_LENGTH = 50  # scans the dashboard's feed shows, the last ones at a reload
AUTHORITY_CHECK_S = 1.0  # how often an open dashboard socket checks who it serves


@router.get("/dashboard")
def dashboard_page(
    request: Request,
    person: StaffPageDep,
    services: ServicesDep,
    wall: Annotated[str | None, Query(max_length=64)] = None,
) -> HTMLResponse:
    walls = list(services.walls.values())
    if not walls:
        raise HTTPException(
            status.HTTP_503_SERVICE_UNAVAILABLE,
            "No walls are configured. Point TAGWALL_WALL_CONFIGS at wall config files "
            "(see docs/wall-config.md) and start the server again.",
        )
    current = services.walls.get(wall or "") or services.walls.get(services.settings.default_wall)
    current = current or walls[0]
    apps = list(services.wall_apps.values())
    # Every app's panel is on the page; only the one of the app on the wall shows (the
    # page follows switches), so an app's panel never speaks while another is up.
    panels = [(app.name, panel) for app in apps if (panel := app.dashboard_panel(current))]
    # The core's volume box belongs to the apps that draw a volume (the brain, the test
    # pattern): an image class has no empty Volume box.
    volume_apps = [app.name for app in apps if VOLUME_LAYER in app.layers]
    _, state = read_state(services.db, current.id)
    # What does not fit this wall at its design distances (as `tagwall config check`
    # says): codes left out are otherwise noticed only when someone looks for them.
    fit = sorted(wall_fit(current, services.apps, services.base_url), key=lambda p: not p.required)
    scans = recent_scans(services.db, current.id, FEED_LENGTH)
    return render(
        request,
        "dashboard.html",
        walls=walls,
        wall=current,
        apps=apps,
        panels=panels,
        volume_apps=volume_apps,
        shown_app=state.app,
        fit=[problem.message() for problem in fit],
        name_modes=NAME_PROMPTS,
        scans_json=json.dumps([scan.model_dump() for scan in scans]),
        wall_json=WallInfo.of(current).model_dump_json(),
        tile_urls={d.id: services.tile_url(current.id, d.id) for d in current.displays},
    )


@router.websocket("/ws/dashboard/{wall_id}")
async def dashboard_socket(websocket: WebSocket, wall_id: str) -> None:
    """Live status and scans for one wall's dashboard: instructors only, same site only."""
    if (opened := await open_wall_socket(websocket, wall_id)) is None:
        return
    services, wall = opened
    if not _same_origin(websocket):
        await websocket.close(CLOSE_POLICY, "cross-site connection refused")
        return
    visitor = visitor_of(websocket, services.secret)
    address = address_of(websocket)

    async def still_staff() -> bool:
        """Sign-out, a password change, a removed account or a role given up rotate or
        demote the session: the socket's cookie then stands for nobody."""
        person = await run_blocking(load_person, services.db, visitor, address, services.settings)
        return person.is_staff

    if not await still_staff():
        await websocket.close(CLOSE_POLICY, "instructors only")
        return
    try:
        async with services.scan_feed.subscribe(wall.id) as scans:
            await _serve_dashboard(websocket, services, wall.id, scans, still_staff)
    except BusUnavailable:
        await websocket.close(CLOSE_TRY_AGAIN, "the event bus is not answering: reconnect")


async def _serve_dashboard(
    websocket: WebSocket,
    services: Services,
    wall_id: str,
    scans: Subscription,
    still_staff: Callable[[], Awaitable[bool]],
) -> None:
    """Send status and scans until the socket closes or its cookie stands for nobody."""
    sender = asyncio.create_task(_send_updates(websocket, services, wall_id, scans))
    reader = asyncio.create_task(_until_closed(websocket))
    try:
        while not sender.done() and not reader.done():
            await asyncio.wait({sender, reader}, timeout=AUTHORITY_CHECK_S)
            if not reader.done() and not await still_staff():
                await websocket.close(CLOSE_POLICY, "signed out: sign in again")
                break
    finally:
        for task in (sender, reader):
            task.cancel()
        for task in (sender, reader):
            with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, RuntimeError):
                await task


async def _until_closed(websocket: WebSocket) -> None:
    """Dashboards only listen; reading notices the close."""
    with contextlib.suppress(WebSocketDisconnect):
        while True:
            await websocket.receive_text()


def _same_origin(websocket: WebSocket) -> bool:
    """Browsers send Origin on websockets; another site's page must not ride our cookie."""
    origin = websocket.headers.get("origin")
    return origin is None or urlsplit(origin).netloc == websocket.headers.get("host")


async def _send_updates(
    websocket: WebSocket, services: Services, wall_id: str, scans: Subscription
) -> None:
    wall = services.walls[wall_id]
    next_status = 0.0
    while True:
        try:
            notice = await asyncio.wait_for(scans.next(), max(0.0, next_status - time.monotonic()))
            await websocket.send_text(notice)  # a ScanSeen, as published
        except SubscriberTooSlow:
            await websocket.close(CLOSE_TRY_AGAIN, "too slow for the scans: reconnect")
            return
        except TimeoutError:
            status_now = await status_of(services, wall)
            queue = await run_blocking(waiting, services.db, wall_id)
            held = await run_blocking(running_class, services.db, wall_id)
            running = None if held is None else await class_info(services, wall, held)
            message = DashboardStatus(
                status=status_now.model_dump(mode="json"),
                waiting=[PublicationInfo.of(r).model_dump(mode="json") for r in queue],
                class_session=None if running is None else running.model_dump(mode="json"),
            )
            await websocket.send_text(message.model_dump_json())
            next_status = time.monotonic() + STATUS_INTERVAL_S


@router.get("/dashboard/admin")
def admin_page(request: Request, person: AdminPageDep, services: ServicesDep) -> HTMLResponse:
    return _admin(request, services, None)


def _admin(request: Request, services: Services, error: str | None) -> HTMLResponse:
    """The admin page, with what went wrong when a form could not be carried out."""
    return render(
        request,
        "admin.html",
        status.HTTP_400_BAD_REQUEST if error else status.HTTP_200_OK,
        accounts=list_accounts(services.db),
        rules=list_rules(services.db),
        audit=recent_entries(services.db),
        groups=GROUP_LABELS,
        error=error,
        grants_roles=services.settings.address_rules_grant_roles,
    )


def _admin_change(
    request: Request,
    services: Services,
    change: Callable[[], object],
    refused: type[Exception],
) -> Response:
    """An admin form's change: back to the admin page when it is done, or the page
    again saying why not (``refused`` carries the reason people read)."""
    try:
        change()
    except refused as error:
        return _admin(request, services, str(error))
    return RedirectResponse("/dashboard/admin", status.HTTP_303_SEE_OTHER)


@router.post("/dashboard/admin/accounts", dependencies=[CsrfDep])
def create_account(
    request: Request,
    person: AdminPageDep,
    services: ServicesDep,
    username: Annotated[str, Form(max_length=64)],
    role: Annotated[str, Form(max_length=16)],
    password: Annotated[str, Form(max_length=1_000)],
) -> Response:
    actor = person.authority or "admin"
    return _admin_change(
        request,
        services,
        lambda: add_account(services.db, username, role, password, actor=actor),
        AccountError,
    )


@router.post("/dashboard/admin/accounts/{username}/remove", dependencies=[CsrfDep])
def delete_account(
    request: Request, username: str, person: AdminPageDep, services: ServicesDep
) -> Response:
    actor = person.authority or "admin"
    return _admin_change(
        request, services, lambda: remove_account(services.db, username, actor=actor), AccountError
    )


def _optional(value: str | None) -> str | None:
    return value.strip() or None if value is not None else None


@router.post("/dashboard/admin/rules", dependencies=[CsrfDep])
def create_rule(
    request: Request,
    person: AdminPageDep,
    services: ServicesDep,
    network: Annotated[str, Form(max_length=64)],
    role: Annotated[str | None, Form(max_length=16)] = None,
    user_group: Annotated[str | None, Form(max_length=16)] = None,
    info_class: Annotated[str | None, Form(max_length=2)] = None,
    note: Annotated[str, Form(max_length=200)] = "",
) -> Response:
    def add() -> None:
        level_text = _optional(info_class)
        if level_text is not None and not level_text.isdigit():
            raise RuleError("the class is a number 1-5")
        add_rule(
            services.db,
            network,
            role=_optional(role),
            user_group=_optional(user_group),
            info_class=int(level_text) if level_text else None,
            note=note,
            actor=person.authority or "admin",
        )

    response = _admin_change(request, services, add, RuleError)
    services.address_rules.forget()  # every process reads the rules afresh
    return response


@router.post("/dashboard/admin/rules/{rule_id}/remove", dependencies=[CsrfDep])
def delete_rule(
    request: Request, rule_id: RowId, person: AdminPageDep, services: ServicesDep
) -> Response:
    actor = person.authority or "admin"
    response = _admin_change(
        request, services, lambda: remove_rule(services.db, rule_id, actor=actor), RuleError
    )
    services.address_rules.forget()  # every process reads the rules afresh
    return response
