"""What each tile fetches of the census map: its share of the tracts and of the colouring."""

from __future__ import annotations

import json
from collections.abc import Callable, Hashable
from typing import Annotated

from fastapi import APIRouter, HTTPException, Query, Response, status
from pydantic import ValidationError
from sqlalchemy import select

from wall_client.layout import Rect, Wall
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.globe import globe_view, map_projection
from webapp.apps.census_map.legend import theme_view
from webapp.apps.census_map.maps import CensusMaps, census_maps
from webapp.apps.census_map.mapview import tile_view, tract_boxes
from webapp.apps.census_map.routes.common import MapViewDep
from webapp.apps.census_map.rules import APP
from webapp.apps.census_map.state import MAX_TILT, Surface
from webapp.apps.census_map.theme import kept_theme
from webapp.choropleth.classes import Method, Theme
from webapp.choropleth.palettes import SchemeName
from webapp.core.threads import run_blocking
from webapp.database.connection import ROW_ID_MAX, RowId
from webapp.database.models import TagRecord
from webapp.engine.wall_state import View
from webapp.tags.schemas import PlacedCode
from webapp.web.context import AppContext
from webapp.web.deps import (
    ContextDep,
    TileDep,
    WallDep,
)
from webapp.web.problems import errors

router = APIRouter(tags=["census"])


@router.get("/api/apps/census/walls/{wall_id}/tiles/{tile_id}", responses=errors(404))
async def tile_map(
    wall: WallDep,
    tile: TileDep,
    context: ContextDep,
    dataset: RowId,
    view: MapViewDep,
    layout: Annotated[int, Query(ge=0, le=ROW_ID_MAX)] = 0,
) -> Response:
    """One tile's share of the census map for a data set, codes layout and view, in the
    tile's native pixels (the tile fetches it before it answers ``ready``)."""
    app = census_maps(context)
    key = (dataset, wall.id, tile.id, layout, view.center, view.zoom)
    return await _render_once(
        app,
        context,
        key,
        dataset,
        lambda found: _tile_body(app, context, wall, tile.id, found.id, layout, view),
    )


def _tile_body(
    app: CensusMaps,
    context: AppContext,
    wall: Wall,
    tile_id: str,
    dataset_id: int,
    layout_id: int,
    view: View,
) -> bytes:

    dataset = app.dataset(context, dataset_id)
    assert dataset is not None
    record = context.layout(wall.id, layout_id)
    placed = [PlacedCode.model_validate(p) for p in record.placed] if record else []
    codes = _census_tags(context, [p.code for p in placed])
    tracts = {tag.params["geoid"]: code for code, tag in codes.items() if tag.action == "tract"}
    occupied = [Rect(*p.footprint) for p in placed if p.display == tile_id]
    view_body = tile_view(dataset, app.geometry(dataset), wall, tile_id, view, tracts, occupied)
    view_body["toggles"] = {
        code: tag.params["group"] for code, tag in codes.items() if tag.action == "toggle"
    }
    clusters = {
        code: [str(g) for g in tag.params["geoids"]]
        for code, tag in codes.items()
        if tag.action == "cluster"
    }
    view_body["clusters"] = {
        code: sorted({dataset.group_of[g] for g in geoids if g in dataset.group_of})
        for code, geoids in clusters.items()
    }
    clustered = sum(len(geoids) for geoids in clusters.values())
    view_body["caption"] = (
        f"{dataset.title} · {len(tracts)} of {len(dataset.tracts)} tracts carry their own"
        f" code, {clustered} a shared one; every tract is in the tract index"
    )
    return json.dumps(view_body, separators=(",", ":")).encode()


def _census_tags(context: AppContext, codes: list[str]) -> dict[str, TagRecord]:
    """The census map's tags among ``codes`` (a layout's), by code."""
    if not codes:
        return {}
    with context.db.session() as session:
        rows = session.scalars(
            select(TagRecord).where(TagRecord.code.in_(codes), TagRecord.app == APP)
        )
        return {tag.code: tag for tag in rows}


@router.get("/api/apps/census/walls/{wall_id}/tiles/{tile_id}/theme", responses=errors(404))
async def tile_theme(
    wall: WallDep,
    tile: TileDep,
    context: ContextDep,
    dataset: RowId,
    attribute: Annotated[str, Query(max_length=64)],
    scheme: SchemeName,
    method: Method,
    classes: int,
    view: MapViewDep,
    layout: Annotated[int, Query(ge=0, le=ROW_ID_MAX)] = 0,
    surface: Surface = "flat",
    heading: Annotated[float, Query(ge=0, lt=360)] = 0.0,
    tilt: Annotated[float, Query(ge=0, le=MAX_TILT)] = 0.0,
) -> Response:
    """The tracts' classes and the legend for the wall's theme (the state's ``theme``),
    the same for every tile of the wall: tiles fetch it before they answer ``ready``.
    The view, surface and globe's camera say where the map lies on the wall, which the
    legend keeps off where it can."""
    try:
        theme = Theme(attribute=attribute, scheme=scheme, method=method, classes=classes)
    except ValidationError as error:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, f"theme: {error.errors()[0]['msg']}"
        ) from None
    app = census_maps(context)
    camera = (surface, heading, tilt)
    key = ("theme", wall.id, dataset, layout, view.center, view.zoom, camera, theme)
    return await _render_once(
        app,
        context,
        key,
        dataset,
        lambda found: _theme_body(app, context, wall, found, layout, view, camera, theme),
    )


def _theme_body(
    app: CensusMaps,
    context: AppContext,
    wall: Wall,
    dataset: DataSet,
    layout_id: int,
    view: View,
    camera: tuple[Surface, float, float],
    theme: Theme,
) -> bytes:
    if kept_theme(dataset, theme) is None:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"{dataset.title} has no value {theme.attribute!r}."
        )
    shading = app.shading(dataset, theme)
    assert shading is not None
    record = context.layout(wall.id, layout_id)
    codes = [
        Rect(*PlacedCode.model_validate(p).footprint) for p in (record.placed if record else [])
    ]
    geometry = app.geometry(dataset)
    mapping = map_projection(geometry, wall, view, *camera)
    on_map = tract_boxes(geometry, wall, view, mapping=mapping)
    body = theme_view(shading, dataset.id, [t.geoid for t in dataset.tracts], wall, codes, on_map)
    return body.model_dump_json().encode()


@router.get("/api/apps/census/walls/{wall_id}/globe", responses=errors(404))
async def wall_globe(
    wall: WallDep,
    context: ContextDep,
    dataset: RowId,
    view: MapViewDep,
    heading: Annotated[float, Query(ge=0, lt=360)] = 0.0,
    tilt: Annotated[float, Query(ge=0, le=MAX_TILT)] = 0.0,
) -> Response:
    """The map on the globe for a data set, view and camera (the state's ``heading`` and
    ``tilt``), the same for every tile of the wall: the wall's one camera, every tract in
    longitude/latitude (tiles colour them with the theme's classes,
    ``.../census/theme``) and the ground the site's servers lay over the bundled
    imagery and ellipsoid (``ground``: this server's relay paths, or nulls)."""
    app = census_maps(context)
    key = ("globe", wall.id, dataset, view.center, view.zoom, heading, tilt)
    return await _render_once(
        app,
        context,
        key,
        dataset,
        lambda found: _globe_body(app, wall, found, view, heading, tilt),
    )


def _globe_body(
    app: CensusMaps, wall: Wall, dataset: DataSet, view: View, heading: float, tilt: float
) -> bytes:
    body = globe_view(dataset, app.geometry(dataset), wall, view, heading, tilt)
    body["ground"] = app.ground.offered().model_dump()  # the site's imagery and terrain
    return json.dumps(body, separators=(",", ":")).encode()


async def _render_once(
    app: CensusMaps,
    context: AppContext,
    key: Hashable,
    dataset_id: int,
    build: Callable[[DataSet], bytes],
) -> Response:
    """A JSON body every tile asks for alike, built once per ``key`` (in a worker
    thread, from its data set; 404 when there is none) and kept in the app's renders."""
    body = app.renders.get(key)
    if body is None:
        found = await run_blocking(app.dataset, context, dataset_id)
        if found is None:
            raise HTTPException(
                status.HTTP_404_NOT_FOUND, f"There is no census data set {dataset_id}."
            )
        body = await run_blocking(build, found)
        app.renders.put(key, body)
    return Response(body, media_type="application/json")
