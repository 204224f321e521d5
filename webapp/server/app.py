"""Application factory: settings in, a ready ASGI app out; nothing happens at import."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from fastapi.routing import APIRoute, iter_route_contexts
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates
from redis.asyncio import Redis
from redis.exceptions import RedisError
from sqlalchemy.exc import SQLAlchemyError
from starlette.exceptions import HTTPException as StarletteHTTPException

from wall_client.config import load_walls
from webapp.apps.discovery import installed_apps
from webapp.apps.hooks import static_url
from webapp.apps.installed import heavy_keys
from webapp.campus.oidc import SIGN_IN_COOKIE, SIGN_IN_PATH, SIGN_IN_WINDOW_S
from webapp.core.logs import ACCESS_LOGGER
from webapp.core.settings import PROJECT_ROOT, Settings
from webapp.core.tasks import cancel_and_wait
from webapp.core.threads import run_blocking
from webapp.database.connection import Database, database_problem, is_outage
from webapp.database.redis import connect_redis
from webapp.engine.bus.base import BusUnavailable, EventBus, WallBusy
from webapp.engine.bus.memory import MemoryBus
from webapp.engine.bus.redis import RedisBus
from webapp.engine.hub import WallHub
from webapp.people.tokens import REFRESH_S as TOKEN_REFRESH_S
from webapp.people.tokens import load_tokens
from webapp.server.routes import (
    classes,
    dashboard,
    health,
    oidc,
    owncodes,
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
from webapp.server.services import Services
from webapp.web.deps import DEPENDENCY_ERRORS
from webapp.web.middleware import HEADERS as SECURITY_HEADERS
from webapp.web.middleware import (
    AccessLogMiddleware,
    ClientAddressMiddleware,
    SecurityHeadersMiddleware,
    SessionCookieMiddleware,
    SignInStateMiddleware,
)
from webapp.web.problems import ERROR_MEANINGS, Problem
from webapp.web.templating import make_templates

log = logging.getLogger(__name__)
OUTAGE_RETRY_S = 5
STATIC_DIR = PROJECT_ROOT / "static"
# CesiumJS from the npm registry (package.json; `make run` installs it with `npm ci`),
# served from our own origin: its module, workers and bundled Natural Earth imagery
# (the Makefile replaces one string in it, see there).
CESIUM_DIR = PROJECT_ROOT / "node_modules" / "cesium" / "Build" / "Cesium"
CESIUM_URL = "/static/cesium"


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the tagwall app for ``settings`` (from the environment when omitted)."""
    settings = settings or Settings()
    db = Database(settings.resolved_database_url)
    # Several processes share the walls through one Redis: the bus and the limits' counts.
    redis = connect_redis(settings.redis_url) if settings.bus == "redis" else None
    apps = installed_apps(settings.apps)
    hub = WallHub(
        db,
        event_bus(settings, redis),
        apply_lead_ms=settings.apply_lead_ms,
        swap_timeout_ms=settings.swap_timeout_ms,
        keep_events=settings.event_history,
        heavy_keys=heavy_keys(apps),
    )
    services = Services(
        settings=settings,
        db=db,
        hub=hub,
        walls=load_walls(settings.resolved_wall_configs),
        apps=apps,
        redis=redis,
    )

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        services.tokens = await run_blocking(load_tokens, db, services.secret)
        await hub.watch(services.walls)
        for wall in services.walls.values():
            await services.door.open(wall)
        tasks = [
            asyncio.create_task(services.scan_log.run()),
            asyncio.create_task(_keep_tokens_fresh(services)),
            asyncio.create_task(services.codes.follow()),
            asyncio.create_task(services.address_rules.follow()),
        ]
        if services.campus.providers:
            tasks.append(asyncio.create_task(services.campus.follow()))
        yield
        await cancel_and_wait(*tasks)
        await run_blocking(services.scan_log.flush)
        await hub.close()
        if redis is not None:
            await redis.aclose()
        db.dispose()

    app = FastAPI(title="tagwall", lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.services = services
    app.state.templates = make_templates([a.templates for a in apps.values() if a.templates])
    if settings.oidc_providers:
        app.add_middleware(
            SignInStateMiddleware,
            secret=settings.resolved_secret_key,
            path=SIGN_IN_PATH,
            cookie=SIGN_IN_COOKIE,
            max_age=SIGN_IN_WINDOW_S,
            https=settings.resolved_public_base_url.startswith("https://"),
        )
    app.add_middleware(SessionCookieMiddleware, secret=settings.resolved_secret_key)
    app.add_middleware(SecurityHeadersMiddleware)
    app.add_middleware(AccessLogMiddleware, log=logging.getLogger(ACCESS_LOGGER))
    app.add_middleware(ClientAddressMiddleware, trusted=settings.trusted_proxies)  # outermost
    for wall_app in services.apps.values():  # before /static, which would take their paths
        if wall_app.static:
            app.mount(static_url(wall_app.name), StaticFiles(directory=wall_app.static))
    # Not installed (no `npm ci`): a 404 for each of its files.
    app.mount(CESIUM_URL, StaticFiles(directory=CESIUM_DIR, check_dir=False))
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    # Routes are tried in order, each at a cost: what phones ask for most (scans and
    # their app's pages) is tried first. An app's routes lie under its own prefixes,
    # where the core has none (checked as apps load: webapp.apps.discovery), so no app
    # answers a path of the core's whatever the order.
    app.include_router(resolve.router)
    for wall_app in services.apps.values():
        if (app_router := wall_app.router()) is not None:
            app.include_router(app_router)
    for router in (
        health.router,
        pages.router,
        people.router,
        oidc.router,
        classes.router,
        pairing.router,
        dashboard.router,
        public.router,
        scan.router,
        tags.router,
        owncodes.router,
        walls.router,
        volume.router,
        ws.router,
    ):
        app.include_router(router)
    _add_error_pages(app)
    _document_errors(app, services)
    return app


def event_bus(settings: Settings, redis: Redis | None) -> EventBus:
    """The bus of ``TAGWALL_BUS``: in memory for one process, or Redis Streams (on the
    process's one Redis client) for several processes serving one wall."""
    if redis is not None:
        return RedisBus(
            redis,
            settings.redis_prefix,
            queue_size=settings.tile_queue_size,
            max_len=settings.event_history,
        )
    return MemoryBus(settings.tile_queue_size)


def _example_names(schema: dict[str, Any], services: Services) -> None:
    """Give the ``wall_id`` and ``tile_id`` parameters this server's names as examples,
    for people reading the document and for tools that try the API."""
    walls = list(services.walls.values())
    names = {
        "wall_id": [wall.id for wall in walls],
        "tile_id": [display.id for display in walls[0].displays] if walls else [],
    }
    for operation in (op for path in schema["paths"].values() for op in path.values()):
        for parameter in operation.get("parameters", []):
            if names.get(parameter["name"]):
                parameter["schema"]["examples"] = names[parameter["name"]]


def _document_errors(app: FastAPI, services: Services) -> None:
    """The OpenAPI document lists, for every operation, the errors its dependencies
    answer with (``deps.DEPENDENCY_ERRORS``), 400 where it reads a body (one that is
    not JSON) and 503 (the database may be down), beside those its route declares."""
    problem = {"$ref": "#/components/schemas/Problem"}

    def openapi() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        schema = FastAPI.openapi(app)
        schema.setdefault("components", {}).setdefault("schemas", {})["Problem"] = (
            Problem.model_json_schema()
        )
        for route in iter_route_contexts(app.routes):
            if not isinstance(route.original_route, APIRoute) or not route.include_in_schema:
                continue
            codes = {400, 503} if route.body_field is not None else {503}
            pending = list(route.dependant.dependencies)
            while pending:
                dependency = pending.pop()
                codes.update(DEPENDENCY_ERRORS.get(dependency.call, ()))
                pending.extend(dependency.dependencies)
            for method in route.methods or ():
                responses = schema["paths"][route.path_format][method.lower()]["responses"]
                for code in sorted(codes):
                    responses.setdefault(
                        str(code),
                        {
                            "description": ERROR_MEANINGS[code],
                            "content": {"application/json": {"schema": problem}},
                        },
                    )
        _example_names(schema, services)
        app.openapi_schema = schema
        return schema

    app.openapi = openapi  # type: ignore[method-assign]


async def _keep_tokens_fresh(services: Services) -> None:
    """Read the token salts again every few seconds: a rotation by the CLI (or another
    process) takes effect here too. A database that does not answer keeps the tokens
    as they were."""
    while True:
        await asyncio.sleep(TOKEN_REFRESH_S)
        try:
            services.tokens = await run_blocking(load_tokens, services.db, services.secret)
        except SQLAlchemyError as error:
            log.warning("could not read the token salts: %s", error.__class__.__name__)


def _wants_json(request: Request) -> bool:
    """Whether errors are JSON: on /api/ paths, /healthz and whatever else the OpenAPI
    document lists (the census KML feeds); pages get an error page."""
    route = request.scope.get("route")
    listed = isinstance(route, APIRoute) and route.include_in_schema
    return listed or request.url.path.startswith("/api/") or request.url.path == "/healthz"


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

    @app.exception_handler(SQLAlchemyError)
    async def database_error(request: Request, error: SQLAlchemyError) -> Response:
        """The database down or unreachable is an outage, not a bug: 503, one log line."""
        if not is_outage(error):
            return await server_error(request, error)
        url = request.app.state.services.db.url
        log.warning("%s (on %s)", database_problem(error, url), request.url.path)
        response = error_page(request, 503, "The database is not answering. Try again in a moment.")
        response.headers["Retry-After"] = str(OUTAGE_RETRY_S)
        return response

    def try_again(request: Request, error: Exception, detail: str) -> Response:
        """An outage or a busy wall, not a bug: 503 with Retry-After, one log line."""
        log.warning("%s (on %s)", error, request.url.path)
        response = error_page(request, 503, detail)
        response.headers["Retry-After"] = str(OUTAGE_RETRY_S)
        return response

    @app.exception_handler(BusUnavailable)
    async def bus_unavailable(request: Request, error: BusUnavailable) -> Response:
        return try_again(request, error, "The event bus is not answering. Try again in a moment.")

    @app.exception_handler(WallBusy)
    async def wall_busy(request: Request, error: WallBusy) -> Response:
        return try_again(request, error, "The wall is busy with another change. Try again.")

    @app.exception_handler(RedisError)
    async def redis_error(request: Request, error: RedisError) -> Response:
        """Redis not answering in a request (the limits are counted there, before the
        request changes anything)."""
        return try_again(
            request, error, "The shared store is not answering. Try again in a moment."
        )

    @app.exception_handler(Exception)
    async def server_error(request: Request, error: Exception) -> Response:
        log.exception("unhandled error on %s", request.url.path, exc_info=error)
        response = error_page(
            request, 500, "Something went wrong on the server; it has been logged."
        )
        # Starlette sends this answer outside every middleware: it brings its own headers.
        response.headers.update({**SECURITY_HEADERS, "cache-control": "no-store"})
        return response


def jsonable_errors(error: RequestValidationError) -> list[dict[str, object]]:
    """Validation errors without the raw input (which may be huge or binary)."""
    return [
        {"loc": list(e.get("loc", ())), "msg": e.get("msg", ""), "type": e.get("type", "")}
        for e in error.errors()
    ]
