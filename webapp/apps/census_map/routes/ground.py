"""The globe's ground from the site's own servers, relayed from this origin for the
tiles (``ground.py`` says why): imagery tiles and the files of a terrain tileset."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Header, HTTPException, Path, Request, Response, status

from webapp.apps.census_map.ground import (
    IMAGERY_PATH,
    KEEP_FOR,
    MAX_ZOOM,
    TERRAIN_PATH,
    Fetched,
    GroundUnavailable,
)
from webapp.apps.census_map.maps import census_maps
from webapp.web.deps import ContextDep
from webapp.web.problems import errors

router = APIRouter(tags=["census"])

TileIndex = Annotated[int, Path(ge=0, lt=2**MAX_ZOOM)]


def _answer(fetched: Fetched) -> Response:
    return Response(
        fetched.body, media_type=fetched.media_type, headers={"Cache-Control": KEEP_FOR}
    )


def _refused(failure: GroundUnavailable) -> HTTPException:
    return HTTPException(failure.status, failure.reason, headers={"Cache-Control": "no-store"})


@router.get(f"{IMAGERY_PATH}/{{z}}/{{x}}/{{y}}", responses=errors(404, 502, 504))
async def imagery_tile(
    context: ContextDep,
    z: Annotated[int, Path(ge=0, le=MAX_ZOOM)],
    x: TileIndex,
    y: TileIndex,
) -> Response:
    """A Web Mercator tile of the site's imagery server (``TAGWALL_CENSUS_IMAGERY_URL``),
    which tiles lay over the bundled Natural Earth II: 404 when there is none (no
    server, or no such tile), 502 when it failed, 504 when it did not answer in time."""
    relay = census_maps(context).ground
    if not relay.settings.imagery_url:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND,
            "This server relays no imagery (TAGWALL_CENSUS_IMAGERY_URL is not set).",
        )
    if x >= 2**z or y >= 2**z:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"Level {z} has no tile {x}/{y}.")
    try:
        return _answer(await relay.imagery(z, x, y))
    except GroundUnavailable as failure:
        raise _refused(failure) from None


@router.get(f"{TERRAIN_PATH}/{{path:path}}", responses=errors(404, 502, 504))
async def terrain_file(
    context: ContextDep,
    request: Request,
    path: str,
    accept: Annotated[str | None, Header()] = None,
) -> Response:
    """A file of the site's quantized-mesh terrain tileset (``TAGWALL_CENSUS_TERRAIN_URL``):
    its ``layer.json`` and tiles, asked as CesiumTerrainProvider asks (the extensions
    its ``Accept`` names, and ``?v=&extensions=``, passed on); 404, 502 and 504 as for
    imagery."""
    relay = census_maps(context).ground
    if not relay.settings.terrain_url:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND,
            "This server relays no terrain (TAGWALL_CENSUS_TERRAIN_URL is not set).",
        )
    try:
        return _answer(await relay.terrain(path, request.query_params, accept))
    except GroundUnavailable as failure:
        raise _refused(failure) from None
