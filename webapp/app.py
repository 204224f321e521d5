"""Application factory: settings in, a ready ASGI app out; nothing happens at import."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates
from starlette.exceptions import HTTPException as StarletteHTTPException

from wall_client.layout import load_walls
from webapp.apps import builtin_apps
from webapp.bus import MemoryBus
from webapp.db import Database
from webapp.hub import WallHub
from webapp.markdown import markdown_html, markdown_inline
from webapp.routes import (
    dashboard,
    health,
    pages,
    pairing,
    people,
    public,
    resolve,
    scan,
    tags,
    volume,
    walls,
    ws,
)
from webapp.security_headers import SecurityHeadersMiddleware
from webapp.services import Services
from webapp.settings import PROJECT_ROOT, Settings
from webapp.tags import declare, show_tag_set
from webapp.visitors import SessionCookieMiddleware
from webapp.wall_state import WallState, read_state

log = logging.getLogger(__name__)
TEMPLATES_DIR = Path(__file__).parent / "templates"
STATIC_DIR = PROJECT_ROOT / "static"


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the tagwall app for ``settings`` (from the environment when omitted)."""
    settings = settings or Settings()
    db = Database(settings.resolved_database_url)
    hub = WallHub(
        db,
        MemoryBus(settings.tile_queue_size),
        apply_lead_ms=settings.apply_lead_ms,
        swap_timeout_ms=settings.swap_timeout_ms,
        keep_events=settings.event_history,
    )
    services = Services(
        settings=settings,
        db=db,
        hub=hub,
        walls=load_walls(settings.wall_configs),
        apps=builtin_apps(),
    )

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        await prepare_walls(services)
        recorder = asyncio.create_task(services.scan_log.run())
        yield
        recorder.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await recorder
        await run_in_threadpool(services.scan_log.flush)
        await hub.close()
        db.dispose()

    app = FastAPI(title="tagwall", lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.services = services
    app.state.templates = Jinja2Templates(directory=TEMPLATES_DIR)
    app.state.templates.env.filters["markdown"] = markdown_html
    app.state.templates.env.filters["markdown_inline"] = markdown_inline
    app.add_middleware(SessionCookieMiddleware, secret=settings.resolved_secret_key)
    app.add_middleware(SecurityHeadersMiddleware)
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    for router in (
        health.router,
        pages.router,
        people.router,
        pairing.router,
        dashboard.router,
        public.router,
        resolve.router,
        scan.router,
        tags.router,
        walls.router,
        volume.router,
        ws.router,
    ):
        app.include_router(router)
    for wall_app in services.apps.values():
        if (app_router := wall_app.router()) is not None:
            app.include_router(app_router)
    _add_error_pages(app)
    return app


async def prepare_walls(services: Services) -> None:
    """Settle the app each wall shows, declare every app's tags on every wall and put
    each wall's tag set up.

    Idempotent: codes stay as they were and an unchanged set is not placed again, so
    every server process of a wall may do this at start.
    """
    for wall in services.walls.values():
        _, state = await run_in_threadpool(read_state, services.db, wall.id)
        if (shown := services.apps.get(state.app)) is not None:
            settled: WallState = await run_in_threadpool(shown.settle, services, wall, state)
            if settled != state:
                await services.hub.change_state(wall.id, _becomes(settled))
                state = settled
        for wall_app in services.apps.values():
            tags = await run_in_threadpool(wall_app.declare_tags, services, wall, state)
            await run_in_threadpool(declare, services.db, wall.id, wall_app.name, tags)
        tag_set = state.tag_set
        if not state.tag_layout and state.app in services.apps:
            tag_set = services.apps[state.app].default_tag_set
        await show_tag_set(services.hub, wall, tag_set, services.base_url)


def _becomes(new: WallState) -> Callable[[WallState], WallState]:
    return lambda _old: new


def _wants_json(request: Request) -> bool:
    return request.url.path.startswith("/api/") or request.url.path == "/healthz"


def _add_error_pages(app: FastAPI) -> None:
    """Errors people cause get a clear page (or JSON for the API), never a traceback."""

    def error_page(request: Request, status: int, detail: str) -> Response:
        if _wants_json(request):
            return JSONResponse({"detail": detail}, status)
        templates: Jinja2Templates = request.app.state.templates
        return templates.TemplateResponse(
            request, "error.html", {"status": status, "detail": detail}, status_code=status
        )

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, error: StarletteHTTPException) -> Response:
        response = error_page(request, error.status_code, str(error.detail))
        response.headers.update(error.headers or {})
        return response

    @app.exception_handler(RequestValidationError)
    async def validation_error(request: Request, error: RequestValidationError) -> Response:
        if _wants_json(request):
            return JSONResponse({"detail": jsonable_errors(error)}, 422)
        return error_page(request, 400, "The request was malformed.")

    @app.exception_handler(Exception)
    async def server_error(request: Request, error: Exception) -> Response:
        log.exception("unhandled error on %s", request.url.path, exc_info=error)
        return error_page(request, 500, "Something went wrong on the server; it has been logged.")


def jsonable_errors(error: RequestValidationError) -> list[dict[str, object]]:
    """Validation errors without the raw input (which may be huge or binary)."""
    return [
        {"loc": list(e.get("loc", ())), "msg": e.get("msg", ""), "type": e.get("type", "")}
        for e in error.errors()
    ]
