"""HTML pages: the start page, tiles and the wall overview."""

from __future__ import annotations

import json

from fastapi import APIRouter, Request
from fastapi.responses import HTMLResponse

from webapp.apps.installed import layer_stacks
from webapp.engine.protocol import ViewportInfo
from webapp.publishing.screen import screen_layout
from webapp.server.deps import ServicesDep
from webapp.server.schemas import WallInfo
from webapp.web.deps import TileDep, TileTokenDep, WallDep
from webapp.web.templating import render

router = APIRouter(include_in_schema=False)


@router.get("/", response_class=HTMLResponse)
def index(request: Request, services: ServicesDep) -> HTMLResponse:
    return render(request, "index.html", walls=list(services.walls.values()))


@router.get("/wall/{wall_id}")
def wall_start_page(request: Request, wall: WallDep) -> HTMLResponse:
    """Where a phone starts (and lands from a code that no longer works)."""
    registration = ", ".join(d.id for d in wall.screen("registration"))
    return render(request, "wall_start.html", wall=wall, registration=registration)


@router.get("/wall/{wall_id}/tile/{tile_id}", dependencies=[TileTokenDep])
def tile_page(
    request: Request, wall: WallDep, tile: TileDep, services: ServicesDep
) -> HTMLResponse:
    viewport = ViewportInfo.of(wall.viewport(tile.id))
    public = tile in wall.screen("public")
    layout = screen_layout(wall, services.settings) if public else None
    return render(
        request,
        "tile.html",
        wall=wall,
        tile=tile,
        token=services.tile_token(wall.id),
        viewport_json=viewport.model_dump_json(),
        wall_json=WallInfo.of(wall).model_dump_json(),
        public_screen_json=layout.model_dump_json() if layout else "",
        layers_json=json.dumps(layer_stacks(services.apps)),
    )


@router.get("/wall/{wall_id}/overview")
def overview_page(request: Request, wall: WallDep, services: ServicesDep) -> HTMLResponse:
    return render(
        request,
        "overview.html",
        wall=wall,
        wall_json=WallInfo.of(wall).model_dump_json(),
        layers_json=json.dumps(layer_stacks(services.apps)),
    )
