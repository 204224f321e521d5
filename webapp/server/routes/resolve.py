"""What phones open: ``/t/{code}`` resolves a scanned code, ``/codes/...`` draws one."""

from __future__ import annotations

from functools import lru_cache
from typing import Annotated, Literal
from urllib.parse import quote

from fastapi import APIRouter, Query, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from tag_service.codes import content_hash, make_symbol, normalize_code, render_png, render_svg
from webapp.apps.hooks import Scan
from webapp.apps.installed import REGISTRATION
from webapp.classes.roll import roll_call
from webapp.core.caching import IMMUTABLE
from webapp.core.threads import run_blocking
from webapp.people.visitors import Visitor, visitor_of
from webapp.server.deps import ServicesDep
from webapp.tags.registry import find, payload_of
from webapp.web.cors import AnyOriginRoute
from webapp.web.deps import ClientAddressDep, limit_action
from webapp.web.templating import render

router = APIRouter(include_in_schema=False)


def problem_page(
    request: Request, status: int, title: str, detail: str, wall_id: str | None = None
) -> HTMLResponse:
    """A friendly, phone-sized page for a code that does not work, with a way on."""
    return render(
        request,
        "scan_problem.html",
        status_code=status,
        title=title,
        detail=detail,
        wall_id=wall_id,
    )


@router.get("/t/{code}")
@router.get("/T/{code}")
async def resolve(
    code: str, request: Request, services: ServicesDep, address: ClientAddressDep
) -> Response:
    """A scanned code: look it up, check it works now, record the scan, hand it to its app."""
    visitor = visitor_of(request, services.secret)
    normalized = normalize_code(code)
    if normalized is None:
        return problem_page(request, 404, "Unknown code", "This is not one of this wall's codes.")
    await limit_action(services, "scan", visitor, address)
    return await _resolve(request, services, normalized, visitor, address)


async def _resolve(
    request: Request, services: ServicesDep, code: str, visitor: Visitor, address: str
) -> Response:
    resolution = await services.codes.resolve(code)
    tag = resolution.tag
    if tag is None:
        return problem_page(request, 404, "Unknown code", "This is not one of this wall's codes.")
    wall = services.walls.get(tag.wall_id)
    app = services.apps.get(tag.app)
    if wall is None or app is None:
        detail = "This code belongs to a wall or app not running here."
        return problem_page(request, 410, "This code is no longer in use", detail, tag.wall_id)
    if resolution.problem:
        scan = Scan(request, services, wall, tag, visitor, address)
        own = await app.on_retired_scan(scan, resolution.problem)
        if own is not None:
            return own
        return problem_page(
            request, 410, "This code is no longer in use", resolution.problem, tag.wall_id
        )
    if not (tag.app == REGISTRATION and tag.params.get("role") == "instructor"):
        joining = await roll_call(
            request,
            services.db,
            services.settings,
            address,
            services.address_rules,
            tag.wall_id,
            visitor.id,
        )
        if joining is not None:  # the class wants the student's name first; back here after
            back = quote(f"/t/{tag.code}", safe="/")
            return RedirectResponse(f"/classes/{joining}/join?next={back}", 303)
    services.scan_log.record(tag, visitor.id, address, request.headers.get("user-agent", ""))
    await services.scan_feed.publish(tag, visitor.id)
    return await app.on_scan(Scan(request, services, wall, tag, visitor, address))


@lru_cache(maxsize=1024)
def _svg(payload: str, error: str) -> bytes:
    """Rendering is pure: cached by content, so a wall's codes render once."""
    return render_svg(make_symbol(payload, "L" if error == "L" else "M"))


async def code_image(
    name: str,
    request: Request,
    services: ServicesDep,
    scale: Annotated[int, Query(ge=1, le=40)] = 10,
    error: Annotated[Literal["M", "L"], Query()] = "M",
) -> Response:
    """``CODE.svg`` / ``CODE.png`` (revalidated) or ``CODE.HASH.svg`` (cached for a year).

    The hash names the payload, so a hashed URL never changes content: when the
    payload changes (a new server address), the URL changes with it. ``error`` is the
    error correction level: a code placed at level L (where space is tight) draws with
    it, so its image has the modules the wall's placement counted.
    """
    stem, _, extension = name.rpartition(".")
    code_text, _, given_hash = stem.partition(".")
    code = normalize_code(code_text)
    tag = await run_blocking(find, services.db, code) if code else None
    if tag is None or extension not in ("svg", "png"):
        return Response("No such code image.", 404, media_type="text/plain")
    payload = payload_of(tag, services.base_url)
    digest = content_hash(payload, error)
    if given_hash and given_hash != digest:
        query = f"?{request.url.query}" if request.url.query else ""  # keeps scale and error
        return RedirectResponse(f"/codes/{tag.code}.{digest}.{extension}{query}", 307)
    etag = f'"{digest}"' if extension == "svg" else f'"{digest}-{scale}"'
    headers = {"ETag": etag, "Cache-Control": IMMUTABLE if given_hash else "no-cache"}
    if request.headers.get("if-none-match") == etag:
        return Response(status_code=304, headers=headers)
    if extension == "svg":
        return Response(_svg(payload, error), media_type="image/svg+xml", headers=headers)
    png = await run_blocking(render_png, make_symbol(payload, error), scale)
    return Response(png, media_type="image/png", headers=headers)


# KML clients draw the codes on pages of any site, and a page may draw an image into
# a canvas or WebGL only where the image's server lets it.
router.add_api_route(
    "/codes/{name}", code_image, methods=["GET"], route_class_override=AnyOriginRoute
)
