"""KML for Google Earth: the census map as a document, and per-display network links for
an Earth wall. A page of any site may read them (CesiumJS loads KML from its own page's
site): they are the same for everyone and read no cookie."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from typing import Annotated, Literal

from fastapi import APIRouter, HTTPException, Query, Response, status

from wall_client.layout import Wall
from webapp.apps.census_map.actions import (
    group_shown,
)
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.earth import (
    DEFAULT_FOV,
    DEFAULT_MAP_REFRESH_S,
    DEFAULT_REFRESH_S,
    MAX_FOV,
    MAX_REFRESH_S,
    MIN_FOV,
    MIN_REFRESH_S,
    EarthBase,
    EarthOptions,
    caption_png,
    display_document,
    earth_displays,
    mounted_box,
    opener_kml,
    screen_role,
)
from webapp.apps.census_map.kml import census_kml, census_kmz, network_link_kml
from webapp.apps.census_map.maps import CensusMaps, census_maps
from webapp.apps.census_map.rules import APP
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.theme import Shading
from webapp.core.caching import IMMUTABLE
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.engine.wall_state import WallState, now_ms
from webapp.tags.schemas import PlacedCode
from webapp.web.context import AppContext
from webapp.web.cors import AnyOriginRoute
from webapp.web.deps import (
    ContextDep,
    WallDep,
)
from webapp.web.problems import errors

router = APIRouter(tags=["census"], route_class=AnyOriginRoute)


NETWORK_LINK_REFRESH_S = 10


KML_TYPE = "application/vnd.google-earth.kml+xml"


KMZ_TYPE = "application/vnd.google-earth.kmz"


async def _kml_inputs(
    context: AppContext, wall_id: str | None
) -> tuple[Wall, WallState, CensusMaps]:
    wall = context.walls.get(wall_id or context.settings.default_wall)
    if wall is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no wall {wall_id!r}.")
    state = await context.state(wall)
    return wall, state, census_maps(context)


@dataclass(frozen=True)
class _KmlInputs:
    dataset: DataSet
    hidden: frozenset[str]
    open_balloons: frozenset[str]
    name: str
    shading: Shading | None
    all_classes: bool = False  # Google Earth walls: a style for every class, see earth.py

    def kml(self) -> bytes:
        return census_kml(
            self.dataset,
            hidden=self.hidden,
            open_balloons=self.open_balloons,
            name=self.name,
            shading=self.shading,
            all_classes=self.all_classes,
        ).encode()

    def kmz(self) -> bytes:
        return census_kmz(
            self.dataset,
            hidden=self.hidden,
            open_balloons=self.open_balloons,
            name=self.name,
            shading=self.shading,
            all_classes=self.all_classes,
        )

    def cached(self, app: CensusMaps, kind: Literal["kml", "kmz"]) -> bytes:
        """Built once per map state: a network link asks every few seconds."""
        theme = self.shading.theme if self.shading else None
        key = (
            kind,
            self.dataset.id,
            self.hidden,
            self.open_balloons,
            self.name,
            theme,
            self.all_classes,
        )
        body = app.renders.get(key)
        if body is None:
            body = self.kml() if kind == "kml" else self.kmz()
            app.renders.put(key, body)
        return body


@dataclass(frozen=True)
class _MapNow:
    """The map as the wall shows it now (the current data set as imported, plain, when
    the map is not on the wall, ``on_wall`` False)."""

    wall: Wall
    state: WallState
    dataset: DataSet
    on_wall: bool
    shading: Shading | None


async def _map_now(context: AppContext, wall_id: str | None) -> _MapNow:
    wall, state, app = await _kml_inputs(context, wall_id)
    dataset = await run_blocking(app.shown, context, state)
    if dataset is None:
        dataset = await run_blocking(app.datasets.current, context.db)
    if dataset is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No census data set has been imported.")
    on_wall = state.app == APP and CensusState.of(state).dataset == dataset.id
    shading = (
        await run_blocking(app.shading, dataset, CensusState.of(state).theme) if on_wall else None
    )
    return _MapNow(wall, state, dataset, on_wall, shading)


async def _kml_of(context: AppContext, wall_id: str | None) -> _KmlInputs:
    """The map as the wall shows it now: its data set, hidden groups, open balloons."""
    now_map = await _map_now(context, wall_id)
    wall, state, dataset, on_wall = now_map.wall, now_map.state, now_map.dataset, now_map.on_wall
    now = now_ms()
    hidden = frozenset(g.id for g in dataset.groups if not group_shown(state, g.id))
    balloons = frozenset(b.id.removeprefix("tract-") for b in state.balloons if b.open_at(now))
    return _KmlInputs(
        dataset=dataset,
        hidden=hidden if on_wall else frozenset(),
        open_balloons=balloons if on_wall else frozenset(),
        name=f"{dataset.title} · {wall.name}",
        shading=now_map.shading,
    )


WallQuery = Annotated[str | None, Query(alias="wall", max_length=64)]


@router.get("/apps/census/census.kml", responses=errors(404))
async def kml(context: ContextDep, wall_id: WallQuery = None) -> Response:
    """The map as Google Earth shows it: tracts, groups as folders, open balloons."""
    inputs = await _kml_of(context, wall_id)
    body = await run_blocking(inputs.cached, census_maps(context), "kml")
    return Response(body, media_type=KML_TYPE)


@router.get("/apps/census/census.kmz", responses=errors(404))
async def kmz(context: ContextDep, wall_id: WallQuery = None) -> Response:
    inputs = await _kml_of(context, wall_id)
    body = await run_blocking(inputs.cached, census_maps(context), "kmz")
    return Response(
        body,
        media_type=KMZ_TYPE,
        headers={"Content-Disposition": 'attachment; filename="census.kmz"'},
    )


@router.get("/apps/census/network-link.kml", responses=errors(404))
async def network_link(context: ContextDep, wall_id: WallQuery = None) -> Response:
    """Open once in Google Earth Pro: it fetches census.kmz (a fifth of census.kml's
    bytes) every few seconds, so Earth follows the wall's groups and balloons."""
    wall, _, _ = await _kml_inputs(context, wall_id)
    url = f"{context.base_url}/apps/census/census.kmz?wall={wall.id}"
    text = network_link_kml(
        url, refresh_seconds=NETWORK_LINK_REFRESH_S, name=f"tagwall census map · {wall.name}"
    )
    return Response(
        text,
        media_type=KML_TYPE,
        headers={"Content-Disposition": 'attachment; filename="network-link.kml"'},
    )


FovQuery = Annotated[float, Query(ge=MIN_FOV, le=MAX_FOV)]


RefreshQuery = Annotated[int, Query(ge=MIN_REFRESH_S, le=MAX_REFRESH_S)]


OpenedQuery = Annotated[str | None, Query(alias="open", max_length=64)]


ColouredQuery = Annotated[str | None, Query(alias="theme", max_length=128)]


BaseQuery = Annotated[str | None, Query(max_length=500)]


SignatureQuery = Annotated[str | None, Query(alias="sig", max_length=64)]


def _earth_base(context: AppContext, url: str | None, signature: str | None) -> EarthBase:
    """The base URL a link named: the public base URL, or one `tagwall earth --base-url`
    signed; never the request's Host header."""
    base = EarthBase.of_request(
        context.settings.resolved_secret_key, context.base_url, url, signature
    )
    if base is None:
        raise HTTPException(
            status.HTTP_400_BAD_REQUEST,
            "This link's base URL is not signed by this server: "
            "write the Earth files again with `tagwall earth`.",
        )
    return base


def _earth_display(wall: Wall, display_id: str) -> None:
    """404 unless ``display_id`` is one of the wall's displays Google Earth can drive."""
    if display_id not in {d.id for d in earth_displays(wall)}:
        role = screen_role(wall, display_id)
        detail = (
            f"Display {display_id!r} is the {role} screen: Google Earth cannot show its "
            "panels, open its tile in a browser."
            if role
            else f"Wall {wall.id!r} has no display {display_id!r}."
        )
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail)


@router.get("/apps/census/earth/{wall_id}/map.kmz", responses=errors(404))
async def earth_map(wall: WallDep, context: ContextDep) -> Response:
    """The map Google Earth walls load: census.kmz with no balloon open (each display
    opens the one on it) and a style for every class (each display recolours them)."""
    inputs = await _kml_of(context, wall.id)
    inputs = replace(inputs, open_balloons=frozenset(), all_classes=True)
    body = await run_blocking(inputs.cached, census_maps(context), "kmz")
    return Response(body, media_type=KMZ_TYPE)


@router.get("/apps/census/earth/{wall_id}/{display_id}.kml", responses=errors(404))
async def earth_opener(
    wall: WallDep,
    display_id: str,
    context: ContextDep,
    fov: FovQuery = DEFAULT_FOV,
    refresh: RefreshQuery = DEFAULT_REFRESH_S,
    map_refresh: RefreshQuery = DEFAULT_MAP_REFRESH_S,
    base: BaseQuery = None,
    signature: SignatureQuery = None,
) -> Response:
    """What the Google Earth on one display opens: the map and its wall document."""
    _earth_display(wall, display_id)
    options = EarthOptions(fov=fov, refresh=refresh, map_refresh=map_refresh)
    return Response(
        opener_kml(_earth_base(context, base, signature), wall, display_id, options),
        media_type=KML_TYPE,
        headers={"Content-Disposition": 'attachment; filename="tagwall-earth.kml"'},
    )


@router.get("/apps/census/earth/{wall_id}/{display_id}/wall.kml", responses=errors(404))
async def earth_display(
    wall: WallDep,
    display_id: str,
    context: ContextDep,
    fov: FovQuery = DEFAULT_FOV,
    opened: OpenedQuery = None,
    coloured: ColouredQuery = None,
    base: BaseQuery = None,
    signature: SignatureQuery = None,
) -> Response:
    """One display's wall document, fetched every few seconds by its Google Earth: the
    view, groups, balloon and colouring (an Update of the map) and the codes on the
    display. ``open`` and ``theme`` come from the previous document's cookie."""
    _earth_display(wall, display_id)
    earth_base = _earth_base(context, base, signature)
    shown = await _map_now(context, wall.id)
    app = census_maps(context)
    geometry = await run_blocking(app.geometry, shown.dataset)
    text = await run_blocking(
        lambda: display_document(
            context.db,
            wall=shown.wall,
            state=shown.state,
            dataset=shown.dataset,
            geometry=geometry,
            on_wall=shown.on_wall,
            shading=shown.shading,
            shading_of=partial(app.shading, shown.dataset),
            display_id=display_id,
            fov=fov,
            opened=opened,
            coloured=coloured,
            # the opener's base, never the request's Host header (a client's to choose):
            # targetHref is the very URL the opener named for the map
            base_url=earth_base.url,
            now=now_ms(),
        )
    )
    return Response(text, media_type=KML_TYPE)


@router.get("/apps/census/earth/{wall_id}/captions/{layout_id}/{code}.png", responses=errors(404))
async def earth_caption(
    wall: WallDep, layout_id: RowId, code: str, context: ContextDep
) -> Response:
    """A placed code's caption as Google Earth draws it under the code (a layout never
    changes, so neither does its image)."""
    record = await run_blocking(context.layout, wall.id, layout_id)
    found = next((p for p in record.placed if p["code"] == code), None) if record else None
    placed = PlacedCode.model_validate(found) if found else None
    if placed is None or not placed.label or placed.caption is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such caption.")
    _, _, width, height = mounted_box(wall, placed.display, placed.caption)
    body = await run_blocking(caption_png, placed.label, (width, height))
    return Response(body, media_type="image/png", headers={"Cache-Control": IMMUTABLE})
